"""Structure: assembly, parameters, influence vector, loads and one test per invalid input."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from femupdate.errors import ModelError
from femupdate.model import Structure, natural_frequencies, shear_building
from femupdate.model.elements import beam_mass, beam_stiffness

E, A, I, RHO = 2.1e11, 1e-3, 1e-6, 7850.0  # noqa: E741


def bridge() -> Structure:
    """The paper's bridge layout: 5 nodes, 4 beams, springs and dampers at every node."""
    s = Structure(dofs_per_node=2)
    for name, x in zip(("A1", "P1", "P2", "P3", "A2"), (0.0, 1.2, 2.4, 3.6, 4.8), strict=True):
        s.add_node(name, x=x)
    for i, (a, b) in enumerate((("A1", "P1"), ("P1", "P2"), ("P2", "P3"), ("P3", "A2"))):
        s.add_beam(a, b, E="E", A=A, I=I, rho=RHO, nu=0.3, kappa=0.5, name=f"deck{i + 1}")
    s.add_spring("A1", "uy", "kp1")
    s.add_spring("A2", "uy", "kp1")
    for i, node in enumerate(("P1", "P2", "P3"), start=2):
        s.add_spring(node, "uy", f"kp{i}")
        s.add_damper(node, "uy", f"c{i}")
    s.add_damper("A1", "rz", "c1")
    s.add_damper("A2", "rz", "c1")
    for node in ("P1", "P2", "P3"):
        s.add_mass(node, m=2.0)
    return s


BRIDGE_VALUES = {
    "E": 2.1e11, "kp1": 3e8, "kp2": 3e5, "kp3": 3e6, "kp4": 3e5,
    "c1": 5.0, "c2": 300.0, "c3": 3000.0, "c4": 300.0,
}  # fmt: skip


def test_bridge_assembles_with_the_papers_dofs() -> None:
    s = bridge()
    assert s.parameters == ("E", "kp1", "kp2", "c2", "kp3", "c3", "kp4", "c4", "c1")
    system = s.assemble(BRIDGE_VALUES)
    assert system.n_dof == 10
    assert system.dof_labels[2] == "P1.uy"
    # the paper's DOFs 3, 5, 7 (1-based) are the pier translations
    assert [s.dof_index(p, "uy") for p in ("P1", "P2", "P3")] == [2, 4, 6]
    for mat in (system.M, system.C, system.K):
        np.testing.assert_array_equal(mat, mat.T)
    np.testing.assert_array_equal(system.r, [1, 0] * 5)
    assert system.friction is None
    assert system.C[2, 2] == 300.0
    assert system.C[1, 1] == 5.0


def test_assembly_equals_hand_scatter() -> None:
    """Two beams and a spring assembled by hand from the element functions."""
    s = Structure(2)
    s.add_node("a", x=0.0)
    s.add_node("b", x=1.0)
    s.add_node("c", x=3.0)
    s.add_beam("a", "b", E="E", A=A, I=I, rho=RHO)
    s.add_beam("b", "c", E="E", A=A, I=I, rho=RHO, mass_per_length=5.0)
    s.add_spring("c", "uy", 7.0)
    s.fix("a", "uy")
    system = s.assemble({"E": 3.0})
    k = np.zeros((6, 6))
    m = np.zeros((6, 6))
    k[0:4, 0:4] += beam_stiffness(3.0 * I, 1.0)
    k[2:6, 2:6] += beam_stiffness(3.0 * I, 2.0)
    k[4, 4] += 7.0
    m[0:4, 0:4] += beam_mass(RHO * A, RHO * I, 1.0)
    m[2:6, 2:6] += beam_mass(RHO * A + 5.0, RHO * I, 2.0)
    np.testing.assert_allclose(system.K, k[1:, 1:], rtol=1e-14)
    np.testing.assert_allclose(system.M, m[1:, 1:], rtol=1e-14)
    assert system.dof_labels == ("a.rz", "b.uy", "b.rz", "c.uy", "c.rz")


def test_reassembly_follows_the_parameters() -> None:
    s = bridge()
    v1 = dict(BRIDGE_VALUES, E=1e11)
    v2 = dict(BRIDGE_VALUES, E=2e11)
    k1, k2 = s.assemble(v1).K, s.assemble(v2).K
    springs = s.assemble(dict(BRIDGE_VALUES, E=0.0)).K
    np.testing.assert_allclose(k2 - springs, 2 * (k1 - springs), rtol=1e-12)
    # an array in `parameters` order gives the same system as the mapping
    arr = np.array([v2[name] for name in s.parameters])
    np.testing.assert_array_equal(s.assemble(arr).K, k2)
    np.testing.assert_array_equal(s.assemble(arr).C, s.assemble(v2).C)


def test_beam_direction_does_not_matter() -> None:
    def two(reverse: bool) -> Structure:
        s = Structure(2)
        s.add_node("a", x=0.0)
        s.add_node("b", x=1.5)
        ends = ("b", "a") if reverse else ("a", "b")
        s.add_beam(*ends, E=E, A=A, I=I, rho=RHO, nu=0.3)
        return s

    forward, backward = two(False).assemble(), two(True).assemble()
    np.testing.assert_allclose(backward.K, forward.K, rtol=1e-14)
    np.testing.assert_allclose(backward.M, forward.M, rtol=1e-14)


def test_cached_mass_is_not_shared_with_callers() -> None:
    s = bridge()
    first = s.assemble(BRIDGE_VALUES)
    reference = first.M.copy()
    first.M[:] = 0.0
    np.testing.assert_array_equal(s.assemble(BRIDGE_VALUES).M, reference)


def test_mass_follows_parameters_that_change_it() -> None:
    """With G given, Φ = 12EI/(κGAL²) depends on E, and so does the consistent mass."""
    s = Structure(2)
    s.add_node("a", x=0.0)
    s.add_node("b", x=0.3)
    s.add_beam("a", "b", E="E", A=A, I=I, rho="rho", G=8e10)
    m1 = s.assemble({"E": 2e11, "rho": 7850.0}).M
    m2 = s.assemble({"E": 1e11, "rho": 7850.0}).M
    m3 = s.assemble({"E": 1e11, "rho": 2 * 7850.0}).M
    assert not np.allclose(m1, m2)
    np.testing.assert_allclose(m3, 2 * m2, rtol=1e-14)


def test_edits_invalidate_the_topology() -> None:
    s = bridge()
    n1 = s.assemble(BRIDGE_VALUES).n_dof
    s.fix("P1", "rz")
    system = s.assemble(BRIDGE_VALUES)
    assert system.n_dof == n1 - 1
    assert "P1.rz" not in system.dof_labels
    i = s.dof_index("P2", "uy")
    s.add_mass("P2", m=3.0, name="extra")
    assert s.assemble(BRIDGE_VALUES).M[i, i] == pytest.approx(system.M[i, i] + 3.0)


def test_influence_vector_carries_the_total_mass() -> None:
    """Free-free frame: the translational inertia along x and y is the total mass."""
    s = Structure(dofs_per_node=3)
    pts = [(0.0, 0.0), (0.0, 2.0), (1.5, 2.5), (3.0, 1.0)]
    for i, (x, y) in enumerate(pts):
        s.add_node(f"N{i}", x=x, y=y)
    for i in range(3):
        s.add_beam(f"N{i}", f"N{i + 1}", E=E, A=A, I=I, rho=RHO, nu=0.3, mass_per_length=2.0)
    s.add_mass("N1", m=4.0, J=0.3)
    s.add_mass("N3", m=1.5)
    length = sum(math.dist(pts[i], pts[i + 1]) for i in range(3))
    total = (RHO * A + 2.0) * length + 4.0 + 1.5
    for direction in ("x", "y"):
        system = s.assemble(direction=direction)
        r = system.r
        along = np.array([lab.endswith(f".u{direction}") for lab in system.dof_labels])
        np.testing.assert_array_equal(r, along.astype(float))
        assert r @ system.M @ r == pytest.approx(total, rel=1e-12)
        assert (system.M @ r)[along].sum() == pytest.approx(total, rel=1e-12)
        # a rigid translation strains nothing
        np.testing.assert_allclose(system.K @ r, 0.0, atol=1e-9 * np.abs(system.K).max())


def test_seismic_load_includes_the_support_coupling() -> None:
    """p = (M_full r_full) on the free rows, from an unsupported copy of the same beam."""

    def beam(fixed: bool) -> Structure:
        s = Structure(2)
        for i in range(5):
            s.add_node(f"N{i}", x=0.5 * i)
        for i in range(4):
            s.add_beam(f"N{i}", f"N{i + 1}", E=E, A=A, I=I, rho=RHO, nu=0.3)
        if fixed:
            s.fix("N0", "uy")
            s.fix("N4", "uy")
        return s

    supported, free = beam(True), beam(False)
    m_full = free.assemble().M
    r_full = free.influence_vector()
    keep = [free.dof_labels.index(lab) for lab in supported.dof_labels]
    expected = (m_full @ r_full)[keep]
    p = supported.seismic_load()
    np.testing.assert_allclose(p, expected, rtol=1e-12)
    system = supported.assemble()
    assert not np.allclose(p, system.M @ system.r)  # M r alone misses the support inertia
    # without supports the two agree
    np.testing.assert_allclose(free.seismic_load(), m_full @ r_full, rtol=1e-14)


def test_dof_index_and_force_vector() -> None:
    s = bridge()
    f = s.force_vector("P2", "uy")
    assert f.shape == (10,)
    assert f[s.dof_index("P2", "uy")] == 1.0
    assert f.sum() == 1.0
    assert s.dof_index("A1", "rz") == 1


def test_friction_elements_map_to_free_dofs() -> None:
    s = Structure(2)
    s.add_node("a", x=0.0)
    s.add_node("b", x=1.0)
    s.add_beam("a", "b", E=E, A=A, I=I, rho=RHO)
    s.add_friction("a", "rz", k_r="kr1", f_u="fu1", name="hinge")
    s.add_friction("b", "uy", k_r=5.0, f_u=1.0, node2="a", dof2="uy")
    s.fix("a", "uy")
    fr = s.assemble({"kr1": 2.0, "fu1": 0.5}).friction
    assert fr is not None
    assert s.parameters == ("kr1", "fu1")
    # a.uy is fixed: the second element becomes a b.uy-to-ground element
    np.testing.assert_array_equal(fr.dof_i, [s.dof_index("a", "rz"), s.dof_index("b", "uy")])
    np.testing.assert_array_equal(fr.dof_j, [-1, -1])
    np.testing.assert_array_equal(fr.k_r, [2.0, 5.0])
    np.testing.assert_array_equal(fr.f_u, [0.5, 1.0])


def test_rayleigh_damping_with_parameters() -> None:
    s = bridge()
    s.set_rayleigh(alpha="alpha", beta=1e-4)
    values = dict(BRIDGE_VALUES, alpha=0.5)
    system = s.assemble(values)
    s2 = bridge()
    plain = s2.assemble(BRIDGE_VALUES)
    np.testing.assert_allclose(system.C, plain.C + 0.5 * plain.M + 1e-4 * plain.K, rtol=1e-14)
    s.set_rayleigh(beta=2e-4)  # replaces: alpha is no longer a parameter
    assert "alpha" not in s.parameters


def test_shear_building_two_storeys_closed_form() -> None:
    """m1 m2 ω⁴ − (m1 k2 + m2 (k1 + k2)) ω² + k1 k2 = 0."""
    m1, m2, k1, k2 = 3.0, 2.0, 4000.0, 2500.0
    s = shear_building(["m1", m2], [k1, "k2"], dampers=[10.0, 5.0])
    assert s.parameters == ("m1", "k2")
    system = s.assemble({"m1": m1, "k2": k2})
    b = m1 * k2 + m2 * (k1 + k2)
    disc = math.sqrt(b * b - 4 * m1 * m2 * k1 * k2)
    w2 = np.array([b - disc, b + disc]) / (2 * m1 * m2)
    f, _ = natural_frequencies(system)
    np.testing.assert_allclose(f, np.sqrt(w2) / (2 * math.pi), rtol=1e-12)
    np.testing.assert_allclose(system.C, [[15.0, -5.0], [-5.0, 5.0]])
    np.testing.assert_array_equal(system.r, [1.0, 1.0])
    assert system.dof_labels == ("F1.ux", "F2.ux")


# ---------------------------------------------------------------------- invalid input


def two_nodes(dpn: int = 2) -> Structure:
    s = Structure(dpn)
    s.add_node("a", x=0.0)
    s.add_node("b", x=1.0)
    return s


def test_unknown_node() -> None:
    s = two_nodes()
    with pytest.raises(ModelError, match=r"unknown node 'zz'.*known nodes: a, b"):
        s.add_beam("a", "zz", E=E, A=A, I=I)
    with pytest.raises(ModelError, match="unknown node 'q'"):
        s.dof_index("q", "uy")


def test_unknown_dof() -> None:
    s = two_nodes()
    with pytest.raises(ModelError, match=r"unknown DOF 'ux'.*\('uy', 'rz'\)"):
        s.add_spring("a", "ux", 1.0)
    with pytest.raises(ModelError, match="unknown DOF 'uz'"):
        s.fix("a", "uz")


def test_duplicate_node_and_element_name() -> None:
    s = two_nodes()
    with pytest.raises(ModelError, match="duplicate node 'a'"):
        s.add_node("a", x=5.0)
    s.add_spring("a", "uy", 1.0, name="k")
    with pytest.raises(ModelError, match="duplicate element name 'k'"):
        s.add_damper("b", "uy", 1.0, name="k")


def test_zero_length_beam() -> None:
    s = two_nodes()
    s.add_node("c", x=1.0)
    with pytest.raises(ModelError, match=r"beam 'deck'.*length = 0.0.*'b' and 'c'"):
        s.add_beam("b", "c", E=E, A=A, I=I, name="deck")


def test_negative_mass_stiffness_and_modulus() -> None:
    s = two_nodes()
    with pytest.raises(ModelError, match=r"mass 'm'.*m = -1.0.*allowed \[0, inf\)"):
        s.add_mass("a", m=-1.0, name="m")
    with pytest.raises(ModelError, match=r"spring 'kp'.*k = -5.0"):
        s.add_spring("a", "uy", -5.0, name="kp")
    with pytest.raises(ModelError, match=r"beam 'deck'.*E = -1.0"):
        s.add_beam("a", "b", E=-1.0, A=A, I=I, name="deck")
    with pytest.raises(ModelError, match=r"beam 'deck'.*A = 0.0.*allowed \(0, inf\)"):
        s.add_beam("a", "b", E=E, A=0.0, I=I, name="deck")


def test_negative_parameter_value_names_element_and_parameter() -> None:
    s = bridge()
    with pytest.raises(ModelError, match=r"spring 'spring3'.*k = -3.0 \(parameter 'kp2'\)"):
        s.assemble(dict(BRIDGE_VALUES, kp2=-3.0))
    with pytest.raises(ModelError, match=r"beam 'deck1'.*E = -1.0 \(parameter 'E'\)"):
        s.assemble(dict(BRIDGE_VALUES, E=-1.0))
    with pytest.raises(ModelError, match=r"parameter 'c3' = nan"):
        s.assemble(dict(BRIDGE_VALUES, c3=math.nan))


def test_spring_to_a_fixed_dof() -> None:
    s = two_nodes()
    s.add_beam("a", "b", E=E, A=A, I=I, rho=RHO)
    s.add_spring("a", "uy", 10.0, name="ground_spring")
    s.fix("a", "uy")
    with pytest.raises(ModelError, match=r"spring 'ground_spring'.*only fixed DOFs.*a\.uy"):
        s.assemble()


def test_spring_between_two_fixed_dofs() -> None:
    s = two_nodes()
    s.add_beam("a", "b", E=E, A=A, I=I, rho=RHO)
    s.add_damper("a", "uy", 10.0, node2="b", name="dash")
    s.fix("a", "uy")
    s.fix("b", "uy")
    with pytest.raises(ModelError, match=r"damper 'dash'.*a\.uy, b\.uy"):
        s.assemble()


def test_link_to_itself() -> None:
    s = two_nodes()
    with pytest.raises(ModelError, match="to itself"):
        s.add_spring("a", "uy", 1.0, node2="a")


def test_singular_mass_matrix_names_the_dofs() -> None:
    """Massless beam with lumped translational masses: the rotations have no inertia."""
    s = two_nodes()
    s.add_node("c", x=2.0)
    s.add_beam("a", "b", E=E, A=A, I=I)
    s.add_beam("b", "c", E=E, A=A, I=I)
    for node in ("b", "c"):
        s.add_mass(node, m=1.0)
    s.fix("a", "uy")
    with pytest.raises(ModelError, match=r"mass matrix is singular.*a\.rz, b\.rz, c\.rz") as info:
        s.assemble()
    assert "uy" not in str(info.value).split("inertia:")[1].split(".")[1]
    # rotary inertia fixes it
    for node in ("a", "b", "c"):
        s.add_mass(node, J=1e-3)
    s.assemble()


def test_missing_and_unknown_parameters() -> None:
    s = bridge()
    with pytest.raises(ModelError, match=r"missing value\(s\) for parameter\(s\) 'c4'"):
        s.assemble({k: v for k, v in BRIDGE_VALUES.items() if k != "c4"})
    with pytest.raises(ModelError, match=r"unknown parameter\(s\) 'kp9'"):
        s.assemble(dict(BRIDGE_VALUES, kp9=1.0))
    with pytest.raises(ModelError, match="got 3 parameter values; this structure has 9"):
        s.assemble([1.0, 2.0, 3.0])
    with pytest.raises(ModelError, match="must be numbers"):
        s.assemble(dict(BRIDGE_VALUES, E="big"))


def test_other_invalid_descriptions() -> None:
    with pytest.raises(ModelError, match="dofs_per_node = 4"):
        Structure(4)
    s = two_nodes()
    s.add_node("up", x=0.0, y=1.0)
    with pytest.raises(ModelError, match="along the x axis"):
        s.add_beam("a", "up", E=E, A=A, I=I)
    with pytest.raises(ModelError, match="G or nu, not both"):
        s.add_beam("a", "b", E=E, A=A, I=I, G=8e10, nu=0.3)
    with pytest.raises(ModelError, match=r"nu = 0.7.*allowed \(-1, 0.5\]"):
        s.add_beam("a", "b", E=E, A=A, I=I, nu=0.7)
    with pytest.raises(ModelError, match="direction = 'x'"):
        s.add_beam("a", "b", E=E, A=A, I=I, rho=RHO)
        s.assemble(direction="x")
    s.fix("a")
    with pytest.raises(ModelError, match=r"DOF a\.uy is fixed"):
        s.force_vector("a", "uy")
    one = Structure(1)
    one.add_node("f", x=0.0)
    with pytest.raises(ModelError, match="beams need rotations"):
        one.add_beam("f", "f", E=E, A=A, I=I)
    with pytest.raises(ModelError, match="needs a rotational DOF"):
        one.add_mass("f", m=1.0, J=2.0)
    with pytest.raises(ModelError, match="no nodes"):
        Structure(2).assemble()
    with pytest.raises(ModelError, match="1 stiffnesses for 2 masses"):
        shear_building([1.0, 2.0], [3.0])


@pytest.mark.parametrize(("kwargs", "words"), [
    ({"m": 400.0, "dofs": ["rx"]}, "names no translation, so m = 400.0 would act on nothing"),
    ({"m": "m1", "dofs": ["rx", "ry"]}, "names no translation, so m = 'm1'"),
    ({"m": 0.0, "J": 5.0, "dofs": ["ux", "uy"]}, "names no rotation, so J = 5.0"),
    ({"m": 400.0, "dofs": ["ux", "ux"]}, "names a DOF more than once"),
])
def test_a_mass_its_dofs_cannot_carry_is_refused(kwargs: dict, words: str) -> None:
    # Issue 33: {m = 400, dofs = ["rx"]} was dropped without a word (the frequencies were
    # those of the model without it).
    s = Structure(dofs_per_node=6)
    s.add_node("C2", x=0.0, z=3.0)
    with pytest.raises(ModelError, match=re.escape(words)):
        s.add_mass("C2", **kwargs)
    s.add_mass("C2", m=0.0, J=5.0, dofs=["rx"])  # what it carries, on the DOFs named

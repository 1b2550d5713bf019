"""3-D Timoshenko element and Frame3D: closed forms, invariance, diaphragms, bad input."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from femupdate.errors import ModelError
from femupdate.model.elements import frame_element
from femupdate.model.elements3d import frame3d_element, frame3d_rotation
from femupdate.model.frame3d import Frame3D
from femupdate.paper.bench.frame3d_check import as_structure, example_frame, portal_frame

SEC = dict(E=2.0e11, A=4e-3, Iy=2e-5, Iz=5e-5, J=3e-5, G=8e10, kappa_y=0.8, kappa_z=0.6)


def _cantilever(axis: np.ndarray, vecxz: tuple[float, float, float], n: int = 1) -> Frame3D:
    f = Frame3D()
    for i in range(n + 1):
        f.add_node(f"P{i}", *(i / n * 2.5 * axis))
    for i in range(n):
        f.add_beam(f"P{i}", f"P{i + 1}", vecxz=vecxz, E=SEC["E"], A=SEC["A"], Iy=SEC["Iy"],
                   Iz=SEC["Iz"], J=SEC["J"], G=SEC["G"], kappa_y=SEC["kappa_y"],
                   kappa_z=SEC["kappa_z"], rho=7850.0)
    f.fix("P0")
    return f


def test_cantilever_tip_flexibilities_are_closed_form():
    # Along global Y with vecxz = X: local y = X × Y = Z and local z = Y × Z = X, so a load
    # along Z bends about local z (Iz, shear area κy A) and a load along X about local y.
    model = _cantilever(np.array([0.0, 1.0, 0.0]), (1.0, 0.0, 0.0)).assemble()
    flex = np.linalg.inv(model.system.K)
    labels = model.system.dof_labels
    L, E, G = 2.5, SEC["E"], SEC["G"]
    uz = labels.index("P1.uz")
    ux = labels.index("P1.ux")
    ry = labels.index("P1.ry")
    uy = labels.index("P1.uy")
    assert flex[uz, uz] == pytest.approx(
        L**3 / (3 * E * SEC["Iz"]) + L / (G * SEC["kappa_y"] * SEC["A"]), rel=1e-12)
    assert flex[ux, ux] == pytest.approx(
        L**3 / (3 * E * SEC["Iy"]) + L / (G * SEC["kappa_z"] * SEC["A"]), rel=1e-12)
    assert flex[uy, uy] == pytest.approx(L / (E * SEC["A"]), rel=1e-12)
    assert flex[ry, ry] == pytest.approx(L / (G * SEC["J"]), rel=1e-12)  # torsion about Y


def test_cantilever_without_shear_deformation_keeps_its_torsion():
    """shear_deformation=False (G given): the tip flexibilities lose the shear terms L / κGA,
    the torsion L / GJ stays; torsional_inertia=True with rotary_inertia=False keeps ρJ only."""
    f = Frame3D()
    f.add_node("P0", 0.0)
    f.add_node("P1", 0.0, 2.5)
    f.add_beam("P0", "P1", vecxz=(1.0, 0.0, 0.0), rho=7850.0, shear_deformation=False,
               rotary_inertia=False, torsional_inertia=True, **SEC)
    f.fix("P0")
    system = f.assemble().system
    flex = np.linalg.inv(system.K)
    labels = system.dof_labels
    L, E, G = 2.5, SEC["E"], SEC["G"]
    uz, ux, ry = (labels.index(f"P1.{d}") for d in ("uz", "ux", "ry"))
    assert flex[uz, uz] == pytest.approx(L**3 / (3 * E * SEC["Iz"]), rel=1e-12)
    assert flex[ux, ux] == pytest.approx(L**3 / (3 * E * SEC["Iy"]), rel=1e-12)
    assert flex[ry, ry] == pytest.approx(L / (G * SEC["J"]), rel=1e-12)
    # the twist's consistent mass ρ J L / 3 at the tip; no rotary inertia on rx, rz
    assert system.M[ry, ry] == pytest.approx(7850.0 * SEC["J"] * L / 3.0, rel=1e-12)
    rx, rz = labels.index("P1.rx"), labels.index("P1.rz")
    assert system.M[rx, rx] == pytest.approx(7850.0 * SEC["A"] * L**3 / 105.0, rel=1e-12)
    assert system.M[rz, rz] == pytest.approx(7850.0 * SEC["A"] * L**3 / 105.0, rel=1e-12)


def test_planar_element_is_embedded():
    x1, x2 = (0.3, 0.1), (2.0, 1.4)
    k3, m3 = frame3d_element((*x1, 0.0), (*x2, 0.0), (0.0, 0.0, 1.0), E=SEC["E"], A=SEC["A"],
                             Iy=SEC["Iy"], Iz=SEC["Iz"], J=SEC["J"], G=SEC["G"],
                             kappa_y=SEC["kappa_y"], rho=7850.0)
    k2, m2 = frame_element(SEC["E"], SEC["A"], SEC["Iz"], *x1, *x2, 7850.0, G=SEC["G"],
                           kappa=SEC["kappa_y"])
    idx = [0, 1, 5, 6, 7, 11]  # ux, uy, rz of both nodes
    np.testing.assert_allclose(k3[np.ix_(idx, idx)], k2, rtol=1e-13, atol=1e-13 * abs(k2).max())
    np.testing.assert_allclose(m3[np.ix_(idx, idx)], m2, rtol=1e-13, atol=1e-13 * abs(m2).max())


def test_rotation_is_orthogonal_and_follows_vecxz():
    t = frame3d_rotation((0, 0, 0), (1.0, 2.0, 2.0), (0.0, 0.0, 1.0))
    np.testing.assert_allclose(t @ t.T, np.eye(12), atol=1e-15)
    z_local = t[2, :3]
    assert z_local @ np.array([0.0, 0.0, 1.0]) > 0  # vecxz on the +z side of the xz plane
    assert abs(t[1, :3] @ np.array([0.0, 0.0, 1.0])) < 1e-15


def test_frequencies_do_not_depend_on_a_rigid_rotation_of_the_frame():
    def freqs(rot: np.ndarray) -> np.ndarray:
        f = Frame3D()
        base = example_frame()
        for name, xyz in zip(base.nodes, base._xyz, strict=True):
            f.add_node(name, *(rot @ np.array(xyz)))
        for name, n1, n2, p in base._beams:
            q = {k: v for k, v in p.items() if k != "vecxz"}
            f.add_beam(base.nodes[n1], base.nodes[n2], vecxz=rot @ p["vecxz"], name=name, **q)
        for name in base.nodes:
            if name.endswith("0"):
                f.fix(name)
        for n, vals in base._masses:
            f.add_mass(base.nodes[n], vals[0], Jx=100.0, Jy=100.0, Jz=100.0)
        s = f.assemble().system
        return scipy.linalg.eigh(s.K, s.M, eigvals_only=True)

    c, s = np.cos(0.7), np.sin(0.7)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ np.array(
        [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    np.testing.assert_allclose(freqs(rot), freqs(np.eye(3)), rtol=1e-10)


def test_diaphragm_slaves_follow_the_master():
    f = example_frame(diaphragm=True)
    model = f.assemble()
    labels = model.node_dof_labels
    q = np.random.default_rng(1).standard_normal(model.transformation.shape[1])
    u = dict(zip(labels, model.transformation @ q, strict=True))
    for name, (x, y, _) in zip(f.nodes, f._xyz, strict=True):
        if name.startswith("N") and not name.endswith("0"):
            m = f"M{name[-1]}"
            xm, ym = 2.5, 2.0
            assert u[f"{name}.ux"] == pytest.approx(u[f"{m}.ux"] - (y - ym) * u[f"{m}.rz"])
            assert u[f"{name}.uy"] == pytest.approx(u[f"{m}.uy"] + (x - xm) * u[f"{m}.rz"])
            assert u[f"{name}.rz"] == pytest.approx(u[f"{m}.rz"])
    assert "N001.ux" not in model.system.dof_labels
    assert "N001.uz" in model.system.dof_labels


def test_mechanism_names_the_loose_dofs():
    f = Frame3D()
    f.add_node("A", 0.0)
    f.add_node("B", 3.0)
    f.add_beam("A", "B", vecxz=(0, 0, 1.0), rho=1.0, **SEC)
    f.fix("A", "ux", "uy", "uz", "ry", "rz")  # rx free: the bar spins about its axis
    with pytest.raises(ModelError, match=r"mechanism.*A\.rx.*B\.rx") as err:
        f.assemble()
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda f: f.add_beam("A", "B", vecxz=(6.0, 0, 2.0), **SEC), "parallel"),
        (lambda f: f.add_beam("A", "B", vecxz=(0, 0, 1.0), E=1.0, A=1.0, Iy=1.0, Iz=1.0,
                              J=1.0), "exactly one of G and nu"),
        (lambda f: f.add_beam("A", "B", vecxz=(0, 0, 1.0), **(SEC | {"Iy": -1.0})), "Iy"),
        (lambda f: f.add_beam("A", "C", vecxz=(0, 0, 1.0), **SEC), "unknown node 'C'"),
        (lambda f: f.fix("A", "uw"), "unknown DOF 'uw'"),
        (lambda f: f.add_diaphragm("A", ["B"]), "not at the master's z"),
    ],
)
def test_bad_input_is_one_line(call, match):
    f = Frame3D()
    f.add_node("A", 0.0)
    f.add_node("B", 3.0, 0.0, 1.0)
    with pytest.raises(ModelError, match=match) as err:
        call(f)
    assert "\n" not in str(err.value)


def test_parameter_names_give_the_numeric_frame():
    def frame(e: float | str, m: float | str) -> Frame3D:
        f = Frame3D()
        f.add_node("A", 0.0)
        f.add_node("B", 0.0, 0.0, 3.0)
        f.add_beam("A", "B", vecxz=(1.0, 0, 0), E=e, A=4e-3, Iy=2e-5, Iz=5e-5, J=3e-5, nu=0.3,
                   rho=7850.0)
        f.add_mass("B", m)
        f.fix("A")
        return f

    named = frame("E", "m")
    assert named.parameters == ("E", "m")
    a = named.assemble({"E": 2.1e11, "m": 300.0}).system
    b = frame(2.1e11, 300.0).assemble().system
    np.testing.assert_array_equal(a.K, b.K)
    np.testing.assert_array_equal(a.M, b.M)
    with pytest.raises(ModelError, match="parameter 'm' has no value"):
        named.assemble({"E": 2.1e11})
    with pytest.raises(ModelError, match=r"E = -1\.0 is out of range"):
        named.assemble({"E": -1.0, "m": 1.0})


def test_structure_with_six_dofs_is_the_frame3d():
    frame = portal_frame()
    a = frame.assemble()
    b = as_structure(frame).assemble(direction="y")
    assert b.dof_labels == a.system.dof_labels
    for x, y in ((b.K, a.system.K), (b.M, a.system.M), (b.C, a.system.C)):
        np.testing.assert_allclose(x, y, rtol=1e-13, atol=1e-13 * np.abs(y).max())
    uy = a.uniform_system("y")
    np.testing.assert_allclose(b.r, uy.r)
    np.testing.assert_allclose(b.seismic_load, uy.seismic_load, rtol=1e-13,
                               atol=1e-13 * np.abs(uy.seismic_load).max())


def test_structure_with_diaphragms_is_the_frame3d():
    """Rigid diaphragms by the sparse transformation of Structure equal Frame3D's dense one:
    matrices, load, labels, and the follower DOFs refused by dof_index."""
    frame = example_frame(diaphragm=True, kappa_z=0.8)
    a = frame.assemble()
    s = as_structure(frame)
    for sparse in (False, True):
        b = s.assemble(sparse=sparse)
        assert b.dof_labels == a.system.dof_labels == s.dof_labels
        for x, y in ((b.K, a.system.K), (b.M, a.system.M), (b.C, a.system.C)):
            x = x.toarray() if sparse else x
            np.testing.assert_allclose(x, y, rtol=1e-13, atol=1e-13 * np.abs(y).max())
        np.testing.assert_allclose(b.r, a.system.r, atol=1e-12)
        np.testing.assert_allclose(b.seismic_load, a.system.seismic_load, rtol=1e-13,
                                   atol=1e-13 * np.abs(a.system.seismic_load).max())
    assert s.n_dof == a.system.n_dof
    assert s.dof_index("M1", "rz") == a.system.dof_labels.index("M1.rz")
    with pytest.raises(ModelError, match=r"N011\.ux follows the rigid diaphragm of 'M1'"):
        s.dof_index("N011", "ux")
    with pytest.raises(ModelError, match="friction element acts on a DOF that follows"):
        s.add_friction("N011", "ux", k_r=1.0, f_u=1.0)
        s.assemble()


def test_structure_with_six_dofs_takes_parameters():
    from femupdate.model.structure import Structure

    s = as_structure(portal_frame("E"))
    assert s.parameters == ("E",)
    np.testing.assert_allclose(s.assemble({"E": 2.1e11}).K, portal_frame().assemble().system.K,
                               rtol=1e-13, atol=1e-6)
    bad = Structure(dofs_per_node=6)
    bad.add_node("A", 0.0)
    bad.add_node("B", 1.0)
    with pytest.raises(ModelError, match="give Iy, Iz and J, not I"):
        bad.add_beam("A", "B", E=1.0, A=1.0, I=1.0, nu=0.3)
    with pytest.raises(ModelError, match="give G or nu"):
        bad.add_beam("A", "B", E=1.0, A=1.0, Iy=1.0, Iz=1.0, J=1.0, vecxz=(0, 0, 1.0))
    with pytest.raises(ModelError, match="parallel"):
        bad.add_beam("A", "B", E=1.0, A=1.0, Iy=1.0, Iz=1.0, J=1.0, nu=0.3, vecxz=(2.0, 0, 0))
    planar = Structure(dofs_per_node=3)
    with pytest.raises(ModelError, match=r"z = 1\.0 needs dofs_per_node=6"):
        planar.add_node("A", 0.0, 0.0, 1.0)

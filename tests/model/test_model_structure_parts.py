"""The pure functions ``Structure`` is made of: properties, topology, matrices, excitation."""

from __future__ import annotations

import numpy as np
import pytest

from femupdate.errors import ModelError
from femupdate.model import Structure, shear_building
from femupdate.model.description import beam_options, check_mass_dofs
from femupdate.model.excitation import coupling_blocks, rigid_translation, seismic_vector
from femupdate.model.matrices import damping_matrix, shear_modulus
from femupdate.model.nonlinear_elements import bouc_wen_elements, friction_elements
from femupdate.model.properties import (
    NONNEG,
    Record,
    Spec,
    parameter_names,
    parameter_vector,
    property_over,
)
from femupdate.model.topology import number_dofs, odd_link_dofs, scatter_plan


def test_parameter_vector_from_a_mapping_or_a_sequence() -> None:
    names = ("a", "b")
    np.testing.assert_array_equal(parameter_vector(names, {"b": 2.0, "a": 1.0}), [1.0, 2.0])
    np.testing.assert_array_equal(parameter_vector(names, [1.0, 2.0]), [1.0, 2.0])
    with pytest.raises(ModelError, match=r"unknown parameter\(s\) 'c'"):
        parameter_vector(names, {"a": 1.0, "b": 2.0, "c": 3.0})
    with pytest.raises(ModelError, match=r"missing value\(s\) for parameter\(s\) 'b'"):
        parameter_vector(names, {"a": 1.0})
    with pytest.raises(ModelError, match="got 3 parameter values; this structure has 2"):
        parameter_vector(names, [1.0, 2.0, 3.0])
    with pytest.raises(ModelError, match="parameter 'b' = nan; it must be finite"):
        parameter_vector(names, [1.0, float("nan")])
    with pytest.raises(ModelError, match="must be numbers"):
        parameter_vector(names, {"a": 1.0, "b": "x"})


def test_a_property_over_its_elements() -> None:
    recs = [Record("spring", "s1", {"k": 5.0}), Record("spring", "s2", {"k": "kp"}),
            Record("spring", "s3", {})]
    params = parameter_names(recs)
    assert params == ("kp",)
    prop = property_over(recs, "spring", "k", Spec(0.0, 10.0), params, default=7.0)
    assert not prop.is_const
    np.testing.assert_array_equal(prop.evaluate(np.array([3.0])), [5.0, 3.0, 7.0])
    with pytest.raises(ModelError, match=r"spring 's2': k = 11.0 \(parameter 'kp'\) is out "
                                         r"of range; allowed \[0, 10\]"):
        prop.evaluate(np.array([11.0]))
    const = property_over(recs[:1], "spring", "k", NONNEG, params)
    assert const.is_const
    assert const.evaluate(np.array([-1.0])) is const.const  # no parameter: nothing to check


def test_scatter_plan_drops_fixed_rows_and_columns() -> None:
    # one link from free DOF 1 to a fixed DOF (-1) in a 3 × 3 matrix
    target, keep = scatter_plan(np.array([[1, -1]]), 3)
    np.testing.assert_array_equal(target, [1 * 3 + 1])
    np.testing.assert_array_equal(keep, [0])
    target, keep = scatter_plan(np.array([[2, 0]]), 3)
    np.testing.assert_array_equal(target, [8, 6, 2, 0])
    np.testing.assert_array_equal(keep, [0, 1, 2, 3])


def test_number_dofs_labels_the_free_ones() -> None:
    dofs = number_dofs(2, 2, {0, 3}, ("A", "B"), ("uy", "rz"))
    assert dofs.n == 2
    assert dofs.labels == ("A.rz", "B.uy")
    np.testing.assert_array_equal(dofs.free, [-1, 0, 1, -1])
    with pytest.raises(ModelError, match="no nodes"):
        number_dofs(0, 2, set(), (), ("uy", "rz"))
    with pytest.raises(ModelError, match="every DOF is fixed"):
        number_dofs(1, 1, {0}, ("A",), ("ux",))


def test_odd_links_start_at_a_free_dof() -> None:
    ends = odd_link_dofs(np.array([[-1, 4], [2, -1], [1, 3]]))
    np.testing.assert_array_equal(ends, [[4, -1], [2, -1], [1, 3]])


def test_rigid_translation_and_its_direction() -> None:
    names = np.array(["ux", "uy", "rz", "ux", "uy", "rz"])
    np.testing.assert_array_equal(rigid_translation(names, ("ux", "uy", "rz"), 3, "y"),
                                  [0, 1, 0, 0, 1, 0])
    np.testing.assert_array_equal(rigid_translation(names, ("ux", "uy", "rz"), 3, None),
                                  [1, 0, 0, 1, 0, 0])
    with pytest.raises(ModelError, match=r"direction = 'z'; allowed \['x', 'y'\]"):
        rigid_translation(names, ("ux", "uy", "rz"), 3, "z")


def test_seismic_vector_is_none_without_coupling() -> None:
    none = (np.zeros(0, dtype=np.int64),) * 3
    assert seismic_vector(np.eye(2), np.ones(2), np.ones(2), none, np.zeros((0, 4, 4)), 2) is None
    # one coupling term: row 0 takes entry 1 of the stack times the support's rigid motion
    coupling = (np.array([0]), np.array([1]), np.array([2]))
    stack = np.array([[[0.0, 0.5], [0.0, 0.0]]])
    got = seismic_vector(np.eye(2), np.ones(2), np.array([1.0, 1.0, 1.0]), coupling, stack, 2)
    np.testing.assert_array_equal(got, [1.5, 1.0])


def test_damping_is_dampers_plus_rayleigh() -> None:
    s = shear_building([1.0, 2.0], [100.0, 50.0], [0.5, 0.25])
    s.set_rayleigh(alpha=0.1, beta=0.01)
    system = s.assemble()
    topo = s._topo()
    c = damping_matrix(topo, np.zeros(0), system.M, system.K,
                       lambda target, w, key="": np.bincount(target, weights=w,
                                                              minlength=4).reshape(2, 2))
    np.testing.assert_array_equal(c, system.C)
    dampers = np.array([[0.75, -0.25], [-0.25, 0.25]])
    np.testing.assert_allclose(system.C, dampers + 0.1 * system.M + 0.01 * system.K, rtol=1e-15)


def test_shear_modulus_given_from_nu_or_rigid() -> None:
    e = np.array([2.0, 2.6, 1.0])
    bp = {"G": np.array([0.7, 1.0, 1.0]), "nu": np.array([0.0, 0.3, 0.0])}
    np.testing.assert_allclose(shear_modulus(e, bp, np.array([1, 2, 0])), [0.7, 1.0, np.inf])


def test_nonlinear_elements_at_parameter_values() -> None:
    s = shear_building([1.0], [100.0], frictions=[{"k_r": 30.0, "f_u": "fu"}],
                       bouc_wen=[{"k": 20.0, "beta": 0.5, "gamma": "g"}])
    topo = s._topo()
    p = np.array([2.0, 0.25]) if s.parameters == ("fu", "g") else np.array([0.25, 2.0])
    fr = friction_elements(topo, p)
    assert fr is not None and fr.f_u.tolist() == [2.0] and fr.k_r.tolist() == [30.0]
    bw = bouc_wen_elements(topo, p)
    assert bw is not None and bw.names == ("bw1",)
    with pytest.raises(ModelError, match="gamma"):
        bouc_wen_elements(topo, np.array([2.0, 0.75]))  # γ > β: not admissible
    assert friction_elements(shear_building([1.0], [1.0])._topo(), np.zeros(0)) is None


def test_coupling_blocks_pick_rows_and_columns() -> None:
    s = Structure(dofs_per_node=1)
    for name in ("A", "B"):
        s.add_node(name, x=0.0)
    s.add_spring("A", "ux", 3.0, node2="B")
    s.add_mass("A", m=1.0)
    s.add_mass("B", m=1.0)
    released = s.assemble()
    k_fs, m_fs, c_fs = coupling_blocks(released, [("A", "ux")], ["B.ux"])
    np.testing.assert_array_equal(k_fs, [[-3.0]])
    np.testing.assert_array_equal(m_fs, [[0.0]])
    np.testing.assert_array_equal(c_fs, [[0.0]])


def test_beam_options_refuse_bad_beams() -> None:
    args = {"I": 1.0, "Iy": None, "Iz": None, "J": None, "vecxz": None, "rotary_inertia": True}
    options, extra = beam_options("beam 'b'", 3, ("A", "B"), (0.0, 0.0, 0.0), (1.0, 1.0, 0.0),
                                  G=None, nu=0.3, **args)
    assert options == {"shear": 2, "rotary": True} and extra == {}
    with pytest.raises(ModelError, match=r"length = 0\.0 between nodes 'A' and 'B'"):
        beam_options("beam 'b'", 3, ("A", "B"), (1.0, 0.0, 0.0), (1.0, 0.0, 0.0), G=None,
                     nu=None, **args)
    with pytest.raises(ModelError, match="along the x axis"):
        beam_options("beam 'b'", 2, ("A", "B"), (0.0, 0.0, 0.0), (1.0, 1.0, 0.0), G=None,
                     nu=None, **args)
    with pytest.raises(ModelError, match="give G or nu, not both"):
        beam_options("beam 'b'", 3, ("A", "B"), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), G=1.0,
                     nu=0.3, **args)


def test_a_mass_must_act_on_something() -> None:
    check_mass_dofs("mass 'm'", ["ux", "rz"], {"m": 1.0, "J": 1.0}, True)
    check_mass_dofs("mass 'm'", ["ux"], {"m": 1.0, "J": 0.0}, True)
    with pytest.raises(ModelError, match=r"dofs = \['ux'\] names no rotation, so J = 2.0"):
        check_mass_dofs("mass 'm'", ["ux"], {"m": 1.0, "J": 2.0}, True)

"""Multi-support excitation: pseudo-static split, uniform limit, record checks, OpenSeesPy."""

from __future__ import annotations

import numpy as np
import pytest

from femupdate.errors import ConfigError, DataError, MissingDependencyError
from femupdate.paper.bench.frame3d_check import (
    SUPPORT_GROUPS,
    example_frame,
    support_records,
    two_span_beam,
)
from femupdate.simulate import simulate
from femupdate.simulate.multisupport import (
    check_records,
    integrate_record,
    multi_support_response,
    pseudo_static_matrix,
    support_matrix,
)

DT = 0.01


def test_pseudo_static_part_is_the_static_solution():
    model = two_span_beam().assemble()
    e = support_matrix(model, SUPPORT_GROUPS)
    r = pseudo_static_matrix(model, e)
    # Equilibrium of the free DOFs with the supports displaced, and a rigid drop of all three
    # supports moves the beam rigidly.
    np.testing.assert_allclose(model.system.K @ r + model.K_fs @ e, 0.0, atol=1e-6)
    uz = np.array([lab.endswith(".uz") for lab in model.system.dof_labels])
    np.testing.assert_allclose(r.sum(axis=1)[uz], 1.0, rtol=1e-10)
    np.testing.assert_allclose(r.sum(axis=1)[~uz], 0.0, atol=1e-10)


def test_one_record_everywhere_is_the_uniform_excitation():
    frame = example_frame()
    model = frame.assemble()
    acc = support_records(200, DT)[:, :1]
    group = [[lab for lab in model.support_labels if lab.endswith(".ux")]]
    ms = multi_support_response(model, group, acc, DT, damping_coupling=False)
    rel = simulate(model.uniform_system("x"), DT, ag=acc[:, 0])
    _, disp = integrate_record(acc, DT)
    r_f, _ = model.rigid_influence("x")
    scale = np.abs(rel.displacement).max()
    np.testing.assert_allclose(ms.dynamic, rel.displacement, atol=1e-10 * scale)
    np.testing.assert_allclose(ms.total, rel.displacement + disp @ r_f[None, :], atol=1e-10 * scale)
    np.testing.assert_allclose(ms.acceleration, rel.acceleration,
                               atol=1e-10 * np.abs(rel.acceleration).max())


def test_integrated_record_is_exact_for_linear_acceleration():
    t = np.arange(50) * DT
    v, d = integrate_record(t, DT)  # a = t
    np.testing.assert_allclose(v, t**2 / 2, atol=1e-15)
    np.testing.assert_allclose(d, t**3 / 6, atol=1e-15)


@pytest.mark.parametrize(
    ("records", "match"),
    [
        ({"A": (np.zeros(10), 0.01), "B": (np.zeros(11), 0.01)}, "differ in length"),
        ({"A": (np.zeros(10), 0.01), "B": (np.zeros(10), 0.02)}, "differ in rate"),
        ({"A": (np.array([0.0, np.nan, 0.0]), 0.01)}, "NaN or inf at sample 1"),
        ({"A": (np.zeros(10), -1.0)}, "dt = -1.0"),
    ],
)
def test_bad_records_are_one_line(records, match):
    with pytest.raises(DataError, match=match) as err:
        check_records(records)
    assert "\n" not in str(err.value)


def test_unknown_support_dof_is_named():
    model = two_span_beam().assemble()
    with pytest.raises(ConfigError, match=r"'P3\.uz' is not a support DOF"):
        support_matrix(model, [["P3.uz"]])


@pytest.fixture(scope="module")
def figures():
    from femupdate.external.openseespy import import_opensees

    try:
        import_opensees()
    except MissingDependencyError as exc:
        pytest.skip(f"openseespy is not installed or does not import here: {exc}")
    from femupdate.paper.bench.frame3d_check import run_checks

    return run_checks(quick=True)


def test_against_opensees(figures):
    # Same equations, same scheme (Newmark, same step) in both codes: the differences are
    # rounding (about 1e-13 measured); the brief's bar is 1e-8.
    assert len(figures) == 9
    for name, value in figures.items():
        assert value < 1e-8, name


def test_two_horizontal_components_add_up():
    # x on every support's ux and y on every uy, as two records, is the sum of the two uniform
    # excitations (linear system; relative motion without the damping coupling).
    model = example_frame(diaphragm=True).assemble()
    acc = support_records(150, DT)[:, :2]
    groups = [[lab for lab in model.support_labels if lab.endswith(f".u{d}")] for d in "xy"]
    both = multi_support_response(model, groups, acc, DT, method="newmark",
                                  damping_coupling=False)
    x = simulate(model.uniform_system("x"), DT, ag=acc[:, 0], method="newmark")
    y = simulate(model.uniform_system("y"), DT, ag=acc[:, 1], method="newmark")
    expected = x.displacement + y.displacement
    np.testing.assert_allclose(both.dynamic, expected, atol=1e-10 * np.abs(expected).max())
    acc_abs = x.acceleration + y.acceleration
    np.testing.assert_allclose(both.acceleration, acc_abs, atol=1e-10 * np.abs(acc_abs).max())


@pytest.mark.parametrize("name", ["velocity", "displacement"])
def test_given_support_motions_of_another_shape_are_refused(name: str) -> None:
    # Issue 33: velocity=np.zeros((10, 3)) for 200 samples of 2 records gave numpy's broadcast
    # error.
    model = example_frame().assemble()
    groups = [["N000.ux"], ["N010.ux"]]
    acc = support_records(200, DT)[:, :2]
    with pytest.raises(DataError, match=rf"{name} has shape \(10, 3\); expected \(200, 2\)"):
        multi_support_response(model, groups, acc, DT, **{name: np.zeros((10, 3))})
    with pytest.raises(DataError, match=f"{name} has non-finite values"):
        multi_support_response(model, groups, acc, DT, **{name: np.full((200, 2), np.nan)})


@pytest.mark.parametrize("group", [[], "N010.ux"])
def test_an_empty_or_string_support_group_is_refused(group: object) -> None:
    model = example_frame().assemble()
    with pytest.raises(ConfigError, match="support motion: group 1 is"):
        support_matrix(model, [["N000.ux"], group])  # type: ignore[list-item]

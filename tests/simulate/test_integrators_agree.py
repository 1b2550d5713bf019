"""All integrators agree on the 10-DOF bridge-like system under a smooth random base motion.

The exact discretisation is the reference: for the same piecewise-linear input it is exact at
the samples, so the differences are the integrators' own errors (second order in h).
"""

from __future__ import annotations

import numpy as np
import pytest
from bridge_like import DT, PIER_DOFS, bridge_like

from femupdate.model.system import System
from femupdate.simulate import central_difference as cd_module
from femupdate.simulate import exact as exact_module
from femupdate.simulate import prepare, prepare_exact, simulate
from femupdate.simulate.central_difference import modal_damping

PIERS = list(PIER_DOFS)


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


@pytest.fixture(scope="module")
def reference(bridge, base_motion):
    return simulate(bridge, DT, ag=base_motion)


@pytest.mark.parametrize(
    ("method", "substeps"), [("central_difference", 10), ("newmark", 10), ("nonlinear", 10)]
)
def test_sub_stepped_integrators_match_exact(bridge, base_motion, reference, method, substeps):
    r = simulate(bridge, DT, ag=base_motion, method=method, substeps=substeps)
    assert not r.diverged
    assert rel(r.displacement[:, PIERS], reference.displacement[:, PIERS]) <= 1e-3
    assert rel(r.velocity[:, PIERS], reference.velocity[:, PIERS]) <= 1e-3
    # absolute acceleration weighs the 1 kHz abutment modes by ω², where a 1.7 % period error
    # of central differences at h·ω = 0.64 accumulates: a looser, still discriminating bound
    assert rel(r.acceleration[:, PIERS], reference.acceleration[:, PIERS]) <= 1e-2


def test_newmark_at_the_sample_rate_is_visibly_worse(bridge, base_motion, reference):
    """Pitfall §6: average acceleration at the sample rate elongates the periods (~1e-2 here)."""
    r = simulate(bridge, DT, ag=base_motion, method="newmark")
    err = rel(r.displacement[:, PIERS], reference.displacement[:, PIERS])
    assert 3e-3 < err < 1e-1


def test_exact_modal_equals_matrix_exponential_fallback(bridge, base_motion, monkeypatch):
    modal = prepare_exact(bridge, DT)
    assert modal.modal
    monkeypatch.setattr(exact_module, "MAX_EIGVEC_CONDITION", 0.0)
    dense = prepare_exact(bridge, DT)
    assert not dense.modal
    rng = np.random.default_rng(3)
    force = np.outer(np.sin(np.arange(base_motion.size) * DT * 60.0), rng.standard_normal(10))
    x0, v0 = 1e-4 * rng.standard_normal(10), 1e-2 * rng.standard_normal(10)
    a = modal.run(base_motion, force, x0=x0, v0=v0)
    b = dense.run(base_motion, force, x0=x0, v0=v0)
    for name in ("displacement", "velocity", "acceleration"):
        assert rel(getattr(a, name), getattr(b, name)) <= 1e-9, name


def test_forces_and_initial_state_agree_across_integrators(bridge):
    """Nodal forces and a non-zero initial state follow the same path in every integrator."""
    n = 2000
    t = np.arange(n) * DT
    force = np.zeros((n, 10))
    force[:, 4] = 50.0 * np.sin(2 * np.pi * 12.0 * t) * np.exp(-t)
    force[:, 3] = 5.0 * (t < 0.2)
    x0 = np.zeros(10)
    x0[2] = 1e-4
    v0 = np.zeros(10)
    v0[6] = -1e-2
    ref = simulate(bridge, DT, force=force, x0=x0, v0=v0)
    for method in ("central_difference", "newmark", "nonlinear"):
        r = simulate(bridge, DT, force=force, x0=x0, v0=v0, method=method, substeps=10)
        assert rel(r.displacement[:, PIERS], ref.displacement[:, PIERS]) <= 1e-3, method


def test_outputs_select_columns(bridge, base_motion):
    for method, sub in (("exact", 1), ("central_difference", 10), ("newmark", 2)):
        full = simulate(bridge, DT, ag=base_motion[:500], method=method, substeps=sub)
        part = simulate(bridge, DT, ag=base_motion[:500], method=method, substeps=sub,
                        outputs=[6, 2])  # fmt: skip
        for name in ("displacement", "velocity", "acceleration"):
            np.testing.assert_allclose(
                getattr(part, name), getattr(full, name)[:, [6, 2]], rtol=1e-12, atol=1e-18
            )
        np.testing.assert_array_equal(part.t, np.arange(500) * DT)


def test_prepared_simulators_are_reusable_and_repeatable(bridge, base_motion):
    for method, sub in (("exact", 1), ("central_difference", 10), ("newmark", 1)):
        sim = prepare(bridge, DT, method=method, substeps=sub, outputs=PIERS)
        a = sim.run(base_motion)
        sim.run(-2.0 * base_motion)
        b = sim.run(base_motion)
        np.testing.assert_array_equal(a.displacement, b.displacement)
        np.testing.assert_array_equal(a.acceleration, b.acceleration)


# ------------------------------------------------------------------- friction


def without_friction(system: System, add_stuck: bool) -> System:
    k = system.K + (system.friction.stuck_stiffness(system.n_dof) if add_stuck else 0.0)
    return System(M=system.M, C=system.C, K=k, r=system.r)


def test_infinite_slip_force_equals_the_linear_stuck_model(base_motion):
    fric = bridge_like(friction=True, f_u=(np.inf,) * 4)
    lin = without_friction(fric, add_stuck=True)
    r = simulate(fric, DT, ag=base_motion, method="nonlinear", substeps=10)
    ref = simulate(lin, DT, ag=base_motion, method="central_difference", substeps=10)
    # same recurrence with K split differently: rounding, grown over 47,680 undamped steps
    for name in ("displacement", "velocity", "acceleration"):
        assert rel(getattr(r, name), getattr(ref, name)) <= 1e-8, name
    # the element forces are those of linear springs k_r, and nothing slips
    b = fric.friction.connectivity(10)
    np.testing.assert_allclose(
        r.friction_force, (r.displacement @ b.T) * fric.friction.k_r, rtol=1e-12, atol=1e-15
    )
    assert np.all(r.slip == 0.0)


def test_zero_slip_force_equals_the_model_without_the_elements(base_motion):
    fric = bridge_like(friction=True, f_u=(0.0,) * 4)
    lin = without_friction(fric, add_stuck=False)
    r = simulate(fric, DT, ag=base_motion, method="nonlinear", substeps=10)
    ref = simulate(lin, DT, ag=base_motion, method="central_difference", substeps=10)
    for name in ("displacement", "velocity", "acceleration"):
        assert rel(getattr(r, name), getattr(ref, name)) <= 1e-12, name
    assert np.all(r.friction_force == 0.0)


def test_friction_outputs_follow_the_law_and_dissipate(base_motion):
    fric = bridge_like(friction=True)
    r = simulate(fric, DT, ag=base_motion, method="nonlinear", substeps=10)
    assert not r.diverged
    f, yr = r.friction_force, r.slip
    assert f.shape == yr.shape == (base_motion.size, 5)
    assert np.all(np.abs(f) <= fric.friction.f_u * (1 + 1e-12))
    y = r.displacement @ fric.friction.connectivity(10).T
    np.testing.assert_allclose(f, fric.friction.k_r * (y - yr), rtol=1e-9, atol=1e-9)
    # this motion makes every element slip: the model is really nonlinear
    assert np.all(np.ptp(yr, axis=0) > 0)
    assert np.all(np.max(np.abs(f), axis=0) == pytest.approx(fric.friction.f_u))


def test_nonlinear_on_a_linear_system_equals_central_differences(bridge, base_motion):
    a = simulate(bridge, DT, ag=base_motion, method="nonlinear", substeps=10)
    b = simulate(bridge, DT, ag=base_motion, method="central_difference", substeps=10)
    np.testing.assert_array_equal(a.displacement, b.displacement)
    assert a.friction_force is None


# ------------------------------------------------------- modal central differences


def test_modal_damping_detects_whether_the_modes_diagonalise_c(bridge):
    assert modal_damping(bridge.M, bridge.C, bridge.K) is None  # discrete dashpots couple modes
    rayleigh = 0.3 * bridge.M + 2e-4 * bridge.K
    w2, phi, c = modal_damping(bridge.M, rayleigh, bridge.K)
    np.testing.assert_allclose(phi.T @ bridge.M @ phi, np.eye(10), atol=1e-12)
    np.testing.assert_allclose(c, 0.3 + 2e-4 * w2, rtol=1e-10)
    assert modal_damping(bridge.M, np.zeros((10, 10)), bridge.K)[2].tolist() == [0.0] * 10


@pytest.mark.parametrize("friction", [True, False])
def test_modal_and_physical_central_differences_agree(base_motion, monkeypatch, friction):
    system = bridge_like(friction=friction)
    if not friction:  # proportional damping, so that the modal form applies
        system = System(M=system.M, C=0.3 * system.M + 2e-4 * system.K, K=system.K, r=system.r)
    method = "nonlinear" if friction else "central_difference"
    modal = prepare(system, DT, method=method, substeps=10)
    assert modal.modal
    monkeypatch.setattr(cd_module, "modal_damping", lambda M, C, K: None)
    physical = prepare(system, DT, method=method, substeps=10)
    assert not physical.modal
    x0 = np.linspace(-1e-4, 1e-4, 10)
    a = modal.run(base_motion, x0=x0, v0=-x0)
    b = physical.run(base_motion, x0=x0, v0=-x0)
    names = ["displacement", "velocity", "acceleration"] + (["friction_force", "slip"] * friction)
    for name in names:  # the same recurrence in other coordinates: rounding only (1e-12…1e-10)
        assert rel(getattr(a, name), getattr(b, name)) <= 1e-9, name

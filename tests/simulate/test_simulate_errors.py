"""Bad inputs raise the right error with a useful message; divergence never raises."""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
import scipy.linalg as sla
from bridge_like import DT, bridge_like

from femupdate.errors import ConfigError, DataError, ModelError, SimulationError
from femupdate.model.system import FrictionElements, System
from femupdate.simulate import prepare, simulate


def sdof(k: float = 100.0) -> System:
    return System(M=np.eye(1), C=np.array([[0.1]]), K=np.array([[k]]), r=np.ones(1))


@pytest.mark.parametrize("method", ["exact", "central_difference", "newmark", "nonlinear"])
def test_nan_in_base_acceleration_names_argument_and_sample(method):
    ag = np.zeros(20)
    ag[7] = np.nan
    with pytest.raises(DataError, match=r"ag contains NaN or inf at sample 7"):
        simulate(sdof(), 0.01, ag=ag, method=method)


def test_inf_in_force_names_argument_sample_and_dof(bridge):
    force = np.zeros((30, 10))
    force[12, 3] = np.inf
    with pytest.raises(DataError, match=r"force contains NaN or inf at sample 12, DOF 3"):
        simulate(bridge, DT, force=force)


def test_unstable_step_gives_largest_stable_step_and_substeps(bridge):
    w_max = np.sqrt(sla.eigvalsh(bridge.K, bridge.M)[-1])
    h_crit = 2.0 / w_max
    needed = int(np.ceil(DT / h_crit))
    with pytest.raises(SimulationError) as info:
        simulate(bridge, DT, ag=np.zeros(10), method="central_difference")
    msg = str(info.value)
    assert f"largest stable step is {h_crit:.6g} s" in msg
    assert f"substeps >= {needed}" in msg
    # and that number of substeps does work
    simulate(bridge, DT, ag=np.zeros(10), method="central_difference", substeps=needed)


def test_unstable_step_of_friction_system_uses_stuck_stiffness():
    fric = System(
        M=np.eye(1), C=np.zeros((1, 1)), K=np.array([[100.0]]), r=np.ones(1),
        friction=FrictionElements(np.array([0]), np.array([-1]), np.array([9900.0]),
                                  np.array([1.0])),
    )  # fmt: skip
    # ω = 10 without the element, 100 with it stuck: h = 0.05 is stable for 10, not for 100
    with pytest.raises(SimulationError, match=r"largest stable step is 0\.02 s"):
        simulate(fric, 0.05, ag=np.zeros(10), method="nonlinear")


def test_conditionally_stable_newmark_is_checked():
    # β = 0, γ = 0.5: explicit, stable for h ω < 2
    with pytest.raises(SimulationError, match=r"largest stable step is 0\.02 s"):
        simulate(sdof(k=1e4), 0.05, ag=np.zeros(5), method="newmark", newmark_beta=0.0)
    simulate(sdof(k=1e4), 0.05, ag=np.zeros(5), method="newmark", newmark_beta=0.0, substeps=3)


@pytest.mark.parametrize(
    ("kwargs", "pattern"),
    [
        (dict(ag=np.zeros((5, 2))), r"ag has shape \(5, 2\); expected \(n_samples,\)"),
        (dict(ag=np.zeros(0)), r"ag has shape \(0,\)"),
        (dict(force=np.zeros((5, 3))), r"force has shape \(5, 3\); expected \(n_samples, 2\)"),
        (dict(ag=np.zeros(5), force=np.zeros((6, 2))), r"force has 6 samples but ag has 5"),
        (dict(ag=np.zeros(5), x0=np.zeros(3)), r"x0 has shape \(3,\); expected \(2,\)"),
        (dict(ag=np.zeros(5), v0=[0.0, np.nan]), r"v0 contains NaN"),
        (dict(ag=np.array([1j, 2j])), r"ag must be an array of real numbers"),
        (dict(), r"no input"),
    ],
)
def test_wrong_shapes_and_values(kwargs, pattern):
    system = System(M=np.eye(2), C=np.zeros((2, 2)), K=np.eye(2), r=np.ones(2))
    with pytest.raises(DataError, match=pattern):
        simulate(system, 0.01, **kwargs)


def test_unknown_method_lists_the_methods():
    with pytest.raises(ConfigError, match="'rk4' is unknown; choose one of exact, central_diff"):
        simulate(sdof(), 0.01, ag=np.zeros(5), method="rk4")


@pytest.mark.parametrize("method", ["exact", "central_difference", "newmark"])
def test_friction_system_with_linear_method_says_use_nonlinear(method):
    with pytest.raises(SimulationError, match="5 friction elements: use method='nonlinear'"):
        simulate(bridge_like(friction=True), DT, ag=np.zeros(5), method=method, substeps=4)


@pytest.mark.parametrize(
    ("beta", "gamma", "pattern"),
    [
        (0.25, 0.4, r"newmark_gamma = 0\.4 is not allowed; it must lie in \[0\.5, 1\.0\]"),
        (-0.1, 0.5, r"newmark_beta = -0\.1 is not allowed; it must lie in \[0\.0, 1\.0\]"),
        (np.nan, 0.5, r"newmark_beta = nan is not allowed"),
        ("a", 0.5, r"must be numbers"),
    ],
)
def test_invalid_newmark_parameters(beta, gamma, pattern):
    with pytest.raises(ConfigError, match=pattern):
        simulate(sdof(), 0.01, ag=np.zeros(5), method="newmark",
                 newmark_beta=beta, newmark_gamma=gamma)  # fmt: skip


@pytest.mark.parametrize(
    ("kwargs", "pattern"),
    [
        (dict(dt=0.0), r"dt = 0\.0 is not allowed"),
        (dict(dt=np.nan), r"dt = nan is not allowed"),
        (dict(substeps=0, method="newmark"), r"substeps = 0 is not allowed; it must be >= 1"),
        (dict(substeps=2.5, method="newmark"), r"substeps = 2\.5 must be an integer"),
        (dict(substeps=2), r"exact discretisation needs no substeps"),
        (dict(outputs=[0, 3]), r"outputs contains DOF index 3; allowed indices are 0 to 0"),
        (dict(outputs=[]), r"non-empty sequence of DOF indices"),
    ],
)
def test_invalid_options(kwargs, pattern):
    kw = dict(dt=0.01) | kwargs
    with pytest.raises(ConfigError, match=pattern):
        simulate(sdof(), ag=np.zeros(5), **kw)


def test_invalid_systems():
    with pytest.raises(ModelError, match=r"system\.M is not positive definite"):
        simulate(System(M=np.zeros((1, 1)), C=np.zeros((1, 1)), K=np.eye(1), r=np.ones(1)),
                 0.01, ag=np.zeros(3))  # fmt: skip
    with pytest.raises(ModelError, match=r"system.K has shape \(2, 2\); expected \(1, 1\)"):
        simulate(System(M=np.eye(1), C=np.zeros((1, 1)), K=np.eye(2), r=np.ones(1)),
                 0.01, ag=np.zeros(3))  # fmt: skip
    bad = System(
        M=np.eye(1), C=np.zeros((1, 1)), K=np.eye(1), r=np.ones(1),
        friction=FrictionElements(np.array([0]), np.array([-1]), np.array([-1.0]),
                                  np.array([1.0])),
    )  # fmt: skip
    with pytest.raises(ModelError, match=re.escape("friction element 0: k_r = -1.0")):
        simulate(bad, 0.01, ag=np.zeros(3), method="nonlinear")


@pytest.mark.parametrize("method", ["exact", "central_difference", "newmark", "nonlinear"])
def test_divergence_returns_a_flag_without_raising_or_warning(method):
    """A negative stiffness grows as e^{100 t}: overflow within 10 s, flagged, NaN outputs."""
    unstable = sdof(k=-1e4)
    ag = np.ones(1000)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = simulate(unstable, 0.01, ag=ag, method=method)
    assert r.diverged
    assert np.all(np.isnan(r.displacement)) and np.all(np.isnan(r.acceleration))
    stable = simulate(sdof(), 0.01, ag=ag, method=method)
    assert not stable.diverged


def test_prepare_rejects_unknown_method_too():
    with pytest.raises(ConfigError, match="unknown"):
        prepare(sdof(), 0.01, method="Exact")

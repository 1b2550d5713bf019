"""The error model: blocks of a case's residuals, the integrated-variance likelihood, N_eff."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate

from femupdate.case import parse_case
from femupdate.errors import ConfigError, DataError
from femupdate.experiment import load_experiments
from femupdate.posterior.likelihood import (
    ar_fit,
    ar_order,
    effective_count,
    error_model,
    lag1_autocorrelation,
    problem_error_model,
    residual_blocks,
)
from femupdate.posterior.method import error_model_data, error_model_from
from femupdate.update import UpdateProblem
from femupdate.virtual import virtual_experiment
from two_storey_case import TRUTH, two_storey_spec


def _spec(root: Path) -> dict:
    return two_storey_spec(root / "a", trials=[
        {"name": "a", "directory": str(root / "a")},
        {"name": "b", "directory": str(root / "b"), "weight": 3.0}])


@pytest.fixture(scope="module")
def problem(tmp_path_factory: pytest.TempPathFactory) -> UpdateProblem:
    root = tmp_path_factory.mktemp("blocks")
    case = parse_case(_spec(root), source=root / "case.toml")
    for folder, seed, rate in (("a", 1, 200.0), ("b", 2, 250.0)):
        virtual_experiment(case, TRUTH, root / folder, seed=seed, rate=rate, duration=2.0,
                           snr=0.03)
    return UpdateProblem(case, load_experiments(case))


def test_blocks_follow_the_residual_layout_trial_by_channel(problem: UpdateProblem) -> None:
    blocks, removed = residual_blocks(problem)
    x = problem.case.to_search(TRUTH)
    r = problem.residuals(x)
    assert len(blocks) == 4 and blocks[-1].stop == r.size
    assert removed == (2, 2, 2, 2)  # experimental parameters: a + b t fitted per channel
    # each block is one trial's channel: its squared norm is that channel's share of φ
    trial_a = problem.fitted[0]
    ra = trial_a.residuals(problem.case.to_physical(x))
    n_a = trial_a.objective.target.shape[0]
    assert blocks[0] == slice(0, n_a) and blocks[1] == slice(n_a, 2 * n_a)
    share_a = 0.25  # weights 1 and 3
    assert np.allclose(r[blocks[0]], math.sqrt(share_a) * ra[:n_a])
    assert np.allclose(r[blocks[1]], math.sqrt(share_a) * ra[n_a:])


def test_integrated_variance_matches_numerical_integration() -> None:
    rng = np.random.default_rng(3)
    r = 0.3 * rng.standard_normal(12)
    model = error_model([slice(0, 12)], "iid")

    def integrand(s: float) -> float:  # Gaussian likelihood × Jeffreys prior 1/v, v = e^s
        v = math.exp(s)
        return (2 * math.pi * v) ** -6 * math.exp(-(r @ r) / (2 * v))

    centre = math.log(r @ r / 12)
    value, _ = integrate.quad(integrand, centre - 30, centre + 30, limit=200)
    assert model.loglike(r) == pytest.approx(math.log(value), rel=1e-8)


def test_blocks_are_independent_and_scale_free() -> None:
    rng = np.random.default_rng(4)
    r = rng.standard_normal(30)
    two = error_model([slice(0, 10), slice(10, 30)], "iid")
    a = error_model([slice(0, 10)], "iid").loglike(r[:10])
    b = error_model([slice(0, 20)], "iid").loglike(r[10:])
    assert two.loglike(r) == pytest.approx(a + b)
    scaled = r.copy()
    scaled[:10] *= 7.0  # a block's scale only shifts log L by a constant
    shift = two.loglike(scaled) - two.loglike(r)
    r2 = r + 0.1 * rng.standard_normal(30)
    s2 = r2.copy()
    s2[:10] *= 7.0
    assert two.loglike(s2) - two.loglike(r2) == pytest.approx(shift)


def test_batch_rows_equal_single_calls_and_failures_are_minus_inf() -> None:
    rng = np.random.default_rng(5)
    rows = rng.standard_normal((4, 40))
    rows[2, 7] = np.nan
    model = error_model([slice(0, 25), slice(25, 40)], "neff", best_residuals=rows[0])
    out = model.loglike_rows(rows)
    assert out[2] == -np.inf
    for i in (0, 1, 3):
        assert out[i] == model.loglike(rows[i])


def test_effective_count_of_an_ar1_series() -> None:
    rng = np.random.default_rng(6)
    rho, n = 0.9, 200_000
    e = np.empty(n)
    e[0] = rng.standard_normal()
    for t in range(1, n):
        e[t] = rho * e[t - 1] + rng.standard_normal()
    assert lag1_autocorrelation(e) == pytest.approx(rho, abs=0.005)
    model = error_model([slice(0, n)], "neff", best_residuals=e)
    assert model.counts[0] == pytest.approx(n * 0.1 / 1.9, rel=0.06)
    assert effective_count(100, -0.5) == 100.0  # never more than N


def test_ar1_whitens_an_ar1_series() -> None:
    rng = np.random.default_rng(7)
    rho, n = 0.8, 20_000
    u = rng.standard_normal(n)
    e = np.empty(n)
    e[0] = u[0]
    for t in range(1, n):
        e[t] = rho * e[t - 1] + u[t]
    model = error_model([slice(0, n)], "ar1", best_residuals=e)
    white = model.whiten(e)[0]
    assert white.size == n - 1
    assert abs(lag1_autocorrelation(white)) < 0.03
    assert model.counts[0] == n - 1


def _ar_series(coefficients: list[float], n: int, rng: np.random.Generator) -> np.ndarray:
    """An AR process x_t = Σ_k a_k x_{t−k} + u_t, u white of unit variance."""
    from scipy.signal import lfilter

    return lfilter([1.0], np.concatenate([[1.0], -np.asarray(coefficients)]),
                   rng.standard_normal(n))


def test_arp_recovers_the_order_and_coefficients_of_an_ar3_series() -> None:
    rng = np.random.default_rng(11)
    truth = [1.6, -0.9, 0.2]
    n = 20_000
    x = _ar_series(truth, n, rng)
    assert ar_order(x, 12) == 3
    a, _ = ar_fit(x, 3)
    assert a == pytest.approx(truth, abs=0.05)  # 4 asymptotic sd of a_2 (0.012)
    model = error_model([slice(0, n)], "arp", best_residuals=x, dof_removed=[2])
    assert model.lag == 3 and model.counts[0] == n - 3 - 2
    white = model.whiten(x)[0]
    assert white.size == n - 3
    assert abs(lag1_autocorrelation(white)) < 0.03
    # the innovations by hand: the likelihood is the i.i.d. one of them
    by_hand = x[3:] - sum(c * x[3 - k - 1:n - k - 1] for k, c in enumerate(model.ar[0]))
    assert white == pytest.approx(by_hand, rel=1e-12, abs=1e-12)
    iid = error_model([slice(0, n - 3)], "iid", dof_removed=[2])
    assert model.loglike(x) == pytest.approx(iid.loglike(by_hand), rel=1e-12)


def test_arp_blocks_share_one_order_and_round_trip_as_data() -> None:
    rng = np.random.default_rng(12)
    x = np.concatenate([_ar_series([0.5], 3000, rng), _ar_series([1.6, -0.9, 0.2], 3000, rng)])
    model = error_model([slice(0, 3000), slice(3000, 6000)], "arp", best_residuals=x)
    assert model.ar.shape == (2, 3)  # the larger order of the two blocks, for both
    assert model.ar[0] == pytest.approx([0.5, 0.0, 0.0], abs=0.05)
    again = error_model_from(error_model_data(model))
    rows = np.vstack([x, 1.1 * x, np.full_like(x, np.nan)])
    assert np.array_equal(again.loglike_rows(rows), model.loglike_rows(rows))
    assert model.loglike_rows(rows)[2] == -np.inf
    with pytest.raises(ConfigError, match="order 5 for a block of 12 samples"):
        ar_fit(x[:12], 5)


def test_weights_are_the_hessian_of_the_log_likelihood() -> None:
    """−∂²log L/∂θ² of r(θ) = a·θ − y at θ where aᵀr = 0 equals aᵀ W a."""
    rng = np.random.default_rng(8)
    a = rng.standard_normal(50)
    y = rng.standard_normal(50)
    theta = (a @ y) / (a @ a)
    model = error_model([slice(0, 20), slice(20, 50)], "iid")
    h = 1e-4
    f = [model.loglike(a * (theta + s) - y) for s in (-h, 0.0, h)]
    hess = -(f[0] - 2 * f[1] + f[2]) / h ** 2
    w = model.weights(a * theta - y)
    # the dropped (Jᵀr)(rᵀJ) terms are of the blocks' own aᵀr, not zero per block
    assert a @ (w * a) == pytest.approx(hess, rel=0.15)
    known = error_model([slice(0, 50)], "known", sigma=0.5)
    assert np.all(known.weights(y) == 4.0)


def test_problem_error_model_and_bad_input(problem: UpdateProblem) -> None:
    r = problem.residuals(problem.case.to_search(TRUTH))
    model = problem_error_model(problem, r)
    assert model.kind == "neff" and model.size == r.size
    assert np.all(model.counts < (model.stops - model.starts))  # correlated residuals
    tau = problem_error_model(problem, r, "tau")
    assert np.all(tau.counts < (tau.stops - tau.starts))
    with pytest.raises(ConfigError, match="allowed: neff, tau, iid, ar1, arp, adjusted, known"):
        error_model([slice(0, 5)], "gaussian")
    with pytest.raises(ConfigError, match="needs the residuals"):
        error_model([slice(0, 5)], "neff")
    with pytest.raises(DataError, match="all zero"):
        error_model([slice(0, 5)], "neff", best_residuals=np.zeros(5))
    with pytest.raises(ConfigError, match="sigma must be > 0"):
        error_model([slice(0, 5)], "known", sigma=0.0)


def test_adjusted_error_model_of_a_case_and_its_laplace_record(problem: UpdateProblem) -> None:
    from femupdate.posterior.best_fit import laplace_record
    from femupdate.posterior.jacobian import residual_jacobian

    x = problem.case.to_search(TRUTH)
    r, jac = residual_jacobian(problem.residuals_batch, problem.bounds, x)
    model = problem_error_model(problem, r, "adjusted", jac)
    iid = problem_error_model(problem, r, "iid")
    # one power for every block, below 1: the residuals of a time history are correlated
    ratio = model.counts / iid.counts
    assert np.all(ratio < 1.0) and np.ptp(ratio) < 1e-12
    record = laplace_record(problem, x, kind="adjusted")
    assert record.note is None and record.error_model == "adjusted"

"""The error models set aside (benchmarks/error_models/kinds.py): AR whitening, τ, the
magnitude adjustment, registered beside the product's."""

from __future__ import annotations

import numpy as np
import pytest
from error_models.kinds import ar_fit, ar_order, error_model, problem_error_model, registry

from femupdate.case import parse_case
from femupdate.errors import ConfigError
from femupdate.inference.likelihood import lag1_autocorrelation
from femupdate.problem.update import UpdateProblem
from femupdate.trials.experiment import load_experiments
from femupdate.trials.virtual import virtual_experiment
from two_storey_case import TRUTH, two_storey_spec


@pytest.fixture(scope="module")
def problem(tmp_path_factory: pytest.TempPathFactory) -> UpdateProblem:
    root = tmp_path_factory.mktemp("kinds")
    case = parse_case(two_storey_spec(root), source=root / "case.toml")
    virtual_experiment(case, TRUTH, root, seed=1, rate=200.0, duration=2.0, snr=0.03)
    return UpdateProblem(case, load_experiments(case))


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
    again = registry().from_data(model.data())
    rows = np.vstack([x, 1.1 * x, np.full_like(x, np.nan)])
    assert np.array_equal(again.loglike_rows(rows), model.loglike_rows(rows))
    assert model.loglike_rows(rows)[2] == -np.inf
    with pytest.raises(ConfigError, match="order 5 for a block of 12 samples"):
        ar_fit(x[:12], 5)


def test_tau_counts_fewer_than_the_samples_of_correlated_residuals(
        problem: UpdateProblem) -> None:
    r = problem.residuals(problem.case.to_search(TRUTH))
    tau = problem_error_model(problem, r, "tau")
    assert np.all(tau.counts < (tau.stops - tau.starts))


def test_adjusted_takes_one_power_below_one_for_every_block(problem: UpdateProblem) -> None:
    from femupdate.inference.jacobian import residual_jacobian

    x = problem.case.to_search(TRUTH)
    r, jac = residual_jacobian(problem.residuals_batch, problem.bounds, x)
    model = problem_error_model(problem, r, "adjusted", jac)
    iid = problem_error_model(problem, r, "iid")
    # one power for every block, below 1: the residuals of a time history are correlated
    ratio = model.counts / iid.counts
    assert np.all(ratio < 1.0) and np.ptp(ratio) < 1e-12

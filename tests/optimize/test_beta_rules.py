"""The update rules of IB and AB (the paper's §2.2.3–2.2.4; docs/method.md §4–5), step by
step against hand computations."""

from __future__ import annotations

import math

import numpy as np
import pytest

from femupdate.optimize import beta_mode_variance
from femupdate.optimize.beta import SIGMA_CAP, VARIANCE_CAP, VARIANCE_FLOOR, BetaSearch


def _tell(opt: BetaSearch, xi: list[float], f: float) -> None:
    opt.tell(np.array([xi]), np.array([f]))


def _check_distribution(opt: BetaSearch, variances: np.ndarray) -> None:
    """(a, b) have the mode in force and the expected variances."""
    mode, var = beta_mode_variance(opt.a, opt.b)
    np.testing.assert_allclose(var, variances, rtol=1e-9)
    np.testing.assert_allclose(mode, opt.mode, rtol=1e-9, atol=1e-12)


def test_first_step_uniform_and_always_successful() -> None:
    opt = BetaSearch(3, np.random.default_rng(0), anisotropic=False, sigma0=0.1)
    np.testing.assert_array_equal(opt.a, 1.0)
    np.testing.assert_array_equal(opt.b, 1.0)
    _tell(opt, [0.2, 0.4, 0.9], math.nan)  # even a failed evaluation
    np.testing.assert_array_equal(opt.mode, [0.2, 0.4, 0.9])
    assert opt.sigma == pytest.approx(0.1 * 2 ** (1 / 3), rel=1e-15)
    _check_distribution(opt, np.full(3, opt.sigma**2))


def test_ib_success_and_failure() -> None:
    n = 4
    alpha = 2 ** (1 / n)
    opt = BetaSearch(n, np.random.default_rng(0), anisotropic=False, sigma0=0.05)
    _tell(opt, [0.5, 0.5, 0.5, 0.5], 1.0)
    sigma = 0.05 * alpha
    _tell(opt, [0.6, 0.1, 0.5, 0.9], 0.5)  # success: mode moves, σ grows by α
    sigma *= alpha
    np.testing.assert_array_equal(opt.mode, [0.6, 0.1, 0.5, 0.9])
    assert opt.sigma == pytest.approx(sigma, rel=1e-14)
    assert opt.phi_m == 0.5
    _tell(opt, [0.0, 0.0, 0.0, 0.0], 0.5)  # not lower: failure, σ shrinks by α^(-1/4)
    sigma *= alpha**-0.25
    np.testing.assert_array_equal(opt.mode, [0.6, 0.1, 0.5, 0.9])
    assert opt.sigma == pytest.approx(sigma, rel=1e-14)
    _check_distribution(opt, np.full(n, sigma**2))
    _tell(opt, [0.0, 0.0, 0.0, 0.0], math.inf)  # a failed evaluation is a failed step
    sigma *= alpha**-0.25
    assert opt.sigma == pytest.approx(sigma, rel=1e-14)


def test_sigma_cap() -> None:
    assert SIGMA_CAP < math.sqrt(1 / 12)
    opt = BetaSearch(2, np.random.default_rng(0), anisotropic=False)
    assert opt.sigma == SIGMA_CAP
    for k in range(5):  # successes only
        _tell(opt, [0.5, 0.5 + 0.01 * k], -float(k))
        assert opt.sigma == SIGMA_CAP
    assert np.all(opt.var < VARIANCE_CAP)


def test_ab_weights_from_last_n_increments() -> None:
    opt = BetaSearch(2, np.random.default_rng(0), anisotropic=True, sigma0=0.01)
    _tell(opt, [0.5, 0.5], 1.0)  # first step: no increment recorded, records all 1
    _check_distribution(opt, np.full(2, opt.sigma**2))
    _tell(opt, [0.6, 0.5], 0.5)  # increment (0.1, 0) -> records (0.1, 0), (1, 1)
    nu = np.array([(0.1**2 + 1) / 2, (0 + 1) / 2])
    _check_distribution(opt, nu / nu.max() * opt.sigma**2)
    _tell(opt, [0.7, 0.45], 0.1)  # records (0.1, 0), (0.1, -0.05)
    nu = np.array([0.01, 0.0025 / 2])
    _check_distribution(opt, nu / nu.max() * opt.sigma**2)
    _tell(opt, [0.9, 0.9], 0.2)  # failure: records unchanged
    _check_distribution(opt, nu / nu.max() * opt.sigma**2)
    _tell(opt, [0.7, 0.55], 0.05)  # (0, 0.1) replaces the oldest record (0.1, 0)
    nu = np.array([0.01 / 2, (0.01 + 0.0025) / 2])
    np.testing.assert_allclose(nu / nu.max(), [0.8, 1.0])
    _check_distribution(opt, nu / nu.max() * opt.sigma**2)


def test_ab_floor_keeps_a_frozen_parameter_positive() -> None:
    opt = BetaSearch(2, np.random.default_rng(0), anisotropic=True, sigma0=0.01)
    _tell(opt, [0.3, 0.5], 1.0)
    _tell(opt, [0.3, 0.6], 0.5)  # parameter 0 did not move: twice -> w_0 = 0
    _tell(opt, [0.3, 0.65], 0.2)
    assert opt.var[0] == VARIANCE_FLOOR
    assert np.all(np.isfinite(opt.a)) and np.all(np.isfinite(opt.b))
    _check_distribution(opt, np.array([VARIANCE_FLOOR, opt.sigma**2]))
    xi = opt.ask()[0]
    assert 0.0 <= xi[0] <= 1.0 and abs(xi[0] - 0.3) < 1e-12


def test_floor_when_sigma_vanishes() -> None:
    opt = BetaSearch(2, np.random.default_rng(0), anisotropic=False, sigma0=1e-20)
    _tell(opt, [0.3, 0.5], 1.0)
    np.testing.assert_array_equal(opt.var, VARIANCE_FLOOR)
    _check_distribution(opt, np.full(2, VARIANCE_FLOOR))


def test_stop_criteria() -> None:
    opt = BetaSearch(2, np.random.default_rng(0), anisotropic=True, sigma_min=1e-3,
                     f_change_min=1e-6, sigma0=0.01)
    _tell(opt, [0.3, 0.5], 1.0)
    assert opt.stop() == {}
    _tell(opt, [0.3, 0.6], 1.0 - 1e-7)  # φ_m fell by 1e-7 < Δφ_s between two successes
    assert set(opt.stop()) == {"f_change_min"}
    assert opt.stop()["f_change_min"] == pytest.approx(1e-7, rel=1e-6)
    while opt.sigma >= 1e-3:
        _tell(opt, [0.0, 0.0], 2.0)
    assert opt.stop()["sigma_min"] == opt.sigma


def test_trace_per_step() -> None:
    opt = BetaSearch(3, np.random.default_rng(1), anisotropic=True)
    f = []
    for _ in range(100):  # more than the initial buffer: it grows
        xs = opt.ask()
        f.append(float(np.sum((xs - 0.3) ** 2)))
        opt.tell(xs, np.array(f[-1:]))
    tr = opt.trace_since(0)
    assert tr["a"].shape == tr["b"].shape == tr["mode"].shape == (100, 3)
    assert tr["sigma"].shape == tr["f_best"].shape == (100,)
    np.testing.assert_array_equal(tr["f_best"], np.minimum.accumulate(f))
    np.testing.assert_array_equal(tr["a"][-1], opt.a)
    np.testing.assert_array_equal(tr["mode"][-1], opt.mode)

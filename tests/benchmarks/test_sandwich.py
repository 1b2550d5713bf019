"""The sandwich covariance of a least-squares fit against the closed form of a linear model."""

from __future__ import annotations

import numpy as np
import pytest
from error_models.kinds import error_model
from error_models.sandwich import (
    andrews_bandwidth,
    curvature_adjustment,
    least_adjustment,
    magnitude_adjustment,
    sandwich_covariance,
    tapered_autocovariance,
)
from scipy.linalg import toeplitz
from scipy.signal import lfilter

from femupdate.errors import ConfigError, DataError


def test_tapered_autocovariance_is_the_biased_sample_autocovariance() -> None:
    r = np.random.default_rng(1).standard_normal(300)
    gamma = tapered_autocovariance(r, bandwidth=299)
    for k in (0, 1, 7, 299):
        assert gamma[k] == pytest.approx((r[:300 - k] @ r[k:]) / 300 * (1 - k / 300),
                                         abs=1e-12)
    assert np.all(tapered_autocovariance(r, bandwidth=4)[5:] == 0.0)


def test_bandwidth_grows_with_the_correlation() -> None:
    rng = np.random.default_rng(2)
    u = rng.standard_normal(5000)
    widths = [andrews_bandwidth(lfilter([1.0], [1.0, -rho], u)) for rho in (0.0, 0.9, 0.999)]
    assert widths[0] <= 3 and widths[0] < widths[1] < widths[2] <= 4999


def test_sandwich_of_a_linear_fit_with_ar1_errors_matches_the_closed_form() -> None:
    """r = X θ − y, y = X θ_true + ε, ε AR(1) (ρ = 0.95) in two blocks: the exact covariance
    of the least-squares θ̂ is (XᵀX)⁻¹ Xᵀ Σ X (XᵀX)⁻¹, Σ block-Toeplitz; the sandwich from the
    residuals of one draw is within 30 % of it in standard deviation (Newey–West is biased
    low: 0.76–1.11 of it over seeds 3–8, 0.85 for this one), where the i.i.d. formula
    σ̂² (XᵀX)⁻¹ is several times too small."""
    rng = np.random.default_rng(3)
    n, rho = 2000, 0.95
    t = np.linspace(0.0, 1.0, n)
    x_block = np.column_stack([np.sin(2 * np.pi * 3 * t), np.cos(2 * np.pi * 5 * t), t])
    design = np.vstack([x_block, 0.5 * x_block])
    noise = np.concatenate([lfilter([1.0], [1.0, -rho], rng.standard_normal(n))
                            for _ in range(2)])
    y = design @ np.array([1.0, -2.0, 0.5]) + noise
    theta = np.linalg.lstsq(design, y, rcond=None)[0]
    r = design @ theta - y
    blocks = [slice(0, n), slice(n, 2 * n)]
    cov = sandwich_covariance(design, r, blocks)
    sigma = toeplitz(rho ** np.arange(n) / (1 - rho ** 2))
    bread = np.linalg.inv(design.T @ design)
    meat = sum(design[b].T @ sigma @ design[b] for b in blocks)
    exact = bread @ meat @ bread
    assert np.sqrt(np.diag(cov)) == pytest.approx(np.sqrt(np.diag(exact)), rel=0.3)
    iid = (r @ r) / r.size * bread
    assert np.all(np.sqrt(np.diag(exact)) > 3 * np.sqrt(np.diag(iid)))
    with pytest.raises(DataError, match="sandwich: the Jacobian has shape"):
        sandwich_covariance(design[:-1], r, blocks)
    # the magnitude adjustment against its value with the exact Σ and the known variance,
    # and against the AR(1) count (1 − ρ)/(1 + ρ) of regressors slow beside the correlation
    # (k / k_exact is 1.0–1.57 over seeds 3–7, 1.32 here: Newey–West's variance is low)
    k = magnitude_adjustment(design, r, blocks)
    w = [1.0 / sigma[0, 0], 1.0 / sigma[0, 0]]
    sens = sum(wc * design[b].T @ design[b] for wc, b in zip(w, blocks, strict=True))
    var = sum(wc ** 2 * design[b].T @ sigma @ design[b] for wc, b in zip(w, blocks, strict=True))
    k_exact = 3 / np.trace(np.linalg.inv(sens) @ var)
    assert k == pytest.approx(k_exact, rel=0.4)
    assert k_exact == pytest.approx((1 - rho) / (1 + rho), rel=0.3)
    # k does not depend on the coordinates of θ; kind "adjusted" is the tempered i.i.d. count
    mixing = np.array([[2.0, 0.3, 0.0], [0.0, 1.0, -1.0], [0.5, 0.0, 3.0]])
    assert magnitude_adjustment(design @ mixing, r, blocks) == pytest.approx(k, rel=1e-9)
    adjusted = error_model(blocks, "adjusted", best_residuals=r, jacobian=design,
                           dof_removed=[2, 2])
    assert adjusted.counts == pytest.approx([(n - 2) * k] * 2, rel=1e-12)
    with pytest.raises(ConfigError, match="'adjusted' needs the Jacobian"):
        error_model(blocks, "adjusted", best_residuals=r)


def test_the_least_adjustment_is_nowhere_sharper_than_the_sandwich() -> None:
    """Regressors of unlike frequencies under AR(1) errors: the sandwich widens the slow one
    most. k = 1/λ_max(H⁻¹M) tempers the i.i.d. likelihood just enough that H⁻¹/k − H⁻¹MH⁻¹
    is positive semi-definite with a zero eigenvalue (tight in one direction), and it is
    below the average adjustment n/tr(H⁻¹M), whose covariance is sharper than the sandwich's
    in that direction."""
    rng = np.random.default_rng(4)
    n, rho = 2000, 0.9
    t = np.linspace(0.0, 1.0, n)
    design = np.column_stack([np.sin(2 * np.pi * 2 * t), np.sin(2 * np.pi * 150 * t), t])
    noise = lfilter([1.0], [1.0, -rho], rng.standard_normal(n))
    theta = np.linalg.lstsq(design, design @ np.ones(3) + noise, rcond=None)[0]
    r = design @ theta - design @ np.ones(3) - noise
    blocks = [slice(0, n)]
    k_least, k_average = least_adjustment(design, r, blocks), magnitude_adjustment(
        design, r, blocks)
    assert 0 < k_least < 0.9 * k_average
    tempered = np.linalg.inv(design.T @ design) * (r @ r) / n / k_least
    gap = np.linalg.eigvalsh(tempered - sandwich_covariance(design, r, blocks))
    assert gap.min() == pytest.approx(0.0, abs=1e-9 * gap.max())
    average = np.linalg.inv(design.T @ design) * (r @ r) / n / k_average
    assert np.linalg.eigvalsh(average - sandwich_covariance(design, r, blocks)).min() < 0


def test_the_curvature_adjusted_likelihood_has_the_sandwich_covariance() -> None:
    """One block of AR(1) errors: the i.i.d. likelihood at ξ* + C (ξ − ξ*) has curvature
    CᵀHC, H the i.i.d. one (weight N/‖r‖²); its inverse is the sandwich covariance, parameter
    by parameter and in the correlations. The magnitude adjustment matches only the trace: a
    slow and a fast regressor see the AR(1) errors' power at different frequencies, and one
    power of the likelihood cannot widen both by their own factors."""
    rng = np.random.default_rng(5)
    n, rho = 3000, 0.9
    t = np.linspace(0.0, 1.0, n)
    design = np.column_stack([np.sin(2 * np.pi * 2 * t), t, np.cos(2 * np.pi * 1000 * t)])
    y = design @ np.array([1.0, 0.5, -1.0]) + lfilter([1.0], [1.0, -rho], rng.standard_normal(n))
    theta = np.linalg.lstsq(design, y, rcond=None)[0]
    r = design @ theta - y
    blocks = [slice(0, n)]
    c = curvature_adjustment(design, r, blocks)
    curvature = c.T @ ((n / (r @ r)) * design.T @ design) @ c
    np.testing.assert_allclose(np.linalg.inv(curvature), sandwich_covariance(design, r, blocks),
                               rtol=1e-8)
    k = magnitude_adjustment(design, r, blocks)
    tempered = np.linalg.inv(k * (n / (r @ r)) * design.T @ design)
    sandwich_sd = np.sqrt(np.diag(sandwich_covariance(design, r, blocks)))
    assert not np.allclose(np.sqrt(np.diag(tempered)), sandwich_sd, rtol=0.1)

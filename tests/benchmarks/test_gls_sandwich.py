"""The GLS sandwich: the covariance of a weighted least-squares estimate under coloured errors
that are correlated across channels, against its closed form on a linear model."""

from __future__ import annotations

import numpy as np
import pytest
from error_models.gls_sandwich import gls_sandwich_covariance
from error_models.kinds import error_model
from scipy.linalg import toeplitz

from femupdate.errors import DataError

N = 512
T = np.arange(N)
#: Two channels of one trial: the sensitivities oscillate at 0.05 and 0.12 cycles per sample
DESIGN = np.vstack([np.column_stack([np.sin(2 * np.pi * 0.05 * T), np.cos(2 * np.pi * 0.12 * T)]),
                    np.column_stack([0.5 * np.sin(2 * np.pi * 0.05 * T + 0.3),
                                     np.sin(2 * np.pi * 0.12 * T)])])
#: A narrow-band AR(2) error at 0.05 cycles per sample, the same in both channels, over white
#: noise of unit variance in each
RADIUS, FREQUENCY, COMMON = 0.97, 0.05, 0.3
AR2 = np.array([2 * RADIUS * np.cos(2 * np.pi * FREQUENCY), -RADIUS ** 2])


def _ar2_autocovariance(lags: int) -> np.ndarray:
    """γ(0 … lags−1) of the unit-innovation AR(2) process (from its impulse response)."""
    h = np.zeros(lags + 4000)
    h[0] = 1.0
    for t in range(1, h.size):
        h[t] = AR2[0] * h[t - 1] + (AR2[1] * h[t - 2] if t > 1 else 0.0)
    return np.array([h[:h.size - k] @ h[k:] for k in range(lags)])


def _noise(rng: np.random.Generator) -> np.ndarray:
    burn = 2000
    e = rng.standard_normal(N + burn)
    x = np.zeros(N + burn)
    for t in range(2, N + burn):
        x[t] = AR2[0] * x[t - 1] + AR2[1] * x[t - 2] + e[t]
    common = COMMON * x[burn:]
    return np.concatenate([common + rng.standard_normal(N), common + rng.standard_normal(N)])


def _exact_covariance() -> np.ndarray:
    """(AᵀA)⁻¹ Aᵀ Σ A (AᵀA)⁻¹ with Σ = I + COMMON² Γ in every block of the 2 × 2 grid."""
    gamma = COMMON ** 2 * toeplitz(_ar2_autocovariance(N))
    sigma = np.block([[np.eye(N) + gamma, gamma], [gamma, np.eye(N) + gamma]])
    bread = np.linalg.inv(DESIGN.T @ DESIGN)
    return bread @ DESIGN.T @ sigma @ DESIGN @ bread


def test_it_matches_the_closed_form_and_needs_the_channels_cross_terms() -> None:
    model = error_model([slice(0, N), slice(N, 2 * N)], "known", sigma=1.0)
    exact = np.diag(_exact_covariance())
    naive = np.diag(np.linalg.inv(DESIGN.T @ DESIGN))
    assert exact[0] > 3 * naive[0]  # the common narrow-band error dominates at 0.05
    rng = np.random.default_rng(11)
    together, apart = [], []
    for _ in range(200):
        y = _noise(rng)
        theta = np.linalg.lstsq(DESIGN, y, rcond=None)[0]
        r = DESIGN @ theta - y
        together.append(np.diag(gls_sandwich_covariance(DESIGN, r, model, [[0, 1]])))
        apart.append(np.diag(gls_sandwich_covariance(DESIGN, r, model)))
    ratio = np.mean(together, axis=0) / exact
    # the second parameter within 10 %; the first, whose sensitivity sits on the narrow-band
    # error, low by 20 % (measured: 0.80): there the fit absorbs more of the error than its
    # leverage says, a bias the HC2 correction does not remove (the module docstring)
    assert 0.9 < ratio[1] < 1.1 and 0.7 < ratio[0] < 0.9, ratio
    # without the cross-periodogram of the two channels the common error counts half
    assert np.mean(apart, axis=0)[0] / exact[0] < 0.7 * ratio[0]


def test_white_errors_give_the_likelihood_s_covariance() -> None:
    model = error_model([slice(0, N), slice(N, 2 * N)], "known", sigma=1.0)
    rng = np.random.default_rng(12)
    estimates = []
    for _ in range(200):  # one estimate rests on a few bins: ±40 % alone
        y = rng.standard_normal(2 * N)
        r = DESIGN @ np.linalg.lstsq(DESIGN, y, rcond=None)[0] - y
        estimates.append(np.diag(gls_sandwich_covariance(DESIGN, r, model, [[0, 1]])))
    ratio = np.mean(estimates, axis=0) / np.diag(np.linalg.inv(DESIGN.T @ DESIGN))
    assert np.all(np.abs(ratio - 1) < 0.1), ratio


def test_bad_groups_are_one_line_errors() -> None:
    model = error_model([slice(0, N), slice(N, 2 * N)], "known", sigma=1.0)
    r = np.ones(2 * N)
    with pytest.raises(DataError, match="must hold each of the 2 blocks once"):
        gls_sandwich_covariance(DESIGN, r, model, [[0]])
    with pytest.raises(DataError, match="allowed: ≥ 0 bins"):
        gls_sandwich_covariance(DESIGN, r, model, smoothing=-1)
    short = error_model([slice(0, N), slice(N, N + 100)], "known", sigma=1.0)
    with pytest.raises(DataError, match="differ in length"):
        gls_sandwich_covariance(DESIGN[:N + 100], r[:N + 100], short, [[0, 1]])

"""The sandwich covariance of the least-squares best fit under correlated errors.

The best fit ξ* of a case minimises φ = ‖r‖², so it solves Jᵀr = 0. If the prediction errors
ε of each block c (trial × channel) are a stationary series of autocovariance γ_c(k), the
least-squares estimate has, to first order, the covariance (White 1980)::

    Cov(ξ*) = H⁻¹ M H⁻¹,   H = JᵀJ,   M = Σ_c J_cᵀ Γ_c J_c,   (Γ_c)_{ts} = γ_c(|t − s|)

whatever the correlation, with no model of it: γ_c is estimated from the block's residuals at
the best fit (the biased sample autocovariance, which keeps M positive semi-definite, tapered
by Bartlett weights 1 − k/(L + 1): the Newey & West 1987 estimator, with the bandwidth L of
Andrews 1991 for an AR(1) plug-in). This is the width that the correlation of the errors
gives the best fit itself, so it is the reference against which the likelihoods of
:mod:`femupdate.inference.likelihood` (which assume a correlation model: N_c independent
values, AR(1), AR(p)) are calibrated.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy.linalg import matmul_toeplitz

from femupdate.inference.input_noise import score_meats
from femupdate.inference.laplace import LaplaceResult, checked_jacobian, summarize_gaussian
from femupdate.inference.likelihood import lag1_autocorrelation
from femupdate.inference.priors import Prior


def andrews_bandwidth(r: np.ndarray) -> int:
    """Andrews' (1991) bandwidth of the Bartlett kernel for a series of lag-1
    autocorrelation ρ: 1.1447 (α N)^{1/3}, α = 4ρ² / ((1 − ρ)² (1 + ρ)²), at most N − 1."""
    n = int(np.asarray(r).size)
    rho = min(abs(lag1_autocorrelation(r)), 1.0 - 1e-9)
    alpha = 4.0 * rho ** 2 / ((1.0 - rho) ** 2 * (1.0 + rho) ** 2)
    return int(min(max(math.ceil(1.1447 * (alpha * n) ** (1.0 / 3.0)), 1), n - 1))


def tapered_autocovariance(r: np.ndarray, bandwidth: int) -> np.ndarray:
    """γ(k) = (1/N) Σ_t r_t r_{t+k} for k = 0 … N − 1, times the Bartlett weight
    max(0, 1 − k/(bandwidth + 1))."""
    r = np.asarray(r, dtype=float)
    n = r.size
    spectrum = np.fft.rfft(r, 2 * n)
    gamma = np.fft.irfft(np.abs(spectrum) ** 2, 2 * n)[:n] / n
    return gamma * np.clip(1.0 - np.arange(n) / (bandwidth + 1.0), 0.0, None)


def sandwich_covariance(jac: np.ndarray, residuals: np.ndarray,
                        blocks: tuple[slice, ...] | list[slice]) -> np.ndarray:
    """H⁻¹ M H⁻¹ (n, n) of the least-squares estimate (module docstring) from the Jacobian J
    (m, n) and the residuals r (m,) at the best fit, the errors of each block stationary and
    the blocks independent."""
    jac, r = checked_jacobian(jac, residuals, "sandwich")
    meat = np.zeros((jac.shape[1], jac.shape[1]))
    for block in blocks:
        rc, jc = r[block], jac[block]
        gamma = tapered_autocovariance(rc, andrews_bandwidth(rc))
        meat += jc.T @ matmul_toeplitz(gamma, jc)
    bread = np.linalg.pinv(jac.T @ jac, hermitian=True)
    cov = bread @ meat @ bread
    return 0.5 * (cov + cov.T)


def sandwich_laplace(jac: np.ndarray, residuals: np.ndarray, best_unit: np.ndarray,
                     blocks: tuple[slice, ...] | list[slice], prior: Prior) -> LaplaceResult:
    """The Gaussian at the best fit ξ* with the sandwich covariance, summarised as a
    :class:`~femupdate.inference.laplace.LaplaceResult` (intervals clipped to the bounds;
    the prior enters only through them)."""
    cov = sandwich_covariance(jac, residuals, blocks)
    return summarize_gaussian(np.asarray(best_unit, dtype=float).reshape(-1), cov, prior)


def _sensitivity_variability(jac: np.ndarray, residuals: np.ndarray,
                             blocks: tuple[slice, ...] | list[slice]
                             ) -> tuple[np.ndarray, np.ndarray]:
    """(H, M) of the i.i.d. likelihood with unknown variance per block (weights
    w_c = N_c/‖r_c‖²): H = Σ w_c J_cᵀJ_c its curvature, M = Σ w_c² J_cᵀ Γ_c J_c the variance of
    its score from the residuals' autocovariance."""
    jac = np.asarray(jac, dtype=float)
    r = np.asarray(residuals, dtype=float).reshape(-1)
    n = jac.shape[1]
    sensitivity = np.zeros((n, n))
    variability = np.zeros((n, n))
    for block in blocks:
        rc, jc = r[block], jac[block]
        w = rc.size / float(rc @ rc)
        gamma = tapered_autocovariance(rc, andrews_bandwidth(rc))
        sensitivity += w * jc.T @ jc
        variability += w ** 2 * jc.T @ matmul_toeplitz(gamma, jc)
    return sensitivity, variability


def magnitude_adjustment(jac: np.ndarray, residuals: np.ndarray,
                         blocks: tuple[slice, ...] | list[slice]) -> float:
    """k = n / tr(H⁻¹ M) of the i.i.d. likelihood with unknown variance per block (weights
    w_c = N_c/‖r_c‖², H = Σ w_c J_cᵀJ_c, M = Σ w_c² J_cᵀ Γ_c J_c): the power the likelihood
    is raised to so that its curvature matches, on average over the parameters, the
    sandwich's (Ribatet, Cooley & Davison 2012, the magnitude adjustment of a composite
    likelihood). Exact when M ∝ H; the error model with N_c·k independent values per block
    is that tempered likelihood."""
    sensitivity, variability = _sensitivity_variability(jac, residuals, blocks)
    n = sensitivity.shape[0]
    return float(n / np.trace(np.linalg.pinv(sensitivity, hermitian=True) @ variability))


def least_adjustment(jac: np.ndarray, residuals: np.ndarray,
                     blocks: tuple[slice, ...] | list[slice]) -> float:
    """k = 1 / λ_max(H⁻¹ M): the largest power of the i.i.d. likelihood (H, M as
    :func:`magnitude_adjustment`'s) whose curvature is nowhere sharper than the sandwich's,
    in any direction of the parameters (its covariance H⁻¹/k ⪰ H⁻¹MH⁻¹): the most a single
    scalar can give without being too narrow where the sandwich is right."""
    sensitivity, variability = _sensitivity_variability(jac, residuals, blocks)
    ratios = np.linalg.eigvals(np.linalg.pinv(sensitivity, hermitian=True) @ variability).real
    return float(1.0 / ratios.max())


def _psd_power(a: np.ndarray, power: float) -> np.ndarray:
    """A symmetric positive semi-definite matrix to a power, its eigenvalues below 1e-12 of
    the largest taken as that floor."""
    w, v = np.linalg.eigh(0.5 * (a + a.T))
    w = np.maximum(w, 1e-12 * max(float(w.max()), 1e-300))
    return (v * w ** power) @ v.T


def curvature_adjustment(jac: np.ndarray, residuals: np.ndarray,
                         blocks: tuple[slice, ...] | list[slice]) -> np.ndarray:
    """C (n, n) of the curvature adjustment of the i.i.d. likelihood (Chandler & Bate 2007;
    Ribatet, Cooley & Davison 2012): ℓ_adj(ξ) = ℓ(ξ* + C (ξ − ξ*)) has at the best fit ξ* the
    curvature CᵀHC = H M⁻¹ H, the inverse of the sandwich covariance, parameter by parameter
    (where the magnitude adjustment matches only its trace). C = H^(−1/2) (H M⁻¹ H)^(1/2), in
    the Jacobian's coordinates."""
    sensitivity, variability = _sensitivity_variability(jac, residuals, blocks)
    target = sensitivity @ np.linalg.pinv(variability, hermitian=True) @ sensitivity
    return _psd_power(sensitivity, -0.5) @ _psd_power(target, 0.5)


def eiv_sandwich_laplaces(problem: Any, model: Any, point: np.ndarray,
                          point_residuals: np.ndarray,
                          at: Sequence[tuple[np.ndarray, np.ndarray]], mode_unit: np.ndarray,
                          prior: Any) -> list[Any]:
    """The Gaussian at the error model's mode ``mode_unit`` for each (residuals, Jacobian)
    pair of ``at`` there, with the sandwich covariance B Var(score) B, B the inverse of the
    Laplace precision (the likelihood's Gauss–Newton curvature less the prior's), Var(score)
    by :func:`~femupdate.inference.input_noise.score_meats` (``model`` built at search
    ``point``, ``point_residuals`` its residuals there): kind ``"eiv-sandwich"``."""
    mode_unit = np.asarray(mode_unit, dtype=float).reshape(-1)
    _, prior_hess = prior.curvature_unit(mode_unit)
    out = []
    for precision, meat in score_meats(problem, model, point, point_residuals, at):
        bread = np.linalg.pinv(precision - np.diag(prior_hess), hermitian=True)
        cov = bread @ meat @ bread
        out.append(summarize_gaussian(mode_unit, 0.5 * (cov + cov.T), prior))
    return out

"""The sandwich covariance of a whitening error model's mode: GLS whose whitening is imperfect.

At the mode ξ̂ of a whitening error model (``"ar1"``, ``"arp"``: residuals whitened by a fixed
AR filter, :func:`error_models.mode.whitened_mode`) the estimate solves J̃ᵀWr̃ = 0, J̃
and r̃ the whitened Jacobian and residuals, W the blocks' weights. If the whitened errors are
white, its covariance is the likelihood's H⁻¹ (H = J̃ᵀWJ̃). If they are not (the noise of a
shake table's record reaches every channel through the structure, narrow-band at its
resonances, which a per-channel AR filter fitted to the whole band leaves coloured), it is,
to first order, whatever the remaining correlation::

    Cov(ξ̂) = H⁻¹ M H⁻¹,   M = Cov(J̃ᵀW ẽ) = Σ_k Σ_{c,d} w_c w_d Re(F_c(k)ᴴ S_cd(k) F_d(k)) / N²

in the frequency domain (F_c(k) the discrete Fourier transform of block c's whitened Jacobian
columns, S_cd(k) the cross-periodogram of blocks c and d of one trial, N their length; blocks
of different trials independent). S is estimated from the whitened residuals at the mode,
averaged over ``smoothing`` bins either side (a Daniell window; ±1 bin is ±0.22 Hz on the
bridge's records, fine enough to follow a resonance's peak), each residual's Fourier
coefficient first divided by √(1 − h_c(k)), h_c(k) the share of that coefficient the fit
itself absorbed (its leverage, Σ h = n): the fitted residual lacks the error along the
sensitivities, most where the sensitivities are concentrated, and the error there is what
spreads the estimate. That is the HC2 correction of MacKinnon & White (1985) applied per
frequency: unbiased when the whitened errors are white (E|ê(k)|² = σ²(1 − h(k)); the HC3
correction, 1/(1 − h), overstates the variance there, by 18 % on the test's sinusoid). Where a
sensitivity sits on a narrow-band error the fit absorbs more of the error than its leverage
says, and the estimate stays low (0.80 of the closed form in tests/inference/
test_gls_sandwich.py): a known bias, measured, not corrected.

This is not a likelihood (TMCMC cannot sample it); it is the width the mode's own scatter has.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.ndimage import uniform_filter1d

from femupdate.errors import DataError
from femupdate.inference.laplace import LaplaceResult, checked_jacobian, summarize_gaussian
from femupdate.inference.likelihood import ErrorModel
from femupdate.inference.priors import Prior

#: Bins either side of each frequency over which the cross-periodogram is averaged.
SMOOTHING_BINS = 1
#: Leverage beyond this is clipped (a coefficient the fit absorbed whole has no error left).
MAX_LEVERAGE = 0.95


def _frequency_weights(length: int) -> np.ndarray:
    """How many of the full transform's coefficients each one of ``rfft`` stands for."""
    weights = np.full(length // 2 + 1, 2.0)
    weights[0] = 1.0
    if length % 2 == 0:
        weights[-1] = 1.0
    return weights


def gls_sandwich_covariance(jac: np.ndarray, residuals: np.ndarray, model: ErrorModel,
                            groups: Sequence[Sequence[int]] | None = None, *,
                            smoothing: int = SMOOTHING_BINS) -> np.ndarray:
    """H⁻¹ M H⁻¹ (n, n) of the mode of ``model`` (module docstring), from the Jacobian J
    (m, n) and the residuals r (m,) at the mode.

    Parameters
    ----------
    jac, residuals : ndarray (m, n), (m,)
        At the mode, unwhitened (the model whitens them).
    model : ErrorModel
        The whitening error model (any kind: for one that does not whiten, this is the
        sandwich of its weighted least-squares estimate).
    groups : sequence of sequence of int, optional
        Blocks whose errors may be correlated with each other (one trial's channels:
        :func:`trial_groups`); blocks of a group must have equal lengths. Default: every
        block alone.
    smoothing : int
        Bins either side over which the cross-periodogram is averaged (≥ 0).
    """
    jac, r = checked_jacobian(jac, residuals, "GLS sandwich")
    if smoothing < 0:
        raise DataError(f"GLS sandwich: smoothing {smoothing} (allowed: ≥ 0 bins)")
    jw = model.whiten(jac.T).T
    rw = model.whiten(r[None, :])[0]
    weights = model.weights(r)
    bounds = model._white_blocks()
    block_weights = np.array([weights[a] for a, _ in bounds])
    groups = [[i] for i in range(len(bounds))] if groups is None else [list(g) for g in groups]
    if sorted(i for g in groups for i in g) != list(range(len(bounds))):
        raise DataError(f"GLS sandwich: groups {groups} must hold each of the {len(bounds)} "
                        "blocks once")
    precision = jw.T @ (weights[:, None] * jw)
    bread = np.linalg.pinv(precision, hermitian=True)
    meat = np.zeros_like(precision)
    for group in groups:
        lengths = {bounds[c][1] - bounds[c][0] for c in group}
        if len(lengths) != 1:
            raise DataError(f"GLS sandwich: the blocks of group {group} differ in length "
                            f"{sorted(lengths)} (allowed: one trial's channels, of one length)")
        length = lengths.pop()
        counts = _frequency_weights(length)
        coeffs = [np.fft.rfft(jw[bounds[c][0]:bounds[c][1]], axis=0) for c in group]
        errors = []
        for c, f in zip(group, coeffs, strict=True):
            # P_kk of the fit's projection in the unitary Fourier basis (Σ over blocks and
            # all N coefficients, ± frequencies alike, is n)
            leverage = (block_weights[c] / length
                        * np.real(np.einsum("ki,ij,kj->k", np.conj(f), bread, f)))
            errors.append(np.fft.rfft(rw[bounds[c][0]:bounds[c][1]])
                          / np.sqrt(1.0 - np.clip(leverage, 0.0, MAX_LEVERAGE)))
        for i, c in enumerate(group):
            for j, d in enumerate(group):
                cross = errors[i] * np.conj(errors[j])
                if smoothing:
                    size = 2 * smoothing + 1
                    cross = (uniform_filter1d(cross.real, size, mode="nearest")
                             + 1j * uniform_filter1d(cross.imag, size, mode="nearest"))
                meat += (block_weights[c] * block_weights[d] / length ** 2) * np.real(
                    np.einsum("k,ki,k,kj->ij", counts, np.conj(coeffs[i]), cross, coeffs[j]))
    cov = bread @ meat @ bread
    return 0.5 * (cov + cov.T)


def gls_sandwich_laplace(jac: np.ndarray, residuals: np.ndarray, mode_unit: np.ndarray,
                         model: ErrorModel, prior: Prior,
                         groups: Sequence[Sequence[int]] | None = None) -> LaplaceResult:
    """The Gaussian at the mode with the GLS sandwich covariance, summarised as a
    :class:`~femupdate.inference.laplace.LaplaceResult` (intervals clipped to the bounds)."""
    cov = gls_sandwich_covariance(jac, residuals, model, groups)
    return summarize_gaussian(np.asarray(mode_unit, dtype=float).reshape(-1), cov, prior)

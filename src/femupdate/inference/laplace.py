"""The Laplace approximation of the posterior at the best fit: cheap, from every run.

With the Jacobian J (m, n) of the residuals with respect to the **unit-cube** coordinates ξ
of the search (x = low + (high − low)·ξ in the search space, log10 on log scales) at the best
fit ξ*, the error model's Gauss–Newton weights W and the prior's curvature, the posterior is
approximated by a Gaussian in ξ::

    H = J_wᵀ W J_w − ∇²log p(ξ*),    Σ = H⁻¹,
    mean = ξ* + Σ · (−J_wᵀ W r_w + ∇log p(ξ*))   (one Newton step: exact for a linear model
                                                   with a Gaussian prior and known variance)

J_w, r_w: J and r as the error model whitens them. Means and covariances are then given in
the search space (a linear map of ξ), and the 5/50/95 % quantiles in physical units (the map to
physical values is monotonic, so quantiles map through it).

*Not determined by the data*: a parameter whose 90 % posterior interval, clipped to the
bounds, spans at least half of its prior's 90 % interval (for a uniform prior, of 90 % of its
range: :data:`UNDETERMINED_FRACTION`). The data have then not even halved the range the prior
allows: whatever value the best fit gives it is an accident of the noise and the search.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.stats import norm

from femupdate.errors import DataError, FemupdateError
from femupdate.inference.jacobian import residual_jacobian
from femupdate.inference.likelihood import ErrorModel
from femupdate.inference.priors import Prior

#: A parameter is "not determined by the data" when its 90 % posterior interval spans at
#: least this fraction of its prior's 90 % interval.
UNDETERMINED_FRACTION = 0.5
Z90 = float(norm.ppf(0.95))


@dataclass(frozen=True)
class LaplaceResult:
    """A Gaussian posterior in the unit cube and what it says of each parameter.

    Attributes
    ----------
    names : tuple of str
    mean_unit, cov_unit : ndarray (n,), (n, n)
        In unit-cube coordinates ξ.
    mean, cov, std : ndarray (n,), (n, n), (n,)
        In the search space (log10 values on log scales).
    correlations : ndarray (n, n)
    quantiles : ndarray (3, n)
        5, 50 and 95 % quantiles in physical units (the Gaussian's, clipped to the bounds).
    spread : ndarray (n,)
        Width of the 90 % interval (clipped to the bounds) over the prior's 90 % interval.
    undetermined : ndarray of bool (n,)
        spread ≥ :data:`UNDETERMINED_FRACTION`.
    sentences : list of str
        One sentence per parameter, in words.
    """

    names: tuple[str, ...]
    mean_unit: np.ndarray
    cov_unit: np.ndarray
    mean: np.ndarray
    cov: np.ndarray
    std: np.ndarray
    correlations: np.ndarray
    quantiles: np.ndarray
    spread: np.ndarray
    undetermined: np.ndarray
    sentences: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, object]:
        """JSON-ready: per parameter mean (physical, of the search-space mean), std (search
        space), quantiles, spread, determined or not; the correlations; the sentences."""
        return {
            "names": list(self.names),
            "mean_search": self.mean.tolist(),
            "std_search": self.std.tolist(),
            "q05": self.quantiles[0].tolist(),
            "q50": self.quantiles[1].tolist(),
            "q95": self.quantiles[2].tolist(),
            "spread": self.spread.tolist(),
            "undetermined": self.undetermined.tolist(),
            "correlations": self.correlations.tolist(),
            "sentences": list(self.sentences),
        }


def checked_jacobian(jac: np.ndarray, residuals: np.ndarray, who: str
                     ) -> tuple[np.ndarray, np.ndarray]:
    """J (m, n) and r (m,) as float arrays, refused (a DataError naming ``who``) when their
    shapes disagree or a value is not finite."""
    jac = np.asarray(jac, dtype=float)
    r = np.asarray(residuals, dtype=float).reshape(-1)
    if jac.ndim != 2 or jac.shape[0] != r.size:
        raise DataError(f"{who}: the Jacobian has shape {jac.shape}, the residual vector "
                        f"{r.size} values (allowed: J of shape (m, n) with m = len(r))")
    if not (np.all(np.isfinite(jac)) and np.all(np.isfinite(r))):
        raise DataError(f"{who}: the Jacobian or the residuals at the best fit are not finite")
    return jac, r


def gaussian_precision(jac: np.ndarray, residuals: np.ndarray, model: ErrorModel
                       ) -> tuple[np.ndarray, np.ndarray]:
    """The likelihood's Gauss–Newton precision J_wᵀ W J_w (n, n) and gradient of log L
    (n,) at residuals r with Jacobian J (m, n)."""
    jac, r = checked_jacobian(jac, residuals, "Laplace")
    jw = model.whiten(jac.T).T
    rw = model.whiten(r[None, :])[0]
    w = model.weights(r)
    precision = jw.T @ (w[:, None] * jw)
    gradient = -jw.T @ (w * rw)
    return precision, gradient


def laplace(jac: np.ndarray, residuals: np.ndarray, best_unit: np.ndarray,
            model: ErrorModel, prior: Prior) -> LaplaceResult:
    """The Laplace approximation at the best fit (see the module docstring).

    Parameters
    ----------
    jac : ndarray (m, n)
        ∂r/∂ξ at the best fit, in unit-cube coordinates (:func:`jacobian_unit`).
    residuals : ndarray (m,)
        r at the best fit.
    best_unit : ndarray (n,)
        The best fit ξ* in the unit cube.
    model : ErrorModel
    prior : Prior
    """
    best = np.asarray(best_unit, dtype=float).reshape(-1)
    precision, gradient = gaussian_precision(jac, residuals, model)
    if best.size != precision.shape[0] or best.size != prior.dim:
        raise DataError(f"Laplace: {best.size} parameters at the best fit, a Jacobian of "
                        f"{precision.shape[0]} columns and a prior of {prior.dim}")
    prior_grad, prior_hess = prior.curvature_unit(best)
    precision = precision - np.diag(prior_hess)
    cov_unit = np.linalg.pinv(precision, hermitian=True)
    mean_unit = best + cov_unit @ (gradient + prior_grad)
    return summarize_gaussian(mean_unit, cov_unit, prior)


def summarize_gaussian(mean_unit: np.ndarray, cov_unit: np.ndarray,
                       prior: Prior) -> LaplaceResult:
    """The :class:`LaplaceResult` of a Gaussian in the unit cube."""
    span = prior.span
    mean = prior.to_search(mean_unit)
    cov = cov_unit * np.outer(span, span)
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(std, std)
    corr = np.where(np.isfinite(corr), corr, 0.0)
    np.fill_diagonal(corr, 1.0)
    low = np.clip(mean - Z90 * std, prior.search_low, prior.search_high)
    high = np.clip(mean + Z90 * std, prior.search_low, prior.search_high)
    mid = np.clip(mean, prior.search_low, prior.search_high)
    quantiles = prior.search_to_physical(np.vstack([low, mid, high]))
    spread = interval_spread(low, high, prior)
    undetermined = spread >= UNDETERMINED_FRACTION
    result = LaplaceResult(prior.names, mean_unit, cov_unit, mean, cov, std, corr, quantiles,
                           spread, undetermined)
    result.sentences.extend(sentences(prior, quantiles, spread))
    return result


def interval_spread(low: np.ndarray, high: np.ndarray, prior: Prior) -> np.ndarray:
    """Width of posterior intervals [low, high] (search space) over the width of the prior's
    central 90 % interval, per parameter."""
    prior_q = prior.quantiles_search([0.05, 0.95])
    return (np.asarray(high) - np.asarray(low)) / (prior_q[1] - prior_q[0])


def sentences(prior: Prior, quantiles: np.ndarray, spread: np.ndarray) -> list[str]:
    """One sentence per parameter: its 90 % interval, or that the data do not determine it
    ("kp1 is not determined by the data: its 90 % interval spans 87 % of its range")."""
    out = []
    for i, name in enumerate(prior.names):
        q05, q50, q95 = quantiles[:, i]
        if prior.kinds[i] == "uniform":  # the prior's 90 % interval is 90 % of the range
            share = f"{100 * 0.9 * min(spread[i], 1 / 0.9):.0f} % of its range"
        else:
            share = f"{100 * spread[i]:.0f} % of its prior's 90 % interval"
        if spread[i] >= UNDETERMINED_FRACTION:
            out.append(f"{name} is not determined by the data: its 90 % interval "
                       f"[{q05:.4g}, {q95:.4g}] spans {share}")
        else:
            half = 0.5 * (q95 - q05)
            rel = f" (±{100 * half / abs(q50):.2g} %)" if q50 != 0 else ""
            out.append(f"{name} = {q50:.4g}, 90 % interval [{q05:.4g}, {q95:.4g}]{rel}")
    return out


def jacobian_unit(residuals_batch: Callable[[np.ndarray], np.ndarray], best_unit: np.ndarray,
                  prior: Prior, step: float = 1e-4) -> np.ndarray:
    """∂r/∂ξ (m, n) at ``best_unit``, in the prior's unit cube: the differences of
    :func:`~femupdate.inference.jacobian.residual_jacobian` (second order, one-sided at a
    bound, one call of ``residuals_batch``: search-space rows -> (k, m)) on the prior's box."""
    bounds = list(zip(prior.to_search(np.zeros(prior.dim)), prior.to_search(np.ones(prior.dim)),
                      strict=True))
    try:
        _, jac = residual_jacobian(residuals_batch, bounds, prior.to_search(best_unit),
                                   step=step)
    except FemupdateError as exc:
        raise DataError(f"Laplace: a finite-difference point near the best fit failed to "
                        f"evaluate ({exc})") from None
    return jac

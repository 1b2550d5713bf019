"""The mode of a whitening error model's posterior, from the least-squares best fit.

The least-squares best fit ξ* minimises φ = ‖r‖², which weights every sample of the residual
alike. An error model that whitens the residuals (kinds ``"ar1"`` and ``"arp"`` of
:mod:`femupdate.inference.likelihood`: innovations r̃ = L r of a fixed AR filter L) has its
own maximum elsewhere: the generalised least-squares (GLS) estimate, which weights each
frequency by the inverse of the error's power there. When the errors are coloured (on the
bridge: acceleration noise integrated twice to displacement, its power ∝ 1/ω⁴ near the 5 Hz
high-pass) the two differ by several of the whitened likelihood's standard deviations, so its
Laplace Gaussian (covariance ≈ (J̃ᵀWJ̃)⁻¹) must be centred at its own mode, not at ξ*.

:func:`whitened_mode` climbs to it by Levenberg–Marquardt steps on the whitened residual
vector (the error model fixed: AR coefficients and counts as measured at ξ*), in the unit
cube of the search (a coordinate on a bound that the step would push out held there, the
others solved without it; the step then clipped to the cube), a step taken only when the
log-posterior rises, stopping when a step moves the point by less than ``tolerance``
posterior standard deviations (√(δᵀPδ), P the Gauss–Newton precision). Each iteration
costs one evaluation for the trial point and 2n + 1 for the Jacobian at an accepted one
(:func:`~femupdate.inference.jacobian.residual_jacobian`), all counted.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from femupdate.errors import DataError, FemupdateError
from femupdate.inference.jacobian import LOCAL_STEP, UNIT_STEP, residual_jacobian
from femupdate.inference.laplace import gaussian_precision
from femupdate.inference.likelihood import ErrorModel
from femupdate.inference.priors import Prior
from femupdate.problem.update import UpdateProblem

#: The error models whose likelihood maximum is not the least-squares best fit: they whiten
#: the residual before weighing it.
WHITENING_KINDS: tuple[str, ...] = ("ar1", "arp", "eiv", "eiv-all")
#: Stop when a step moves the point by less than this many posterior standard deviations.
MODE_TOLERANCE = 1e-2
MAX_ITERATIONS = 20
#: Levenberg–Marquardt damping: first value after a rejected step, growth, and the value at
#: which the search gives up (the step is then far below the tolerance).
DAMPING_START, DAMPING_GROWTH, DAMPING_LIMIT = 1e-3, 10.0, 1e8


@dataclass(frozen=True)
class ModeResult:
    """The mode of a whitened likelihood (times the prior) in the unit cube.

    Attributes
    ----------
    unit : ndarray (n,)
        The mode ξ̂ (the start if no step was accepted).
    residuals : ndarray (m,)
        r(ξ̂).
    log_posterior : float
        log L(r(ξ̂)) + log p(ξ̂) (unit-cube density).
    start_log_posterior : float
        The same at the start.
    iterations : int
        Accepted steps.
    evaluations : int
        Residual vectors evaluated (trial points and Jacobians; not the start's, when given).
    converged : bool
        The last step was below the tolerance (False: the iteration or damping limit ended
        the climb, the point is still the best one reached).
    """

    unit: np.ndarray
    residuals: np.ndarray
    log_posterior: float
    start_log_posterior: float
    iterations: int
    evaluations: int
    converged: bool


def log_posterior(r: np.ndarray, unit: np.ndarray, model: ErrorModel, prior: Prior) -> float:
    """log L(r) + log p(unit), −inf outside the prior's support."""
    lp = float(prior.logpdf_unit(unit[None, :])[0])
    return lp + model.loglike(r) if np.isfinite(lp) else -np.inf


def newton_system(jac: np.ndarray, r: np.ndarray, unit: np.ndarray, model: ErrorModel,
                  prior: Prior) -> tuple[np.ndarray, np.ndarray]:
    """The Gauss–Newton precision P (n, n) and gradient g (n,) of the log-posterior at
    ``unit``: the likelihood's J̃ᵀWJ̃ and −J̃ᵀWr̃ plus the prior's curvature and slope."""
    precision, gradient = gaussian_precision(jac, r, model)
    prior_grad, prior_hess = prior.curvature_unit(unit)
    return precision - np.diag(prior_hess), gradient + prior_grad


def damped_step(precision: np.ndarray, gradient: np.ndarray, damping: float,
                unit: np.ndarray) -> np.ndarray:
    """δ solving (P + λ·diag(P)) δ = g over the coordinates free to move: a coordinate on a
    bound of the cube that the step would push out is held there and the others solved
    again without it (a projected Newton step), so that the step along a bound is the
    constrained one, not the unconstrained one clipped."""
    scale = np.diag(precision).copy()
    scale[scale <= 0.0] = 1.0
    system = precision + damping * np.diag(scale)
    free = np.ones(unit.size, dtype=bool)
    step = np.zeros(unit.size)
    while free.any():
        step = np.zeros(unit.size)
        sub = system[np.ix_(free, free)]
        try:
            step[free] = np.linalg.solve(sub, gradient[free])
        except np.linalg.LinAlgError:
            step[free] = np.linalg.lstsq(sub, gradient[free], rcond=None)[0]
        pushed = free & (((unit <= 0.0) & (step < 0.0)) | ((unit >= 1.0) & (step > 0.0)))
        if not pushed.any():
            break
        free &= ~pushed
    return step


def whitened_mode(residuals_batch: Callable[[np.ndarray], np.ndarray], prior: Prior,
                  model: ErrorModel, start_unit: np.ndarray, *,
                  residuals: np.ndarray | None = None, jacobian: np.ndarray | None = None,
                  step: float = LOCAL_STEP, tolerance: float = MODE_TOLERANCE,
                  max_iterations: int = MAX_ITERATIONS) -> ModeResult:
    """The mode of prior × ``model``'s likelihood, climbed to from ``start_unit`` (module
    docstring).

    Parameters
    ----------
    residuals_batch : callable
        ``(k, n)`` points of the search space → ``(k, m)`` residual vectors.
    prior : Prior
        Its unit cube is the search's; its density enters the log-posterior.
    model : ErrorModel
        Fixed (typically measured at the least-squares best fit).
    start_unit : ndarray (n,)
        The start (the least-squares best fit), in the unit cube.
    residuals, jacobian : ndarray (m,), (m, n), optional
        r and ∂r/∂ξ at the start, when the caller has them (saves 2n + 1 evaluations).
    step : float
        Difference step of the Jacobians, in the unit cube.
    tolerance : float
        Stop when a step moves the point by less than this many posterior standard
        deviations.
    max_iterations : int
        At most this many accepted steps.

    Raises
    ------
    DataError
        The residuals or the Jacobian at the start cannot be had.
    """
    if max_iterations < 0 or not tolerance > 0:
        raise DataError(f"mode: max_iterations {max_iterations} and tolerance {tolerance} "
                        "(allowed: max_iterations ≥ 0, tolerance > 0)")
    bounds = list(zip(prior.to_search(np.zeros(prior.dim)), prior.to_search(np.ones(prior.dim)),
                      strict=True))
    evaluations = 0

    def jacobian_at(unit: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        nonlocal evaluations
        evaluations += 2 * unit.size + 1
        try:
            return residual_jacobian(residuals_batch, bounds, prior.to_search(unit), step=step)
        except FemupdateError as exc:
            raise DataError(f"mode: a finite-difference point failed to evaluate ({exc})") \
                from None

    unit = np.clip(np.asarray(start_unit, dtype=float).reshape(-1), 0.0, 1.0)
    if residuals is None or jacobian is None:
        r, jac = jacobian_at(unit)
    else:
        r, jac = np.asarray(residuals, dtype=float), np.asarray(jacobian, dtype=float)
    start_value = value = log_posterior(r, unit, model, prior)
    if not np.isfinite(value):
        raise DataError("mode: the log-posterior at the start is not finite")
    iterations, converged, damping = 0, False, 0.0
    while iterations < max_iterations:
        precision, gradient = newton_system(jac, r, unit, model, prior)
        while True:
            trial = np.clip(unit + damped_step(precision, gradient, damping, unit), 0.0,
                            1.0)
            r_trial = np.asarray(residuals_batch(prior.to_search(trial)[None, :])[0],
                                 dtype=float)
            evaluations += 1
            trial_value = (log_posterior(r_trial, trial, model, prior)
                           if np.all(np.isfinite(r_trial)) else -np.inf)
            if trial_value >= value:
                break
            damping = DAMPING_START if damping == 0.0 else damping * DAMPING_GROWTH
            if damping > DAMPING_LIMIT:
                return ModeResult(unit, r, value, start_value, iterations, evaluations, False)
        moved = trial - unit
        size = float(np.sqrt(max(moved @ precision @ moved, 0.0)))
        unit, r, value = trial, r_trial, trial_value
        iterations += 1
        damping = 0.0 if damping <= DAMPING_START else damping / DAMPING_GROWTH
        if size < tolerance:
            converged = True
            break
        if iterations < max_iterations:
            r, jac = jacobian_at(unit)
    return ModeResult(unit, r, value, start_value, iterations, evaluations, converged)


def mode_jacobians(problem: UpdateProblem, prior: Prior, model: ErrorModel,
                   start_unit: np.ndarray, r: np.ndarray, jac: np.ndarray,
                   steps: tuple[float, ...] = (LOCAL_STEP, UNIT_STEP)
                   ) -> tuple[np.ndarray, list[tuple[np.ndarray, np.ndarray]], int]:
    """The mode of a whitening error model (:func:`whitened_mode`
    from the best fit, with r and the local Jacobian there), the residuals and Jacobians at
    the mode over each of ``steps``, and the evaluations all that took."""
    mode = whitened_mode(problem.residuals_batch, prior, model, start_unit, residuals=r,
                         jacobian=jac)
    x = prior.to_search(mode.unit)
    jacobians = [residual_jacobian(problem.residuals_batch, problem.bounds, x, step=step)
                 for step in steps]
    return mode.unit, jacobians, mode.evaluations + len(steps) * (2 * x.size + 1)

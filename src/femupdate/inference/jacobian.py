"""The residuals' Jacobian at a point of the search space, by one batch of the problem.

The Laplace approximation at a best fit needs J = ∂r/∂ξ with ξ the unit-cube coordinates of
the search (x = low + (high − low)·ξ in the search space, log10 of a log-scale parameter).
It is taken by second-order differences in the unit cube,
central where both neighbours are inside and one-sided (three points) at a bound, as the coarse
stage of multistart-lm takes its own (:func:`femupdate.optimize.trust.second_order_stencils`):
all 2n points go to the problem's ``residuals_batch`` in one call (compiled, threads), so the
Jacobian costs 2n evaluations.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from femupdate.errors import FemupdateError
from femupdate.optimize.trust import second_order_columns, second_order_stencils

#: Difference step in the unit cube over 1 % of each range, the step of multistart-lm's coarse
#: stage, for the same reason: φ has ripples finer than that along weakly seen directions
#: (see :func:`femupdate.inference.best_fit.two_scale_record`), which it sees through.
UNIT_STEP = 1e-2
#: The local step: the compiled residuals are smooth to rounding (about 1e-13 of their size),
#: so a central difference's error (h² of the third derivative, plus rounding over h) is small
#: at 1e-4, far inside the bounds.
LOCAL_STEP = 1e-4


def residual_jacobian(residuals_batch: Callable[[np.ndarray], np.ndarray],
                      bounds: Sequence[tuple[float, float]], x: np.ndarray, *,
                      step: float = UNIT_STEP) -> tuple[np.ndarray, np.ndarray]:
    """The residual vector at ``x`` and its Jacobian with respect to the search space.

    Parameters
    ----------
    residuals_batch : callable
        ``(k, n)`` points of the search space → ``(k, m)`` residual vectors (an update
        problem's ``residuals_batch``).
    bounds : sequence of (low, high)
        The search space (the case's ``bounds``).
    x : ndarray (n,)
        The point (a best fit), in the search space.
    step : float
        Difference step in the unit cube.

    Returns
    -------
    r : ndarray (m,)
    jacobian : ndarray (m, n)
        ∂r/∂ξ in unit-cube coordinates (divide column i by ``high_i − low_i`` for the
        search space).

    Raises
    ------
    FemupdateError
        The residuals at ``x`` are not finite, or a parameter's differences failed on both
        sides (its column would be a guess).
    """
    low, high = (np.asarray(b, dtype=float) for b in zip(*bounds, strict=True))
    span = high - low
    xi = np.clip((np.asarray(x, dtype=float) - low) / span, 0.0, 1.0)
    n = xi.size
    offsets, weights = second_order_stencils(xi, step)
    eye = np.eye(n) * step
    unit_rows = np.vstack([xi, xi + eye * offsets[:, :1], xi + eye * offsets[:, 1:]])
    values = np.asarray(residuals_batch(low + span * unit_rows), dtype=float)
    base = values[0]
    if not np.all(np.isfinite(base)):
        raise FemupdateError("the residuals at the best fit are not finite: no Jacobian there")
    rows = values[1:]
    failed = ~np.all(np.isfinite(rows), axis=1)
    if failed.any():
        bad = sorted({int(i) % n for i in np.flatnonzero(failed)})
        raise FemupdateError(f"the model failed beside the best fit (a step of {step:g} of the "
                             f"range of parameter(s) {bad}): no Jacobian there")
    return base, second_order_columns(base, rows, weights, step)

"""The residuals' Jacobian at a point of the search space, by one batch of the problem.

The Laplace approximation at a best fit needs J = ∂r/∂θ with θ the search-space coordinates
(log10 of a log-scale parameter). It is taken by second-order differences in the unit cube,
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

#: Difference step in the unit cube. The compiled residuals are smooth to rounding (≈1e-13 of
#: their size), so a central difference's error h²·r'''/6 + ε/h is smallest near ε^(1/3) ≈ 1e-5;
#: 1e-4 keeps a friction model's stick–slip kinks (a step smaller than a kink's effect sees
#: the kink, not the slope) from dominating while staying far inside the bounds.
UNIT_STEP = 1e-4


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
        ∂r/∂θ per unit of the search-space coordinate.

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
    unit_jac = second_order_columns(base, rows, weights, step)
    return base, unit_jac / span

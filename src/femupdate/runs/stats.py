"""Statistics over repeated runs (the paper's Tables 2, 5, 6 and 9)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

#: A parameter within this fraction of its search range from a bound sits at the bound: an
#: improper minimum (the paper's §2.1; docs/method.md §2).
BOUND_TOL = 1e-3


def evaluation_stats(nfev: Sequence[int], success: Sequence[bool]) -> dict[str, Any]:
    """Success ratio and evaluations over the successful runs.

    Parameters
    ----------
    nfev : sequence of int
        Evaluations of each run; for a successful run, up to the first that reached f_target.
    success : sequence of bool
        Whether each run reached f_target.

    Returns
    -------
    dict
        ``runs, successes, success_ratio, evals_min, evals_mean, evals_median, evals_max``
        (the evaluation figures are None when no run succeeded), and ``evals_per_success``:
        the evaluations of all runs, failed ones included, per successful run (the expected
        running time of restarts until a success, Hansen's ERT).
    """
    nfev_arr = np.asarray(nfev, dtype=float)
    ok = np.asarray(success, dtype=bool)
    good = nfev_arr[ok]
    have = good.size > 0
    return {
        "runs": int(ok.size),
        "successes": int(ok.sum()),
        "success_ratio": float(ok.mean()) if ok.size else 0.0,
        "evals_min": int(good.min()) if have else None,
        "evals_mean": float(good.mean()) if have else None,
        "evals_median": float(np.median(good)) if have else None,
        "evals_max": int(good.max()) if have else None,
        "evals_per_success": float(nfev_arr.sum() / good.size) if have else None,
    }


def spread(values: np.ndarray, names: Sequence[str]) -> dict[str, dict[str, float]]:
    """Mean, standard deviation, min and max of each column of ``values`` (runs × names)."""
    values = np.atleast_2d(np.asarray(values, dtype=float))
    if values.shape[0] == 0:
        return {}
    return {
        name: {
            "mean": float(col.mean()),
            "std": float(col.std(ddof=1)) if col.size > 1 else 0.0,
            "min": float(col.min()),
            "max": float(col.max()),
        }
        for name, col in zip(names, values.T, strict=True)
    }


def bound_flags(positions: np.ndarray, tol: float = BOUND_TOL) -> np.ndarray:
    """−1 at (or below) the lower bound, +1 at (or above) the upper, 0 inside.

    "At" means within ``tol`` of the search range; ``positions`` are 0 at the lower bound and 1
    at the upper, in the search space (log10 for log-scale parameters).
    """
    p = np.asarray(positions, dtype=float)
    return np.where(p <= tol, -1, np.where(p >= 1.0 - tol, 1, 0)).astype(np.int8)


def at_bounds(x: np.ndarray, bounds: Sequence[tuple[float, float]],
              names: Sequence[str]) -> dict[str, str]:
    """The parameters of search point ``x`` that sit at a bound: name → "lower" or "upper".

    A run that ends with any is at an improper minimum (the paper's §2.1; docs/method.md §2),
    the typical failure of a bounded search, unless the bound is where the parameter physically
    is.
    """
    lower, upper = np.asarray(bounds, dtype=float).T
    flags = bound_flags((np.asarray(x, dtype=float) - lower) / (upper - lower))
    return {name: ("lower" if f < 0 else "upper")
            for name, f in zip(names, flags, strict=True) if f}

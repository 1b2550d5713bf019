"""What ``minimize`` refuses or bounds before and while it evaluates (issue 33): complex
values (a float conversion drops their imaginary part), a ``fun`` that ``workers=N`` cannot
pickle, and first pools or populations larger than the budget or than memory holds."""

from __future__ import annotations

import math
import numbers
import pickle
from typing import Any

import numpy as np

from femupdate.errors import ConfigError

__all__ = ["CMAES_MAX_PARAMETERS", "MAX_WORKING_FLOATS", "as_value", "budget_options",
           "check_picklable", "real_array", "refuse_complex"]


def refuse_complex(value: Any, x: np.ndarray, what: str) -> None:
    """ConfigError for complex numbers: a float conversion drops their imaginary part without
    a word (and φ = r·r of complex r is not ‖r‖²)."""
    if np.iscomplexobj(value) or (isinstance(value, list | tuple) and any(
            isinstance(v, complex | np.complexfloating) for v in value)):
        raise ConfigError(f"{what} returned complex values at x = {x.tolist()} (allowed: real "
                          "numbers; for |r|² of complex residuals return the real and "
                          "imaginary parts as separate residuals)")


def real_array(value: Any, x: np.ndarray, what: str) -> np.ndarray:
    """``value`` as a float array, complex numbers refused (:func:`refuse_complex`)."""
    refuse_complex(value, x, what)
    return np.asarray(value, dtype=float)


def check_picklable(fun: Any, workers: Any) -> None:
    """ConfigError, before any evaluation, when ``workers=N`` cannot send ``fun`` to its
    processes (a lambda, a closure): the pickling error came back as an error of fun(x)."""
    if isinstance(workers, bool) or not isinstance(workers, numbers.Integral) or workers == 1:
        return
    try:
        pickle.dumps(fun)
    except Exception as exc:  # pickle raises PicklingError, AttributeError, TypeError, ...
        raise ConfigError(f"workers={workers}: fun cannot be sent to worker processes ("
                          f"{type(exc).__name__}: {exc}) (allowed: a picklable fun, e.g. a "
                          "function defined at module level, or workers=1, or a map-like "
                          "workers that needs no pickling)") from None


#: The most floats (8 bytes each) a method may hold at once: 2 GB.
MAX_WORKING_FLOATS = 2.5e8
#: CMA-ES decomposes its n × n covariance (O(n³)) as it learns it: 12 s before the first
#: evaluation at n = 1,000 on a 2-core machine; above this it is refused.
CMAES_MAX_PARAMETERS = 2_000


def budget_options(method: str, n: int, max_evals: int, options: dict[str, Any]
                   ) -> dict[str, Any]:
    """The options with a first pool or population no larger than the budget (a pool of
    20·n points of multistart-lm, DE's 15·n members), so memory follows ``max_evals``; a
    dimension the method cannot serve in MAX_WORKING_FLOATS refused up front.

    Only defaults change, and only where the budget ends the run inside its first pool or
    population anyway (4,000 parameters and max_evals = 10 took 5.1 GB and 206 s).
    """
    options = dict(options)
    if method == "multistart-lm" and options.get("pool") is None and max_evals < 20 * n:
        options["pool"] = max_evals
    if method == "de" and "popsize" not in options and max_evals < 15 * n:
        options["popsize"] = max(5, max_evals)
    held = {"multistart-lm": lambda: (options.get("pool") or 20 * n) * n + 4.0 * n * n,
            "scipy-lsq": lambda: 4.0 * n * n,
            "cmaes": lambda: 4.0 * n * n,
            # scipy's DE holds its population several times over (1 GB at 15,000 × 1,000)
            "de": lambda: 8.0 * int(options.get("popsize", 15 * n)) * n}.get(method)
    floats = held() if held is not None and isinstance(options.get("pool", 1) or 1, int) \
        and isinstance(options.get("popsize", 1), int) else 0.0
    if floats > MAX_WORKING_FLOATS or (method == "cmaes" and n > CMAES_MAX_PARAMETERS):
        raise ConfigError(
            f"method {method!r} cannot serve {n:,} parameters: it would hold about "
            f"{floats * 8 / 1e9:.1f} GB at once" + (
                f" and decompose an n × n covariance (allowed: up to "
                f"{CMAES_MAX_PARAMETERS:,} parameters)" if method == "cmaes" else
                f" (allowed: up to {MAX_WORKING_FLOATS * 8 / 1e9:.0f} GB; a smaller pool or "
                "popsize option, fewer parameters, or method 'ab' or 'ib', whose "
                "memory grows as n)"))
    return options


def as_value(value: Any, x: np.ndarray) -> float:
    """``fun``'s value as a float; NaN and ±inf are a failed evaluation (+inf).

    Only real numbers are accepted (a numpy scalar or a one-element array too): a string or a
    bool is a mistake in ``fun``, not a value to minimise.
    """
    if isinstance(value, np.ndarray) and value.size == 1:
        value = value.reshape(()).item()
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise ConfigError(f"fun(x) must return a real number, got {value!r} (of type "
                          f"{type(value).__name__}) at x = {x.tolist()}")
    f = float(value)
    return f if math.isfinite(f) else math.inf

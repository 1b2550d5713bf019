"""Stopping criteria owned by ``minimize`` (target, budget) and the result's status and message.

The optimizers' own criteria (σ_s, Δφ_s, pycma's, DE's tol) come from their ``stop()``;
``minimize`` merges everything that fired into one ``stop`` dict of the result.
"""

from __future__ import annotations

import math
import numbers
from enum import IntEnum
from typing import Any

from femupdate.errors import ConfigError


class Status(IntEnum):
    """``OptimizeResult.status``: why the run ended (the first that applies, in this order)."""

    F_TARGET = 0  #: φ ≤ f_target
    MAX_EVALS = 1  #: the evaluation budget was used up
    OPTIMIZER = 2  #: one of the optimizer's own criteria fired (it converged or stalled)
    CALLBACK = 3  #: the callback raised StopIteration


def is_success(stop: dict[str, object], f_target: float | None) -> bool:
    """scipy's meaning of ``success``: the search ended by converging, not by running out.

    With an ``f_target`` the user has said what success is: reaching it. Without one, a run
    succeeds when the optimizer's own criteria ended it (σ_s, Δφ_s, pycma's tolerances, DE's
    tol), not the budget or the callback.
    """
    if f_target is not None:
        return "f_target" in stop
    return bool(stop) and not ({"max_evals", "callback"} & set(stop))


def check_max_evals(max_evals: Any) -> int:
    """``max_evals`` as a positive int; ConfigError otherwise."""
    if isinstance(max_evals, bool) or not isinstance(max_evals, numbers.Integral) or max_evals < 1:
        raise ConfigError(f"max_evals must be an integer ≥ 1, got {max_evals!r}")
    return int(max_evals)


def check_f_target(f_target: Any, *, sum_of_squares: bool = True) -> float | None:
    """``f_target`` as a finite float or None; ConfigError otherwise. A target below 0 is
    refused for a sum of squares (φ = ‖r‖², a case's error), which never goes below 0; a
    scalar function of :func:`~femupdate.minimize` may have negative values (bbob's optima)."""
    if f_target is None:
        return None
    if isinstance(f_target, bool) or not isinstance(f_target, numbers.Real):
        raise ConfigError(f"f_target must be a finite real number or None, got {f_target!r}")
    value = float(f_target)
    if not math.isfinite(value):
        raise ConfigError(f"f_target must be a finite real number or None, got {f_target!r}")
    if value < 0 and sum_of_squares:
        raise ConfigError(f"f_target: got {value!r} (allowed: >= 0 or None: φ is an error, a "
                          "sum of squares or a normalised one, never below 0, so a negative "
                          "target can never be reached; as [search] f_target in a case file)")
    return value


def loop_criteria(f: float, nfev: int, f_target: float | None, max_evals: int) -> dict[str, object]:
    """The loop's criteria fired by the evaluation that made ``nfev`` and returned ``f``."""
    fired: dict[str, object] = {}
    if f_target is not None and f <= f_target:
        fired["f_target"] = f
    if nfev >= max_evals:
        fired["max_evals"] = nfev
    return fired


def status_and_message(stop: dict[str, object]) -> tuple[Status, str]:
    """Status code and a one-line message from the merged ``stop`` dict (non-empty)."""
    if "f_target" in stop:
        return Status.F_TARGET, f"f_target reached: f = {stop['f_target']:.6g}"
    if "max_evals" in stop:
        return Status.MAX_EVALS, f"max_evals reached: {stop['max_evals']} evaluations"
    if "callback" in stop:
        return Status.CALLBACK, "the callback raised StopIteration"
    fired = ", ".join(f"{k} = {v!r}" for k, v in stop.items())
    return Status.OPTIMIZER, f"the optimizer's criteria fired: {fired}"

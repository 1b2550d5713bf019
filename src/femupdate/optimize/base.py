"""The ask/tell protocol every optimizer follows, and the checks of their options.

Optimizers work only in the unit cube [0, 1]^n (the map to the user's bounds, Eq. 8, is
``minimize``'s). One step is ``X = opt.ask()`` (k candidates, one per row), the caller evaluates
them, ``opt.tell(X, F)``, then ``opt.stop()`` says which internal criteria fired. The budget
(``max_evals``) and the target (``f_target``) belong to ``minimize``, not to the optimizers.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Iterable, Mapping
from typing import Any, Protocol, runtime_checkable

import numpy as np

from femupdate.errors import ConfigError


@runtime_checkable
class Optimizer(Protocol):
    """What ``minimize`` needs from an optimizer (all in the unit cube).

    Optimizers are picklable unless their docstring says otherwise (``de`` and ``ga`` are not:
    their runs restart instead of resuming).
    """

    def ask(self) -> np.ndarray:
        """The next candidates, shape (k, n), inside [0, 1]^n."""
        ...

    def tell(self, xs: np.ndarray, fs: np.ndarray) -> None:
        """Values ``fs`` (k,) of the candidates ``xs`` (k, n); NaN or inf is a failed one."""
        ...

    def stop(self) -> dict[str, object]:
        """The internal criteria that fired, with their values; empty: go on."""
        ...

    @property
    def result(self) -> tuple[np.ndarray, float]:
        """The best point so far (unit cube) and its value."""
        ...

    def trace(self) -> dict[str, np.ndarray]:
        """Per-step arrays for plots (may be empty)."""
        ...

    def close(self) -> None:
        """Release resources (threads); the optimizer is unusable afterwards."""
        ...


class KeepsBest:
    """The best candidate told so far, for optimizers whose library does not keep it: call
    :meth:`_keep_best` in ``tell`` and set ``best_x`` (a start point) in ``__init__``."""

    best_x: np.ndarray
    best_f: float = math.inf

    def _keep_best(self, xs: np.ndarray, fs: np.ndarray) -> None:
        i = int(np.argmin(fs))
        if fs[i] < self.best_f:
            self.best_f = float(fs[i])
            self.best_x = xs[i].copy()

    @property
    def result(self) -> tuple[np.ndarray, float]:
        return self.best_x.copy(), self.best_f


#: A factory ``(n, rng, **options) -> Optimizer`` that validates its options.
Factory = Callable[..., Optimizer]


def failed_as_inf(fs: np.ndarray) -> np.ndarray:
    """Values as floats, with NaN and ±inf (failed evaluations) replaced by +inf."""
    out = np.array(fs, dtype=float)
    out[~np.isfinite(out)] = np.inf
    return out


def check_option_names(method: str, options: Mapping[str, Any], allowed: Iterable[str]) -> None:
    """Raise ConfigError naming the unknown options of ``method`` and listing the allowed ones."""
    allowed = tuple(allowed)
    unknown = sorted(set(options) - set(allowed))
    if unknown:
        listed = ", ".join(allowed) if allowed else "(none)"
        raise ConfigError(
            f"unknown option(s) {', '.join(map(repr, unknown))} for method {method!r}; "
            f"allowed options: {listed}"
        )


def real_option(
    method: str,
    name: str,
    value: Any,
    low: float,
    high: float = math.inf,
    *,
    low_open: bool = False,
    high_open: bool = False,
    allow_none: bool = False,
) -> float | None:
    """A real option checked against [low, high] (or open ends); ConfigError otherwise."""
    if value is None and allow_none:
        return None
    lo = "(" if low_open else "["
    hi = ")" if high_open else "]"
    allowed = f"{lo}{low:g}, {high:g}{hi}" + (" or None" if allow_none else "")
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ConfigError(
            f"option {name!r} of method {method!r} must be a real number in {allowed}, "
            f"got {value!r}"
        )
    x = float(value)
    below = x <= low if low_open else x < low
    above = x >= high if high_open else x > high
    if math.isnan(x) or below or above:
        raise ConfigError(
            f"option {name!r} of method {method!r} must be in {allowed}, got {value!r}"
        )
    return x


def int_option(method: str, name: str, value: Any, low: int, high: int | None = None) -> int:
    """An integer option checked against [low, high]; ConfigError otherwise."""
    allowed = f"[{low}, {high if high is not None else 'inf'}]"
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ConfigError(
            f"option {name!r} of method {method!r} must be an integer in {allowed}, "
            f"got {value!r}"
        )
    if value < low or (high is not None and value > high):
        raise ConfigError(
            f"option {name!r} of method {method!r} must be in {allowed}, got {value!r}"
        )
    return int(value)


def check_batch(xs: np.ndarray, fs: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``xs`` as a float (k, n) array and ``fs`` as (k,) with failures as +inf."""
    xs = np.asarray(xs, dtype=float)
    fs = failed_as_inf(np.asarray(fs, dtype=float).reshape(-1))
    if xs.ndim != 2 or xs.shape[1] != n or xs.shape[0] != fs.shape[0]:
        raise ConfigError(
            f"tell() expects xs of shape (k, {n}) and fs of shape (k,), "
            f"got {xs.shape} and {fs.shape}"
        )
    return xs, fs

"""The ask/tell protocol every optimizer follows, and the checks of their options.

Optimizers work only in the unit cube [0, 1]^n (the map to the user's bounds, Eq. 8, is
``minimize``'s). One step is ``X = opt.ask()`` (k candidates, one per row), the caller evaluates
them, ``opt.tell(X, F)``, then ``opt.stop()`` says which internal criteria fired. The budget
(``max_evals``) and the target (``f_target``) belong to ``minimize``, not to the optimizers.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any, Protocol, runtime_checkable

import numpy as np

from femupdate.errors import ConfigError


@runtime_checkable
class Optimizer(Protocol):
    """What ``minimize`` needs from an optimizer (all in the unit cube).

    The checkpoint protocol: an optimizer's state is its attributes, pickled between chunks of
    a long run (``femupdate.runs``). Its per-step plot data live in a :class:`StepTrace`, which
    a pickle leaves out (the run's store keeps them, read with :meth:`trace_since` before each
    checkpoint), so a checkpoint does not grow with the run. Optimizers are picklable unless
    their docstring says otherwise (``de`` and ``ga`` are not: their runs restart instead of
    resuming).
    """

    def ask(self) -> np.ndarray:
        """The next candidates, shape (k, n), inside [0, 1]^n."""
        ...

    def tell(self, xs: np.ndarray, fs: np.ndarray, rs: np.ndarray | None = None) -> None:
        """Values ``fs`` (k,) of the candidates ``xs`` (k, n); NaN or inf is a failed one.
        ``rs`` (k, m): their residual vectors when the function gives them (φ = ‖r‖²)."""
        ...

    def stop(self) -> dict[str, object]:
        """The internal criteria that fired, with their values; empty: go on."""
        ...

    def trace_since(self, step: int) -> dict[str, np.ndarray]:
        """Per-step arrays for plots, rows of steps ``step`` … still held (may be empty)."""
        ...

    def close(self) -> None:
        """Release resources (threads); the optimizer is unusable afterwards."""
        ...


class StepTrace:
    """Rows an optimizer records once per step for plots: σ, a, b, the mode, the best φ, ….

    They are not part of the search state: pickling (a checkpoint) drops the rows held and
    keeps their count, so that a checkpoint does not grow with the run; a long run stores the
    rows of each chunk (:meth:`since`) before it checkpoints.
    """

    def __init__(self) -> None:
        self.first = 0  # step of the first row held
        self.count = 0  # rows held
        self._columns: dict[str, np.ndarray] = {}

    @property
    def steps(self) -> int:
        """Steps recorded since the optimizer started (held or not)."""
        return self.first + self.count

    def append(self, **row: float | np.ndarray) -> None:
        """Record one step's values (the same names at every step)."""
        k = self.count
        for name, value in row.items():
            column = self._columns.get(name)
            if column is None:
                column = np.empty((64, *np.shape(value)))
                self._columns[name] = column
            elif k == column.shape[0]:  # grow geometrically
                grown = np.empty((2 * k, *column.shape[1:]))
                grown[:k] = column
                self._columns[name] = column = grown
            column[k] = value
        self.count = k + 1

    def since(self, step: int) -> dict[str, np.ndarray]:
        """Copies of the rows of steps ``step`` … that are held."""
        start = min(max(step - self.first, 0), self.count)
        return {name: column[start:self.count].copy() for name, column in self._columns.items()}

    def __getstate__(self) -> dict[str, Any]:
        return {"first": self.first + self.count, "count": 0, "_columns": {}}


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


class Restarts:
    """Stagnation, and restarts from scratch when a search has converged or stalled.

    An optimizer that mixes this in sets ``restarts`` (how many, ≥ 0), ``stall_window`` (in
    evaluations, or None: off) and ``stall_tol`` in ``__init__``, then calls
    :meth:`_new_search`; it implements ``_restart()`` (its state as before the first step,
    drawing any new start from the same Generator) and ``_criteria()`` (its own stopping
    criteria that fired, merged with :meth:`_stall`), and in ``tell`` calls :meth:`_track`
    with the values told and then :meth:`_restart_if_converged`.

    A search has *stalled* when its best φ fell by less than the fraction ``stall_tol`` (of
    |φ|) over its last ``stall_window`` evaluations. On the noise-free viscous bridge (AB,
    window 1,000, tolerance 1 %) searches creeping into an improper minimum (a parameter at a
    bound) stalled after 1,500–1,800 evaluations, long before σ reached σ_s, and none of the 17
    that went on to φ < 1e-6 stalled on the way. With ``restarts`` left, a converged or stalled
    search gives way to a fresh one; the best point over all of them is the result. ``stop()``
    reports the criteria once no restart is left.
    """

    restarts: int = 0
    restarts_done: int = 0
    stall_window: int | None = None
    stall_tol: float = 0.01

    def _criteria(self) -> dict[str, object]:
        raise NotImplementedError

    def _restart(self) -> None:
        raise NotImplementedError

    def _new_search(self) -> None:
        self._restart()
        # The search's best φ after each of its last stall_window + 1 evaluations: a ring,
        # inf where not yet written (so the entry before the first is inf too).
        window = self.stall_window
        self._search_bests = None if window is None else np.full(window + 1, math.inf)
        self._search_evals = 0

    def _track(self, fs: np.ndarray) -> None:
        """Record the values of a step (in the order evaluated) for the stall criterion."""
        ring = self._search_bests
        if ring is None:
            return
        for f in fs:
            n = self._search_evals
            ring[n % ring.size] = min(ring[(n - 1) % ring.size], float(f))
            self._search_evals = n + 1

    def _stall(self) -> dict[str, object]:
        """``stall``: the relative fall of the search's best φ over its last ``stall_window``
        evaluations, when below ``stall_tol``."""
        ring = self._search_bests
        n = self._search_evals
        if ring is None or n < ring.size:
            return {}
        best, before = ring[(n - 1) % ring.size], ring[n % ring.size]  # now, window ago
        with np.errstate(invalid="ignore"):  # inf − inf (nothing finite yet): not a stall
            fall = (before - best) / abs(before) if before != 0.0 else math.inf
        if fall < self.stall_tol:
            return {"stall": fall}
        return {}

    def _restart_if_converged(self) -> None:
        if self.restarts_done < self.restarts and self._criteria():
            self._new_search()
            self.restarts_done += 1

    def stop(self) -> dict[str, object]:
        """The optimizer's criteria that fired (none while restarts are left)."""
        return self._criteria()


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


def restart_options(method: str, options: Mapping[str, Any]) -> dict[str, Any]:
    """``stall_window``, ``stall_tol`` and ``restarts`` of :class:`Restarts`, checked."""
    window = options.get("stall_window")
    return {
        "stall_window": None if window is None else int_option(method, "stall_window", window, 1),
        "stall_tol": real_option(method, "stall_tol", options.get("stall_tol", 0.01), 0.0, 1.0,
                                 low_open=True, high_open=True),
        "restarts": int_option(method, "restarts", options.get("restarts", 0), 0),
    }


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


def stack_rows(rows: Sequence[np.ndarray]) -> np.ndarray:
    """The vectors as the rows of one (k, m) array: when they are the rows of one batch's
    array, in order (a batch of residual vectors that all came back finite), that array
    itself (no stacking copy of k vectors), else ``np.vstack``."""
    first = rows[0]
    base = first.base
    if (isinstance(base, np.ndarray) and base.ndim == 2 and base.shape == (len(rows), first.size)
            and base.flags.c_contiguous and base.dtype == np.float64):
        start = base.__array_interface__["data"][0]
        step = base.strides[0]
        if all(r.base is base and r.ndim == 1 and r.size == first.size
               and r.strides == (base.itemsize,)
               and r.__array_interface__["data"][0] == start + i * step
               for i, r in enumerate(rows)):
            return base
    return np.vstack(rows)

"""``minimize``: the one loop of the package, and the registry of optimizers by name.

Every optimizer sees only the unit cube; ``minimize`` maps its candidates to the user's bounds
(x = low + (high − low)·ξ, Eq. 8), evaluates them in order, keeps the history and owns the
budget (``max_evals``) and the target (``f_target``). The loop state lives in one picklable
:class:`MinimizeState`, so a run can be checkpointed between steps.
"""

from __future__ import annotations

import builtins
import inspect
import math
import numbers
import time
import warnings
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import Any

import numpy as np
from scipy.optimize import Bounds, OptimizeResult

from femupdate._parallel import PoolMap, default_workers
from femupdate.errors import ConfigError, FemupdateError
from femupdate.optimize.base import Optimizer, stack_rows
from femupdate.optimize.limits import (
    as_value,
    budget_options,
    check_picklable,
    real_array,
    refuse_complex,
)
from femupdate.optimize.registry import (  # noqa: F401 (the registry, re-exported)
    METHODS,
    POPULATION_METHODS,
    RESIDUAL_METHODS,
    objective_for,
    register_method,
)
from femupdate.optimize.termination import (
    check_f_target,
    check_max_evals,
    is_success,
    loop_criteria,
    status_and_message,
)
from femupdate.optimize.timed import FAILED, TimedFunction, check_timeout

#: Added to the result's message when every evaluation failed (φ NaN or inf).
NO_SUCCESS = ("no evaluation succeeded: fun returned NaN or inf at every point tried, so x is "
              "not a minimum")

#: φ(x) of a point in original units.
ScalarFunction = Callable[[np.ndarray], float]
#: ``map(fun, rows)``: evaluates the rows lazily, in order.
MapLike = Callable[[ScalarFunction, Iterable[np.ndarray]], Iterable[Any]]


def parse_bounds(bounds: Sequence[tuple[float, float]] | Bounds) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds as float arrays (n,), finite with low < high; ConfigError if not."""
    try:
        if isinstance(bounds, Bounds):
            low, high = np.broadcast_arrays(np.asarray(bounds.lb, dtype=float),
                                            np.asarray(bounds.ub, dtype=float))
            if low.ndim != 1:
                raise ConfigError(
                    f"Bounds must give one (low, high) per parameter (1-D lb and ub), got "
                    f"lb={bounds.lb!r}, ub={bounds.ub!r}"
                )
        else:
            pairs = np.asarray(bounds, dtype=float)
            if pairs.size == 0:
                raise ConfigError("bounds must give at least one parameter, got none")
            if pairs.ndim != 2 or pairs.shape[1] != 2:
                raise ConfigError(
                    f"bounds must be a sequence of (low, high) pairs or scipy.optimize.Bounds, "
                    f"got an array of shape {pairs.shape}"
                )
            low, high = pairs[:, 0], pairs[:, 1]
    except (TypeError, ValueError) as exc:
        if isinstance(exc, ConfigError):
            raise
        raise ConfigError(
            f"bounds must be a sequence of (low, high) pairs of numbers or scipy.optimize.Bounds,"
            f" got {bounds!r}"
        ) from exc
    if low.size == 0:
        raise ConfigError("bounds must give at least one parameter, got none")
    for i, (lo, hi) in enumerate(zip(low.tolist(), high.tolist(), strict=True)):
        if not (math.isfinite(lo) and math.isfinite(hi)):
            raise ConfigError(f"bounds[{i}] = ({lo!r}, {hi!r}): both must be finite")
        if not lo < hi:
            raise ConfigError(f"bounds[{i}] = ({lo!r}, {hi!r}): low must be < high")
        if not math.isfinite(hi - lo):
            raise ConfigError(f"bounds[{i}] = ({lo!r}, {hi!r}): the interval is too wide, its "
                              f"length high − low overflows (allowed: high − low at most "
                              f"{np.finfo(float).max:.4g}; rescale the parameter)")
    return low.copy(), high.copy()


class MinimizeState:
    """Everything the loop carries from one step to the next (picklable if the optimizer is).

    A pickle of the state is a checkpoint: it leaves out the history of evaluations (a long
    run keeps it in its store, read with :meth:`evaluations_since` before each checkpoint)
    and, through the optimizer's :class:`~femupdate.optimize.base.StepTrace`, its per-step
    trace, so that it does not grow with the run.

    Parameters
    ----------
    optimizer : Optimizer
        Working on the unit cube.
    method : str
        Its name, reported in the result.
    low, high : ndarray
        Bounds (n,).
    max_evals : int
        Budget of evaluations.
    f_target : float or None
        Stop (successfully) once φ ≤ f_target.
    record_times : bool
        Keep the wall-clock time (``time.perf_counter``) of every evaluation.
    residuals : bool
        ``fun`` returns the residual vector r; φ = r·r.
    """

    def __init__(self, optimizer: Optimizer, method: str, low: np.ndarray, high: np.ndarray,
                 max_evals: int, f_target: float | None, record_times: bool = False,
                 residuals: bool = False) -> None:
        self.optimizer = optimizer
        self.method = method
        self.low = low
        self.high = high
        self.span = high - low
        self.max_evals = max_evals
        self.f_target = f_target
        self.record_times = record_times
        self.nfev = 0
        self.nit = 0
        self.best_x = low + 0.5 * self.span  # replaced by the first evaluation
        self.best_f = math.inf
        self.stopped: dict[str, object] = {}
        self.nfail = 0  # evaluations that failed (φ = inf)
        self.first_failure: str | None = None  # why the first one failed, if fun says
        self.residuals = residuals
        self.best_r: np.ndarray | None = None  # r at best_x (residuals mode)
        self._new_history(room=min(max_evals, 1024))

    # -- checkpoints ---------------------------------------------------------------------------

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        for name in ("_hist_x", "_hist_f", "_hist_t", "_failures"):
            del state[name]
        state.pop("_last_value", None)  # the last value fun returned: not part of the run
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._new_history(room=1024)

    def _new_history(self, room: int) -> None:
        """Empty history buffers for evaluations ``nfev`` … (rows before are not held)."""
        self._hist_first = self.nfev
        cap = max(1, min(room, self.max_evals - self.nfev))
        self._hist_x = np.empty((cap, self.low.size))
        self._hist_f = np.empty(cap)
        self._hist_t = np.empty(cap if self.record_times else 0)
        self._failures: list[tuple[int, str]] = []

    def failures_since(self, nfev: int) -> list[tuple[int, str]]:
        """(evaluation, why it failed) of the failed evaluations ``nfev`` … that are held,
        when ``fun`` says why (its attribute ``last_failure``)."""
        return [(i, why) for i, why in self._failures if i >= nfev]

    def evaluations_since(self, nfev: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Copies of ``x`` (k, n), φ (k,) and wall times (k,; empty without ``record_times``)
        of evaluations ``nfev`` … that are held."""
        i = min(max(nfev - self._hist_first, 0), self.nfev - self._hist_first)
        j = self.nfev - self._hist_first
        times = self._hist_t[i:j].copy() if self.record_times else np.empty(0)
        return self._hist_x[i:j].copy(), self._hist_f[i:j].copy(), times

    def trace_since(self, step: int) -> dict[str, np.ndarray]:
        """The optimizer's per-step trace from step ``step`` on (rows held)."""
        return self.optimizer.trace_since(step)

    # -- the loop ------------------------------------------------------------------------------

    @property
    def done(self) -> bool:
        """Whether a stopping criterion fired."""
        return bool(self.stopped)

    def step(self, fun: ScalarFunction, map: MapLike = builtins.map,
             on_evaluation: Callable[[np.ndarray, float], Any] | None = None) -> None:
        """One ask, the evaluations in order (stopping at once on target or budget), one tell."""
        xi = self.optimizer.ask()
        x = np.clip(self.low + self.span * xi, self.low, self.high)
        k = x.shape[0]
        if k == 0:
            raise FemupdateError(f"the {self.method!r} optimizer proposed no candidates")
        fs = np.empty(k)
        rs: list[np.ndarray] = []
        evaluated = 0
        batch = batch_of(fun, self.residuals)
        # ``fun`` gets copies: one that writes into its x must not move the point recorded
        # for its value (r.x was not the point of r.fun).
        if map is builtins.map and callable(batch) and k > 1:
            # A population (or a Jacobian's columns) in one call of a function that evaluates
            # batches (femupdate's update problems: compiled), taken in order as below.
            values = real_array(batch(x.copy()), x[0], "fun's batch")
            results: Iterator[Any] = iter(values if self.residuals else values.tolist())
        else:
            results = iter(map(fun, iter(x.copy())))
        try:
            for i in range(k):
                fs[i] = f = self._evaluate_next(results, x[i], rs)
                if f == math.inf:
                    self._record_failure(fun, x[i])
                evaluated += 1
                if on_evaluation is not None:
                    on_evaluation(x[i].copy(), f)  # a copy, as fun's
                fired = loop_criteria(f, self.nfev, self.f_target, self.max_evals)
                if fired:
                    self.stopped.update(fired)
                    break
        finally:
            close = getattr(results, "close", None)
            if close is not None:  # a generator (e.g. an executor's map): cancel the rest
                close()
        if evaluated == k:
            if self.residuals:
                self.optimizer.tell(xi, fs, stack_rows(rs))  # a batch: no copy
            else:
                self.optimizer.tell(xi, fs)
            self.nit += 1
            self.stopped.update(self.optimizer.stop())

    def _evaluate_next(self, results: Iterator[Any], x: np.ndarray,
                       rs: list[np.ndarray]) -> float:
        try:
            value = next(results)
        except StopIteration:
            raise ConfigError("map(fun, rows) returned fewer results than rows") from None
        except Exception as exc:
            exc.add_note(f"femupdate.minimize: raised while evaluating fun(x) at x = {x.tolist()}")
            raise
        r = None
        self._last_value = value
        if self.residuals:
            size = rs[0].size if rs else (None if self.best_r is None else self.best_r.size)
            r, f = _residual_vector(value, x, size)
            rs.append(r)
        elif value is FAILED:
            f = math.inf
        else:
            f = as_value(value, x)
        n = self.nfev - self._hist_first
        if n == self._hist_f.shape[0]:
            self._grow_history()
        self._hist_x[n] = x
        self._hist_f[n] = f
        if self.record_times:
            self._hist_t[n] = time.perf_counter()
        self.nfev += 1
        if f < self.best_f or self.nfev == 1:
            self.best_f = f
            self.best_x = x.copy()
            if r is not None:
                self.best_r = r.copy()
        return f

    def _record_failure(self, fun: ScalarFunction, x: np.ndarray) -> None:
        """Count a failed evaluation and keep why, when ``fun`` (evaluated here) says, or the
        object it is a method of (an update problem's ``residuals``); else what it returned."""
        self.nfail += 1
        why = getattr(fun, "last_failure", getattr(getattr(fun, "__self__", None),
                                                   "last_failure", None))
        if not isinstance(why, str):
            value = getattr(self, "_last_value", None)
            shown = ("a residual vector with non-finite entries" if self.residuals and
                     value is not FAILED else repr(value))
            why = f"fun(x) returned {shown} at x = {x.tolist()}"
        if isinstance(why, str):
            self._failures.append((self.nfev - 1, why))
            if self.first_failure is None:
                self.first_failure = why

    def _grow_history(self) -> None:
        held = self.nfev - self._hist_first
        cap = max(1, min(2 * held, self.max_evals - self._hist_first))
        for name in ("_hist_x", "_hist_f") + (("_hist_t",) if self.record_times else ()):
            old = getattr(self, name)
            new = np.empty((cap, *old.shape[1:]))
            new[:held] = old[:held]
            setattr(self, name, new)

    def history(self) -> dict[str, np.ndarray]:
        """``x`` (nfev, n) in original units, ``fun`` (nfev,), and the optimizer's trace (the
        rows held: all of them unless the state was restored from a checkpoint)."""
        x, f, _ = self.evaluations_since(0)
        return {"x": x, "fun": f, **self.trace_since(0)}

    def intermediate_result(self) -> OptimizeResult:
        """What a callback receives after each step: ``x``, ``fun``, ``nfev``, ``nit``."""
        return OptimizeResult(x=self.best_x.copy(), fun=self.best_f, nfev=self.nfev,
                              nit=self.nit)

    def result(self) -> OptimizeResult:
        """The ``OptimizeResult`` of the run so far."""
        stop = dict(self.stopped)
        if stop:
            status, message = status_and_message(stop)
        else:
            status, message = -1, "not finished"
        failed = self.nfev > 0 and not math.isfinite(self.best_f)
        if failed:
            message += f"; {NO_SUCCESS}"
        return OptimizeResult(
            x=self.best_x.copy(),
            fun=self.best_f,
            nfev=self.nfev,
            nit=self.nit,
            success=is_success(stop, self.f_target) and not failed,
            status=int(status),
            message=message,
            stop=stop,
            method=self.method,
            restarts=int(getattr(self.optimizer, "restarts_done", 0)),
            nfail=self.nfail,
            failure=self.first_failure,
            history=self.history(),
            **({} if self.best_r is None else {"residuals": self.best_r.copy()}),
            # What a sampler hands back besides a best point (TMCMC: its final samples).
            **({} if not hasattr(self.optimizer, "extras") else
               {"extras": self.optimizer.extras()}),
        )


def batch_of(fun: Callable[[np.ndarray], Any], residuals: bool
             ) -> Callable[..., Any] | None:
    """What evaluates a batch of rows for ``fun`` in one call, if anything: its
    ``evaluate_batch`` (φ), or for the ``residuals`` method of an object (an update
    problem's) that object's ``residuals_batch``."""
    if not residuals:
        return getattr(fun, "evaluate_batch", None)
    if getattr(fun, "__name__", None) != "residuals":
        return None
    return getattr(getattr(fun, "__self__", None), "residuals_batch", None)


def _residual_vector(value: Any, x: np.ndarray, size: int | None) -> tuple[np.ndarray, float]:
    """A residual vector as a float array (m,) and φ = r·r; a non-finite r, or an evaluation
    that timed out (FAILED), is a failed evaluation: all inf, φ = inf."""
    if value is FAILED:
        if size is None:
            raise ConfigError(f"fun(x) timed out at x = {x.tolist()} before any residual "
                              "vector came back, so their length is unknown (allowed: a "
                              "timeout that the first evaluation keeps)")
        return np.full(size, math.inf), math.inf
    if isinstance(value, bool | np.bool_ | str | bytes):
        raise ConfigError(f"fun(x) must return a vector of real residuals with "
                          f"residuals=True, got {value!r} at x = {x.tolist()}")
    refuse_complex(value, x, "fun(x)")
    try:
        r = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f"fun(x) must return a vector of real residuals with "
                          f"residuals=True, got {value!r} at x = {x.tolist()}") from None
    if r.ndim > 1:
        raise ConfigError(f"fun(x) returned residuals of shape {r.shape} at x = {x.tolist()} "
                          "(allowed: a 1-D vector (m,), as scipy.optimize.least_squares' fun; "
                          "flatten it with .ravel() if every entry is a residual)")
    r = r.reshape(-1)
    if r.size == 0:
        raise ConfigError(f"fun(x) returned an empty residual vector at x = {x.tolist()} "
                          "(allowed: at least one residual)")
    if size is not None and r.size != size:
        raise ConfigError(f"fun(x) returned {r.size} residuals at x = {x.tolist()}, earlier "
                          f"{size}: the residual vector must keep its length")
    if not np.all(np.isfinite(r)):
        return np.full(r.size, math.inf), math.inf
    f = float(r @ r)
    return (r, f) if math.isfinite(f) else (np.full(r.size, math.inf), math.inf)


def start(fun: ScalarFunction, bounds: Sequence[tuple[float, float]] | Bounds,
          method: str = "ab", *, seed: Any = None, max_evals: int = 50_000,
          f_target: float | None = None, record_times: bool = False,
          residuals: bool = False, **options: Any) -> MinimizeState:
    """Validate the arguments and build the loop state of a run (see :func:`minimize`)."""
    if not callable(fun):
        raise ConfigError(f"fun must be callable, got {fun!r}")
    if method not in METHODS:
        raise ConfigError(f"unknown method {method!r}; allowed methods: {', '.join(METHODS)}")
    low, high = parse_bounds(bounds)
    max_evals = check_max_evals(max_evals)
    f_target = check_f_target(f_target, sum_of_squares=residuals)
    try:
        rng = np.random.default_rng(seed)
    except (TypeError, ValueError) as exc:
        raise ConfigError(
            f"seed must be None, an int, a SeedSequence or a Generator, got {seed!r}"
        ) from exc
    if not isinstance(residuals, bool):
        raise ConfigError(f"residuals must be True or False, got {residuals!r}")
    options = budget_options(method, low.size, max_evals, options)
    optimizer = METHODS[method](low.size, rng, **options)
    if getattr(optimizer, "needs_residuals", False) and not residuals:
        optimizer.close()
        raise ConfigError(
            f"method {method!r} needs residual vectors: pass residuals=True and a fun that "
            f"returns r (φ = r·r), as scipy.optimize.least_squares' fun"
        )
    if f_target is not None and hasattr(optimizer, "target_given"):
        optimizer.target_given()  # e.g. multistart-lm's patience: the target says when to stop
    return MinimizeState(optimizer, method, low, high, max_evals, f_target, record_times,
                         residuals)


def _callback_kind(callback: Callable[..., Any]) -> str:
    """``"result"``: scipy's ``callback(intermediate_result)``, once per step; ``"legacy"``:
    femupdate's former ``callback(x, f)``, once per evaluation (deprecated)."""
    try:
        params = list(inspect.signature(callback).parameters.values())
    except (TypeError, ValueError):  # a builtin without a signature: take scipy's form
        return "result"
    positional = [p for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    required = [p for p in positional if p.default is p.empty]
    varargs = any(p.kind is p.VAR_POSITIONAL for p in params)
    if len(required) >= 2 or (len(positional) >= 2 and not required) or (
            varargs and not positional):
        return "legacy"
    return "result"


def _workers_map(workers: Any) -> tuple[MapLike, Callable[[], None]]:
    """The map-like of ``workers`` (scipy's convention) and what closes it."""
    if callable(workers):
        return workers, lambda: None
    if isinstance(workers, bool) or not isinstance(workers, numbers.Integral) or workers == 0 \
            or workers < -1:
        raise ConfigError(f"workers must be an int >= 1, -1 (all CPUs) or a map-like callable "
                          f"map(fun, rows), got {workers!r}")
    count = default_workers() if workers == -1 else int(workers)
    if count == 1:
        return builtins.map, lambda: None
    pool = PoolMap(count)
    return pool, pool.close


def minimize(
    fun: ScalarFunction,
    bounds: Sequence[tuple[float, float]] | Bounds,
    method: str = "ab",
    *,
    seed: Any = None,
    max_evals: int = 50_000,
    f_target: float | None = None,
    callback: Callable[..., Any] | None = None,
    workers: int | MapLike = 1,
    map: MapLike | None = None,
    residuals: bool = False,
    timeout: float | None = None,
    **options: Any,
) -> OptimizeResult:
    """Minimize ``fun`` within ``bounds`` with the bounded optimizer ``method``.

    Parameters
    ----------
    fun : callable
        φ(x) -> float, x of shape (n,) in original units. A NaN or infinite value is a failed
        evaluation: counted, treated as +inf. Anything but a real number (a string, a bool)
        is a ConfigError; an exception propagates, with a note giving x. With
        ``residuals=True``: the residual vector r(x) (m,), what
        ``scipy.optimize.least_squares`` calls ``fun``; φ = r·r. With ``workers=1``, a step's
        candidates go in one call when ``fun`` has ``evaluate_batch(X)`` (k values), or is the
        ``residuals`` method of an object with ``residuals_batch(X)`` (k rows): femupdate's
        update problems, whose batches are compiled loops with the single calls' values.
    bounds : sequence of (low, high) or scipy.optimize.Bounds
        Finite, low < high, one pair per parameter, high − low finite (not overflowing).
    method : {"multistart-lm", "ab", "ib", "cmaes"} or a registered name
        See ``METHODS``; each validates its own ``options``. ``"multistart-lm"``:
        space-filling starts, a bounded Levenberg–Marquardt local phase and restarts
        (quasi-Newton on φ without residuals); ``"ab"``, ``"ib"``: the paper's adaptive Beta
        sampling; ``"cmaes"``: pycma. Others plug in with :func:`register_method`.
    seed : None, int, SeedSequence or Generator
        Passed to ``numpy.random.default_rng``: the run's only randomness.
    max_evals : int
        Budget of evaluations of ``fun`` (≥ 1).
    f_target : float or None
        Stop at once when φ ≤ f_target.
    callback : callable or None
        As scipy's: ``callback(intermediate_result)`` after each step (an ask/tell iteration)
        with an ``OptimizeResult`` holding ``x`` and ``fun`` (the best so far), ``nfev`` and
        ``nit``; raising ``StopIteration`` ends the run (status ``CALLBACK``). A callable of two
        arguments ``callback(x, f)``, called after every evaluation, is still accepted
        (deprecated: femupdate's former convention).
    workers : int or map-like callable
        As scipy's: 1 (default) evaluates in this process; ``N > 1`` spreads each step's
        candidates over ``N`` worker processes (``fun`` must be picklable); -1 uses every CPU;
        a map-like ``workers(fun, rows)`` (e.g. an executor's ``map``) evaluates the rows in
        order. Population methods (cmaes) and multistart-lm (a Jacobian's points)
        ask several candidates per step.
    map : callable or None
        Deprecated name of a map-like ``workers``.
    residuals : bool
        ``fun`` returns residuals r and φ = r·r is minimised: ``f_target``, the history,
        ``callback`` and ``res.fun`` refer to φ. Methods that need them (``needs_residuals``)
        refuse to run without; the others ignore them or, like ``"multistart-lm"``, use them.
    timeout : float or None
        Seconds one evaluation of ``fun`` may take (None: no limit). With a timeout each
        evaluation runs in a forked child process (``fun`` need not be picklable), killed when
        it takes longer: that evaluation failed (φ = inf, ``res.failure`` says so) and the
        search goes on. ``workers=1`` only; POSIX only.
    **options
        Options of the method (unknown names or values out of range: ConfigError).

    Returns
    -------
    scipy.optimize.OptimizeResult
        ``x, fun, nfev, nit`` (ask/tell steps), ``success`` (as scipy: the search ended by its
        own convergence criteria, not the budget; with an ``f_target``: it was reached),
        ``status`` (:class:`~femupdate.optimize.termination.Status`), ``message`` (which says
        so, with ``success`` False and a ``RuntimeWarning``, when no evaluation succeeded),
        ``stop``
        (every criterion that fired, with its value), ``method``, ``restarts`` (how many times
        the optimizer started afresh: its option ``restarts``), ``nfail`` (evaluations that
        failed, φ = inf) and ``failure`` (why the first did, when ``fun`` has an attribute
        ``last_failure`` saying it, as femupdate's update problems do), ``history`` (``x``
        (nfev, n), ``fun`` (nfev,) and the optimizer's trace arrays); with
        ``residuals=True`` also ``residuals``, r at ``x`` (what scipy's ``least_squares``
        calls ``fun``).
    """
    if callback is not None and not callable(callback):
        raise ConfigError(f"callback must be callable or None, got {callback!r}")
    if map is not None:
        if not callable(map):
            raise ConfigError(f"map must be callable or None, got {map!r}")
        warnings.warn("minimize(map=...) is deprecated: pass the map-like as workers=... "
                      "(scipy's convention)", DeprecationWarning, stacklevel=2)
        workers = map
    kind = None if callback is None else _callback_kind(callback)
    if kind == "legacy":
        warnings.warn("callback(x, f) after every evaluation is deprecated: use scipy's "
                      "callback(intermediate_result), called after every step",
                      DeprecationWarning, stacklevel=2)
    timeout = check_timeout(timeout, workers)
    check_picklable(fun, workers)
    state = start(fun, bounds, method, seed=seed, max_evals=max_evals, f_target=f_target,
                  residuals=residuals, **options)
    if timeout is not None:
        fun = TimedFunction(fun, timeout)
    map_fn, close_map = _workers_map(workers)
    per_evaluation = callback if kind == "legacy" else None
    try:
        while not state.done:
            nit = state.nit
            state.step(fun, map_fn, per_evaluation)
            if kind == "result" and state.nit > nit:  # a step cut short is not an iteration
                try:
                    callback(state.intermediate_result())  # type: ignore[misc]
                except StopIteration:
                    state.stopped["callback"] = True
    finally:
        close_map()
        state.optimizer.close()
        if isinstance(fun, TimedFunction):
            fun.close()
    result = state.result()
    if not math.isfinite(result.fun):
        warnings.warn(f"minimize({method!r}): {NO_SUCCESS} ({result.nfev} evaluations; "
                      f"stopped by {', '.join(result.stop) or 'nothing'})", RuntimeWarning,
                      stacklevel=2)
    return result

"""``minimize``: the one loop of the package, and the registry of optimizers by name.

Every optimizer sees only the unit cube; ``minimize`` maps its candidates to the user's bounds
(x = low + (high − low)·ξ, Eq. 8), evaluates them in order, keeps the history and owns the
budget (``max_evals``) and the target (``f_target``). The loop state lives in one picklable
:class:`MinimizeState`, so a run can be checkpointed between steps.
"""

from __future__ import annotations

import builtins
import math
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import Any

import numpy as np
from scipy.optimize import Bounds, OptimizeResult

from femupdate.errors import ConfigError, FemupdateError
from femupdate.optimize.base import Factory, Optimizer
from femupdate.optimize.beta import make_ab, make_ib
from femupdate.optimize.cmaes import make_cmaes
from femupdate.optimize.evolutionary import make_de, make_ga
from femupdate.optimize.multistart import make_multistart_lm
from femupdate.optimize.scipy_lsq import make_scipy_lsq
from femupdate.optimize.termination import (
    check_f_target,
    check_max_evals,
    loop_criteria,
    status_and_message,
)

#: The optimizers by name: factories ``(n, rng, **options) -> Optimizer``.
METHODS: dict[str, Factory] = {
    "ib": make_ib,
    "ab": make_ab,
    "cmaes": make_cmaes,
    "de": make_de,
    "ga": make_ga,
    "multistart-lm": make_multistart_lm,
    "scipy-lsq": make_scipy_lsq,
}

#: Methods that use residual vectors when the problem has them: ``run_case`` and the
#: benchmarks give them ``problem.residuals`` with ``residuals=True``.
RESIDUAL_METHODS: frozenset[str] = frozenset({"multistart-lm", "scipy-lsq"})

Objective = Callable[[np.ndarray], float]
MapLike = Callable[[Objective, Iterable[np.ndarray]], Iterable[Any]]


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
    return low.copy(), high.copy()


class MinimizeState:
    """Everything the loop carries from one step to the next (picklable if the optimizer is).

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
    residuals : bool
        ``fun`` returns the residual vector r; φ = r·r.
    """

    def __init__(self, optimizer: Optimizer, method: str, low: np.ndarray, high: np.ndarray,
                 max_evals: int, f_target: float | None, residuals: bool = False) -> None:
        self.optimizer = optimizer
        self.method = method
        self.low = low
        self.high = high
        self.span = high - low
        self.max_evals = max_evals
        self.f_target = f_target
        self.nfev = 0
        self.nit = 0
        self.best_x = low + 0.5 * self.span  # replaced by the first evaluation
        self.best_f = math.inf
        self.stopped: dict[str, object] = {}
        self.residuals = residuals
        self.best_r: np.ndarray | None = None  # r at best_x (residuals mode)
        cap = min(max_evals, 1024)
        self._hist_x = np.empty((cap, low.size))
        self._hist_f = np.empty(cap)

    @property
    def done(self) -> bool:
        """Whether a stopping criterion fired."""
        return bool(self.stopped)

    def step(self, fun: Objective, map: MapLike = builtins.map,
             callback: Callable[[np.ndarray, float], Any] | None = None) -> None:
        """One ask, the evaluations in order (stopping at once on target or budget), one tell."""
        xi = self.optimizer.ask()
        x = np.clip(self.low + self.span * xi, self.low, self.high)
        k = x.shape[0]
        if k == 0:
            raise FemupdateError(f"the {self.method!r} optimizer proposed no candidates")
        fs = np.empty(k)
        rs: list[np.ndarray] = []
        evaluated = 0
        results: Iterator[Any] = iter(map(fun, iter(x)))
        try:
            for i in range(k):
                fs[i] = f = self._evaluate_next(results, x[i], rs)
                evaluated += 1
                if callback is not None:
                    callback(x[i], f)
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
                self.optimizer.tell(xi, fs, _stack_residuals(rs))
            else:
                self.optimizer.tell(xi, fs)
            self.nit += 1
            self.stopped.update(self.optimizer.stop())

    def _evaluate_next(self, results: Iterator[Any], x: np.ndarray,
                       rs: list[np.ndarray]) -> float:
        r = None
        try:
            value = next(results)
            if self.residuals:
                r, f = _residual_vector(value, rs[0].size if rs else None)
                rs.append(r)
            else:
                f = float(value)
        except StopIteration:
            raise ConfigError("map(fun, rows) returned fewer results than rows") from None
        except Exception as exc:
            exc.add_note(f"femupdate.minimize: raised while evaluating fun(x) at x = {x.tolist()}")
            raise
        if not math.isfinite(f):
            f = math.inf  # a failed evaluation
        n = self.nfev
        if n == self._hist_f.shape[0]:
            self._grow_history()
        self._hist_x[n] = x
        self._hist_f[n] = f
        self.nfev = n + 1
        if f < self.best_f or n == 0:
            self.best_f = f
            self.best_x = x.copy()
            if r is not None:
                self.best_r = r.copy()
        return f

    def _grow_history(self) -> None:
        cap = min(2 * self._hist_f.shape[0], self.max_evals)
        hist_x = np.empty((cap, self._hist_x.shape[1]))
        hist_f = np.empty(cap)
        hist_x[: self.nfev] = self._hist_x[: self.nfev]
        hist_f[: self.nfev] = self._hist_f[: self.nfev]
        self._hist_x, self._hist_f = hist_x, hist_f

    def history(self) -> dict[str, np.ndarray]:
        """``x`` (nfev, n) in original units, ``fun`` (nfev,), and the optimizer's trace."""
        out = {"x": self._hist_x[: self.nfev].copy(), "fun": self._hist_f[: self.nfev].copy()}
        out.update(self.optimizer.trace())
        return out

    def result(self) -> OptimizeResult:
        """The ``OptimizeResult`` of the run so far."""
        stop = dict(self.stopped)
        if stop:
            status, message = status_and_message(stop)
        else:
            status, message = -1, "not finished"
        extra = {} if self.best_r is None else {"residuals": self.best_r.copy()}
        return OptimizeResult(
            x=self.best_x.copy(),
            fun=self.best_f,
            nfev=self.nfev,
            nit=self.nit,
            success="f_target" in stop,
            status=int(status),
            message=message,
            stop=stop,
            method=self.method,
            restarts=int(getattr(self.optimizer, "restarts_done", 0)),
            history=self.history(),
            **extra,
        )


def _residual_vector(value: Any, size: int | None) -> tuple[np.ndarray, float]:
    """A residual vector as a flat float array and φ = r·r; a non-finite r is a failed
    evaluation: all inf, φ = inf."""
    r = np.asarray(value, dtype=float).reshape(-1)
    if size is not None and r.size != size:
        raise ConfigError(f"fun returned {r.size} residuals, earlier {size}")
    if not np.all(np.isfinite(r)):
        return np.full(r.size, math.inf), math.inf
    return r, float(r @ r)


def _stack_residuals(rs: list[np.ndarray]) -> np.ndarray:
    """The residual vectors of one step as (k, m) rows."""
    return np.vstack(rs)


def start(fun: Objective, bounds: Sequence[tuple[float, float]] | Bounds, method: str = "ab", *,
          seed: Any = None, max_evals: int = 50_000, f_target: float | None = None,
          residuals: bool = False, **options: Any) -> MinimizeState:
    """Validate the arguments and build the loop state of a run (see :func:`minimize`)."""
    if not callable(fun):
        raise ConfigError(f"fun must be callable, got {fun!r}")
    if method not in METHODS:
        raise ConfigError(f"unknown method {method!r}; allowed methods: {', '.join(METHODS)}")
    low, high = parse_bounds(bounds)
    max_evals = check_max_evals(max_evals)
    f_target = check_f_target(f_target)
    try:
        rng = np.random.default_rng(seed)
    except (TypeError, ValueError) as exc:
        raise ConfigError(
            f"seed must be None, an int, a SeedSequence or a Generator, got {seed!r}"
        ) from exc
    if not isinstance(residuals, bool):
        raise ConfigError(f"residuals must be True or False, got {residuals!r}")
    optimizer = METHODS[method](low.size, rng, **options)
    if getattr(optimizer, "needs_residuals", False) and not residuals:
        optimizer.close()
        raise ConfigError(
            f"method {method!r} needs residual vectors: pass residuals=True and a fun that "
            f"returns r (φ = r·r), as scipy.optimize.least_squares' fun"
        )
    return MinimizeState(optimizer, method, low, high, max_evals, f_target, residuals)


def minimize(
    fun: Objective,
    bounds: Sequence[tuple[float, float]] | Bounds,
    method: str = "ab",
    *,
    seed: Any = None,
    max_evals: int = 50_000,
    f_target: float | None = None,
    callback: Callable[[np.ndarray, float], Any] | None = None,
    map: MapLike | None = None,
    residuals: bool = False,
    **options: Any,
) -> OptimizeResult:
    """Minimize ``fun`` within ``bounds`` with the bounded optimizer ``method``.

    Parameters
    ----------
    fun : callable
        φ(x) -> float, x of shape (n,) in original units. A NaN or infinite value is a failed
        evaluation: counted, treated as +inf. An exception propagates, with a note giving x.
        With ``residuals=True``: the residual vector r(x) (m,), what
        ``scipy.optimize.least_squares`` calls ``fun``; φ = r·r.
    bounds : sequence of (low, high) or scipy.optimize.Bounds
        Finite, low < high, one pair per parameter.
    method : {"ab", "ib", "cmaes", "de", "ga", "multistart-lm", "scipy-lsq"}
        See ``METHODS``; each validates its own ``options``. ``"multistart-lm"``: space-filling
        starts, a bounded Levenberg–Marquardt local phase and restarts (quasi-Newton without
        residuals); ``"scipy-lsq"``: multistart scipy ``least_squares``, a baseline that
        needs ``residuals=True``.
    seed : None, int, SeedSequence or Generator
        Passed to ``numpy.random.default_rng``: the run's only randomness.
    max_evals : int
        Budget of evaluations of ``fun`` (≥ 1).
    f_target : float or None
        Stop at once when φ ≤ f_target (then ``success`` is True).
    callback : callable or None
        ``callback(x, f)`` after each evaluation (original units; failures as inf).
    map : callable or None
        ``map(fun, rows)`` evaluating the rows lazily, in order (default: builtin ``map``);
        e.g. an executor's ``map`` to evaluate a population in parallel.
    residuals : bool
        ``fun`` returns residuals r and φ = r·r is minimised: ``f_target``, the history,
        ``callback`` and ``res.fun`` refer to φ. Methods that need them (``needs_residuals``)
        refuse to run without; the others ignore them or, like ``"multistart-lm"``, use them.
    **options
        Options of the method (unknown names or values out of range: ConfigError).

    Returns
    -------
    scipy.optimize.OptimizeResult
        ``x, fun, nfev, nit`` (ask/tell steps), ``success`` (f_target given and reached),
        ``status`` (:class:`~femupdate.optimize.termination.Status`), ``message``, ``stop``
        (every criterion that fired, with its value), ``method``, ``restarts`` (how many times
        the optimizer started afresh: its option ``restarts``), ``history`` (``x`` (nfev, n),
        ``fun`` (nfev,) and the optimizer's trace arrays); with ``residuals=True`` also
        ``residuals``, r at ``x`` (scipy's ``least_squares`` calls it ``fun``).
    """
    if callback is not None and not callable(callback):
        raise ConfigError(f"callback must be callable or None, got {callback!r}")
    if map is not None and not callable(map):
        raise ConfigError(f"map must be callable or None, got {map!r}")
    state = start(fun, bounds, method, seed=seed, max_evals=max_evals, f_target=f_target,
                  residuals=residuals, **options)
    map_fn = builtins.map if map is None else map
    try:
        while not state.done:
            state.step(fun, map_fn, callback)
    finally:
        state.optimizer.close()
    return state.result()

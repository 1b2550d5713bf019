"""Repeated independent runs of one optimisation, in parallel processes.

Run ``i`` draws its randomness from child ``i`` of ``SeedSequence(seed)`` (``spawn``), never from
consecutive integer seeds, so any run can be repeated alone, bit for bit.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Executor, ProcessPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from femupdate.errors import ConfigError
from femupdate.optimize import minimize


@dataclass(frozen=True)
class RunOutcome:
    """What one run returns: small enough to send between processes."""

    index: int
    seed: dict[str, Any]
    x: np.ndarray
    fun: float
    nfev: int
    nit: int
    success: bool
    status: int
    message: str
    stop: dict[str, Any]
    wall_s: float
    history: dict[str, np.ndarray] | None = field(default=None, repr=False)

    def to_dict(self, names: Sequence[str] | None = None) -> dict[str, Any]:
        """JSON-ready summary; ``params`` maps the names to the values when names are given."""
        out: dict[str, Any] = {
            "index": self.index,
            "seed": self.seed,
            "success": self.success,
            "status": self.status,
            "message": self.message,
            "stop": {k: _jsonable(v) for k, v in self.stop.items()},
            "phi": self.fun,
            "nfev": self.nfev,
            "nit": self.nit,
            "wall_s": self.wall_s,
            "x": self.x.tolist(),
        }
        if names is not None:
            out["params"] = dict(zip(names, self.x.tolist(), strict=True))
        return out


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value


def run_seeds(seed: int | None, runs: int) -> list[np.random.SeedSequence]:
    """Children of one SeedSequence, one per run."""
    if runs < 1:
        raise ConfigError(f"runs must be at least 1, got {runs}")
    return np.random.SeedSequence(seed).spawn(runs)


def _seed_record(ss: np.random.SeedSequence) -> dict[str, Any]:
    return {"entropy": int(ss.entropy), "spawn_key": list(ss.spawn_key)}


@dataclass(frozen=True)
class RunTask:
    """One run's full description (picklable, sent to a worker process)."""

    fun: Callable[[np.ndarray], float]
    bounds: Sequence[tuple[float, float]]
    method: str
    index: int
    seed: np.random.SeedSequence
    max_evals: int
    f_target: float | None
    options: dict[str, Any]
    keep_history: bool = False

    def __call__(self) -> RunOutcome:
        start = time.perf_counter()
        res = minimize(
            self.fun,
            self.bounds,
            self.method,
            seed=np.random.default_rng(self.seed),
            max_evals=self.max_evals,
            f_target=self.f_target,
            **self.options,
        )
        return RunOutcome(
            index=self.index,
            seed=_seed_record(self.seed),
            x=np.asarray(res.x),
            fun=float(res.fun),
            nfev=int(res.nfev),
            nit=int(res.nit),
            success=bool(res.success),
            status=int(res.status),
            message=str(res.message),
            stop=dict(res.stop),
            wall_s=time.perf_counter() - start,
            history=res.history if self.keep_history else None,
        )


def _call(task: RunTask) -> RunOutcome:
    return task()


def _limit_blas_threads() -> None:
    # Small dense linear algebra is many times slower with several BLAS threads per process
    # (pitfalls.md §1), and the processes already use the cores.
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)


def default_workers() -> int:
    return max(1, os.cpu_count() or 1)


def iter_runs(tasks: Sequence[RunTask], workers: int = 1, executor: Executor | None = None
              ) -> Iterator[RunOutcome]:
    """Run the tasks, yielding outcomes in the order they finish.

    ``workers == 1`` (and no executor) runs in this process; otherwise a process pool, or the
    given ``concurrent.futures``-style executor.
    """
    if workers < 1:
        raise ConfigError(f"workers must be at least 1, got {workers}")
    if executor is None and workers == 1:
        for task in tasks:
            yield task()
        return
    from concurrent.futures import as_completed

    own = executor is None
    pool = executor or ProcessPoolExecutor(max_workers=workers, initializer=_limit_blas_threads)
    try:
        futures = [pool.submit(_call, task) for task in tasks]
        for fut in as_completed(futures):
            yield fut.result()
    finally:
        if own:
            pool.shutdown(cancel_futures=True)


def repeat(
    fun: Callable[[np.ndarray], float],
    bounds: Sequence[tuple[float, float]],
    method: str = "ab",
    *,
    runs: int = 25,
    seed: int | None = 0,
    workers: int = 1,
    max_evals: int = 50_000,
    f_target: float | None = None,
    executor: Executor | None = None,
    on_outcome: Callable[[RunOutcome], None] | None = None,
    **options: Any,
) -> list[RunOutcome]:
    """Run ``minimize`` ``runs`` times with independent seeds; outcomes sorted by run index."""
    tasks = [
        RunTask(fun, tuple(map(tuple, bounds)), method, i, ss, max_evals, f_target, options)
        for i, ss in enumerate(run_seeds(seed, runs))
    ]
    outcomes = []
    for outcome in iter_runs(tasks, workers, executor):
        outcomes.append(outcome)
        if on_outcome is not None:
            on_outcome(outcome)
    return sorted(outcomes, key=lambda o: o.index)

"""Repeated runs kept in memory: whole runs as tasks, in this process or local processes.

The store-less path (the dynamic benchmark, the demo). For a results store, resume after a
crash, Dask and progress, see :func:`femupdate.runs.runner.run_all`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass
from typing import Any

import numpy as np

from femupdate._parallel import process_pool, single_blas_thread
from femupdate.errors import ConfigError
from femupdate.optimize import minimize
from femupdate.runs.outcome import RunOutcome, outcome_of, run_seeds


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
    residuals: bool = False  # fun returns residual vectors (minimize's residuals=True)

    def __call__(self) -> RunOutcome:
        start = time.perf_counter()
        res = minimize(
            self.fun,
            self.bounds,
            self.method,
            seed=np.random.default_rng(self.seed),
            max_evals=self.max_evals,
            f_target=self.f_target,
            residuals=self.residuals,
            **self.options,
        )
        return outcome_of(self.index, self.seed, res, time.perf_counter() - start,
                          res.history if self.keep_history else None)


def _call(task: RunTask) -> RunOutcome:
    return task()


def iter_runs(tasks: Sequence[RunTask], workers: int = 1, executor: Executor | None = None
              ) -> Iterator[RunOutcome]:
    """Run the tasks, yielding outcomes in the order they finish.

    ``workers == 1`` (and no executor) runs in this process; otherwise a process pool, or the
    given ``concurrent.futures``-style executor.
    """
    if workers < 1:
        raise ConfigError(f"workers must be at least 1, got {workers}")
    if executor is None and workers == 1:
        with single_blas_thread():  # as worker processes have
            for task in tasks:
                yield task()
        return
    from concurrent.futures import as_completed

    own = executor is None
    pool = executor or process_pool(workers)
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
    keep_history: bool = False,
    residuals: bool = False,
    **options: Any,
) -> list[RunOutcome]:
    """Run ``minimize`` ``runs`` times with independent seeds; outcomes sorted by run index.

    The store-less path, everything in memory (``keep_history``: each outcome carries its
    run's history). For a results store, resume, Dask and progress, see
    :func:`femupdate.runs.runner.run_all`.
    """
    tasks = [
        RunTask(fun, tuple(map(tuple, bounds)), method, i, ss, max_evals, f_target,
                options, keep_history, residuals)
        for i, ss in enumerate(run_seeds(seed, runs))
    ]
    outcomes = []
    for outcome in iter_runs(tasks, workers, executor):
        outcomes.append(outcome)
        if on_outcome is not None:
            on_outcome(outcome)
    return sorted(outcomes, key=lambda o: o.index)

"""Batches of candidates over local processes or a Dask cluster, saying why each failed.

The candidates are split into as many contiguous parts as the executor runs tasks at once; each
part is one task, evaluated in a worker process (an external model: by the problem's own
isolated child there, started on the first evaluation and reused). Every candidate comes back
as an :class:`~femupdate.external.protocol.Evaluation`, failed ones with φ = inf and their
message: a failure never ends the batch.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np

from femupdate.external.protocol import Evaluation
from femupdate.runs.executors import RunExecutor

__all__ = ["evaluate_batch", "evaluate_rows"]


class Evaluates(Protocol):
    """A problem that says why an evaluation failed (``femupdate.problem.update.UpdateProblem``)."""

    def evaluate(self, x: np.ndarray) -> Evaluation: ...


def evaluate_rows(problem: Evaluates, rows: Sequence[np.ndarray]) -> list[Evaluation]:
    """``[problem.evaluate(x) for x in rows]``: one task of :func:`evaluate_batch`."""
    return [problem.evaluate(np.asarray(x, dtype=float)) for x in rows]


def evaluate_batch(problem: Evaluates, candidates: Sequence[np.ndarray] | np.ndarray,
                   executor: RunExecutor | None = None) -> list[Evaluation]:
    """Evaluate ``candidates`` (search-space points) in order, spread over ``executor``.

    Parameters
    ----------
    problem : UpdateProblem or any object with ``evaluate(x) -> Evaluation``
        Picklable; each worker process keeps one loaded external model per concurrent task.
    candidates : sequence of ndarray, or ndarray (n, n_params)
    executor : RunExecutor or None
        ``femupdate.runs.executors.open_executor(workers, scheduler)``; None or one slot:
        in this process (the model still in its own child when the problem isolates it).

    Returns
    -------
    list of Evaluation
        One per candidate, in order.
    """
    rows = [np.asarray(x, dtype=float) for x in candidates]
    if executor is None or executor.inline or executor.capacity == 1 or len(rows) <= 1:
        return evaluate_rows(problem, rows)
    parts = np.array_split(np.arange(len(rows)), min(executor.capacity, len(rows)))
    shared: Any = executor.share(problem)
    futures = [executor.submit(evaluate_rows, shared, [rows[i] for i in part])
               for part in parts]
    out: list[Evaluation] = []
    try:
        for fut in futures:
            out.extend(fut.result())
    finally:
        for fut in futures:
            fut.cancel()
    return out

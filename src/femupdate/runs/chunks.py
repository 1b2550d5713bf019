"""Chunks of a run that lasts: advance a run from its checkpoint, return what to store.

:func:`advance_chunk` (the task a worker runs) steps a run's ``MinimizeState`` for up to
``chunk_evals`` evaluations or ``chunk_seconds``; it returns the chunk's evaluations, the
optimizer's per-step trace rows and the new checkpoint (the pickled state, which leaves out the
history and the trace: see :class:`~femupdate.optimize.minimize.MinimizeState`), written by the
coordinator in one transaction. Optimizers that cannot be pickled (``de``, ``ga``) run whole in
one chunk; an interrupted one restarts from its seed. Pickling is bit-exact for ``ib``, ``ab``
and ``cmaes``, so where the chunks fall changes nothing: a resumed run ends exactly as an
uninterrupted one.
"""

from __future__ import annotations

import builtins
import pickle
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import Bounds

from femupdate.optimize.minimize import MapLike, MinimizeState, parse_bounds, start
from femupdate.optimize.termination import check_f_target, check_max_evals
from femupdate.runs.outcome import RunOutcome, outcome_of
from femupdate.runs.store import ChunkRecord


@dataclass(frozen=True)
class RunSpec:
    """What every run of a set shares (validated, picklable)."""

    bounds: tuple[tuple[float, float], ...]
    method: str
    max_evals: int
    f_target: float | None
    options: dict[str, Any]
    residuals: bool = False  # fun returns residual vectors (minimize's residuals=True)

    @classmethod
    def make(cls, fun: Callable[[np.ndarray], float],
             bounds: Sequence[tuple[float, float]] | Bounds, method: str, max_evals: int,
             f_target: float | None, options: Mapping[str, Any] | None,
             residuals: bool = False) -> RunSpec:
        """Check everything ``minimize`` would check (ConfigError), before any run starts."""
        low, high = parse_bounds(bounds)
        spec = cls(tuple(zip(low.tolist(), high.tolist(), strict=True)), method,
                   check_max_evals(max_evals), check_f_target(f_target), dict(options or {}),
                   residuals)
        spec.start(fun, np.random.SeedSequence(0)).optimizer.close()  # method and options
        return spec

    def start(self, fun: Callable[[np.ndarray], float],
              seed: np.random.SeedSequence) -> MinimizeState:
        return start(fun, self.bounds, self.method, seed=np.random.default_rng(seed),
                     max_evals=self.max_evals, f_target=self.f_target, record_times=True,
                     residuals=self.residuals, **self.options)

    def settings(self, runs: int, names: Sequence[str] | None) -> dict[str, Any]:
        """The settings a resumed store must match (run_all adds the root seed's entropy)."""
        out = {"method": self.method, "bounds": [list(b) for b in self.bounds], "runs": runs,
               "max_evals": self.max_evals, "f_target": self.f_target,
               "options": self.options, "names": None if names is None else list(names)}
        if self.residuals:  # only then: stores written before residuals existed still match
            out["residuals"] = True
        return out


@dataclass(frozen=True)
class ChunkTask:
    """Advance run ``run`` by one chunk: from ``state`` (pickled) or, if None, from its seed."""

    run: int
    spec: RunSpec
    seed: np.random.SeedSequence
    state: bytes | None
    wall_s: float
    chunk_evals: int
    chunk_seconds: float


@dataclass(frozen=True)
class ChunkResult:
    """What a chunk returns: the store record and, when the run ended, its outcome."""

    record: ChunkRecord
    outcome: RunOutcome | None



def advance_chunk(fun: Callable[[np.ndarray], float], task: ChunkTask,
                  map: MapLike = builtins.map) -> ChunkResult:
    """Advance one run by a chunk (the task a worker runs).

    Steps until the run is done, or ``task.chunk_evals`` evaluations or ``task.chunk_seconds``
    have passed (checked between steps, so a step's population is never split). A run whose
    state cannot be pickled (a plug-in such as de or ga) runs to its end in this one chunk.
    """
    t0 = time.perf_counter()
    if task.state is None:
        state = task.spec.start(fun, task.seed)
        checkpointable = _picklable(state)
    else:
        state = pickle.loads(task.state)
        checkpointable = True
    nfev0, nit0 = state.nfev, state.nit
    try:
        while not state.done:
            state.step(fun, map)
            if checkpointable and (state.nfev - nfev0 >= task.chunk_evals
                                   or time.perf_counter() - t0 >= task.chunk_seconds):
                break
    except BaseException:
        state.optimizer.close()
        raise
    x, phi, stamps = state.evaluations_since(nfev0)
    trace = state.trace_since(nit0)
    outcome = blob = None
    if state.done:
        state.optimizer.close()
        run_wall = task.wall_s + (time.perf_counter() - t0)
        outcome = outcome_of(task.run, task.seed, state.result(), run_wall)
    else:
        blob = pickle.dumps(state, protocol=pickle.HIGHEST_PROTOCOL)
        run_wall = task.wall_s + (time.perf_counter() - t0)
    record = ChunkRecord(
        run=task.run, first_eval=nfev0, x=x, phi=phi, wall_s=task.wall_s + (stamps - t0),
        first_step=nit0, trace=trace, nfev=state.nfev, nit=state.nit,
        best_phi=float(state.best_f), run_wall_s=run_wall, state=blob,
        failures=state.failures_since(nfev0),
    )
    return ChunkResult(record, outcome)


def _picklable(state: MinimizeState) -> bool:
    try:
        pickle.dumps(state, protocol=pickle.HIGHEST_PROTOCOL)
    except (TypeError, AttributeError, pickle.PicklingError):
        return False
    return True

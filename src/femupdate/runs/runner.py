"""Repeated independent runs of one optimisation: in this process, local processes or Dask.

Run ``i`` draws its randomness from child ``i`` of ``SeedSequence(seed)`` (``spawn``), never from
consecutive integer seeds, so any run can be repeated alone, bit for bit.

Two entries:

- :func:`run_all`, runs that last: a results store (:mod:`femupdate.runs.store`), resume after
  a crash, local processes or a Dask cluster (:mod:`femupdate.runs.executors`), a progress bar
  and a JSON-lines log (:mod:`femupdate.runs.progress`).
- :func:`repeat`, the store-less path: whole runs as tasks, everything in memory.

Chunks. :func:`run_all` advances each run by chunks (:func:`advance_chunk`, in a worker): up to
``chunk_evals`` evaluations or ``chunk_seconds``, from the run's pickled ``MinimizeState``; the
worker returns the chunk's evaluations and the new state, the coordinator writes both in one
transaction and submits the next chunk. The state travels without its history buffers (they
would grow with every chunk): the evaluations and the optimizer's per-step trace rows are kept
in the store and the history is rebuilt from it. Optimizers that cannot be pickled (``de``,
``ga``) run whole in one task; an interrupted one restarts from its seed. Pickling is bit-exact
for ``ib``, ``ab`` and ``cmaes``, so where the chunks fall changes nothing: a resumed run ends
exactly as an uninterrupted one.
"""

from __future__ import annotations

import builtins
import math
import os
import pickle
import time
from collections import deque
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Executor, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.optimize import Bounds

from femupdate.errors import ConfigError
from femupdate.optimize import minimize
from femupdate.optimize.minimize import MapLike, MinimizeState, parse_bounds, start
from femupdate.optimize.termination import check_f_target, check_max_evals
from femupdate.runs.executors import (
    CONNECT_TIMEOUT_S,
    InlineExecutor,
    RunExecutor,
    default_workers,
    limit_blas_threads,
    open_executor,
)
from femupdate.runs.progress import RunProgress
from femupdate.runs.store import FILENAME, ChunkRecord, ResultsStore, fingerprint_of

__all__ = [
    "CHUNK_EVALS",
    "CHUNK_SECONDS",
    "ChunkResult",
    "ChunkTask",
    "RunOutcome",
    "RunSpec",
    "RunTask",
    "advance_chunk",
    "default_workers",
    "iter_runs",
    "repeat",
    "run_all",
    "run_seeds",
]

#: Default chunk limits: a checkpoint every second or so of work (whichever limit comes first).
CHUNK_EVALS = 100_000
CHUNK_SECONDS = 1.0
#: Methods whose steps evaluate a population (several candidates): with fewer runs than
#: workers their populations are spread over the workers instead.
POPULATION_METHODS = frozenset({"cmaes", "de", "ga"})


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
    restarts: int = 0
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
            "restarts": self.restarts,
            "wall_s": self.wall_s,
            "x": self.x.tolist(),
        }
        if names is not None:
            out["params"] = dict(zip(names, self.x.tolist(), strict=True))
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> RunOutcome:
        """The outcome written by :meth:`to_dict` (without history)."""
        return cls(
            index=int(data["index"]),
            seed=dict(data["seed"]),
            x=np.array(data["x"], dtype=float),
            fun=float(data["phi"]),
            nfev=int(data["nfev"]),
            nit=int(data["nit"]),
            success=bool(data["success"]),
            status=int(data["status"]),
            message=str(data["message"]),
            stop=dict(data["stop"]),
            wall_s=float(data["wall_s"]),
            restarts=int(data.get("restarts", 0)),
        )


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


def _seed_from_record(record: Mapping[str, Any]) -> np.random.SeedSequence:
    # What SeedSequence.spawn builds for a child: same entropy, the child's spawn key.
    return np.random.SeedSequence(int(record["entropy"]), spawn_key=tuple(record["spawn_key"]))


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
            restarts=int(res.restarts),
            history=res.history if self.keep_history else None,
        )


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
        for task in tasks:
            yield task()
        return
    from concurrent.futures import as_completed

    own = executor is None
    pool = executor or ProcessPoolExecutor(max_workers=workers, initializer=limit_blas_threads)
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
    run's history). For a results store, resume, Dask and progress, see :func:`run_all`.
    """
    tasks = [
        RunTask(fun, tuple(map(tuple, bounds)), method, i, ss, max_evals, f_target, options,
                keep_history, residuals)
        for i, ss in enumerate(run_seeds(seed, runs))
    ]
    outcomes = []
    for outcome in iter_runs(tasks, workers, executor):
        outcomes.append(outcome)
        if on_outcome is not None:
            on_outcome(outcome)
    return sorted(outcomes, key=lambda o: o.index)


# -- chunked runs ----------------------------------------------------------------------------


@dataclass(frozen=True)
class RunSpec:
    """What every run of a set shares (validated, picklable)."""

    bounds: tuple[tuple[float, float], ...]
    method: str
    max_evals: int
    f_target: float | None
    options: dict[str, Any]
    residuals: bool = False

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
                     max_evals=self.max_evals, f_target=self.f_target,
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
    state cannot be pickled (de, ga) runs to its end in this one chunk.
    """
    t0 = time.perf_counter()
    if task.state is None:
        state = task.spec.start(fun, task.seed)
        checkpointable = _picklable(state)
    else:
        state = pickle.loads(task.state)
        checkpointable = True
        _attach_history(state, room=min(task.chunk_evals, 8192) + 64)
    nfev0, nit0 = state.nfev, state.nit
    stamps: list[float] = []

    def stamp(x: np.ndarray, f: float) -> None:
        stamps.append(time.perf_counter())

    try:
        while not state.done:
            state.step(fun, map, stamp)
            if checkpointable and (state.nfev - nfev0 >= task.chunk_evals
                                   or time.perf_counter() - t0 >= task.chunk_seconds):
                break
    except BaseException:
        state.optimizer.close()
        raise
    x = state._hist_x[nfev0:state.nfev].copy()
    phi = state._hist_f[nfev0:state.nfev].copy()
    trace = _trace_since(state.optimizer.trace(), nit0, state.nit)
    outcome = blob = None
    if state.done:
        state.optimizer.close()
        run_wall = task.wall_s + (time.perf_counter() - t0)
        outcome = _outcome(task.run, task.seed, state, run_wall)
    else:
        _detach_history(state)
        blob = pickle.dumps(state, protocol=pickle.HIGHEST_PROTOCOL)
        run_wall = task.wall_s + (time.perf_counter() - t0)
    record = ChunkRecord(
        run=task.run, first_eval=nfev0, x=x, phi=phi,
        wall_s=task.wall_s + (np.asarray(stamps, dtype=float) - t0),
        first_step=nit0, trace=trace, nfev=state.nfev, nit=state.nit,
        best_phi=float(state.best_f), run_wall_s=run_wall, state=blob,
    )
    return ChunkResult(record, outcome)


def _outcome(index: int, seed: np.random.SeedSequence, state: MinimizeState,
             wall_s: float) -> RunOutcome:
    res = state.result()
    return RunOutcome(index=index, seed=_seed_record(seed), x=np.asarray(res.x),
                      fun=float(res.fun), nfev=int(res.nfev), nit=int(res.nit),
                      success=bool(res.success), status=int(res.status),
                      message=str(res.message), stop=dict(res.stop), wall_s=wall_s,
                      restarts=int(res.restarts))


def _picklable(state: MinimizeState) -> bool:
    try:
        pickle.dumps(state, protocol=pickle.HIGHEST_PROTOCOL)
    except (TypeError, AttributeError, pickle.PicklingError):
        return False
    return True


# The history buffers of MinimizeState (_hist_x, _hist_f) and the optimizers' per-step trace
# buffers (attributes named _trace_*: arrays written at row ``step``, or lists appended to) are
# write-only for the search itself. They are dropped before a state is pickled and replaced by
# uninitialised room when it is loaded: what a chunk adds is read from the rows past where it
# started, and the store keeps the rest.


def _detach_history(state: MinimizeState) -> None:
    state._hist_x = state._hist_x[:0].copy()
    state._hist_f = state._hist_f[:0].copy()
    opt = state.optimizer
    for name, value in vars(opt).items():
        if name.startswith("_trace_"):
            if isinstance(value, np.ndarray):
                setattr(opt, name, value[:0].copy())
            elif isinstance(value, list):
                setattr(opt, name, [])


def _attach_history(state: MinimizeState, room: int) -> None:
    n = state.low.size
    cap = max(1, min(state.max_evals, state.nfev + room))
    state._hist_x = np.empty((cap, n))
    state._hist_f = np.empty(cap)
    opt = state.optimizer
    for name, value in vars(opt).items():
        if name.startswith("_trace_"):
            if isinstance(value, np.ndarray):
                setattr(opt, name, np.empty((state.nit + room, *value.shape[1:]), value.dtype))
            elif isinstance(value, list):
                setattr(opt, name, [math.nan] * state.nit)


def _trace_since(trace: Mapping[str, np.ndarray], nit0: int, nit: int) -> dict[str, np.ndarray]:
    """The trace rows of steps ``nit0 …``: arrays with one row per step (others only whole,
    from a run's first chunk)."""
    out = {}
    for key, value in trace.items():
        arr = np.asarray(value)
        if arr.ndim >= 1 and arr.shape[0] == nit:
            out[key] = arr[nit0:].copy()
        elif nit0 == 0:
            out[key] = arr.copy()
    return out


@dataclass
class _Pending:
    """A run still to advance, and where it stands."""

    run: int
    seed: np.random.SeedSequence
    state: bytes | None = None
    wall_s: float = 0.0


def run_all(
    fun: Callable[[np.ndarray], float],
    bounds: Sequence[tuple[float, float]] | Bounds,
    method: str = "ab",
    *,
    runs: int = 25,
    seed: int | None = 0,
    max_evals: int = 50_000,
    f_target: float | None = None,
    options: Mapping[str, Any] | None = None,
    store_dir: str | os.PathLike[str] | None = None,
    resume: bool = False,
    workers: int = 1,
    scheduler: str | None = None,
    executor: Executor | None = None,
    connect_timeout: float = CONNECT_TIMEOUT_S,
    quiet: bool = True,
    log_json: str | os.PathLike[str] | None = None,
    case_dict: Mapping[str, Any] | None = None,
    fingerprint: str | None = None,
    names: Sequence[str] | None = None,
    label: str | None = None,
    chunk_evals: int = CHUNK_EVALS,
    chunk_seconds: float = CHUNK_SECONDS,
    keep_history: bool = False,
    on_outcome: Callable[[RunOutcome], None] | None = None,
    residuals: bool = False,
) -> list[RunOutcome]:
    """Independent runs of ``minimize`` with a results store, resume, processes or Dask.

    Parameters
    ----------
    fun, bounds, method, max_evals, f_target
        As :func:`femupdate.minimize`; ``fun`` must be picklable for workers or Dask.
    runs : int
        Independent runs (≥ 1); run ``i`` uses child ``i`` of ``SeedSequence(seed)``.
    seed : int or None
        Root seed; None draws fresh entropy (recorded in the store, so a resume continues it).
    options : mapping or None
        Options of the method.
    store_dir : path or None
        Directory of the results store (``results.sqlite``); None: a store in memory.
    resume : bool
        Continue the store in ``store_dir``: finished runs are kept, unfinished ones continue
        from their last checkpoint (``de``/``ga`` restart from their seed). Refused when the
        store was written by another case, other settings or another femupdate version.
        Without ``resume`` an existing store is never touched (StoreError). A ``store_dir``
        without a store simply starts.
    workers : int
        Local worker processes (1: in this process). Ignored with ``scheduler``/``executor``.
    scheduler : str or None
        Dask scheduler address: run on that cluster (extra ``dask``).
    executor : concurrent.futures.Executor or None
        Run on this executor instead (``workers`` is then its number of parallel tasks).
    connect_timeout : float
        Seconds to wait for the Dask scheduler.
    quiet : bool
        No progress bar (library default); the command line shows one.
    log_json : path or None
        Append a JSON line per chunk and per run event to this file.
    case_dict, fingerprint : mapping, str or None
        The case as JSON-ready data and its fingerprint, kept in the store; a resume is refused
        when the fingerprint differs. Without a fingerprint, the SHA-256 of ``case_dict``.
    names : sequence of str or None
        Parameter names (``params`` in each stored result).
    label : str or None
        Text before the progress bar.
    chunk_evals, chunk_seconds : int, float
        A chunk ends after this many evaluations or seconds (whichever first): how often a
        run is checkpointed.
    keep_history : bool
        Give each outcome its history (``x``, ``fun`` and the optimizer trace), rebuilt from
        the store.
    on_outcome : callable or None
        Called with each run's outcome as it finishes in this session.
    residuals : bool
        ``fun`` returns residual vectors (``minimize``'s ``residuals=True``).

    Returns
    -------
    list of RunOutcome
        By run index, including runs finished in an earlier session.

    Raises
    ------
    ConfigError
        Invalid arguments (before anything is written).
    StoreError
        The store cannot be created or resumed (see :class:`~femupdate.runs.store.ResultsStore`).
    FemupdateError
        An unreachable Dask scheduler.
    """
    runs = _positive_int("runs", runs)
    chunk_evals = _positive_int("chunk_evals", chunk_evals)
    if not (isinstance(chunk_seconds, (int, float)) and chunk_seconds > 0):
        raise ConfigError(f"chunk_seconds must be a positive number, got {chunk_seconds!r}")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int) or seed < 0):
        raise ConfigError(f"seed must be a non-negative integer or None, got {seed!r}")
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ConfigError(f"workers must be at least 1, got {workers!r}")
    spec = RunSpec.make(fun, bounds, method, max_evals, f_target, options, residuals)
    if names is not None and len(names) != len(spec.bounds):
        raise ConfigError(f"names must give one name per parameter ({len(spec.bounds)}), "
                          f"got {len(names)}: {list(names)}")
    if fingerprint is None:
        fingerprint = fingerprint_of(case_dict)
    root = np.random.SeedSequence(seed)
    settings = {**spec.settings(runs, names), "entropy": root.entropy}

    # The executor first: an unreachable scheduler fails before anything is written.
    with open_executor(workers, scheduler, executor=executor, capacity=workers,
                       connect_timeout=connect_timeout) as ex:
        store = _open_store(store_dir, resume, case_dict, fingerprint, settings,
                            ignore=("entropy",) if seed is None else ())
        try:
            return _run_store(fun, spec, ex, store, root, runs, quiet=quiet, log_json=log_json,
                              label=label, chunk_evals=chunk_evals,
                              chunk_seconds=float(chunk_seconds), names=names,
                              keep_history=keep_history, on_outcome=on_outcome)
        finally:
            store.close()


def _run_store(fun: Callable[[np.ndarray], float], spec: RunSpec, ex: RunExecutor,
               store: ResultsStore, root: np.random.SeedSequence, runs: int, *, quiet: bool,
               log_json: str | os.PathLike[str] | None, label: str | None, chunk_evals: int,
               chunk_seconds: float, names: Sequence[str] | None, keep_history: bool,
               on_outcome: Callable[[RunOutcome], None] | None) -> list[RunOutcome]:
    """Finish every unfinished run of ``store``; the outcomes of all its runs."""
    rows = store.runs()
    resumed = bool(rows)
    if not rows:
        store.add_runs([_seed_record(ss) for ss in root.spawn(runs)])
        rows = store.runs()
    outcomes: dict[int, RunOutcome] = {}
    pending: list[_Pending] = []
    for row in rows:
        if row.status == "done" and row.result is not None:
            outcomes[row.run] = RunOutcome.from_dict(row.result)
            continue
        store.discard_after_checkpoint(row.run)
        ckpt = store.checkpoint(row.run)
        item = _Pending(row.run, _seed_from_record(row.seed))
        if ckpt is not None:
            item.state, item.wall_s = ckpt.state, ckpt.wall_s
        pending.append(item)
    rows = store.runs()
    best = min((r.best_phi for r in rows if r.best_phi is not None), default=math.inf)
    with RunProgress(runs, label=label or spec.method, quiet=quiet,
                     log_json=log_json) as progress:
        progress.start(runs_done=len(outcomes), evals=sum(r.nfev for r in rows),
                       best_phi=best, method=spec.method, resumed=resumed,
                       store=None if store.path is None else str(store.path))
        if pending:
            _advance_all(fun, spec, pending, ex, store, progress, outcomes, chunk_evals,
                         chunk_seconds, names, on_outcome)
    result = [outcomes[i] for i in sorted(outcomes)]
    if keep_history:
        result = [replace(o, history=store.history(o.index)) for o in result]
    return result


def _positive_int(name: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ConfigError(f"{name} must be at least 1, got {value!r}")
    return value


def _open_store(store_dir: str | os.PathLike[str] | None, resume: bool,
                case_dict: Mapping[str, Any] | None, fingerprint: str,
                settings: Mapping[str, Any], ignore: Sequence[str]) -> ResultsStore:
    if store_dir is None:
        return ResultsStore.memory(case_dict=case_dict, fingerprint=fingerprint,
                                   settings=settings)
    path = os.path.join(os.fspath(store_dir), FILENAME)
    if resume and os.path.isfile(path) and os.path.getsize(path) > 0:
        return ResultsStore.open(store_dir, fingerprint=fingerprint, settings=settings,
                                 ignore=ignore)
    return ResultsStore.create(store_dir, case_dict=case_dict, fingerprint=fingerprint,
                               settings=settings)


def _advance_all(fun: Callable[[np.ndarray], float], spec: RunSpec, pending: list[_Pending],
                 ex: RunExecutor, store: ResultsStore, progress: RunProgress,
                 outcomes: dict[int, RunOutcome], chunk_evals: int, chunk_seconds: float,
                 names: Sequence[str] | None,
                 on_outcome: Callable[[RunOutcome], None] | None) -> None:
    """Keep ``capacity`` runs in flight, one chunk each, until every run is done."""
    if spec.method in POPULATION_METHODS and len(pending) < ex.capacity and not ex.inline:
        # Fewer runs than workers: the runs go one after the other in this process and each
        # population is spread over the workers.
        inline = InlineExecutor()
        spread = ex.mapper(fun)

        def submit(task: ChunkTask) -> Future:
            return inline.submit(advance_chunk, fun, task, spread)

        capacity = 1
    else:
        shared = ex.share(fun)

        def submit(task: ChunkTask) -> Future:
            return ex.submit(advance_chunk, shared, task)

        capacity = ex.capacity

    queue = deque(pending)
    inflight: dict[Future, _Pending] = {}

    def send(item: _Pending) -> None:
        task = ChunkTask(item.run, spec, item.seed, item.state, item.wall_s, chunk_evals,
                         chunk_seconds)
        inflight[submit(task)] = item

    try:
        while queue or inflight:
            while queue and len(inflight) < capacity:
                item = queue.popleft()
                store.mark_running(item.run)
                send(item)
            finished, _ = wait(list(inflight), return_when=FIRST_COMPLETED)
            for fut in finished:
                item = inflight.pop(fut)
                res: ChunkResult = fut.result()
                rec = res.record
                if res.outcome is not None:
                    rec = replace(rec, result=res.outcome.to_dict(names))
                store.write_chunk(rec)
                progress.chunk(rec.run, rec.nfev, rec.best_phi, rec.phi.shape[0])
                if res.outcome is None:
                    item.state, item.wall_s = rec.state, rec.run_wall_s
                    send(item)
                    continue
                outcomes[item.run] = res.outcome
                progress.run_done(item.run, res.outcome.nfev, res.outcome.fun,
                                  res.outcome.message)
                if on_outcome is not None:
                    on_outcome(res.outcome)
    finally:
        for fut in inflight:
            fut.cancel()



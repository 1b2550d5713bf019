"""Repeated runs that last: a results store, resume after a crash, local processes or Dask.

:func:`run_all` runs ``runs`` independent runs of one optimisation (run ``i`` with child ``i``
of ``SeedSequence(seed)``), advancing each by chunks (:mod:`femupdate.runs.chunks`) in workers
(:mod:`femupdate.runs.executors`): after every chunk the coordinator writes the chunk's
evaluations, trace rows and the run's checkpoint to the results store
(:mod:`femupdate.runs.store`) in one transaction, and reports progress
(:mod:`femupdate.runs.progress`). Its arguments come in three groups: what the runs compute
(function, bounds, method, budget, target, options, runs, seed), where their results go (the
store and the case they belong to, :class:`CaseIdentity`) and how they execute
(:class:`Execution`: nothing there changes a result).

With residuals and no target (where no target says when a search is done) ``agree`` stops the
set early: once runs 0 … k − 1 have all ended and ``agree`` of them at their best φ
(:func:`femupdate.runs.verdict.runs_needed`), no further run starts and runs k … are not
needed. The decision takes the runs in index order, so it is the same with any number of
workers and after a resume; the runs not needed stay in the store as they were (pending, or
checkpointed where a worker had started one) and are left out of the outcomes.
"""

from __future__ import annotations

import math
import os
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Executor, Future, wait
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from scipy.optimize import Bounds

from femupdate._parallel import single_blas_thread
from femupdate.errors import ConfigError
from femupdate.optimize.registry import POPULATION_METHODS
from femupdate.runs.chunks import ChunkResult, ChunkTask, RunSpec, advance_chunk
from femupdate.runs.executors import (
    CONNECT_TIMEOUT_S,
    InlineExecutor,
    RunExecutor,
    open_executor,
)
from femupdate.runs.outcome import RunOutcome, seed_from_record, seed_record
from femupdate.runs.progress import RunProgress
from femupdate.runs.store import FILENAME, ResultsStore, fingerprint_of
from femupdate.runs.verdict import runs_agreeing, runs_needed

__all__ = ["CHUNK_EVALS", "CHUNK_SECONDS", "CaseIdentity", "Execution", "run_all"]

#: Default chunk limits: a checkpoint every second or so of work (whichever limit comes first).
CHUNK_EVALS = 100_000
CHUNK_SECONDS = 1.0


@dataclass(frozen=True)
class Execution:
    """Where and how runs execute. Nothing here changes their results.

    Attributes
    ----------
    workers : int
        Local worker processes (1: in this process). Ignored with ``scheduler``/``executor``.
    scheduler : str or None
        Dask scheduler address: run on that cluster (extra ``dask``).
    executor : concurrent.futures.Executor or None
        Run on this executor instead (``workers`` is then its number of parallel tasks).
    connect_timeout : float
        Seconds to wait for the Dask scheduler.
    chunk_evals, chunk_seconds : int, float
        A chunk ends after this many evaluations or seconds (whichever first): how often a run
        is checkpointed.
    quiet : bool
        No progress bar (library default); the command line shows one.
    log_json : path or None
        Append a JSON line per chunk and per run event to this file.
    label : str or None
        Text before the progress bar.
    """

    workers: int = 1
    scheduler: str | None = None
    executor: Executor | None = None
    connect_timeout: float = CONNECT_TIMEOUT_S
    chunk_evals: int = CHUNK_EVALS
    chunk_seconds: float = CHUNK_SECONDS
    quiet: bool = True
    log_json: str | os.PathLike[str] | None = None
    label: str | None = None

    def checked(self) -> Execution:
        """Itself, once its numbers are checked (ConfigError names the bad one)."""
        _positive_int("workers", self.workers)
        _positive_int("chunk_evals", self.chunk_evals)
        if not (isinstance(self.chunk_seconds, int | float) and self.chunk_seconds > 0):
            raise ConfigError(f"chunk_seconds must be a positive number, got "
                              f"{self.chunk_seconds!r}")
        return self


@dataclass(frozen=True)
class CaseIdentity:
    """What the runs belong to, kept in the store: a resume of another case is refused.

    Attributes
    ----------
    case_dict : mapping or None
        The case as JSON-ready data.
    fingerprint : str or None
        Its fingerprint (default: the SHA-256 of ``case_dict``).
    names : sequence of str or None
        Parameter names (``params`` in each stored result).
    data : mapping or None
        Content hash of each data file the case reads (file → SHA-256): a resume on changed
        data is refused, naming the file.
    """

    case_dict: Mapping[str, Any] | None = None
    fingerprint: str | None = None
    names: Sequence[str] | None = None
    data: Mapping[str, str] | None = None


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
    identity: CaseIdentity | None = None,
    execution: Execution | None = None,
    keep_history: bool = False,
    on_outcome: Callable[[RunOutcome], None] | None = None,
    residuals: bool = False,
    agree: int | None = None,
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
    identity : CaseIdentity or None
        The case the runs belong to.
    execution : Execution or None
        Workers, scheduler, chunks, progress (default: in this process, quiet).
    keep_history : bool
        Give each outcome its history (``x``, ``fun`` and the optimizer trace), rebuilt from
        the store.
    on_outcome : callable or None
        Called with each run's outcome as it finishes in this session.
    residuals : bool
        ``fun`` returns residual vectors (``minimize``'s ``residuals=True``).
    agree : int or None
        With ``residuals`` and no ``f_target`` only: stop once ``agree`` runs, taken in
        index order, have ended at their best φ (within multistart-lm's ``patience``
        tolerance); the later runs are not needed (not started, or not continued after the
        chunk in flight). 0 or None: every run (also the rule's answer without residuals or
        with a target). It changes which runs are needed, never what a run computes, so a
        store resumes with another ``agree``.

    Returns
    -------
    list of RunOutcome
        By run index, including runs finished in an earlier session; with ``agree``, only
        the runs needed (fewer than ``runs`` when the first ones agreed).

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
    execution = (execution or Execution()).checked()
    identity = identity or CaseIdentity()
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int) or seed < 0):
        raise ConfigError(f"seed must be a non-negative integer or None, got {seed!r}")
    spec = RunSpec.make(fun, bounds, method, max_evals, f_target, options, residuals)
    agree = check_agree(agree)
    if not residuals or f_target is not None:
        agree = None  # a target says when a run is done; without residuals, no patience
    names = identity.names
    if names is not None and len(names) != len(spec.bounds):
        raise ConfigError(f"names must give one name per parameter ({len(spec.bounds)}), "
                          f"got {len(names)}: {list(names)}")
    fingerprint = identity.fingerprint
    if fingerprint is None:
        fingerprint = fingerprint_of(identity.case_dict)
    root = np.random.SeedSequence(seed)
    settings = {**spec.settings(runs, names), "entropy": root.entropy}

    # The executor first: an unreachable scheduler fails before anything is written.
    with open_executor(execution.workers, execution.scheduler, executor=execution.executor,
                       capacity=execution.workers,
                       connect_timeout=execution.connect_timeout) as ex:
        store = _open_store(store_dir, resume, identity, fingerprint, settings,
                            ignore=("entropy",) if seed is None else ())
        # This process gets one BLAS thread, as worker processes do: a run made here (or the
        # optimizer of a run whose batches the workers evaluate) then gives the same bits as
        # in a worker, and small dense algebra in a hot loop is many times slower with
        # several threads.
        try:
            with single_blas_thread():
                return _run_store(fun, spec, ex, store, root, runs, execution, names,
                                  keep_history, on_outcome, agree)
        finally:
            store.close()


@dataclass
class _Pending:
    """A run still to advance, and where it stands."""

    run: int
    seed: np.random.SeedSequence
    state: bytes | None = None
    wall_s: float = 0.0


def _run_store(fun: Callable[[np.ndarray], float], spec: RunSpec, ex: RunExecutor,
               store: ResultsStore, root: np.random.SeedSequence, runs: int,
               execution: Execution, names: Sequence[str] | None, keep_history: bool,
               on_outcome: Callable[[RunOutcome], None] | None,
               agree: int | None = None) -> list[RunOutcome]:
    """Finish every unfinished run of ``store`` that is needed; the outcomes of the runs
    needed (all of them without ``agree``)."""
    rows = store.runs()
    resumed = bool(rows)
    if not rows:
        store.add_runs([seed_record(ss) for ss in root.spawn(runs)])
        rows = store.runs()
    outcomes: dict[int, RunOutcome] = {}
    pending: list[_Pending] = []
    for row in rows:
        if row.status == "done" and row.result is not None:
            outcomes[row.run] = RunOutcome.from_dict(row.result)
            continue
        store.discard_after_checkpoint(row.run)
        ckpt = store.checkpoint(row.run)
        item = _Pending(row.run, seed_from_record(row.seed))
        if ckpt is not None:
            item.state, item.wall_s = ckpt.state, ckpt.wall_s
        pending.append(item)
    rows = store.runs()
    best = min((r.best_phi for r in rows if r.best_phi is not None), default=math.inf)
    needed = _needed(outcomes, runs, agree)
    with RunProgress(runs, label=execution.label or spec.method, quiet=execution.quiet,
                     log_json=execution.log_json, max_evals=spec.max_evals) as progress:
        progress.start(runs_done=len(outcomes), evals=sum(r.nfev for r in rows),
                       best_phi=best, method=spec.method, resumed=resumed,
                       store=None if store.path is None else str(store.path),
                       budget_done=sum(spec.max_evals if r.run in outcomes else r.nfev
                                       for r in rows))
        if pending and needed is None:
            needed = _advance_all(fun, spec, pending, ex, store, progress, outcomes,
                                  execution, names, on_outcome, agree, runs)
        if needed is not None and needed < runs:
            progress.not_needed(needed, runs_agreeing([outcomes[i].fun for i in range(needed)]))
    result = [outcomes[i] for i in sorted(outcomes) if needed is None or i < needed]
    if keep_history:
        result = [replace(o, history=store.history(o.index)) for o in result]
    return result


def check_agree(agree: Any) -> int | None:
    """``agree`` checked: None for 0 or None (every run), else an integer ≥ 1 (ConfigError)."""
    if agree is None or (isinstance(agree, int) and not isinstance(agree, bool) and agree == 0):
        return None
    if isinstance(agree, bool) or not isinstance(agree, int) or agree < 0:
        raise ConfigError(f"agree must be 0 or None (every run) or an integer ≥ 1, got "
                          f"{agree!r}")
    return agree


def _needed(outcomes: Mapping[int, RunOutcome], runs: int, agree: int | None) -> int | None:
    """Runs needed so far by the agreement stop (None: not decided, or no ``agree``)."""
    if agree is None:
        return None
    return runs_needed([outcomes[i].fun if i in outcomes else None for i in range(runs)],
                       agree)


def _positive_int(name: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ConfigError(f"{name} must be at least 1, got {value!r}")
    return value


def _open_store(store_dir: str | os.PathLike[str] | None, resume: bool,
                identity: CaseIdentity, fingerprint: str,
                settings: Mapping[str, Any], ignore: Sequence[str]) -> ResultsStore:
    if store_dir is None:
        return ResultsStore.memory(case_dict=identity.case_dict, fingerprint=fingerprint,
                                   settings=settings)
    path = os.path.join(os.fspath(store_dir), FILENAME)
    if resume and os.path.isfile(path) and os.path.getsize(path) > 0:
        return ResultsStore.open(store_dir, fingerprint=fingerprint, settings=settings,
                                 ignore=ignore, case_dict=identity.case_dict,
                                 data=identity.data)
    return ResultsStore.create(store_dir, case_dict=identity.case_dict, fingerprint=fingerprint,
                               settings=settings, data=identity.data)


def _advance_all(fun: Callable[[np.ndarray], float], spec: RunSpec, pending: list[_Pending],
                 ex: RunExecutor, store: ResultsStore, progress: RunProgress,
                 outcomes: dict[int, RunOutcome], execution: Execution,
                 names: Sequence[str] | None,
                 on_outcome: Callable[[RunOutcome], None] | None,
                 agree: int | None = None, runs: int = 0) -> int | None:
    """Keep ``capacity`` runs in flight, one chunk each, until every run is done, or (with
    ``agree``) until the first runs agree: then no run starts and the chunks in flight end
    (written to the store) without a successor. Returns the runs needed (None: all)."""
    if spec.method in POPULATION_METHODS and len(pending) < ex.capacity and not ex.inline:
        # Fewer runs than workers: the runs go one after the other in this process and each
        # population is spread over the workers (or, compiled, over as many threads).
        inline = InlineExecutor()
        spread = ex.mapper(fun, residuals=spec.residuals)

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
    needed: int | None = None

    def send(item: _Pending) -> None:
        task = ChunkTask(item.run, spec, item.seed, item.state, item.wall_s,
                         execution.chunk_evals, execution.chunk_seconds)
        inflight[submit(task)] = item

    try:
        while queue or inflight:
            while queue and len(inflight) < capacity:
                item = queue.popleft()
                store.mark_running(item.run)
                send(item)
            finished, _ = wait(list(inflight), return_when=FIRST_COMPLETED)
            for fut in sorted(finished, key=lambda f: inflight[f].run):  # by index: the same
                # runs are reported whichever of them a worker ended first
                item = inflight.pop(fut)
                res: ChunkResult = fut.result()
                rec = res.record
                if res.outcome is not None:
                    rec = replace(rec, result=res.outcome.to_dict(names))
                store.write_chunk(rec)
                progress.chunk(rec.run, rec.nfev, rec.best_phi, rec.phi.shape[0])
                progress.stages(rec.run, rec.trace)  # a sampler's (TMCMC's) stages
                if res.outcome is None:
                    item.state, item.wall_s = rec.state, rec.run_wall_s
                    if needed is None:
                        send(item)
                    continue
                outcomes[item.run] = res.outcome
                if needed is not None and item.run >= needed:
                    continue  # ended in the chunk in flight, but not needed
                progress.run_done(item.run, res.outcome.nfev, res.outcome.fun,
                                  res.outcome.message)
                if on_outcome is not None:
                    on_outcome(res.outcome)
                if needed is None:
                    needed = _needed(outcomes, runs, agree)
                    if needed is not None:
                        queue.clear()  # the runs not started are not needed
    finally:
        for fut in inflight:
            fut.cancel()
    return needed



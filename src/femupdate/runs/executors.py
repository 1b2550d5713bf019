"""Where runs execute: this process, local worker processes, or a Dask cluster.

Every backend is a ``concurrent.futures.Executor`` wrapped in a :class:`RunExecutor` that also
knows how many tasks it runs at once (``capacity``), how to send a large object once
(``share``) and how to evaluate a population across its workers (``map``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from typing import Any

import numpy as np

from femupdate._optional import require
from femupdate._parallel import limit_blas_threads
from femupdate.errors import ConfigError, FemupdateError
from femupdate.optimize.minimize import batch_of

#: Seconds to wait for a Dask scheduler before giving up.
CONNECT_TIMEOUT_S = 5.0


class InlineExecutor(Executor):
    """Runs each task at once, in this process, when it is submitted (no pickling)."""

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future:
        fut: Future = Future()
        try:
            fut.set_result(fn(*args, **kwargs))
        except Exception as exc:  # handed over through the future, like any executor
            fut.set_exception(exc)
        return fut


class RunExecutor:
    """An executor, its number of parallel slots, and what it needs closed.

    Parameters
    ----------
    executor : concurrent.futures.Executor
        Runs the tasks.
    capacity : int
        How many tasks it runs at once (the runner keeps that many runs in flight).
    owned : bool
        Shut the executor down on :meth:`close`.
    client : dask.distributed.Client or None
        Closed on :meth:`close` when owned; used by :meth:`share`.
    """

    def __init__(self, executor: Executor, capacity: int, *, owned: bool = True,
                 client: Any = None) -> None:
        self.executor = executor
        self.capacity = max(1, int(capacity))
        self.owned = owned
        self.client = client

    @property
    def inline(self) -> bool:
        """Whether tasks run in this process."""
        return isinstance(self.executor, InlineExecutor)

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future:
        return self.executor.submit(fn, *args, **kwargs)

    def share(self, obj: Any) -> Any:
        """``obj`` for passing to many tasks: on Dask sent to every worker once, else itself."""
        if self.client is None:
            return obj
        return self.client.scatter(obj, broadcast=True, hash=False)

    def mapper(self, fun: Callable[[np.ndarray], Any], *, residuals: bool = False
               ) -> Callable[[Callable[[np.ndarray], Any], Iterable[np.ndarray]], Iterator[Any]]:
        """A ``map`` for ``minimize`` that evaluates ``fun`` over the workers.

        ``fun`` is sent to the workers once (Dask: scattered); the returned ``map(f, rows)``
        evaluates it (``f`` must be that same ``fun``) over ``rows`` in order, split in up to
        ``capacity`` batches run in parallel. Closing the iterator cancels the batches not yet
        started, as ``minimize`` needs when a run stops within a population.

        On local worker processes, a ``fun`` that evaluates batches in parallel threads (an
        update problem evaluated compiled, or its ``residuals`` with ``residuals=True``: see
        ``UpdateProblem.parallel_batches``) gets its rows as one batch split over ``capacity``
        threads of this process instead: nothing is pickled, and the values are the same (a
        batch gives the single calls' bits).
        """
        threaded = self._threaded_batch(fun, residuals)
        shared = None if threaded is not None else self.share(fun)

        def map_rows(f: Callable[[np.ndarray], Any], rows: Iterable[np.ndarray]
                     ) -> Iterator[Any]:
            if f is not fun:
                raise ConfigError("this map evaluates only the function it was made for")
            if threaded is not None:
                return iter(threaded(np.array(list(rows), dtype=float), threads=self.capacity))
            return self._map_batches(shared, list(rows))

        return map_rows

    def _threaded_batch(self, fun: Callable[[np.ndarray], Any], residuals: bool
                        ) -> Callable[..., Any] | None:
        """``fun``'s batch method when it runs rows in parallel threads and the workers are
        this machine's processes (not Dask's, nor a caller's executor); else None."""
        if not (self.owned and isinstance(self.executor, ProcessPoolExecutor)):
            return None
        batch = batch_of(fun, residuals)
        if not getattr(getattr(batch, "__self__", None), "parallel_batches", False):
            return None
        return batch

    def _map_batches(self, shared: Any, batch: list[np.ndarray]) -> Iterator[Any]:
        if self.inline or self.capacity == 1 or len(batch) <= 1:
            fun = shared
            if self.client is not None:
                fun = shared.result()
            yield from builtins_map(fun, batch)
            return
        parts = np.array_split(np.arange(len(batch)), min(self.capacity, len(batch)))
        futures = [self.submit(evaluate_rows, shared, [batch[i] for i in part])
                   for part in parts]
        try:
            for fut in futures:
                yield from fut.result()
        finally:
            for fut in futures:
                fut.cancel()

    def close(self) -> None:
        """Shut down what this object started (cancelling queued tasks)."""
        if not self.owned:
            return
        if self.client is not None:
            self.executor.shutdown(wait=False)  # Dask's: cancels what is still queued
            self.client.close()
        else:
            self.executor.shutdown(wait=True, cancel_futures=True)

    def __enter__(self) -> RunExecutor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


builtins_map = map


def evaluate_rows(fun: Callable[[np.ndarray], Any], rows: list[np.ndarray]) -> list[Any]:
    """``[fun(x) for x in rows]``: one task of :meth:`RunExecutor.map`."""
    return [fun(x) for x in rows]


def open_executor(workers: int = 1, scheduler: str | None = None, *,
                  executor: Executor | None = None, capacity: int | None = None,
                  connect_timeout: float = CONNECT_TIMEOUT_S) -> RunExecutor:
    """The executor of a set of runs.

    Parameters
    ----------
    workers : int
        Local worker processes (≥ 1); 1 runs everything in this process. Ignored with a
        ``scheduler`` or an ``executor``.
    scheduler : str or None
        Address of a Dask scheduler (e.g. ``"tcp://10.0.0.5:8786"``): run on its workers.
        Needs the ``dask`` extra.
    executor : concurrent.futures.Executor or None
        Use this one (not shut down afterwards); ``capacity`` says how many tasks it runs at
        once (default ``workers``).
    connect_timeout : float
        Seconds to wait for the scheduler (> 0).

    Raises
    ------
    ConfigError
        Bad ``workers`` or ``connect_timeout``, or both ``scheduler`` and ``executor``.
    FemupdateError
        The scheduler cannot be reached within ``connect_timeout``.
    MissingDependencyError
        A scheduler without dask.distributed installed.
    """
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ConfigError(f"workers must be at least 1, got {workers!r}")
    if not (isinstance(connect_timeout, (int, float)) and math.isfinite(connect_timeout)
            and connect_timeout > 0):
        raise ConfigError(f"connect_timeout must be a positive number of seconds, "
                          f"got {connect_timeout!r}")
    if executor is not None:
        if scheduler is not None:
            raise ConfigError("give either scheduler or executor, not both")
        return RunExecutor(executor, capacity or workers, owned=False)
    if scheduler is not None:
        return _dask_executor(scheduler, connect_timeout)
    if workers == 1:
        return RunExecutor(InlineExecutor(), 1)
    pool = ProcessPoolExecutor(max_workers=workers, initializer=limit_blas_threads)
    return RunExecutor(pool, workers)


def _dask_executor(address: str, timeout: float) -> RunExecutor:
    if not isinstance(address, str) or not address.strip():
        raise ConfigError(f"scheduler must be an address such as 'tcp://host:8786', "
                          f"got {address!r}")
    distributed = require("dask.distributed", "dask")
    from distributed.comm.addressing import parse_address, parse_host_port

    try:  # before a Client exists: a half-made one complains and waits when it is collected
        scheme, location = parse_address(address)
        if scheme in ("tcp", "tls", "ws", "wss", "ucx"):  # inproc:// has no port
            parse_host_port(location)
        client = distributed.Client(address, timeout=f"{timeout}s", set_as_default=False)
    except ValueError as exc:
        raise ConfigError(f"scheduler address {address!r} is not valid ({exc}); expected e.g. "
                          f"'tcp://host:8786'") from None
    except (OSError, TimeoutError) as exc:
        raise FemupdateError(
            f"cannot reach the Dask scheduler at {address!r} within {timeout:g} s ({exc}); "
            f"check the address and that `dask scheduler` and its workers are running, or "
            f"omit the scheduler to run on local processes"
        ) from None
    # Workers started by a Dask nanny already have OPENBLAS/MKL/OMP_NUM_THREADS=1.
    threads = sum(client.nthreads().values())
    return RunExecutor(client.get_executor(pure=False), max(1, threads), client=client)

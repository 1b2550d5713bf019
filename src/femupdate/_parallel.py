"""Worker processes and threads shared by the layers that evaluate in parallel (optimize, runs,
update).

Small dense linear algebra is many times slower with several BLAS threads per process on a
small machine, and the processes already use the cores: every worker process runs with one
BLAS thread. Threads serve compiled batches that release the GIL; their pools live as long as
the process, because each thread keeps its own evaluator buffers (built at its first batch).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from contextlib import AbstractContextManager
from typing import Any


def limit_blas_threads() -> None:
    """Initializer of worker processes: one BLAS thread each. Never called in the caller."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)


def single_blas_thread() -> AbstractContextManager:
    """One BLAS thread in this process while the context lasts (the previous limits restored
    after): what :func:`limit_blas_threads` gives worker processes, for runs that execute in
    the caller's process (one worker)."""
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1)


def default_workers() -> int:
    """The number of CPUs (at least 1)."""
    return max(1, os.cpu_count() or 1)


_THREAD_POOLS: dict[int, ThreadPoolExecutor] = {}

if hasattr(os, "register_at_fork"):  # a forked child has none of its parent's threads
    os.register_at_fork(after_in_child=_THREAD_POOLS.clear)


def thread_pool(threads: int) -> ThreadPoolExecutor:
    """This process's pool of ``threads`` threads, made at first use and kept: a batch split
    over fresh threads would build fresh evaluators every time."""
    pool = _THREAD_POOLS.get(threads)
    if pool is None:
        pool = _THREAD_POOLS[threads] = ThreadPoolExecutor(
            threads, thread_name_prefix=f"femupdate-{threads}")
    return pool


def process_pool(workers: int) -> ProcessPoolExecutor:
    """Local worker processes with one BLAS thread each."""
    return ProcessPoolExecutor(max_workers=workers, initializer=limit_blas_threads)


class PoolMap:
    """A map-like callable over a process pool, evaluating rows in order (``workers=N``).

    Each batch is split into one chunk per worker; results come back in order. Closing the
    returned iterator cancels the chunks not yet started.
    """

    def __init__(self, workers: int) -> None:
        self.workers = workers
        self.pool = process_pool(workers)

    def __call__(self, fun: Callable[[Any], Any], rows: Iterable[Any]) -> Iterator[Any]:
        batch = list(rows)
        chunksize = max(1, -(-len(batch) // self.workers))
        return self.pool.map(fun, batch, chunksize=chunksize)

    def close(self) -> None:
        self.pool.shutdown(wait=True, cancel_futures=True)

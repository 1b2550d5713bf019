"""Worker processes shared by the layers that evaluate in parallel (optimize, runs).

Small dense linear algebra is many times slower with several BLAS threads per process on a
small machine, and the processes already use the cores: every worker process runs with one
BLAS thread.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor
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

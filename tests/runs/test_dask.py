"""Runs on a Dask cluster equal local runs; an unreachable scheduler fails fast and clearly."""

from __future__ import annotations

import socket
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from grouped import run_all

from femupdate.errors import FemupdateError
from femupdate.paper.problems.dynamic import DynamicProblem

distributed = pytest.importorskip("dask.distributed", reason="needs the 'dask' extra")

PROBLEM = DynamicProblem()


@pytest.fixture(scope="module")
def cluster() -> Iterator[object]:
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as local:
        yield local


@pytest.mark.slow
@pytest.mark.parametrize(("method", "runs", "max_evals", "options"), [
    ("ab", 3, 1500, {}),  # runs in chunks on the workers
    ("cmaes", 1, 240, {"popsize": 6}),  # one run: its populations split across the workers
])
def test_dask_runs_equal_local_runs(cluster: object, tmp_path: Path, method: str, runs: int,
                                    max_evals: int, options: dict) -> None:
    kw = dict(runs=runs, seed=13, max_evals=max_evals, f_target=1e-10, options=options,
              chunk_evals=200, keep_history=True)
    local = run_all(PROBLEM, PROBLEM.bounds, method, **kw)
    remote = run_all(PROBLEM, PROBLEM.bounds, method, scheduler=cluster.scheduler_address,
                     store_dir=tmp_path, **kw)
    for a, b in zip(local, remote, strict=True):
        np.testing.assert_array_equal(a.x, b.x)
        assert (a.fun, a.nfev, a.nit, a.stop) == (b.fun, b.nfev, b.nit, b.stop)
        assert a.history["x"].tobytes() == b.history["x"].tobytes()
        assert a.history["fun"].tobytes() == b.history["fun"].tobytes()


def _closed_port() -> int:
    with socket.socket() as sock:  # a port nobody listens on once this socket is closed
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def test_an_unreachable_scheduler_is_a_clear_error(tmp_path: Path) -> None:
    address = f"tcp://127.0.0.1:{_closed_port()}"
    started = time.monotonic()
    with pytest.raises(FemupdateError, match=f"cannot reach the Dask scheduler at '{address}'"):
        run_all(PROBLEM, PROBLEM.bounds, "ab", runs=1, scheduler=address, connect_timeout=2.0,
                store_dir=tmp_path / "out")
    print(f"refused after {time.monotonic() - started:.1f} s")  # for the record, not asserted
    assert not (tmp_path / "out").exists()  # failed before writing anything

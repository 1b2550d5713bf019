"""The results store: atomic chunks, exact round trips, and every way opening it is refused."""

from __future__ import annotations

import contextlib
import hashlib
import math
import multiprocessing
import os
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from femupdate.runs.store import (
    FILENAME,
    SCHEMA_VERSION,
    ChunkRecord,
    ResultsStore,
    StoreError,
    fingerprint_of,
    software_versions,
)

SETTINGS = {"method": "ab", "runs": 2, "max_evals": 100}
CASE = {"name": "two-mode", "bounds": [[0.0, 1.0]]}


def _record(run: int, first: int, k: int, *, state: bytes | None = b"state", n: int = 3,
            result: dict | None = None) -> ChunkRecord:
    x = np.arange(first * n, (first + k) * n, dtype=float).reshape(k, n)
    return ChunkRecord(
        run=run, first_eval=first, x=x, phi=np.linspace(1.0, 0.5, k), wall_s=np.arange(k) * 0.1,
        first_step=first, trace={"sigma": np.full(k, 0.25)}, nfev=first + k, nit=first + k,
        best_phi=0.5, run_wall_s=1.0, state=state, result=result,
    )


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _new_store(directory: Path) -> ResultsStore:
    store = ResultsStore.create(directory, case_dict=CASE, fingerprint=fingerprint_of(CASE),
                                settings=SETTINGS)
    store.add_runs([{"entropy": 1, "spawn_key": [0]}, {"entropy": 1, "spawn_key": [1]}])
    return store


def test_meta_runs_and_versions(tmp_path: Path) -> None:
    with _new_store(tmp_path) as store:
        meta = store.meta()
        assert meta["schema_version"] == SCHEMA_VERSION
        assert meta["case"] == CASE and meta["settings"] == SETTINGS
        assert meta["fingerprint"] == fingerprint_of(CASE)
        assert set(meta["versions"]) == {"femupdate", "python", "numpy", "scipy", "numba",
                                         "cma", "pymoo"}
        assert meta["versions"]["numpy"] == np.__version__
        assert [(r.run, r.status, r.nfev) for r in store.runs()] == [(0, "pending", 0),
                                                                     (1, "pending", 0)]
        with contextlib.closing(sqlite3.connect(tmp_path / FILENAME)) as conn:
            assert conn.execute("PRAGMA journal_mode").fetchone()[0] == "wal"  # while open
    # closed: the WAL folded in, rollback journal, no journal or lock files left beside it
    assert sorted(p.name for p in tmp_path.iterdir()) == [FILENAME]
    with contextlib.closing(sqlite3.connect(tmp_path / FILENAME)) as conn:
        assert conn.execute("PRAGMA journal_mode").fetchone()[0] == "delete"


def test_a_closed_store_reads_and_resumes_without_leaving_journal_files(tmp_path: Path) -> None:
    _new_store(tmp_path).close()
    with ResultsStore.open(tmp_path, read_only=True) as store:  # as a report reads it
        assert len(store.runs()) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == [FILENAME]
    with ResultsStore.open(tmp_path, fingerprint=fingerprint_of(CASE),
                           settings=SETTINGS) as store:
        assert store._conn.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
        assert (tmp_path / (FILENAME + ".lock")).is_file()  # held while writing
    assert sorted(p.name for p in tmp_path.iterdir()) == [FILENAME]


def test_a_lock_file_removed_under_a_waiting_opener_is_not_shared(tmp_path: Path) -> None:
    from femupdate.runs.lock import StoreLock, _names

    store_path = tmp_path / FILENAME
    first = StoreLock.acquire(store_path)
    stale = os.open(first.path, os.O_RDWR)  # a second process got this far before the release
    assert _names(first.path, stale)
    first.release()
    assert not first.path.exists()
    assert not _names(first.path, stale)  # its flock would not count: acquire() retries
    second = StoreLock.acquire(store_path)  # a new lock file, not the removed one
    try:
        assert os.fstat(second.fd).st_ino != os.fstat(stale).st_ino
        with pytest.raises(StoreError, match="in use"):
            StoreLock.acquire(store_path)
    finally:
        os.close(stale)
        second.release()


def test_fingerprint_is_canonical() -> None:
    assert fingerprint_of({"a": 1, "b": [1.0, 2]}) == fingerprint_of({"b": [1.0, 2], "a": 1})
    assert fingerprint_of({"a": 1}) != fingerprint_of({"a": 2})


def test_chunks_round_trip_bit_for_bit(tmp_path: Path) -> None:
    # -0.0, inf, the smallest subnormal and a NaN payload-free value survive exactly.
    phi = np.array([-0.0, math.inf, 5e-324, 0.1])
    x = np.array([[-0.0, 1e-300], [np.pi, -np.e], [5e-324, 1.0], [0.1, 0.2]])
    rec = ChunkRecord(run=0, first_eval=0, x=x, phi=phi, wall_s=np.zeros(4), first_step=0,
                      trace={}, nfev=4, nit=4, best_phi=-0.0, run_wall_s=0.5, state=b"s")
    with _new_store(tmp_path) as store:
        store.write_chunk(rec)
        idx, x2, phi2, _ = store.evaluations(0)
    np.testing.assert_array_equal(idx, [0, 1, 2, 3])
    assert x2.tobytes() == x.tobytes()
    assert phi2.tobytes() == phi.tobytes()


def test_history_and_checkpoint_follow_the_chunks(tmp_path: Path) -> None:
    with _new_store(tmp_path) as store:
        store.write_chunk(_record(0, 0, 3, state=b"after-3"))
        store.write_chunk(_record(0, 3, 2, state=b"after-5"))
        ckpt = store.checkpoint(0)
        assert (ckpt.nfev, ckpt.state) == (5, b"after-5")
        hist = store.history(0)
        assert hist["x"].shape == (5, 3) and hist["fun"].shape == (5,)
        np.testing.assert_array_equal(hist["x"].ravel(), np.arange(15.0))
        np.testing.assert_array_equal(hist["sigma"], np.full(5, 0.25))
        run = store.runs()[0]
        assert (run.status, run.nfev) == ("running", 5)
        # The last chunk of a run: done, result kept, checkpoint dropped.
        store.write_chunk(_record(0, 5, 1, state=None, result={"phi": 0.5}))
        assert store.checkpoint(0) is None
        run = store.runs()[0]
        assert (run.status, run.nfev, run.result) == ("done", 6, {"phi": 0.5})


def test_an_evaluation_is_never_stored_twice(tmp_path: Path) -> None:
    with _new_store(tmp_path) as store:
        store.write_chunk(_record(0, 0, 3, state=b"after-3"))
        with pytest.raises(StoreError, match=r"evaluations 2…3 are already stored"):
            store.write_chunk(_record(0, 2, 2, state=b"after-4"))
        # The failed chunk left nothing behind: not its evaluations, nor its checkpoint.
        assert store.evaluations(0)[0].tolist() == [0, 1, 2]
        assert store.checkpoint(0).state == b"after-3"


def test_discard_after_checkpoint_restores_the_invariant(tmp_path: Path) -> None:
    with _new_store(tmp_path) as store:
        store.write_chunk(_record(0, 0, 3, state=b"after-3"))
        store.write_chunk(_record(1, 0, 4, state=None))  # no checkpoint: e.g. de
        with store.transaction() as cur:  # as if something else had added rows
            cur.execute("INSERT INTO evaluations VALUES (0, 3, x'00', 1.0, 0.0)")
        assert store.discard_after_checkpoint(0) == 1
        assert store.discard_after_checkpoint(1) == 4
        assert store.evaluations(0)[0].tolist() == [0, 1, 2]
        assert store.evaluations(1)[0].size == 0


def test_an_existing_store_is_never_recreated(tmp_path: Path) -> None:
    _new_store(tmp_path).close()
    before = _sha(tmp_path / FILENAME)
    with pytest.raises(StoreError, match=r"already holds a results store.*--resume"):
        _new_store(tmp_path)
    assert _sha(tmp_path / FILENAME) == before


def _set_meta(path: Path, key: str, value: str) -> None:
    with sqlite3.connect(path) as conn:
        conn.execute("UPDATE meta SET value = ? WHERE key = ?", (value, key))
    conn.close()


def test_resume_refuses_another_case(tmp_path: Path) -> None:
    _new_store(tmp_path).close()
    before = _sha(tmp_path / FILENAME)
    with pytest.raises(StoreError, match="written by another case"):
        ResultsStore.open(tmp_path, fingerprint=fingerprint_of({"name": "bridge"}))
    with pytest.raises(StoreError, match=r"written with max_evals = 100.*max_evals = 200"):
        ResultsStore.open(tmp_path, fingerprint=fingerprint_of(CASE),
                          settings={**SETTINGS, "max_evals": 200})
    assert _sha(tmp_path / FILENAME) == before
    ResultsStore.open(tmp_path, fingerprint=fingerprint_of(CASE), settings=SETTINGS).close()


def test_resume_refuses_another_femupdate_version(tmp_path: Path) -> None:
    _new_store(tmp_path).close()
    versions = {**software_versions(), "femupdate": "0.0.1"}
    import json

    _set_meta(tmp_path / FILENAME, "versions", json.dumps(versions))
    before = _sha(tmp_path / FILENAME)
    with pytest.raises(StoreError, match=r"written by femupdate 0\.0\.1.*cannot be resumed"):
        ResultsStore.open(tmp_path)
    assert _sha(tmp_path / FILENAME) == before
    with ResultsStore.open(tmp_path, read_only=True) as store:  # still readable for a report
        assert store.meta()["versions"]["femupdate"] == "0.0.1"
        with pytest.raises(sqlite3.OperationalError, match="readonly"):
            store.mark_running(0)
    assert _sha(tmp_path / FILENAME) == before


def test_resume_refuses_another_schema(tmp_path: Path) -> None:
    _new_store(tmp_path).close()
    _set_meta(tmp_path / FILENAME, "schema_version", str(SCHEMA_VERSION + 1))
    before = _sha(tmp_path / FILENAME)
    with pytest.raises(StoreError, match=f"schema {SCHEMA_VERSION + 1}, this femupdate reads"):
        ResultsStore.open(tmp_path)
    assert _sha(tmp_path / FILENAME) == before


@pytest.mark.parametrize("content", [
    b"x,phi\n0.1,0.2\n" * 100,
    b"SQLite format 3\x00" + bytes(range(256)) * 16,
], ids=["not-a-database", "garbage-after-the-header"])
def test_a_corrupt_file_is_refused_and_left_untouched(tmp_path: Path, content: bytes) -> None:
    (tmp_path / FILENAME).write_bytes(content)
    with pytest.raises(StoreError, match="left untouched"):
        ResultsStore.open(tmp_path)
    with pytest.raises(StoreError, match="left untouched"):
        _new_store(tmp_path)
    assert (tmp_path / FILENAME).read_bytes() == content


def test_another_database_is_not_taken_for_a_store(tmp_path: Path) -> None:
    with sqlite3.connect(tmp_path / FILENAME) as conn:
        conn.execute("CREATE TABLE meta (key TEXT, value TEXT)")
    conn.close()
    with pytest.raises(StoreError, match="not a femupdate results store"):
        ResultsStore.open(tmp_path)


HOLDER = """
import sys
from femupdate.runs.store import ResultsStore
store = ResultsStore.open(sys.argv[1])
print("holding", flush=True)
sys.stdin.read()  # until the test closes our stdin
"""


def test_a_store_in_use_by_another_process_is_refused(tmp_path: Path) -> None:
    _new_store(tmp_path).close()
    holder = subprocess.Popen([sys.executable, "-c", HOLDER, str(tmp_path)],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "holding"
        with pytest.raises(StoreError, match=f"process {holder.pid} is running in it"):
            ResultsStore.open(tmp_path)
        with ResultsStore.open(tmp_path, read_only=True) as reader:  # watching is allowed
            assert len(reader.runs()) == 2
    finally:
        holder.stdin.close()
        holder.wait(timeout=30)
    ResultsStore.open(tmp_path).close()  # free again once it has gone


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_a_process_forked_while_the_store_is_open_does_not_keep_it_locked(tmp_path: Path) -> None:
    # A worker forked by the writer shares its lock file; were the lock left in it, a killed
    # run's orphaned workers would refuse the resume until they finished.
    store = _new_store(tmp_path)
    fork = multiprocessing.get_context("fork")
    release = fork.Event()
    worker = fork.Process(target=release.wait, args=(60,))
    worker.start()
    try:
        store.close()
        assert worker.is_alive()
        ResultsStore.open(tmp_path).close()
    finally:
        release.set()
        worker.join(timeout=30)


def test_memory_store_needs_no_directory() -> None:
    with ResultsStore.memory(settings=SETTINGS) as store:
        store.add_runs([{"entropy": 3, "spawn_key": [0]}])
        store.write_chunk(_record(0, 0, 2))
        assert store.path is None and store.runs()[0].nfev == 2

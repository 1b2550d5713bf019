"""The results store of a set of runs: one SQLite database, ``DIR/results.sqlite``.

It holds the case and its fingerprint, the content hashes of the data files the case reads,
the software versions, the wall time of all sessions so far, every run (seed, status, final
result), every evaluation (x, φ, wall time) and the latest optimizer-state checkpoint of each
unfinished run. A resume is refused, with the field or file named, when the case, its data
files or the settings changed. The evaluations, the optimizer trace and the checkpoint of one
chunk are written in ONE transaction, so after a crash the store holds exactly the evaluations
up to the last checkpoint: a resumed run neither repeats nor loses one (``PRIMARY KEY (run,
eval)`` guards it).

Only one process writes a store at a time: it holds an exclusive ``flock`` on
``DIR/results.sqlite.lock`` (released by the kernel even when the process is killed), and the
lock file names its pid for the error message of the next one.

Why this file is long (about 650 lines): it is the one module that speaks SQL. The schema, the
opening checks (each refusal says what differs and what to do; the wording of the differences is
in :mod:`femupdate.runs.changes`), the atomic chunk writes, the readers and the lock share the
connection and the table layout; split up, each part would need the others' private SQL.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import os
import platform
import sqlite3
import time
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from femupdate.errors import StoreError
from femupdate.runs.changes import SETTING_NAMES, SETTING_WORDS, case_changes, data_changes, short
from femupdate.runs.lock import StoreLock as _Lock

#: Bumped whenever the tables change incompatibly.
SCHEMA_VERSION = 2
FILENAME = "results.sqlite"
#: How long a statement waits for another connection's write lock before failing.
BUSY_TIMEOUT_MS = 10_000
_SQLITE_HEADER = b"SQLite format 3\x00"
_VERSIONED = ("femupdate", "numpy", "scipy", "numba", "cma", "pymoo")

_SCHEMA = """
CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE runs (
    run INTEGER PRIMARY KEY,
    seed TEXT NOT NULL,
    status TEXT NOT NULL CHECK (status IN ('pending', 'running', 'done')),
    nfev INTEGER NOT NULL DEFAULT 0,
    nit INTEGER NOT NULL DEFAULT 0,
    best_phi,
    wall_s REAL NOT NULL DEFAULT 0,
    result TEXT,
    updated REAL
);
-- phi has no declared type: SQLite's REAL affinity would store -0.0 as the integer 0.
CREATE TABLE evaluations (
    run INTEGER NOT NULL REFERENCES runs (run),
    eval INTEGER NOT NULL,
    x BLOB NOT NULL,
    phi NOT NULL,
    wall_s REAL NOT NULL,
    PRIMARY KEY (run, eval)
) WITHOUT ROWID;
CREATE TABLE traces (
    run INTEGER NOT NULL REFERENCES runs (run),
    step0 INTEGER NOT NULL,
    data BLOB NOT NULL,
    PRIMARY KEY (run, step0)
) WITHOUT ROWID;
CREATE TABLE failures (
    run INTEGER NOT NULL REFERENCES runs (run),
    eval INTEGER NOT NULL,
    message TEXT NOT NULL,
    PRIMARY KEY (run, eval)
) WITHOUT ROWID;
CREATE TABLE checkpoints (
    run INTEGER PRIMARY KEY REFERENCES runs (run),
    nfev INTEGER NOT NULL,
    nit INTEGER NOT NULL,
    wall_s REAL NOT NULL,
    state BLOB NOT NULL,
    written REAL NOT NULL
);
"""


def software_versions() -> dict[str, str]:
    """Versions of femupdate, Python and the libraries that decide the numbers."""
    out = {"python": platform.python_version()}
    for name in _VERSIONED:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def fingerprint_of(case_dict: Mapping[str, Any] | None) -> str:
    """SHA-256 of the case as canonical JSON (sorted keys); "" for no case."""
    if case_dict is None:
        return ""
    text = json.dumps(case_dict, sort_keys=True, separators=(",", ":"), default=_json_default)
    return hashlib.sha256(text.encode()).hexdigest()


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (set, frozenset, tuple)):
        return list(value)
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def to_json(value: Any) -> str:
    """JSON with numpy scalars and arrays as Python values (inf as ``Infinity``)."""
    return json.dumps(value, default=_json_default)


@dataclass(frozen=True)
class RunRow:
    """One row of the ``runs`` table."""

    run: int
    seed: dict[str, Any]
    status: str
    nfev: int
    nit: int
    best_phi: float | None
    wall_s: float
    result: dict[str, Any] | None


@dataclass(frozen=True)
class Checkpoint:
    """The latest optimizer state of an unfinished run (pickled, history stripped)."""

    nfev: int
    nit: int
    wall_s: float
    state: bytes


@dataclass(frozen=True)
class ChunkRecord:
    """What one chunk of one run adds to the store, written in one transaction.

    ``x`` (k, n), ``phi`` (k,) and ``wall_s`` (k,) are evaluations ``first_eval`` … ``first_eval
    + k − 1``; ``trace`` holds the optimizer's per-step rows from step ``first_step`` on.
    ``state`` is the checkpoint after the chunk (None: not checkpointable, or the run is done);
    ``result`` (JSON-ready) marks the run done; ``failures`` (evaluation, message) says why
    evaluations of the chunk failed.
    """

    run: int
    first_eval: int
    x: np.ndarray
    phi: np.ndarray
    wall_s: np.ndarray
    first_step: int
    trace: Mapping[str, np.ndarray]
    nfev: int
    nit: int
    best_phi: float
    run_wall_s: float
    state: bytes | None
    result: Mapping[str, Any] | None = None
    failures: Sequence[tuple[int, str]] = ()


class ResultsStore:
    """A results store, opened by :meth:`create`, :meth:`open` or :meth:`memory`.

    Use it as a context manager (or call :meth:`close`): closing releases the lock.
    """

    def __init__(self, conn: sqlite3.Connection, path: Path | None, lock: _Lock | None) -> None:
        self._conn = conn
        self.path = path
        self._lock = lock
        self._t0 = time.perf_counter()  # this session's start
        self._wall_before = 0.0  # wall time of the sessions before it

    # -- opening -------------------------------------------------------------------------------

    @classmethod
    def create(cls, directory: str | os.PathLike[str], *, case_dict: Mapping[str, Any] | None,
               fingerprint: str, settings: Mapping[str, Any],
               data: Mapping[str, str] | None = None) -> ResultsStore:
        """A new store in ``directory`` (created if needed); StoreError if one is there.

        ``data``: content hash of each data file the case reads (file → SHA-256), checked by
        a resume.
        """
        path = Path(directory) / FILENAME
        path.parent.mkdir(parents=True, exist_ok=True)
        lock = _Lock.acquire(path)
        try:
            if path.exists() and path.stat().st_size > 0:
                _check_header(path)
                raise StoreError(
                    f"{path.parent} already holds a results store ({path.name}), left untouched: "
                    f"add --resume to continue its runs, or --restart to discard them and start "
                    f"over, or choose another output directory (--out)"
                )
            conn = _connect(path)
            _configure(conn)
            store = cls(conn, path, lock)
            store._initialise(case_dict, fingerprint, settings, data)
        except BaseException:
            lock.release()
            raise
        return store

    @classmethod
    def open(cls, directory: str | os.PathLike[str], *, fingerprint: str | None = None,
             settings: Mapping[str, Any] | None = None, ignore: Sequence[str] = (),
             read_only: bool = False, case_dict: Mapping[str, Any] | None = None,
             data: Mapping[str, str] | None = None) -> ResultsStore:
        """Open an existing store to continue it, checking that it belongs to this case.

        Parameters
        ----------
        directory : path
            Holding ``results.sqlite``.
        fingerprint : str or None
            The case's; refused when it differs from the stored one (None: not checked).
        settings : mapping or None
            The run settings (method, bounds, budget, ...); refused when any differs from the
            stored ones, except the keys in ``ignore`` (None: not checked).
        read_only : bool
            Only to read (a report, or watching a set that is running): no lock taken, and a
            store written by another femupdate version is accepted if its schema is the same.
        case_dict : mapping or None
            The case: when the fingerprint differs, the message names the fields that changed.
        data : mapping or None
            Content hash of each data file (file → SHA-256); refused when a file the store
            recorded changed or is no longer read (None, or a store that recorded none: not
            checked).

        Raises
        ------
        StoreError
            No store there, a file that is not a results store (left untouched), a store locked
            by another process, written by another schema or femupdate version, another case,
            other data or other settings.
        """
        path = Path(directory) / FILENAME
        if not path.is_file():
            raise StoreError(f"no results store in {path.parent} (expected {path.name})")
        _check_header(path)
        if read_only:
            conn = sqlite3.connect(path.resolve().as_uri() + "?mode=ro", uri=True,
                                   isolation_level=None, timeout=BUSY_TIMEOUT_MS / 1000)
            store = cls(conn, path, None)
            try:
                meta = store._read_meta_checked()
                store._check_compatible(meta, fingerprint, settings, ignore, versions=False,
                                        case_dict=case_dict, data=data)
            except BaseException:
                conn.close()
                raise
            return store
        lock = _Lock.acquire(path)
        try:
            conn = _connect(path)
            store = cls(conn, path, lock)
            meta = store._read_meta_checked()
            store._check_compatible(meta, fingerprint, settings, ignore, case_dict=case_dict,
                                    data=data)
            _configure(conn)  # the first write, after every check
            store._wall_before = float(meta.get("wall_s", 0.0))
        except BaseException:
            if "conn" in locals():
                conn.close()
            lock.release()
            raise
        return store

    @classmethod
    def memory(cls, *, case_dict: Mapping[str, Any] | None = None, fingerprint: str = "",
               settings: Mapping[str, Any] | None = None) -> ResultsStore:
        """A store in memory (nothing on disk, no lock): runs without an output directory."""
        conn = sqlite3.connect(":memory:", isolation_level=None)
        store = cls(conn, None, None)
        store._initialise(case_dict, fingerprint, settings or {})
        return store

    def _initialise(self, case_dict: Mapping[str, Any] | None, fingerprint: str,
                    settings: Mapping[str, Any],
                    data: Mapping[str, str] | None = None) -> None:
        meta = {
            "schema_version": SCHEMA_VERSION,
            "fingerprint": fingerprint,
            "case": case_dict,
            "data": None if data is None else dict(data),
            "settings": dict(settings),
            "versions": software_versions(),
            "created": time.time(),
            "wall_s": 0.0,
        }
        with self.transaction() as cur:
            # One statement at a time: executescript() would COMMIT the open transaction.
            for statement in _SCHEMA.split(";"):
                if statement.strip():
                    cur.execute(statement)
            cur.executemany("INSERT INTO meta (key, value) VALUES (?, ?)",
                            [(k, to_json(v)) for k, v in meta.items()])

    def _read_meta_checked(self) -> dict[str, Any]:
        try:
            rows = self._conn.execute("SELECT key, value FROM meta").fetchall()
            meta = {k: json.loads(v) for k, v in rows}
        except sqlite3.DatabaseError as exc:
            raise StoreError(
                f"{self.path} is not a femupdate results store or is damaged ({exc}); it was "
                f"left untouched: move it away or choose another output directory"
            ) from exc
        if "schema_version" not in meta:
            raise StoreError(
                f"{self.path} is an SQLite database but not a femupdate results store (no "
                f"schema version); it was left untouched: choose another output directory"
            )
        return meta

    def _check_compatible(self, meta: Mapping[str, Any], fingerprint: str | None,
                          settings: Mapping[str, Any] | None, ignore: Sequence[str], *,
                          versions: bool = True, case_dict: Mapping[str, Any] | None = None,
                          data: Mapping[str, str] | None = None) -> None:
        where = self.path.parent if self.path is not None else "the store"
        over = ("start over in it with --restart (its runs are discarded), or choose another "
                "output directory (--out)")
        keep = f"the store was left as it was: {over}"
        if meta["schema_version"] != SCHEMA_VERSION:
            raise StoreError(
                f"{where} was written with results-store schema {meta['schema_version']}, this "
                f"femupdate reads schema {SCHEMA_VERSION}; resume it with the femupdate that "
                f"wrote it ({meta.get('versions', {}).get('femupdate', '?')}), or {over}"
            )
        theirs = meta.get("versions", {}).get("femupdate")
        ours = software_versions()["femupdate"]
        if versions and theirs != ours:
            # A checkpoint pickles femupdate's optimizers: another version may not load it, or
            # continue differently, and the runs would no longer be repeatable.
            raise StoreError(
                f"{where} was written by femupdate {theirs}, this is femupdate {ours}: runs "
                f"cannot be resumed across versions; use femupdate {theirs}, or {over}"
            )
        if fingerprint is not None and meta.get("fingerprint") != fingerprint:
            changes = case_changes(meta.get("case"), case_dict)
            what = ("the case changed since its runs started: " + "; ".join(changes)
                    if changes else
                    f"it was written by another case (fingerprint "
                    f"{str(meta.get('fingerprint'))[:12]}…, this case {fingerprint[:12]}…)")
            raise StoreError(f"{where}: cannot resume: {what}; {keep}")
        stored_data = meta.get("data")
        if data is not None and stored_data:
            changed = data_changes(stored_data, data)
            if changed:
                raise StoreError(f"{where}: cannot resume: the data changed since its runs "
                                 f"started: {'; '.join(changed)}; {keep}")
        if settings is not None:
            stored = meta.get("settings", {})
            new = json.loads(to_json(dict(settings)))  # compare in the stored (JSON) form
            for key in sorted(set(stored) | set(new)):
                if key in ignore:
                    continue
                if stored.get(key) != new.get(key):
                    shown = SETTING_NAMES.get(key, key)
                    raise StoreError(
                        f"{where}: cannot resume: it was written with {shown} = "
                        f"{short(stored.get(key))}, this run asks for {shown} = "
                        f"{short(new.get(key))}"
                        + (f" ({SETTING_WORDS[key]})" if key in SETTING_WORDS else "")
                        + f"; resume with the same settings, or {over}"
                    )

    def wall_s(self) -> float:
        """Wall time of the runs over every session so far, this one up to now (s)."""
        return self._wall_before + (time.perf_counter() - self._t0)

    # -- plumbing ------------------------------------------------------------------------------

    def close(self) -> None:
        """Close the database and release the lock (idempotent).

        The writer first folds the write-ahead log into the database and returns it to a
        rollback journal (:func:`_settle`), so that a finished results directory holds
        ``results.sqlite`` alone; the next writer turns WAL on again.
        """
        if self._conn is not None:
            if self._lock is not None and self.path is not None:
                _settle(self._conn)
            self._conn.close()
            self._conn = None  # type: ignore[assignment]
        if self._lock is not None:
            self._lock.release()
            self._lock = None

    def __enter__(self) -> ResultsStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @contextmanager
    def transaction(self) -> Iterator[sqlite3.Cursor]:
        """``BEGIN IMMEDIATE`` … ``COMMIT`` (``ROLLBACK`` on any exception)."""
        cur = self._conn.cursor()
        try:
            cur.execute("BEGIN IMMEDIATE")
        except sqlite3.OperationalError as exc:
            raise StoreError(f"{self.path} is locked by another connection ({exc})") from exc
        try:
            yield cur
        except BaseException:
            cur.execute("ROLLBACK")
            raise
        cur.execute("COMMIT")

    # -- reading -------------------------------------------------------------------------------

    def meta(self) -> dict[str, Any]:
        """The case, fingerprint, settings, versions, schema version and creation time."""
        rows = self._conn.execute("SELECT key, value FROM meta").fetchall()
        return {k: json.loads(v) for k, v in rows}

    def runs(self) -> list[RunRow]:
        """Every run, by index."""
        rows = self._conn.execute(
            "SELECT run, seed, status, nfev, nit, best_phi, wall_s, result FROM runs ORDER BY run"
        ).fetchall()
        return [
            RunRow(run, json.loads(seed), status, nfev, nit, best, wall,
                   None if result is None else json.loads(result))
            for run, seed, status, nfev, nit, best, wall, result in rows
        ]

    def checkpoint(self, run: int) -> Checkpoint | None:
        """The latest checkpoint of ``run`` (None: none written, or the run is done)."""
        row = self._conn.execute(
            "SELECT nfev, nit, wall_s, state FROM checkpoints WHERE run = ?", (run,)
        ).fetchone()
        return None if row is None else Checkpoint(row[0], row[1], row[2], bytes(row[3]))

    def evaluations(self, run: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``eval`` indices (k,), ``x`` (k, n), ``phi`` (k,), ``wall_s`` (k,) of a run, in order."""
        rows = self._conn.execute(
            "SELECT eval, x, phi, wall_s FROM evaluations WHERE run = ? ORDER BY eval", (run,)
        ).fetchall()
        idx = np.array([r[0] for r in rows], dtype=np.int64)
        if rows:
            x = np.stack([np.frombuffer(r[1], dtype="<f8") for r in rows])
        else:
            x = np.empty((0, 0))
        phi = np.array([r[2] for r in rows], dtype=float)
        wall = np.array([r[3] for r in rows], dtype=float)
        return idx, x, phi, wall

    def history(self, run: int) -> dict[str, np.ndarray]:
        """The run's history as ``minimize`` returns it: ``x``, ``fun`` and the trace arrays."""
        _, x, phi, _ = self.evaluations(run)
        out: dict[str, np.ndarray] = {"x": x, "fun": phi}
        blocks = [
            _unpack_arrays(bytes(data)) for (data,) in self._conn.execute(
                "SELECT data FROM traces WHERE run = ? ORDER BY step0", (run,))
        ]
        if blocks:
            keys = set(blocks[0]).intersection(*blocks[1:])
            out.update({k: np.concatenate([b[k] for b in blocks]) for k in sorted(keys)})
        return out

    # -- writing -------------------------------------------------------------------------------

    def add_runs(self, seeds: Sequence[Mapping[str, Any]]) -> None:
        """Rows ``0 … len(seeds) − 1``, pending, with their seed records."""
        with self.transaction() as cur:
            cur.executemany(
                "INSERT INTO runs (run, seed, status, updated) VALUES (?, ?, 'pending', ?)",
                [(i, to_json(dict(s)), time.time()) for i, s in enumerate(seeds)],
            )

    def mark_running(self, run: int) -> None:
        with self.transaction() as cur:
            cur.execute("UPDATE runs SET status = 'running', updated = ? WHERE run = ? "
                        "AND status != 'done'", (time.time(), run))

    def discard_after_checkpoint(self, run: int) -> int:
        """Delete what a run holds beyond its checkpoint (normally nothing); how many rows.

        Chunks are atomic, so this only matters for a store written by something else: it
        keeps "evaluations = 0 … checkpoint.nfev − 1" true before a run continues.
        """
        ckpt = self.checkpoint(run)
        nfev, nit = (0, 0) if ckpt is None else (ckpt.nfev, ckpt.nit)
        with self.transaction() as cur:
            cur.execute("DELETE FROM evaluations WHERE run = ? AND eval >= ?", (run, nfev))
            removed = cur.rowcount
            cur.execute("DELETE FROM failures WHERE run = ? AND eval >= ?", (run, nfev))
            cur.execute("DELETE FROM traces WHERE run = ? AND step0 >= ?", (run, nit))
            cur.execute("UPDATE runs SET nfev = ?, nit = ? WHERE run = ?", (nfev, nit, run))
        return removed

    def failures(self, run: int) -> list[tuple[int, str]]:
        """(evaluation, why it failed) of the run's failed evaluations whose reason is known."""
        rows = self._conn.execute("SELECT eval, message FROM failures WHERE run = ? ORDER BY "
                                  "eval", (run,)).fetchall()
        return [(int(i), str(m)) for i, m in rows]

    def write_chunk(self, chunk: ChunkRecord) -> None:
        """The chunk's evaluations, trace rows, checkpoint and run row, in one transaction."""
        k = chunk.phi.shape[0]
        x = np.ascontiguousarray(chunk.x, dtype="<f8")
        now = time.time()
        rows = [
            (chunk.run, chunk.first_eval + i, x[i].tobytes(), float(chunk.phi[i]),
             float(chunk.wall_s[i]))
            for i in range(k)
        ]
        done = chunk.result is not None
        with self.transaction() as cur:
            try:
                cur.executemany(
                    "INSERT INTO evaluations (run, eval, x, phi, wall_s) VALUES (?, ?, ?, ?, ?)",
                    rows,
                )
            except sqlite3.IntegrityError as exc:
                raise StoreError(
                    f"run {chunk.run}: evaluations {chunk.first_eval}…{chunk.first_eval + k - 1}"
                    f" are already stored ({exc}); the store and the run disagree"
                ) from exc
            cur.executemany("INSERT OR REPLACE INTO failures (run, eval, message) VALUES "
                            "(?, ?, ?)", [(chunk.run, i, why) for i, why in chunk.failures])
            if any(np.shape(v)[0] for v in chunk.trace.values()):
                cur.execute("INSERT OR REPLACE INTO traces (run, step0, data) VALUES (?, ?, ?)",
                            (chunk.run, chunk.first_step, _pack_arrays(chunk.trace)))
            if chunk.state is not None and not done:
                cur.execute(
                    "INSERT OR REPLACE INTO checkpoints (run, nfev, nit, wall_s, state, written)"
                    " VALUES (?, ?, ?, ?, ?, ?)",
                    (chunk.run, chunk.nfev, chunk.nit, chunk.run_wall_s, chunk.state, now),
                )
            if done:
                cur.execute("DELETE FROM checkpoints WHERE run = ?", (chunk.run,))
            best = chunk.best_phi if math.isfinite(chunk.best_phi) else None
            cur.execute("INSERT OR REPLACE INTO meta (key, value) VALUES ('wall_s', ?)",
                        (to_json(self.wall_s()),))
            cur.execute(
                "UPDATE runs SET status = ?, nfev = ?, nit = ?, best_phi = ?, wall_s = ?, "
                "result = ?, updated = ? WHERE run = ?",
                ("done" if done else "running", chunk.nfev, chunk.nit, best, chunk.run_wall_s,
                 None if chunk.result is None else to_json(dict(chunk.result)), now, chunk.run),
            )


def discard(directory: str | os.PathLike[str]) -> bool:
    """Delete the results store in ``directory`` to start over there; whether there was one.

    Only a femupdate results store is deleted (with its WAL files), under its lock: a store in
    use by another process, or a file that is not a store, is refused (StoreError) and left.
    """
    path = Path(directory) / FILENAME
    if not path.exists():
        return False
    lock = _Lock.acquire(path)
    try:
        if path.stat().st_size > 0:
            _check_header(path)
            conn = sqlite3.connect(path.resolve().as_uri() + "?mode=ro", uri=True)
            try:
                ResultsStore(conn, path, None)._read_meta_checked()
            finally:
                conn.close()
        for suffix in ("", "-wal", "-shm"):
            Path(f"{path}{suffix}").unlink(missing_ok=True)
    finally:
        lock.release()
    return True


def _connect(path: Path) -> sqlite3.Connection:
    """A connection that has not read or written the file yet (with a busy timeout)."""
    return sqlite3.connect(path, isolation_level=None, timeout=BUSY_TIMEOUT_MS / 1000)


def _configure(conn: sqlite3.Connection) -> None:
    """WAL journal (readers never block the writer) and NORMAL sync: a killed process loses
    nothing committed; a power cut may lose the last chunks, never the consistency of the rest.
    """
    conn.execute("PRAGMA journal_mode=WAL")
    conn.execute("PRAGMA synchronous=NORMAL")


def _settle(conn: sqlite3.Connection) -> None:
    """Checkpoint the WAL into the database (truncating it) and leave WAL mode, so that no
    ``-wal`` and ``-shm`` files stay beside a closed store (a read-only reader of a WAL-mode
    database would create them again, and could not remove them). A reader still connected
    (``femupdate report`` of a running set) keeps WAL on: the files then stay, harmless."""
    try:
        conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")
        conn.execute("PRAGMA journal_mode=DELETE")
    except sqlite3.OperationalError:  # busy: another connection reads it now
        pass


def _check_header(path: Path) -> None:
    with path.open("rb") as fh:
        head = fh.read(len(_SQLITE_HEADER))
    if head != _SQLITE_HEADER:
        raise StoreError(
            f"{path} is not an SQLite database (corrupt or another file); it was left "
            f"untouched: move it away, or choose another output directory"
        )


def _pack_arrays(arrays: Mapping[str, np.ndarray]) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **{k: np.asarray(v) for k, v in arrays.items()})
    return buf.getvalue()


def _unpack_arrays(data: bytes) -> dict[str, np.ndarray]:
    with np.load(io.BytesIO(data), allow_pickle=False) as npz:
        return {k: npz[k] for k in npz.files}

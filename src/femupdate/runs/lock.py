"""The exclusive lock of a results store: one writing process at a time.

The writer holds an exclusive ``flock`` on ``DIR/results.sqlite.lock`` (released by the kernel
even when the process is killed), and the lock file names its pid for the error message of the
next one.

A ``flock`` belongs to the open file, which a forked child shares: a worker process forked while
the store is open would hold the lock after the writer died (a killed run's orphaned workers
finishing their evaluation would refuse the resume). Forked children therefore close their
copies at once; the writer's own descriptor keeps the lock.

The writer removes the lock file when it releases the lock, so that a finished results
directory does not keep it (a killed writer leaves it: the next one takes it over). A process
that opened the file just before it was removed would lock a file no longer in the directory,
so a lock counts only once the path still names the file locked; else it is taken again.
"""

from __future__ import annotations

import os
from pathlib import Path

from femupdate.errors import StoreError

try:  # POSIX; elsewhere the lock falls back to the pid written in the lock file
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]

__all__ = ["StoreLock"]

LOCK_SUFFIX = ".lock"

#: Descriptors of the locks this process holds (closed in forked children).
_held: set[int] = set()


def _close_inherited() -> None:
    for fd in _held:
        try:
            os.close(fd)
        except OSError:  # pragma: no cover - already closed
            pass
    _held.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_close_inherited)


class StoreLock:
    """An exclusive lock on ``<store>.lock`` for the lifetime of an open store."""

    def __init__(self, path: Path, fd: int) -> None:
        self.path = path
        self.fd: int | None = fd

    @classmethod
    def acquire(cls, store_path: Path) -> StoreLock:
        path = store_path.with_name(store_path.name + LOCK_SUFFIX)
        while True:
            fd = cls._lock_file(store_path, path)
            if _names(path, fd):
                break
            os.close(fd)  # removed by the writer that just released it: lock the new one
        _held.add(fd)
        return cls(path, fd)

    @staticmethod
    def _lock_file(store_path: Path, path: Path) -> int:
        """A descriptor of ``path`` holding its exclusive flock, the pid written in it."""
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:  # a read-only or removed folder: said, not a traceback
            raise StoreError(f"{store_path.parent}: cannot make the results store's lock "
                             f"{path.name}: {exc.strerror} (allowed: a writable folder; "
                             "choose another --out)") from None
        try:
            if fcntl is not None:
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                except BlockingIOError:
                    raise StoreError(_locked_message(store_path, _read_pid(fd))) from None
            else:  # pragma: no cover - no flock: trust a live pid in the file
                pid = _read_pid(fd)
                if pid is not None and pid != os.getpid() and _alive(pid):
                    raise StoreError(_locked_message(store_path, pid))
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        except BaseException:
            os.close(fd)
            raise
        return fd

    def release(self) -> None:
        """Remove the lock file, then drop the lock (idempotent)."""
        if self.fd is not None:
            _held.discard(self.fd)
            if _names(self.path, self.fd):
                self.path.unlink(missing_ok=True)
            os.close(self.fd)  # closing drops the flock
            self.fd = None


def _names(path: Path, fd: int) -> bool:
    """Whether ``path`` is the file open as ``fd`` (not removed or replaced since)."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return False
    own = os.fstat(fd)
    return (st.st_dev, st.st_ino) == (own.st_dev, own.st_ino)


def _read_pid(fd: int) -> int | None:
    try:
        return int(os.pread(fd, 32, 0).decode().strip())
    except (ValueError, OSError):
        return None


def _alive(pid: int) -> bool:  # pragma: no cover - used without fcntl only
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _locked_message(store_path: Path, pid: int | None) -> str:
    who = f"process {pid}" if pid is not None else "another process"
    return (
        f"{store_path.parent} is in use: {who} is running in it (lock {store_path.name}"
        f"{LOCK_SUFFIX}); wait for it to finish or stop it, then resume"
    )

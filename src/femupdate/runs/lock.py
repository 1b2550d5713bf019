"""The exclusive lock of a results store: one writing process at a time.

The writer holds an exclusive ``flock`` on ``DIR/results.sqlite.lock`` (released by the kernel
even when the process is killed), and the lock file names its pid for the error message of the
next one.
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


class StoreLock:
    """An exclusive lock on ``<store>.lock`` for the lifetime of an open store."""

    def __init__(self, path: Path, fd: int) -> None:
        self.path = path
        self.fd: int | None = fd

    @classmethod
    def acquire(cls, store_path: Path) -> StoreLock:
        path = store_path.with_name(store_path.name + LOCK_SUFFIX)
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
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
        return cls(path, fd)

    def release(self) -> None:
        if self.fd is not None:
            os.close(self.fd)  # closing drops the flock
            self.fd = None


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

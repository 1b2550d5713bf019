"""One external model in its own process, killable on a time-out.

A model written by someone else may keep global state (OpenSees has one domain per process),
crash the interpreter or hang. Each :class:`IsolatedModel` holds one model in a child process
(:mod:`femupdate.external.worker`) and asks it for predictions over a socket:

- a time-out is the parent waiting on the socket no longer than ``timeout`` seconds and then
  killing the child (a hung function cannot be interrupted inside its own thread, a process
  can be killed); the next request starts a fresh child;
- a crash (a segfault, ``os._exit``) is an end of file on the socket;
- an exception in the user's code comes back as a message;

all three raise :class:`EvaluationError`, so the caller records φ = inf and goes on. What the
model prints goes to a log file, whose last lines are quoted in the message.

The child is started with ``subprocess`` rather than ``multiprocessing``: Dask's worker
processes are daemonic and may not have ``multiprocessing`` children. POSIX only (the socket
is passed as a file descriptor).

:func:`checkout` keeps, per process, the idle children of each model (by key), so that the
many calls of a search in a worker process, or a Dask worker, reuse one loaded model.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator, Mapping
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

import numpy as np

import femupdate
from femupdate.errors import ConfigError, FemupdateError, MissingDependencyError
from femupdate.external.protocol import EvaluationError, ExternalModel
from femupdate.external.worker import output_tail

__all__ = ["START_TIMEOUT_S", "IsolatedModel", "checkout", "close_all"]

#: Seconds a child may take to start and load its model (imports of large packages).
START_TIMEOUT_S = 120.0
#: Seconds to wait for a stopped or killed child to exit.
EXIT_WAIT_S = 5.0
#: Bytes of model output kept: the log restarts empty beyond (only its tail is ever quoted).
LOG_LIMIT = 1 << 20
_THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def _child_env() -> dict[str, str]:
    """The parent's environment, this femupdate first on the path, one BLAS thread
    (the processes already use the cores) unless the user set otherwise."""
    env = dict(os.environ)
    src = str(Path(femupdate.__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join(p for p in (src, env.get("PYTHONPATH")) if p)
    for name in _THREAD_VARS:
        env.setdefault(name, "1")
    return env


def _new_log() -> str:
    """A new empty file for what a model prints."""
    fd, path = tempfile.mkstemp(prefix="femupdate-model-", suffix=".log")
    os.close(fd)
    return path


def _signal_text(code: int | None) -> str:
    if code is None:
        return "still running"
    if code < 0:
        import signal

        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit code {code}"


class IsolatedModel:
    """An external model in a child process, for one caller at a time.

    Parameters
    ----------
    model : ExternalModel
        Pickled to the child, which calls its ``prepare`` once.
    ag : ndarray (n_samples,)
        The base acceleration of every prediction (sent once).
    dt : float
        Its sample interval (s).
    timeout : float or None
        Seconds one prediction may take before the child is killed (None: no limit).
    start_timeout : float
        Seconds the child may take to start and load the model.
    """

    def __init__(self, model: ExternalModel, ag: np.ndarray, dt: float, *,
                 timeout: float | None = None, start_timeout: float = START_TIMEOUT_S) -> None:
        if timeout is not None and not (isinstance(timeout, int | float) and timeout > 0):
            raise ConfigError(f"timeout: got {timeout!r} (allowed: a positive number of "
                              "seconds, or none)")
        self.model = model
        self.ag = np.ascontiguousarray(ag, dtype=float)
        self.dt = float(dt)
        self.timeout = None if timeout is None else float(timeout)
        self.start_timeout = float(start_timeout)
        self._proc: subprocess.Popen[bytes] | None = None
        self._conn: Connection | None = None
        self._owner = os.getpid()
        self.log = _new_log()
        self.starts = 0  # children started (1 + restarts after time-outs and crashes)

    @property
    def alive(self) -> bool:
        return self._proc is not None and self._proc.poll() is None

    @property
    def pid(self) -> int | None:
        return None if self._proc is None else self._proc.pid

    # ------------------------------------------------------------------ life cycle

    def start(self) -> None:
        """Start the child and load the model in it (nothing if it is running).

        Raises
        ------
        ConfigError, MissingDependencyError
            The model cannot be loaded (a missing module or function, a missing extra).
        FemupdateError
            The child died or did not load within ``start_timeout``.
        """
        if self._owner != os.getpid():
            self.forget()  # a copy in another process: the child and log are not its own
            self._owner, self.log = os.getpid(), _new_log()
        if self.alive:
            return
        self._discard()
        parent_end, child_end = socket.socketpair()
        with open(self.log, "ab") as log:
            self._proc = subprocess.Popen(
                [sys.executable, "-m", "femupdate.external.worker", str(child_end.fileno()),
                 self.log],
                pass_fds=(child_end.fileno(),), stdin=subprocess.DEVNULL, stdout=log,
                stderr=subprocess.STDOUT, env=_child_env(), close_fds=True)
        child_end.close()
        self._conn = Connection(parent_end.detach())
        self.starts += 1
        offset = os.path.getsize(self.log)
        sys_path = [os.getcwd() if p == "" else p for p in sys.path]
        self._conn.send(("init", self.model, self.ag, self.dt, sys_path))
        try:
            reply = self._receive(self.start_timeout, "loading the model", offset)
        except EvaluationError as exc:
            # Not one bad candidate: no evaluation can run (a crash or hang while importing).
            raise FemupdateError(f"the model {self.model!r} could not be loaded in its own "
                                 f"process: {exc}") from None
        if reply[0] == "config":
            self._discard()
            error = MissingDependencyError if reply[1] == "MissingDependencyError" else ConfigError
            raise error(reply[2])
        if reply[0] != "ready":
            self._discard()
            raise EvaluationError(f"the model's process answered {reply[0]!r} to loading")

    def close(self) -> None:
        """Stop the child (killed if it does not exit) and remove its log."""
        if self._owner != os.getpid():
            self.forget()
            return
        if self._conn is not None and self.alive:
            with contextlib.suppress(OSError, ValueError):
                self._conn.send(("stop",))
        self._discard(wait=EXIT_WAIT_S)
        with contextlib.suppress(OSError):
            os.unlink(self.log)

    def forget(self) -> None:
        """Drop the child without stopping it (a forked copy of this object must not)."""
        if self._conn is not None:
            with contextlib.suppress(OSError):
                self._conn.close()
        self._conn = None
        self._proc = None

    def _discard(self, wait: float = 0.0) -> None:
        """Forget the child: closed socket, process ended (killed unless it exits in time)."""
        if self._conn is not None:
            with contextlib.suppress(OSError):
                self._conn.close()
            self._conn = None
        if self._proc is not None:
            try:
                self._proc.wait(timeout=wait)
            except subprocess.TimeoutExpired:
                pass
            if self._proc.poll() is None:
                self._proc.kill()
                with contextlib.suppress(subprocess.TimeoutExpired):
                    self._proc.wait(timeout=EXIT_WAIT_S)
            self._proc = None

    def __enter__(self) -> IsolatedModel:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ requests

    def _receive(self, timeout: float | None, doing: str, offset: int) -> tuple[Any, ...]:
        """The child's reply, or EvaluationError (child killed) on a time-out or a crash."""
        assert self._conn is not None and self._proc is not None
        t0 = time.perf_counter()
        try:
            ready = self._conn.poll(timeout)
        except (OSError, EOFError):
            ready = True  # a broken socket: recv says how
        if not ready:
            self._discard()  # kills it
            tail = output_tail(self.log, offset)
            raise EvaluationError(
                f"timed out: {doing} took longer than {timeout:g} s; the model's process was "
                f"killed" + (f"; model output: {tail}" if tail else ""))
        try:
            return self._conn.recv()
        except (EOFError, OSError):
            proc = self._proc
            with contextlib.suppress(subprocess.TimeoutExpired):
                proc.wait(timeout=EXIT_WAIT_S)
            code = proc.poll()
            self._discard()
            tail = output_tail(self.log, offset)
            raise EvaluationError(
                f"the model's process died ({_signal_text(code)}) while {doing}, after "
                f"{time.perf_counter() - t0:.3g} s"
                + (f"; model output: {tail}" if tail else "")) from None

    def request(self, kind: str, values: Mapping[str, float]) -> np.ndarray | None:
        """``kind`` ("predict" or "frequencies") at ``values``; the child started if needed.

        Raises
        ------
        EvaluationError
            The model raised, timed out (child killed) or crashed.
        ConfigError
            The model raised a ConfigError (a configuration to fix, not a bad candidate).
        FemupdateError
            A new child could not load the model (see :meth:`start`).
        """
        self.start()
        assert self._conn is not None
        if os.path.getsize(self.log) > LOG_LIMIT:
            os.truncate(self.log, 0)  # the child appends (O_APPEND): it writes from 0 again
        offset = os.path.getsize(self.log)
        try:
            self._conn.send((kind, {str(k): float(v) for k, v in values.items()}))
        except (OSError, ValueError) as exc:
            self._discard()
            raise EvaluationError(f"the model's process cannot be reached ({exc})") from None
        doing = "predicting" if kind == "predict" else "computing frequencies"
        reply = self._receive(self.timeout, doing, offset)
        if reply[0] == "ok":
            return reply[1]
        if reply[0] == "config":
            error = MissingDependencyError if reply[1] == "MissingDependencyError" else ConfigError
            raise error(reply[2])
        raise EvaluationError(str(reply[1]))

    def predict(self, values: Mapping[str, float]) -> np.ndarray:
        out = self.request("predict", values)
        if out is None:
            raise EvaluationError("the model returned None instead of its prediction")
        return out

    def frequencies(self, values: Mapping[str, float]) -> np.ndarray | None:
        return self.request("frequencies", values)


# ---------------------------------------------------------------------- per-process cache

_idle: dict[str, list[IsolatedModel]] = {}
_all: dict[str, list[IsolatedModel]] = {}
_lock = threading.Lock()


@contextlib.contextmanager
def checkout(key: str, factory: Callable[[], IsolatedModel]) -> Iterator[IsolatedModel]:
    """An idle isolated model of ``key`` in this process (made by ``factory`` if none is),
    returned to the idle ones afterwards: one child per concurrent caller, reused."""
    with _lock:
        idle = _idle.setdefault(key, [])
        worker = idle.pop() if idle else None
    if worker is None:
        worker = factory()
        with _lock:
            _all.setdefault(key, []).append(worker)
    try:
        yield worker
    finally:
        with _lock:
            _idle.setdefault(key, []).append(worker)


def _forget_inherited() -> None:
    """In a forked process: drop the parent's children without touching them (they are the
    parent's to use and stop); only this process's copies of their sockets are closed."""
    for workers in _all.values():
        for worker in workers:
            worker.forget()
    _all.clear()
    _idle.clear()


os.register_at_fork(after_in_child=_forget_inherited)


def close_all(key: str | None = None) -> None:
    """Stop the children of ``key`` (all keys if None) started by this process."""
    with _lock:
        keys = list(_all) if key is None else [key]
        workers = [w for k in keys for w in _all.pop(k, [])]
        for k in keys:
            _idle.pop(k, None)
    for worker in workers:
        worker.close()


atexit.register(close_all)

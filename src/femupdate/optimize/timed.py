"""``minimize(..., timeout=T)``: each evaluation of ``fun`` in a child process, killed after T s.

A Python function that never returns cannot be interrupted inside its own thread; a process can
be killed (as the external models' :mod:`femupdate.external.isolation` does). The child is
forked, so ``fun`` need not be picklable; it stays alive between evaluations and a fresh one is
forked after a time-out or a crash. A timed-out or crashed evaluation is a failed one (φ = inf)
whose reason is kept (``res.failure``); an exception raised by ``fun`` is raised again here.
"""

from __future__ import annotations

import contextlib
import math
import multiprocessing
import numbers
from collections.abc import Callable
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from femupdate.errors import ConfigError, FemupdateError

__all__ = ["FAILED", "TimedFunction", "check_timeout"]

#: Seconds to wait for a child to exit once asked or killed.
EXIT_WAIT_S = 5.0


class _Failed:
    """The value of an evaluation that timed out or crashed (φ = inf; its reason is kept)."""

    def __repr__(self) -> str:
        return "FAILED"


#: Returned by :class:`TimedFunction` for an evaluation that did not finish.
FAILED = _Failed()


def check_timeout(timeout: Any, workers: Any = 1) -> float | None:
    """``timeout`` as seconds (a positive finite number) or None; ConfigError otherwise, or
    when ``workers`` (minimize's) is not 1."""
    if timeout is None:
        return None
    if isinstance(timeout, bool) or not isinstance(timeout, numbers.Real) \
            or not (math.isfinite(float(timeout)) and float(timeout) > 0):
        raise ConfigError(f"timeout: got {timeout!r} (allowed: a positive number of seconds "
                          "per evaluation of fun, or None: no limit)")
    if workers != 1:
        raise ConfigError(f"timeout with workers={workers!r}: a timeout needs workers=1 (each "
                          "evaluation then runs in a child process of its own, killed on a "
                          "time-out)")
    return float(timeout)


def _serve(fun: Callable[[np.ndarray], Any], conn: Connection) -> None:
    """The child's loop: evaluate each x received, send back ("ok", value) or the error."""
    while True:
        try:
            x = conn.recv()
        except EOFError:
            return
        try:
            reply: tuple[str, Any] = ("ok", fun(x))
        except Exception as exc:  # any: sent to the parent, raised there
            reply = ("error", exc)
        try:
            conn.send(reply)
        except Exception as exc:  # an unpicklable value or exception
            conn.send(("unsendable", f"{type(exc).__name__}: {exc}"))


class TimedFunction:
    """``fun`` evaluated in a forked child process, no longer than ``timeout`` seconds.

    Parameters
    ----------
    fun : callable
        φ(x) or r(x), as ``minimize``'s ``fun``.
    timeout : float
        Seconds one evaluation may take; beyond, the child is killed and the evaluation
        returns :data:`FAILED` with ``last_failure`` saying why.
    """

    def __init__(self, fun: Callable[[np.ndarray], Any], timeout: float) -> None:
        self.fun = fun
        self.timeout = timeout
        self.last_failure: str | None = None
        self.timeouts = 0
        self._proc: Any = None
        self._conn: Connection | None = None

    def _start(self) -> Connection:
        if self._proc is not None and self._proc.is_alive() and self._conn is not None:
            return self._conn
        self._stop()
        try:
            context = multiprocessing.get_context("fork")
        except ValueError:  # pragma: no cover - no fork (Windows)
            raise ConfigError("timeout: needs a platform with fork (Linux, macOS): fun is "
                              "run in a child process that is killed on a time-out") from None
        parent, child = context.Pipe()
        self._proc = context.Process(target=_serve, args=(self.fun, child), daemon=True)
        self._proc.start()
        child.close()
        self._conn = parent
        return parent

    def _stop(self) -> None:
        """End the child: killed at once (it may be stuck), waited for."""
        if self._conn is not None:
            with contextlib.suppress(OSError):
                self._conn.close()
            self._conn = None
        if self._proc is not None:
            if self._proc.is_alive():
                self._proc.kill()
            self._proc.join(EXIT_WAIT_S)
            self._proc = None

    def __call__(self, x: np.ndarray) -> Any:
        self.last_failure = None
        conn = self._start()
        conn.send(x)
        if not conn.poll(self.timeout):
            self._stop()
            self.timeouts += 1
            self.last_failure = (f"timed out: fun(x) took longer than {self.timeout:g} s "
                                 f"(timeout) at x = {x.tolist()}; its process was killed")
            return FAILED
        try:
            kind, value = conn.recv()
        except (EOFError, OSError):
            if self._proc is not None:
                self._proc.join(EXIT_WAIT_S)  # its exit code, once it has exited
            code = self._proc.exitcode if self._proc is not None else None
            self._stop()
            self.last_failure = (f"fun(x)'s process died (exit code {code}) at x = "
                                 f"{x.tolist()}")
            return FAILED
        if kind == "ok":
            return value
        if kind == "error":
            raise value
        raise FemupdateError(f"fun(x) at x = {x.tolist()} returned or raised something that "
                             f"cannot be sent from its process: {value}")

    def close(self) -> None:
        """Stop the child process."""
        self._stop()

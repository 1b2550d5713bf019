"""A library solver with a closed loop, driven as ask/tell: ``de`` (scipy's
``differential_evolution``) and ``scipy-lsq`` (scipy's ``least_squares``).

The solver runs in a worker thread; the function it calls (a :class:`Handoff`) hands each
point set to the main thread's :meth:`ThreadedSolver.ask` and waits for
:meth:`ThreadedSolver.tell` (inversion of control). :meth:`ThreadedSolver.close` (called by
``minimize`` when the run ends, and by a finalizer otherwise) unwinds the solver and joins the
thread. A thread cannot be pickled: such runs restart from their seed instead of resuming.
"""

from __future__ import annotations

import queue
import threading
import weakref
from collections.abc import Callable
from typing import Any

import numpy as np

from femupdate.errors import FemupdateError
from femupdate.optimize.base import KeepsBest, check_batch


class Abort(Exception):
    """Raised inside the worker thread to unwind the solver when the run ends."""


_ABORT = object()


class Handoff:
    """The function the solver calls in the worker thread: the rows it asks for go to the main
    thread (``("ask", rows)`` on ``asks``) and it waits for their values on ``tells``. Holds only
    the two queues, so the optimizer itself can be garbage collected (and its finalizer stop
    the thread).

    Parameters
    ----------
    asks, tells : queue.Queue
        Messages to the main thread; answers from it.
    rows : callable
        The solver's argument as rows (k, n) in the unit cube.
    """

    def __init__(self, asks: queue.Queue, tells: queue.Queue,
                 rows: Callable[[np.ndarray], np.ndarray]) -> None:
        self.asks = asks
        self.tells = tells
        self.rows = rows

    def __call__(self, x: np.ndarray) -> Any:
        self.asks.put(("ask", self.rows(x)))
        answer = self.tells.get()
        if answer is _ABORT:
            raise Abort
        return answer

    def say(self, kind: str, payload: Any = None) -> None:
        """Another message to the main thread: "restart", "done", "aborted" or "error"."""
        self.asks.put((kind, payload))


def _shutdown(tells: queue.Queue, thread: threading.Thread) -> None:
    if thread.is_alive():
        tells.put(_ABORT)
        thread.join()


class ThreadedSolver(KeepsBest):
    """The ask/tell side of a solver running in a worker thread. Not picklable.

    A subclass sets ``name`` (the method's), ``n`` and ``best_x`` and calls :meth:`_setup`
    with the thread's body ``solve(handoff, *args)``; the thread starts at the first ask. The
    body reports through ``handoff.say``: ``"restart"`` when a solve ends and the next begins
    (counted in ``restarts_done``), ``"done"`` with the solver's result when it has ended on
    its own, ``"aborted"`` when unwound, ``"error"`` with an exception to raise here.
    """

    name = ""
    n: int
    restarts_done = 0

    def _setup(self, solve: Callable[..., None], args: tuple[Any, ...],
               rows: Callable[[np.ndarray], np.ndarray]) -> None:
        self._asks: queue.Queue = queue.Queue()
        self._tells: queue.Queue = queue.Queue()
        self._message: tuple[str, Any] | None = None
        self._body = (solve, (Handoff(self._asks, self._tells, rows), *args))
        self._finalizer: weakref.finalize | None = None
        self._closed = False

    def __getstate__(self) -> dict[str, Any]:
        raise TypeError(f"the {self.name!r} optimizer runs scipy's solver in a thread and cannot "
                        f"be pickled: its runs restart from their seed instead of resuming")

    def _next_message(self) -> tuple[str, Any]:
        """The solver's next message (it asks for rows, or has ended), waiting for it."""
        if self._closed:
            raise FemupdateError(f"the {self.name!r} optimizer was closed")
        if self._finalizer is None:
            solve, args = self._body
            thread = threading.Thread(target=solve, args=args, name=f"femupdate-{self.name}",
                                      daemon=True)
            thread.start()
            self._finalizer = weakref.finalize(self, _shutdown, self._tells, thread)
        while self._message is None:
            kind, payload = self._asks.get()
            if kind == "restart":
                self.restarts_done += 1
                continue
            self._message = (kind, payload)
        kind, payload = self._message
        if kind == "error":
            raise payload
        return kind, payload

    def ask(self) -> np.ndarray:
        """The rows the solver wants evaluated next, shape (k, n)."""
        kind, payload = self._next_message()
        if kind != "ask":
            raise FemupdateError(f"the {self.name!r} solver has ended ({kind}); nothing more "
                                 "to ask")
        return payload.copy()

    def _answer(self, xs: np.ndarray, fs: np.ndarray,
                answer: Callable[[np.ndarray], Any]) -> None:
        """Hand the solver ``answer(fs)`` for the rows it asked for (``fs``: their φ, failures
        as inf)."""
        xs, fs = check_batch(xs, fs, self.n)
        kind, payload = self._next_message()
        if kind != "ask" or payload.shape[0] != fs.shape[0]:
            raise FemupdateError("tell() must follow ask() with one value per asked row")
        self._keep_best(xs, fs)
        self._message = None
        self._tells.put(answer(fs))

    def trace_since(self, step: int) -> dict[str, np.ndarray]:
        """No per-step trace."""
        return {}

    def close(self) -> None:
        """Unwind the solver and join its thread (idempotent)."""
        self._closed = True
        if self._finalizer is not None:
            self._finalizer()

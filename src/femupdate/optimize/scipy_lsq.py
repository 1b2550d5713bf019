"""``scipy-lsq``: a baseline — multistart of scipy's ``least_squares`` as a user would run it.

Uniform random starts in the unit cube, ``method="trf"``, bounds [0, 1], the 2-point
finite-difference Jacobian and ``x_scale="jac"``, scipy's defaults otherwise; when a solve
ends, the next starts, until ``minimize``'s budget or target. Every call of the residual
function (Jacobian columns included) is an evaluation.

scipy's solver is a closed loop, so it runs in a worker thread whose residual function hands
each point to :meth:`ScipyLeastSquares.ask` and waits for :meth:`~ScipyLeastSquares.tell`
(inversion of control, as ``de``). A thread cannot be pickled: runs restart instead of resuming.
"""

from __future__ import annotations

import queue
import threading
import weakref
from typing import Any

import numpy as np

from femupdate.errors import FemupdateError
from femupdate.optimize.base import KeepsBest, check_batch, check_option_names


class _Abort(Exception):
    """Raised in the worker thread to unwind scipy's solver when the run ends."""


_ABORT = object()


class _Residuals:
    """The function scipy calls in the worker thread: one point out, its residuals back."""

    def __init__(self, asks: queue.Queue, tells: queue.Queue) -> None:
        self.asks = asks
        self.tells = tells

    def __call__(self, x: np.ndarray) -> np.ndarray:
        self.asks.put(("ask", np.array(x, dtype=float)[None, :]))
        r = self.tells.get()
        if r is _ABORT:
            raise _Abort
        return r


def _solve_forever(fun: _Residuals, n: int, rng: np.random.Generator) -> None:
    """Body of the worker thread: least_squares from uniform starts until aborted."""
    from scipy.optimize import least_squares

    try:
        while True:
            x0 = rng.random(n)  # the main thread waits meanwhile: no concurrent draws
            try:
                least_squares(fun, x0, bounds=(0.0, 1.0), method="trf", x_scale="jac")
            except ValueError:  # residuals not finite at the start: take another
                pass
            fun.asks.put(("restart", None))
    except _Abort:
        fun.asks.put(("aborted", None))
    except BaseException as exc:  # handed to the main thread, raised there
        fun.asks.put(("error", exc))


def _shutdown(tells: queue.Queue, thread: threading.Thread) -> None:
    if thread.is_alive():
        tells.put(_ABORT)
        thread.join()


class ScipyLeastSquares(KeepsBest):
    """Multistart ``scipy.optimize.least_squares`` (trf, 2-point, x_scale="jac"). Not picklable.

    Parameters
    ----------
    n : int
        Number of parameters.
    rng : numpy.random.Generator
        Draws the starts.
    """

    #: scipy's least_squares minimises ‖r‖²: it cannot run on φ alone.
    needs_residuals = True

    def __init__(self, n: int, rng: np.random.Generator) -> None:
        self.n = n
        self.rng = rng
        self.best_x = np.full(n, 0.5)
        self.restarts_done = 0
        self._asks: queue.Queue = queue.Queue()
        self._tells: queue.Queue = queue.Queue()
        self._message: tuple[str, Any] | None = None
        self._thread: threading.Thread | None = None  # started at the first ask
        self._finalizer: weakref.finalize | None = None

    def __getstate__(self) -> dict[str, Any]:
        raise TypeError("the 'scipy-lsq' optimizer runs scipy's solver in a thread and cannot "
                        "be pickled: its runs restart from their seed instead of resuming")

    def _next_message(self) -> tuple[str, Any]:
        if self._thread is None:
            self._thread = threading.Thread(
                target=_solve_forever, args=(_Residuals(self._asks, self._tells), self.n,
                                             self.rng),
                name="femupdate-scipy-lsq", daemon=True)
            self._thread.start()
            self._finalizer = weakref.finalize(self, _shutdown, self._tells, self._thread)
        while self._message is None:
            if self._finalizer is not None and not self._finalizer.alive:
                raise FemupdateError("the 'scipy-lsq' optimizer was closed")
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
        """The point scipy wants evaluated next, shape (1, n)."""
        kind, payload = self._next_message()
        if kind != "ask":
            raise FemupdateError(f"the 'scipy-lsq' solver has ended ({kind})")
        return payload.copy()

    def tell(self, xs: np.ndarray, fs: np.ndarray, rs: np.ndarray | None = None) -> None:
        """φ and the residuals of the point last asked (failures: all inf)."""
        xs, fs = check_batch(xs, fs, self.n)
        if rs is None:
            raise FemupdateError("the 'scipy-lsq' optimizer needs residuals (rs)")
        kind, payload = self._next_message()
        if kind != "ask" or payload.shape[0] != fs.shape[0]:
            raise FemupdateError("tell() must follow ask() with one value per asked row")
        self._keep_best(xs, fs)
        self._message = None
        self._tells.put(np.asarray(rs, dtype=float).reshape(fs.shape[0], -1)[0].copy())

    def stop(self) -> dict[str, object]:
        """Never: a converged solve is followed by the next start."""
        return {}

    def trace_since(self, step: int) -> dict[str, np.ndarray]:
        """No per-step trace."""
        return {}

    def close(self) -> None:
        """Unwind the solver and join its thread (idempotent)."""
        if self._finalizer is not None:
            self._finalizer()


def make_scipy_lsq(n: int, rng: np.random.Generator, **options: Any) -> ScipyLeastSquares:
    """Multistart scipy ``least_squares`` (no options: scipy's defaults, as a user runs it)."""
    check_option_names("scipy-lsq", options, ())
    return ScipyLeastSquares(n, rng)

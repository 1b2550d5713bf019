"""``scipy-lsq``: a baseline — multistart of scipy's ``least_squares`` as a user would run it.

Uniform random starts in the unit cube, ``method="trf"``, bounds [0, 1], the 2-point
finite-difference Jacobian and ``x_scale="jac"``, scipy's defaults otherwise; when a solve
ends, the next starts, until ``minimize``'s budget or target. Every call of the residual
function (Jacobian columns included) is an evaluation.

scipy's solver is a closed loop, so it runs in a worker thread whose residual function hands
each point to :meth:`ScipyLeastSquares.ask` and waits for :meth:`~ScipyLeastSquares.tell`
(:mod:`femupdate.optimize.threaded`, as ``de``). A thread cannot be pickled: runs restart
instead of resuming.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from femupdate.errors import FemupdateError
from femupdate.optimize.base import check_option_names
from plugins.threaded import Abort, Handoff, ThreadedSolver


def _solve_forever(handoff: Handoff, n: int, rng: np.random.Generator) -> None:
    """Body of the worker thread: least_squares from uniform starts until aborted."""
    from scipy.optimize import least_squares

    try:
        while True:
            x0 = rng.random(n)  # the main thread waits meanwhile: no concurrent draws
            try:
                least_squares(handoff, x0, bounds=(0.0, 1.0), method="trf", x_scale="jac")
            except ValueError:  # residuals not finite at the start: take another
                pass
            handoff.say("restart")
    except Abort:
        handoff.say("aborted")
    except BaseException as exc:  # handed to the main thread, raised there
        handoff.say("error", exc)


def _one_row(x: np.ndarray) -> np.ndarray:
    return np.array(x, dtype=float)[None, :]


class ScipyLeastSquares(ThreadedSolver):
    """Multistart ``scipy.optimize.least_squares`` (trf, 2-point, x_scale="jac"). Not picklable.

    Parameters
    ----------
    n : int
        Number of parameters.
    rng : numpy.random.Generator
        Draws the starts.
    """

    name = "scipy-lsq"
    #: scipy's least_squares minimises ‖r‖²: it cannot run on φ alone.
    needs_residuals = True

    def __init__(self, n: int, rng: np.random.Generator) -> None:
        self.n = n
        self.best_x = np.full(n, 0.5)
        self._setup(_solve_forever, (n, rng), _one_row)

    def tell(self, xs: np.ndarray, fs: np.ndarray, rs: np.ndarray | None = None) -> None:
        """φ and the residuals of the point last asked (failures: all inf)."""
        if rs is None:
            raise FemupdateError("the 'scipy-lsq' optimizer needs residuals (rs)")
        self._answer(xs, fs, lambda values: np.asarray(rs, dtype=float).reshape(
            values.shape[0], -1)[0].copy())

    def stop(self) -> dict[str, object]:
        """Never: a converged solve is followed by the next start."""
        return {}


def make_scipy_lsq(n: int, rng: np.random.Generator, **options: Any) -> ScipyLeastSquares:
    """Multistart scipy ``least_squares`` (no options: scipy's defaults, as a user runs it)."""
    check_option_names("scipy-lsq", options, ())
    return ScipyLeastSquares(n, rng)

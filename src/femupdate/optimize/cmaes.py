"""CMA-ES as the paper ran it (Zapico-Valle et al. 2010, §3): pycma through ask/tell on the unit
cube.

The initial mean is uniform at random in the box, σ0 = 0.5 (half the box), λ = 5 by default,
pycma's default strategy otherwise (without mirrored sampling). Bounds by resampling: each
candidate outside [0, 1]^n is redrawn from the same distribution until it lies inside (a
truncated Gaussian), at most MAX_RESAMPLES times; after that the last draw is projected onto
the box (clipped) and told to pycma as it is, which treats it as a solution it did not send
and shortens its step to a plausible length before the update. Resampling is cheap while the
distribution lies mostly inside the box; near a bound with an elongated covariance the chance
of an inside draw falls to 2^−n or below, and without a cap one run drew 25.9 million
candidates for 9,515 evaluations. pycma's ``BoundPenalty`` is not used (in cma 4.5 it computes
the penalty on points already clipped into the box, so it is always zero),
nor ``BoundTransform``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from femupdate.optimize.base import (
    KeepsBest,
    Restarts,
    StepTrace,
    check_batch,
    check_option_names,
    int_option,
    real_option,
    restart_options,
)

#: Redraws of one candidate before it is clipped into the box instead (the fallback). The
#: mean stays inside the box, but at a corner (an improper minimum at several bounds) with an
#: elongated covariance a draw may land inside with probability well below 2^−n: with a cap of
#: 100,000 a bridge run drew 25.9 million candidates for 9,515 evaluations (50–100× slower per
#: evaluation). At 1,000 an inside draw is kept whenever the truncated Gaussian keeps at least
#: 0.5 % of the distribution (probability 1 − 0.995^1000 > 99 %), and a step costs at most
#: λ·1,000 draws.
MAX_RESAMPLES = 1_000
#: Largest batch of redraws asked of pycma at once (batches double from 1 up to this).
MAX_BATCH = 1024


class GeneratorRandn:
    """pycma's ``randn`` option drawing from our Generator (picklable, no global state)."""

    def __init__(self, rng: np.random.Generator) -> None:
        self.rng = rng

    def __call__(self, *shape: int) -> np.ndarray:
        return self.rng.standard_normal(shape)


class CMAES(KeepsBest, Restarts):
    """pycma's ``CMAEvolutionStrategy`` on the unit cube, truncated by resampling. Picklable.

    Parameters
    ----------
    n : int
        Number of parameters.
    rng : numpy.random.Generator
        The only source of randomness (pycma's ``randn`` draws from it; numpy's global state is
        neither seeded nor used).
    popsize : int
        λ, candidates per step (default 5, as the paper).
    sigma0 : float
        Initial step size in the unit cube (default 0.5, half the box).
    tolfun, tolfunhist, tolx : float
        pycma's termination tolerances on the range of recent φ values, of the best φ over the
        last iterations, and on the step size (its defaults: 1e-11, 1e-12, 1e-11); 0 switches a
        criterion off. They are absolute: with a target φ near 1e-6 on an ill-conditioned
        problem, the defaults may stop a run that is still converging.
    stall_window, stall_tol : int or None, float
        Stop (or restart) when the best φ fell by less than the fraction ``stall_tol`` over the
        last ``stall_window`` evaluations (:class:`~femupdate.optimize.base.Restarts`); off
        (None) by default.
    restarts : int
        How many times to start afresh (a new uniform mean, σ = sigma0, λ unchanged) when
        pycma's criteria or the stall criterion fire; 0 (default) as the paper ran it.

    Notes
    -----
    ``stop()`` reports pycma's own termination criteria (``tolfun``, ``tolx``, ``tolstagnation``
    and so on, with their values); its budgets ``maxfevals`` and ``maxiter`` are off: ``minimize``
    owns the budget.
    Failed evaluations (inf) are passed to pycma as a value worse than every finite value of
    the step, so the ranking (all CMA-ES uses) stays well defined.
    """

    def __init__(self, n: int, rng: np.random.Generator, *, popsize: int = 5,
                 sigma0: float = 0.5, tolfun: float = 1e-11, tolfunhist: float = 1e-12,
                 tolx: float = 1e-11, stall_window: int | None = None, stall_tol: float = 0.01,
                 restarts: int = 0) -> None:
        self.n = n
        self.rng = rng
        self.sigma0 = sigma0
        self.restarts = restarts
        self.stall_window = stall_window
        self.stall_tol = stall_tol
        self.es_options = {
            "popsize": popsize,
            "tolfun": tolfun,
            "tolfunhist": tolfunhist,
            "tolx": tolx,
            "randn": GeneratorRandn(rng),
            "seed": math.nan,  # "do nothing" to numpy's global state
            "verbose": -9,
            "verb_log": 0,
            "verb_disp": 0,
            "maxfevals": math.inf,  # minimize owns the budget,
            "maxiter": math.inf,  # in evaluations or in steps
            "bounds": [None, None],
            # No mirrored sampling: a mirror redrawn for lying outside the box breaks the
            # pair pycma's selective mirroring relies on ("orphanated injected solution");
            # the paper's CMA-ES (2010) had none either.
            "CMA_mirrors": 0,
        }
        self._new_search()
        self.best_x = self.es.mean.copy()
        self.resamples = 0  # redraws of candidates outside the box
        self.projected = 0  # candidates clipped into the box after MAX_RESAMPLES redraws
        self.trace = StepTrace()

    def _restart(self) -> None:
        """A new strategy: mean uniform at random in the box, σ = sigma0."""
        import cma  # imported here: about a second to import

        self.es = cma.CMAEvolutionStrategy(self.rng.random(self.n), self.sigma0,
                                           dict(self.es_options))

    def ask(self) -> np.ndarray:
        """λ candidates inside [0, 1]^n, each redrawn until inside."""
        xs = np.array(self.es.ask(), dtype=float)
        for i in range(xs.shape[0]):
            if _inside(xs[i]):
                continue
            # The first inside draw of an i.i.d. sequence is a draw of the truncated Gaussian;
            # batches of redraws (1, 2, 4, …) keep pycma's per-call overhead off a long search.
            tries, batch = 0, 1
            while True:
                if tries >= MAX_RESAMPLES:
                    np.clip(xs[i], 0.0, 1.0, out=xs[i])
                    self.projected = getattr(self, "projected", 0) + 1
                    break
                size = min(batch, MAX_RESAMPLES - tries)
                draws = np.array(self.es.ask(size), dtype=float)
                inside = np.flatnonzero(np.all((draws >= 0.0) & (draws <= 1.0), axis=1))
                if inside.size:
                    xs[i] = draws[inside[0]]
                    tries += int(inside[0]) + 1
                    break
                tries += size
                batch = min(2 * batch, MAX_BATCH)
            self.resamples += tries
        return xs

    def tell(self, xs: np.ndarray, fs: np.ndarray, rs: np.ndarray | None = None) -> None:
        """Pass the values to pycma (failures ranked last; residuals not used)."""
        xs, fs = check_batch(xs, fs, self.n)
        self._keep_best(xs, fs)
        finite = np.isfinite(fs)
        if not finite.all():
            worst = float(fs[finite].max()) if finite.any() else 0.0
            fs = np.where(finite, fs, worst + 1.0 + abs(worst))
        self.es.tell(list(xs), fs.tolist())
        self.trace.append(sigma=float(self.es.sigma), f_best=self.best_f,
                          restarts=self.restarts_done)
        self._track(fs)
        self._restart_if_converged()

    def _criteria(self) -> dict[str, object]:
        """pycma's termination criteria that fired, and ``stall``."""
        return {**self.es.stop(), **self._stall()}

    def trace_since(self, step: int) -> dict[str, np.ndarray]:
        """Per step: pycma's global ``sigma``, ``f_best`` and ``restarts`` (how many so far)."""
        return self.trace.since(step)

    def close(self) -> None:
        """Nothing to release."""


def _inside(x: np.ndarray) -> bool:
    return bool(np.all(x >= 0.0) and np.all(x <= 1.0))


_CMAES_OPTIONS = ("popsize", "sigma0", "tolfun", "tolfunhist", "tolx", "stall_window",
                  "stall_tol", "restarts")


def make_cmaes(n: int, rng: np.random.Generator, **options: Any) -> CMAES:
    """CMA-ES. Options: ``popsize`` (int ≥ 2, default 5), ``sigma0`` (in (0, 1], default 0.5),
    ``tolfun``, ``tolfunhist``, ``tolx`` (≥ 0, pycma's defaults; 0 switches off),
    ``stall_window``, ``stall_tol``, ``restarts`` (see :class:`CMAES`)."""
    check_option_names("cmaes", options, _CMAES_OPTIONS)
    popsize = int_option("cmaes", "popsize", options.get("popsize", 5), 2)
    sigma0 = real_option("cmaes", "sigma0", options.get("sigma0", 0.5), 0.0, 1.0, low_open=True)
    tolfun = real_option("cmaes", "tolfun", options.get("tolfun", 1e-11), 0.0, high_open=True)
    tolfunhist = real_option("cmaes", "tolfunhist", options.get("tolfunhist", 1e-12), 0.0,
                             high_open=True)
    tolx = real_option("cmaes", "tolx", options.get("tolx", 1e-11), 0.0, high_open=True)
    return CMAES(n, rng, popsize=popsize, sigma0=sigma0,  # type: ignore[arg-type]
                 tolfun=tolfun, tolfunhist=tolfunhist, tolx=tolx,
                 **restart_options("cmaes", options))

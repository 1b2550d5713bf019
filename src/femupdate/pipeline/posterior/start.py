"""Is the posterior centred on the best fit? The start's verdict.

``femupdate posterior`` samples from the search's best fit: the error model is measured on its
residuals (each channel's variance and correlation), and TMCMC's first population is the
Laplace Gaussian there. If that fit is not the best minimum, neither is right: the residuals
of a poor fit hold model error, not noise, so the error model is too wide, and the samples
gather around the wrong basin. The agreement of the sampler's runs cannot see this (runs
started from one Gaussian agree on its basin), so two other checks are made:

* **the search's own verdict** (:mod:`femupdate.runs.verdict`): a best fit no other search
  found again may not be the best minimum; the posterior says so;
* **the sampler's best fit**: TMCMC evaluates the model tens of thousands of times around the
  start. When one of its evaluations fits better than the search's best by more than the
  verdict's "same minimum" tolerance (:data:`~femupdate.runs.verdict.SAME_PHI`), the start
  was not the minimum. The run then polishes that point by a local least-squares search
  (:data:`POLISH_EVALS` evaluations) and samples again from there, with the error model
  measured anew (``[posterior] recentre`` times at most); what it did, and a better fit it
  could not follow any more, are said in words.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from femupdate.optimize.minimize import minimize
from femupdate.pipeline.results import VerdictRecord
from femupdate.runs import RunOutcome
from femupdate.runs.verdict import SAME_PHI

#: Budget of the local search that polishes the sampler's best point before sampling again:
#: one Levenberg–Marquardt search from there takes a few hundred evaluations on the bridge.
POLISH_EVALS = 1000


def better_fit(outcomes: Sequence[RunOutcome], phi: float,
               tolerance: float = SAME_PHI) -> RunOutcome | None:
    """The sampler run whose best evaluation fits better than ``phi`` by more than the
    fraction ``tolerance`` (the best such run), else None."""
    finite = [o for o in outcomes if np.isfinite(o.fun)]
    if not finite:
        return None
    best = min(finite, key=lambda o: o.fun)
    return best if best.fun < phi * (1.0 - tolerance) else None


def polish(residuals: Any, bounds: Sequence[tuple[float, float]], x: np.ndarray,
           seed: np.random.SeedSequence) -> tuple[np.ndarray, float, int]:
    """(x, φ, evaluations): a local least-squares search (multistart-lm, first start at
    ``x``, :data:`POLISH_EVALS` evaluations at most), never worse than ``x`` itself."""
    lows = np.array([b[0] for b in bounds], dtype=float)
    highs = np.array([b[1] for b in bounds], dtype=float)
    start = np.clip((np.asarray(x, dtype=float) - lows) / (highs - lows), 0.0, 1.0)
    res = minimize(residuals, bounds, "multistart-lm", residuals=True, seed=seed,
                   max_evals=POLISH_EVALS, x0=start)
    return np.asarray(res.x, dtype=float), float(res.fun), int(res.nfev)


def search_sentence(verdict: VerdictRecord | None, recentred: bool) -> str | None:
    """What the search's verdict means for the posterior, when it is not converged
    (``recentred``: the posterior was sampled again from a better fit the sampler found)."""
    if verdict is None or verdict.converged:
        return None
    where = ("the better fit the sampler found, which no independent search confirmed either"
             if recentred else "the search's best fit")
    return (f"the search's verdict is '{verdict.words}': the posterior is of the basin around "
            f"{where}, and a better minimum elsewhere would move it (more [search] runs or a "
            "larger max_evals, then `femupdate posterior --restart`)")


def recentred_sentence(search_phi: float, phi: float, passes: int) -> str:
    """The sampler found a better fit than the search's, and the posterior followed it."""
    times = "" if passes == 1 else f" ({passes} times)"
    return (f"the sampler found a better fit than the search's (φ {phi:.6g} against "
            f"{search_phi:.6g}): the posterior was sampled again from there{times}, with the "
            "error model measured anew")


def unfollowed_sentence(start_phi: float, phi: float) -> str:
    """The sampler found a better fit than its start, and no re-centring was left."""
    return (f"the sampler found a better fit than the one it started from (φ {phi:.6g} "
            f"against {start_phi:.6g}) and was not started again from it ([posterior] "
            "recentre): the error model and the samples are of a fit that is not the best "
            "minimum; the search missed it (more runs or a larger [search] max_evals, then "
            "`femupdate posterior --restart`)")

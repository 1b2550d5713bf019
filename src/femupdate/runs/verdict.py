"""A set of runs' verdict: was the best found again by independent searches?

On real records there is no f_target: a search cannot know it found the global minimum, only
that independent searches keep ending at the same one. The verdict groups the runs' best
points into minima (the same φ within ``SAME_PHI``, the same parameters within ``SAME_X``)
and calls the best *converged* when at least ``MIN_AGREE`` independent runs ended in its
group, or when the best run's own searches found it again (multistart-lm's ``patience``:
that many searches of the run ended at its best φ). Otherwise the runs ended in m different
minima, whose φ range it gives. docs/verdicts.md says what success then means.

Agreement alone is not enough where most runs end at a φ no other run reaches: there the
next run would likely end at a φ not yet seen, perhaps a lower one. The share of runs that
each ended alone at their φ (the best's aside) is the Good–Turing estimate of that chance
(Good 1953): :func:`unseen_share`, in the verdict as ``unseen``.

:func:`runs_needed` is the run-level stop (``[search] agree``): on such records, once
``agree`` runs, taken in index order, have ended at their best φ (within multistart-lm's own
``patience`` tolerance), and no more than :data:`UNSEEN_SHARE` of them each ended alone at
another φ, the runs after them are not needed; the verdict then says how many of the planned
runs were.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from femupdate.optimize.multistart import PATIENCE_TOL

#: Two runs ended at the same minimum when their φ differ by less than this fraction of the
#: smaller (searches of one run stop 0.1–0.3 % apart along the bridge's flat kp1 valley) ...
SAME_PHI = 0.01
#: ... or by less than this in absolute terms: φ is an NMSE, and 1e-10 % is no difference on
#: any record (at φ = 0, as on exact virtual data, a relative tolerance is zero).
SAME_PHI_FLOOR = 1e-12
#: ... and their parameters by less than this RMS distance in the unit search box (the
#: distance multistart-lm treats as one basin, its ``min_distance``).
SAME_X = 0.05
#: Independent runs (or searches of one run) that must end at the best minimum.
MIN_AGREE = 2
#: Runs that must end at the best φ before the others are not needed (``[search] agree``).
AGREE = 2
#: φ is an NMSE (a fraction): at 1 (100 %) the model is no better than predicting zero.
NO_FIT = 1.0
#: The largest share of runs that may each have ended alone at a φ other than the best's
#: when the runs are done: beyond it another run more likely than not ends at a φ none has
#: reached (its Good–Turing estimate, :func:`unseen_share`).
UNSEEN_SHARE = 0.5


@dataclass(frozen=True)
class Verdict:
    """What the runs say about their best minimum.

    Attributes
    ----------
    converged : bool
        The best was found again: ≥ MIN_AGREE runs in its group, or the best run's
        ``patience`` fired (that many of its searches ended at its best φ).
    agreeing_runs : list of int
        Indices of the runs that ended at the best minimum (the best run first).
    confirmations : int
        Independent searches that ended there: the agreeing runs, or the best run's patience
        count when it is larger.
    minima : int
        Distinct minima the runs ended in (groups of same φ and parameters).
    phi_range : tuple of float
        The smallest and largest φ over the runs (finite ones).
    fits : bool
        The best φ is below NO_FIT (an NMSE under 100 %).
    words : str
        The verdict in one sentence.
    planned : int or None
        Runs the case asked for, when the agreement stop (``[search] agree``) left some of
        them not needed; None when every planned run ran.
    unseen : float
        :func:`unseen_share` of the runs: about how often another run would end at a φ none
        of them reached.
    """

    converged: bool
    agreeing_runs: list[int]
    confirmations: int
    minima: int
    phi_range: tuple[float, float]
    fits: bool
    words: str
    planned: int | None = None
    unseen: float = 0.0


def same_phi_level(best: float | np.ndarray) -> float | np.ndarray:
    """The largest φ that counts as "ended at the best φ" ``best`` (each, for an array):
    within the fraction PATIENCE_TOL (multistart-lm's ``patience`` tolerance), or
    SAME_PHI_FLOOR at φ ≈ 0."""
    return best + np.maximum(PATIENCE_TOL * np.abs(best), SAME_PHI_FLOOR)


def runs_needed(phis: Sequence[float | None], agree: int, unseen: float = UNSEEN_SHARE
                ) -> int | None:
    """How many runs are needed: the smallest k such that runs 0 … k − 1 have all ended,
    ``agree`` of them ended at their best φ (:func:`same_phi_level`), and no more than
    ``unseen`` of them each ended alone at another φ (:func:`unseen_share`); None while no
    such k.

    Runs are taken in index order, never in the order they happen to end, so the answer is
    the same with any number of workers and after any interruption.

    Parameters
    ----------
    phis : sequence of float or None
        Each run's final φ by run index; None for a run that has not ended. A non-finite φ
        (a run that never evaluated the model) ends but agrees with nothing.
    agree : int
        Runs that must agree (≥ 1).
    unseen : float
        The largest share of runs alone at their φ (:data:`UNSEEN_SHARE`; 1: agreement
        alone, as the stop was before it).
    """
    for k, phi in enumerate(phis, start=1):
        if phi is None:
            return None
        ended = [float(p) for p in phis[:k]]  # none is None: the loop returns at the first
        if runs_agreeing(ended) >= agree and unseen_share(ended) <= unseen:
            return k
    return None


def alone(phis: Sequence[float] | np.ndarray) -> np.ndarray:
    """Whether each run ended alone at its φ: no other run's φ within :func:`same_phi_level`'s
    tolerance of it (False for a non-finite φ). Parameters are not compared: what a better fit
    needs is a lower φ, and runs at one φ with their parameters apart (a flat direction) say
    the same of it."""
    phis = np.asarray(phis, dtype=float)
    out = np.zeros(phis.size, dtype=bool)
    finite = np.flatnonzero(np.isfinite(phis))
    order = finite[np.argsort(phis[finite], kind="stable")]
    ranked = phis[order]
    close = ranked[1:] <= same_phi_level(ranked[:-1])
    near = np.zeros(ranked.size, dtype=bool)
    near[:-1] |= close
    near[1:] |= close
    out[order] = ~near
    return out


def unseen_share(phis: Sequence[float] | np.ndarray) -> float:
    """The share of the runs with a finite φ that each ended alone (:func:`alone`) above the
    best's level (:func:`same_phi_level`): the Good–Turing estimate (Good 1953) of how often
    another run would end at a φ none of them reached. 0 for no such run."""
    phis = np.asarray(phis, dtype=float)
    finite = np.isfinite(phis)
    if not finite.any():
        return 0.0
    lone = alone(phis) & (phis > same_phi_level(float(phis[finite].min())))
    return float(lone.sum() / finite.sum())


def minimum_groups(phis: np.ndarray, positions: np.ndarray, same_phi: float = SAME_PHI,
                   same_x: float = SAME_X) -> np.ndarray:
    """Label each run with the minimum it ended in (0: the best's).

    Runs are taken best first; each joins the first group whose best run has a φ within
    ``same_phi`` (relative) and parameters within ``same_x`` (RMS, unit box) of its own,
    else opens a new group. Runs with a non-finite φ are labelled −1.

    Parameters
    ----------
    phis : ndarray (k,)
        Each run's best φ.
    positions : ndarray (k, n)
        Each run's best point in the unit box of the search space.
    """
    phis = np.asarray(phis, dtype=float)
    positions = np.atleast_2d(np.asarray(positions, dtype=float))
    labels = np.full(phis.size, -1)
    heads: list[int] = []
    for i in np.argsort(phis, kind="stable"):
        if not math.isfinite(phis[i]):
            continue
        for label, head in enumerate(heads):
            close_phi = abs(phis[i] - phis[head]) <= max(same_phi * abs(phis[head]),
                                                         SAME_PHI_FLOOR)
            close_x = float(np.sqrt(np.mean((positions[i] - positions[head]) ** 2))) <= same_x
            if close_phi and close_x:
                labels[i] = label
                break
        else:
            labels[i] = len(heads)
            heads.append(int(i))
    return labels


def verdict_of(phis: Sequence[float], positions: np.ndarray,
               stops: Sequence[Mapping[str, object]], planned: int | None = None) -> Verdict:
    """The verdict of runs ending at ``phis`` and ``positions`` (unit box), with their
    ``stop`` dicts (the best run's ``patience`` counts its searches that found the best).
    ``planned``: the runs asked for, when more than ran (the others were not needed: their
    first runs agreed, :func:`runs_needed`)."""
    phis_arr = np.asarray(phis, dtype=float)
    labels = minimum_groups(phis_arr, positions)
    finite = phis_arr[np.isfinite(phis_arr)]
    if finite.size == 0:
        return Verdict(False, [], 0, 0, (math.inf, math.inf), False,
                       "no run evaluated the model successfully")
    best = int(np.nanargmin(np.where(np.isfinite(phis_arr), phis_arr, np.nan)))
    agreeing = [best] + [int(i) for i in np.flatnonzero(labels == 0) if i != best]
    searches = stops[best].get("patience")
    by_searches = int(searches) if isinstance(searches, (int, np.integer)) else 0
    confirmations = max(len(agreeing), by_searches)
    converged = confirmations >= MIN_AGREE
    minima = int(labels.max()) + 1
    lo, hi = float(finite.min()), float(finite.max())
    fits = lo < NO_FIT
    runs = len(phis_arr)
    planned = planned if planned is not None and planned > runs else None
    if converged and len(agreeing) >= MIN_AGREE and planned is not None:
        who = "they" if len(agreeing) == runs else f"{len(agreeing)} of them"
        words = (f"converged: {runs} of {planned} runs were needed: {who} ended at the same "
                 f"best minimum (φ within {SAME_PHI:.0%}, parameters within {SAME_X:g} of "
                 f"the box)")
    elif converged and len(agreeing) >= MIN_AGREE:
        words = (f"converged: {len(agreeing)} of {runs} runs ended at the best minimum "
                 f"(φ within {SAME_PHI:.0%}, parameters within {SAME_X:g} of the box)")
    elif converged:
        words = (f"converged within run {best}: {by_searches} of its searches ended at its "
                 f"best φ" + ("; the other runs ended elsewhere" if runs > 1 else ""))
    elif runs == 1:
        words = ("not converged: the only run's best was not found again by another search "
                 "(run more runs, or a larger budget)")
    else:
        words = (f"not converged: the {runs} runs ended in {minima} different minima, "
                 f"φ {lo:.4g} … {hi:.4g}; the best was found once")
    if converged and minima > 1 and len(agreeing) >= MIN_AGREE:
        words += f"; the {runs - len(agreeing)} others in {minima - 1} other minima"
    if planned is not None and not (converged and len(agreeing) >= MIN_AGREE):
        # the stop's φ-only agreement, which the verdict's grouping (φ and parameters) did
        # not confirm
        words += (f"; {runs} of {planned} runs were needed: {runs_agreeing(phis_arr)} ended "
                  f"at the same best φ (within {PATIENCE_TOL:.1%})")
    unseen = unseen_share(phis_arr)
    if not fits:
        words += (f"; the best fit is no fit: NMSE {100 * lo:.3g} % ≥ {100 * NO_FIT:.0f} % "
                  f"(no better than predicting zero)")
    return Verdict(converged, agreeing, confirmations, minima, (lo, hi), fits, words, planned,
                   unseen)


def runs_agreeing(phis: Sequence[float]) -> int:
    """How many of ``phis`` ended at their best φ (:func:`same_phi_level`)."""
    finite = [p for p in phis if math.isfinite(p)]
    if not finite:
        return 0
    level = same_phi_level(min(finite))
    return sum(1 for p in finite if p <= level)


def successes(verdict: Verdict, phis: Sequence[float], reached: Sequence[bool] | None
              ) -> list[bool]:
    """Which runs succeeded.

    With an f_target (``reached``: each run reached it) a run succeeds when it reached it and
    its φ is below NO_FIT. Without one, a run succeeds when it ended at the best minimum, the
    best is converged (found again) and fits (NMSE < 100 %): being the best of the runs is
    not enough.
    """
    phis_arr = np.asarray(phis, dtype=float)
    if reached is not None:
        return [bool(ok and p < NO_FIT) for ok, p in zip(reached, phis_arr, strict=True)]
    if not (verdict.converged and verdict.fits):
        return [False] * phis_arr.size
    agree = set(verdict.agreeing_runs)
    return [i in agree for i in range(phis_arr.size)]


def success_rule(f_target: float | None) -> str:
    """What success meant, in words (summary.json ``success_rule``)."""
    if f_target is not None:
        return f"reached f_target = {f_target:g} with NMSE < {100 * NO_FIT:.0f} %"
    return (f"ended at the best minimum, found again by ≥ {MIN_AGREE} independent runs or "
            f"searches (φ within {SAME_PHI:.0%}, parameters within {SAME_X:g} of the box), "
            f"with NMSE < {100 * NO_FIT:.0f} % (no f_target given)")


def run_verdict(problem: object, outcomes: Sequence[object], planned: int | None = None
                ) -> Verdict:
    """The verdict of a case's run outcomes: their best points placed in the unit box of the
    problem's search bounds (``problem.bounds``: (low, high) per parameter). ``planned``: the
    runs asked for (more than the outcomes when the others were not needed)."""
    bounds = np.asarray(problem.bounds, dtype=float)  # type: ignore[attr-defined]
    low, high = bounds[:, 0], bounds[:, 1]
    xs = np.array([np.asarray(o.x, dtype=float) for o in outcomes])  # type: ignore[attr-defined]
    positions = (xs - low) / np.where(high > low, high - low, 1.0)
    return verdict_of([float(o.fun) for o in outcomes],  # type: ignore[attr-defined]
                      positions, [dict(o.stop) for o in outcomes],  # type: ignore[attr-defined]
                      planned)

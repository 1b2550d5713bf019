"""Do independent sampler runs agree? The sampled posterior's verdict.

A TMCMC run estimates its own effective sample size from its genealogy
(:func:`femupdate.inference.tmcmc.ess_by_ancestry`), and that estimate cannot see what the
run never reached: a tail of the posterior its particles did not migrate into, a mode its
start missed. Independent runs can: if each run's mean of a parameter were worth e
independent samples, the runs' means would scatter with variance σ²/e. So, per parameter,
with R runs of within-run variances s_r² and means m_r,

    e_across = W / B,   W = mean_r s_r²,   B = var_r(m_r) (R − 1 degrees of freedom),

is the effective sample size per run measured across runs, and the pooled samples are worth

    ESS = min(Σ_r e_r, R · e_across),

the smaller of what the runs claim and what their scatter shows. A parameter whose ESS is
below :data:`MIN_ESS` is *unsettled*: its 90 % interval is not to be trusted, and the verdict
says so in words, and says whether the runs *disagree* (their means scatter more than their
own counts allow in 99 % of sets of runs: a χ² test of R − 1 degrees of freedom) or are only
too few. Gelman & Rubin's potential scale reduction R̂ = √((N − 1)/N + B/W) is
reported beside it, for users who know that number.

Like the searches' verdict (:mod:`femupdate.runs.verdict`), this needs no truth: only runs
that started from independent seeds. With R = 4 the scatter B has 3 degrees of freedom, so a
run whose own estimate is 100 times too high is caught in 98 % of sets of runs; with one run
nothing can be checked, and the verdict says that.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

#: The effective samples below which a parameter's posterior is called unsettled: Vehtari et
#: al. (2021) ask for 400 before trusting quantiles and R̂ (100 for each of 4 chains).
MIN_ESS = 400.0
#: Runs disagree when their means scatter more than this share of sets of agreeing runs would.
DISAGREE_LEVEL = 0.99


@dataclass(frozen=True)
class Agreement:
    """What independent runs of the sampler say of their pooled samples.

    Attributes
    ----------
    runs : int
    ess : ndarray (n,)
        Effective samples of the pooled mean of each parameter: the smaller of the runs' own
        estimates summed and what their scatter shows (``runs`` · ``ess_across``).
    ess_within : ndarray (n,)
        The runs' own estimates, summed.
    ess_across : ndarray (n,)
        Effective samples per run measured across runs (inf when the runs' means agree
        exactly; NaN with one run).
    rhat : ndarray (n,)
        Gelman–Rubin R̂ (NaN with one run).
    unsettled : list of str
        The parameters whose ``ess`` is below :data:`MIN_ESS`.
    words : str
        The verdict in one sentence.
    """

    runs: int
    ess: np.ndarray
    ess_within: np.ndarray
    ess_across: np.ndarray
    rhat: np.ndarray
    unsettled: list[str]
    words: str


def runs_agreement(samples: Sequence[np.ndarray], ess_within: Sequence[np.ndarray],
                   names: Sequence[str], min_ess: float = MIN_ESS) -> Agreement:
    """The agreement of independent runs' equally weighted samples.

    Parameters
    ----------
    samples : sequence of ndarray (N_r, n)
        Each run's samples (in the coordinates the intervals are taken in: the search space).
    ess_within : sequence of ndarray (n,)
        Each run's own effective sample size per parameter.
    names : sequence of str
    min_ess : float
        Below it a parameter is unsettled.
    """
    runs = len(samples)
    within = np.sum(np.asarray(ess_within, dtype=float), axis=0)
    n = len(names)
    if runs < 2:
        across = np.full(n, np.nan)
        rhat = np.full(n, np.nan)
        ess = within
    else:
        means = np.array([s.mean(axis=0) for s in samples])
        w = np.mean([s.var(axis=0, ddof=1) for s in samples], axis=0)
        b = means.var(axis=0, ddof=1)
        size = min(s.shape[0] for s in samples)
        with np.errstate(divide="ignore", invalid="ignore"):
            across = np.where(b > 0, w / b, np.inf)
            rhat = np.sqrt((size - 1) / size + np.where(w > 0, b / w, 0.0))
        ess = np.minimum(within, runs * across)
    unsettled = [name for name, e in zip(names, ess, strict=True) if e < min_ess]
    return Agreement(runs, ess, within, across, rhat, unsettled,
                     agreement_words(runs, names, ess, within, across, unsettled, min_ess))


def agreement_words(runs: int, names: Sequence[str], ess: np.ndarray, within: np.ndarray,
                    across: np.ndarray, unsettled: list[str], min_ess: float) -> str:
    """The verdict in one sentence."""
    if runs < 2:
        head = "one run: whether independent runs agree was not checked (set [posterior] runs)"
        if unsettled:
            return f"{head}; too few effective samples (< {min_ess:.0f}) for {', '.join(unsettled)}"
        return head
    if not unsettled:
        return (f"the {runs} independent runs agree: every parameter has at least "
                f"{_count(float(np.min(ess)))} effective samples")
    parts = []
    disagree = runs_disagree(runs, within, across)
    for j, name in enumerate(names):
        if name not in unsettled:
            continue
        if disagree[j]:
            parts.append(f"{name} (the runs disagree: their means scatter as if each run held "
                         f"{_count(across[j])} independent samples, where each claims "
                         f"{_count(within[j] / runs)})")
        else:
            parts.append(f"{name} ({_count(ess[j])} effective samples)")
    return (f"UNSETTLED: the {runs} runs do not pin down {', '.join(parts)}; their pooled "
            f"90 % intervals are not to be trusted (raise [posterior] max_runs or samples, or "
            "see docs/posterior-usage.md)")


def runs_disagree(runs: int, within: np.ndarray, across: np.ndarray,
                  level: float = DISAGREE_LEVEL) -> np.ndarray:
    """Per parameter: do the runs' means scatter more than their own counts allow? If each
    run's mean were worth e = within / runs samples, (R − 1)·e·B/W would be χ² with R − 1
    degrees of freedom; the runs disagree where it exceeds that law's ``level`` quantile (a
    scatter that large by chance in 1 % of sets of runs, at the default)."""
    if runs < 2:
        return np.zeros(within.shape, dtype=bool)
    with np.errstate(divide="ignore"):
        statistic = (runs - 1) * (within / runs) / across
    return statistic > chi2.ppf(level, runs - 1)


def _count(value: float) -> str:
    return "∞" if not math.isfinite(value) else f"{value:,.0f}"

"""The final check of a surrogate-aided posterior (:mod:`femupdate.inference.surrogate`):
random draws of its samples run on the true model, and what reweighting them by
exp(true − surrogate log L) changes.

The true posterior is the surrogate's reweighted by those weights, so they say what matters:
how much they spread (their effective share; a constant error in log L changes nothing) and
how far they move each mean and sd, read as the 90 % intervals a user reads. The largest
error at a few points of little posterior mass (the tails) says little about either.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

#: The final check passes when the importance weights exp(true − surrogate log L) of its
#: samples keep at least this share of them effective (the degeneracy threshold of
#: sequential Monte Carlo, and the weights' spread TMCMC itself accepts between stages:
#: a coefficient of variation of 1) ...
MIN_CHECK_ESS = 0.5
#: ... and leave each 90 % interval of the surrogate's posterior holding between these
#: shares of the reweighted one (a Gaussian of the reweighted mean and sd), and the other
#: way round: off by at most half the interval's tail mass. A mean moved by 0.55 sd, or an
#: sd 14 % too wide or 16 % too narrow, alone reaches a bound.
COVERAGE_BAND = (0.85, 0.95)


def centred_error(predicted: np.ndarray, true: np.ndarray) -> float:
    """The 90th percentile of |e − median(e)|, e = predicted − true log L over finite pairs
    (inf when fewer than two)."""
    ok = np.isfinite(predicted) & np.isfinite(true)
    if ok.sum() < 2:
        return math.inf
    e = predicted[ok] - true[ok]
    return float(np.quantile(np.abs(e - np.median(e)), 0.9))


@dataclass(frozen=True)
class Check:
    """The final check: surrogate posterior samples run on the true model, and what
    reweighting them by exp(true − surrogate log L) changes.

    Attributes
    ----------
    runs : int
        Check samples run (failed ones included).
    ess : float
        The weights' effective sample size as a share of the samples with a finite true
        log L, (Σw)²/(k·Σw²) in (0, 1]: 1 when true and surrogate agree up to a constant.
    shifts : ndarray (n,)
        Each posterior mean moved by the reweighting, in the surrogate posterior's
        standard deviations (unit cube).
    sd_ratios : ndarray (n,)
        Each standard deviation over the check samples, reweighted over unweighted.
    coverage : ndarray (2, n)
        The share of the reweighted posterior (a Gaussian of the shifted mean and the
        ratio's sd) inside each 90 % interval of the surrogate's (:func:`coverage_of`), and
        of the surrogate's inside the reweighted one's (a shift cannot hide behind a
        narrower sd).
    error : float
        :func:`centred_error` of the surrogate's log L there (nats).
    passed : bool
        ``ess`` ≥ :data:`MIN_CHECK_ESS` and every ``coverage`` inside
        :data:`COVERAGE_BAND`.
    """

    runs: int
    ess: float
    shifts: np.ndarray
    sd_ratios: np.ndarray
    coverage: np.ndarray
    error: float
    passed: bool

    def words(self, names: Sequence[str]) -> str:
        """The check in one clause: the weights' effective share, the largest shift of a
        mean, the sd ratios and the 90 % intervals' coverage."""
        if not np.all(np.isfinite(self.coverage)):
            return (f"the final check at {self.runs} posterior samples has fewer than two "
                    "finite true log-likelihoods")
        j = int(np.argmax(np.abs(self.shifts)))
        low, high = COVERAGE_BAND
        return (f"importance weights of true against surrogate likelihood at {self.runs} "
                f"posterior samples: effective share {self.ess:.0%} (at least "
                f"{MIN_CHECK_ESS:.0%}), largest shift of a mean {self.shifts[j]:+.2f} sd "
                f"({names[j]}), sd ratios {self.sd_ratios.min():.2f}–"
                f"{self.sd_ratios.max():.2f}: the 90 % intervals of the two hold "
                f"{self.coverage.min():.0%}–{self.coverage.max():.0%} of each other "
                f"({low:.0%}–{high:.0%} needed)")


def coverage_of(shifts: np.ndarray, ratios: np.ndarray) -> np.ndarray:
    """The share of N(δ, r²) inside [−z, z], z the 95 % quantile of the standard normal: how
    much of a posterior whose mean is δ sds away and whose sd is r times as large a 90 %
    interval (mean ± z sd) holds."""
    from scipy.stats import norm

    z = norm.ppf(0.95)
    return norm.cdf((z - shifts) / ratios) - norm.cdf((-z - shifts) / ratios)


def importance_check(unit: np.ndarray, predicted: np.ndarray, true: np.ndarray,
                     sd: np.ndarray) -> Check:
    """The final check of surrogate posterior samples ``unit`` (k, n), drawn at random from
    it: ``predicted`` and ``true`` log L there (the surrogate's as TMCMC sampled it), ``sd``
    the surrogate posterior's standard deviations.

    The true posterior is the surrogate's reweighted by w ∝ exp(true − predicted), so the
    weights say what matters: their effective share (a constant error in log L changes
    nothing; an error that varies over the posterior spreads them) and how far they move
    each mean, in posterior sds (a mean moves by at most the weights' coefficient of
    variation in sds, by Cauchy–Schwarz, and by less when the error does not follow that
    parameter), and each sd. The reweighted and unweighted figures are of the same samples,
    so the sampling noise of drawing k of them mostly cancels. What a user reads is the
    90 % interval, so the rule is on its coverage of the reweighted posterior
    (:data:`COVERAGE_BAND`) besides the weights' effective share (:data:`MIN_CHECK_ESS`)."""
    ok = np.isfinite(predicted) & np.isfinite(true)
    k, n = ok.sum(), unit.shape[1]
    if k < 2:
        nan = np.full(n, np.nan)
        return Check(int(predicted.size), 0.0, nan, nan, np.full((2, n), np.nan), math.inf,
                     False)
    x, d = unit[ok], (true - predicted)[ok]
    w = np.exp(d - d.max())
    w /= w.sum()
    ess = float(1.0 / (k * np.sum(w ** 2)))
    mean, weighted = x.mean(axis=0), w @ x
    shifts = (weighted - mean) / np.maximum(sd, 1e-300)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratios = np.sqrt((w @ (x - weighted) ** 2) / ((x - mean) ** 2).mean(axis=0))
    coverage = np.array([coverage_of(shifts, ratios), coverage_of(-shifts / ratios, 1 / ratios)])
    low, high = COVERAGE_BAND
    passed = ess >= MIN_CHECK_ESS and bool(np.all((coverage >= low) & (coverage <= high)))
    return Check(int(predicted.size), ess, shifts, ratios, coverage,
                 centred_error(predicted, true), passed)

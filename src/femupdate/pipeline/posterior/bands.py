"""Predictive bands: what the posterior predicts of a trial, and how much of it the record
falls inside.

For each posterior sample s the model predicts y_s(t) of every channel (as φ compares it,
over the trial's scored samples). The prediction error is the error model's: Gaussian noise
of the channel's variance, σ_c² = NMSE_c · mean(y²), with NMSE_c the channel's error at the
best fit on the fitted trials (the same channel's, else the mean over the fitted channels),
so that a trial the model was not fitted to gets the noise level learnt from those it was.
The band's 5–95 % quantiles at each time are those of y_s(t) + ε_s(t) over the samples (one
draw of ε per sample and time, from the Generator passed in); ``coverage`` is the share of
the measured samples inside it (90 % if the model and its error model are right).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from femupdate.errors import FemupdateError
from femupdate.pipeline.results import Summary
from femupdate.pipeline.run import trial_fit
from femupdate.problem.update import TrialProblem, UpdateProblem


@dataclass(frozen=True)
class Bands:
    """The 5/50/95 % predictive quantiles (T, c) of one trial and its measured record."""

    trial: str
    role: str
    channels: tuple[str, ...]
    unit: str
    t: np.ndarray
    measured: np.ndarray
    q05: np.ndarray
    q50: np.ndarray
    q95: np.ndarray
    coverage: np.ndarray  # (c,)
    samples: int  # posterior samples that simulated


def noise_levels(summary: Summary) -> dict[str, float]:
    """Each channel's NMSE at the best fit on the fitted trials (mean over them), and
    ``"*"``: the mean over every fitted channel."""
    per: dict[str, list[float]] = {}
    for t in summary.trials:
        if t.role == "fit":
            for c, v in t.nmse_per_channel.items():
                per.setdefault(c, []).append(v)
    levels = {c: float(np.mean(v)) for c, v in per.items()}
    levels["*"] = float(np.mean([v for vs in per.values() for v in vs])) if per else 0.0
    return levels


def coverage_of(measured: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Share of each column of ``measured`` within [low, high]."""
    inside = (measured >= low) & (measured <= high)
    return inside.mean(axis=0)


def trial_bands(trial: TrialProblem, samples: np.ndarray, names: Sequence[str],
                levels: dict[str, float], rng: np.random.Generator,
                measured: np.ndarray | None = None) -> Bands | None:
    """The predictive bands of one trial over physical ``samples`` (k, n); None if no sample
    simulates."""
    predictions = []
    fit = None
    for row in np.atleast_2d(samples):
        values = dict(zip(names, row.tolist(), strict=True))
        try:
            fit = trial_fit(trial, values)
        except FemupdateError:
            continue  # a sample at which the model fails predicts nothing
        if np.all(np.isfinite(fit.predicted)):
            predictions.append(fit.predicted)
    if fit is None or not predictions:
        return None
    y = np.stack(predictions)  # (s, T, c)
    measured = fit.measured if measured is None else measured
    channels = tuple(fit.channels)
    nmse = np.array([levels.get(c, levels["*"]) for c in channels])
    sigma = np.sqrt(nmse * np.mean(np.median(y, axis=0) ** 2, axis=0))  # (c,)
    noisy = y + rng.standard_normal(y.shape) * sigma
    q05, q50, q95 = np.quantile(noisy, [0.05, 0.5, 0.95], axis=0)
    return Bands(trial.name, trial.experiment.role, channels, fit.unit, fit.t, measured, q05,
                 q50, q95, coverage_of(measured, q05, q95), len(predictions))


def predictive_bands(problem: UpdateProblem, samples: np.ndarray, summary: Summary,
                     rng: np.random.Generator,
                     trials: Sequence[TrialProblem] | None = None) -> list[Bands]:
    """The bands of every trial (fitted and validated) of ``problem``, or of ``trials``."""
    levels = noise_levels(summary)
    out = []
    for trial in (problem.trials if trials is None else trials):
        bands = trial_bands(trial, samples, problem.names, levels, rng)
        if bands is not None:
            out.append(bands)
    return out


def save_bands(path: Path, names: list[str], samples: np.ndarray, freqs: np.ndarray,
               bands: list[Bands]) -> Path:
    """``posterior.npz``: the samples (physical), the modes' frequencies over the thinned
    subset, and every trial's bands (``band{i}/…``)."""
    arrays: dict[str, np.ndarray] = {"names": np.array(names), "samples": samples,
                                     "mode_freqs": freqs, "band_count": np.array(len(bands))}
    for i, b in enumerate(bands):
        p = f"band{i}/"
        arrays.update({p + "trial": np.array(b.trial), p + "role": np.array(b.role),
                       p + "channels": np.array(b.channels), p + "unit": np.array(b.unit),
                       p + "t": b.t, p + "measured": b.measured, p + "q05": b.q05,
                       p + "q50": b.q50, p + "q95": b.q95, p + "coverage": b.coverage,
                       p + "samples": np.array(b.samples)})
    np.savez_compressed(path, **arrays)
    return path

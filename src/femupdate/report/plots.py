"""The report's figures beyond the paper's Figs. 2–5 (:mod:`femupdate.report.figures`): the
spread of the parameters over the runs, Fourier spectra and the correlation heat map. Each
returns a matplotlib ``Figure`` whose size does not grow without bound with the number of
parameters.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from femupdate.report.canvas import new_figure
from femupdate.report.figures import MAX_FIT_CHANNELS

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: Up to this many parameters the spread is drawn as box plots with a label each.
MAX_BOXES = 30
#: Above this many parameters the heat map shows no numbers in its cells.
MAX_ANNOTATED = 12
#: Above this many parameters only every k-th gets a tick label.
MAX_TICK_LABELS = 40


def _tick_labels(names: Sequence[str]) -> tuple[np.ndarray, list[str]]:
    """Positions (from 0) and labels of at most :data:`MAX_TICK_LABELS` ticks."""
    step = max(1, int(np.ceil(len(names) / MAX_TICK_LABELS)))
    idx = np.arange(0, len(names), step)
    return idx, [names[i] for i in idx]


def plot_spread(
    positions: np.ndarray,
    names: Sequence[str],
    *,
    success: np.ndarray | None = None,
    truth: np.ndarray | None = None,
) -> Figure:
    """The parameters of every run between their bounds: box plots over the successful runs.

    Above :data:`MAX_BOXES` parameters the boxes give way to the runs' dots and their median
    (one artist each), with every k-th parameter named.

    Parameters
    ----------
    positions : ndarray, shape (runs, n)
        Each run's parameters as positions in their search interval: 0 at the lower bound,
        1 at the upper (log scale for log parameters).
    success : ndarray of bool, shape (runs,), optional
        Boxes are drawn over the successful runs; the others are shown as crosses.
    truth : ndarray, shape (n,), optional
        Normalised true values, drawn as diamonds.
    """
    positions = np.atleast_2d(np.asarray(positions, dtype=float))
    ok = np.ones(positions.shape[0], bool) if success is None else np.asarray(success, bool)
    n = len(names)
    fig = new_figure(min(12.0, max(4.5, 0.45 * n + 2.0)), 4.2)
    ax = fig.add_subplot()
    slots = np.arange(1, n + 1)
    good, bad = positions[ok], positions[~ok]
    if good.shape[0] and n <= MAX_BOXES:
        ax.boxplot(good, positions=slots, widths=0.5, showfliers=False)
    elif good.shape[0]:
        ax.plot(slots, np.median(good, axis=0), "_", color="C1", ms=8, mew=1.5,
                label="median")
    if good.shape[0]:
        # Deterministic jitter: the runs of one parameter side by side, not on top.
        offsets = np.linspace(-0.12, 0.12, good.shape[0]) if good.shape[0] > 1 else np.zeros(1)
        ax.plot((slots[None, :] + offsets[:, None]).ravel(), good.ravel(), "o", ms=3.0,
                color="C0", alpha=0.7, label="successful runs")
    if bad.shape[0]:
        ax.plot(np.broadcast_to(slots + 0.25, bad.shape).ravel(), bad.ravel(), "x",
                color="C3", ms=4, label="unsuccessful runs")
    if truth is not None:
        ax.plot(slots, truth, "D", color="k", ms=4.5, mfc="none", label="truth")
    ax.legend(fontsize=7, loc="upper right")
    ax.axhspan(-0.05, 0.0, color="0.85", zorder=0)
    ax.axhspan(1.0, 1.05, color="0.85", zorder=0)
    ax.set_ylim(-0.05, 1.05)
    ax.set_xlim(0.3, n + 0.7)
    idx, labels = _tick_labels(names)
    ax.set_xticks(slots[idx], labels, rotation=45 if n > 6 else 0, fontsize=8)
    ax.set_ylabel("position between bounds [−]\n(0 lower, 1 upper)")
    ax.grid(True, axis="y", alpha=0.3)
    return fig


def plot_spectra(
    f: np.ndarray,
    measured: np.ndarray,
    predicted: np.ndarray,
    *,
    labels: Sequence[str],
    f_max: float | None = None,
    marks: Sequence[float] = (),
    truth_marks: Sequence[float] = (),
    title: str = "Fourier amplitude",
) -> Figure:
    """Fourier amplitude spectra of measured and predicted channels, one panel each.

    ``measured`` and ``predicted`` are (frequencies, channels), as
    :func:`femupdate.data.signal.fourier_amplitude` returns them; ``marks`` (the model's
    natural frequencies) are drawn as dotted vertical lines, ``truth_marks`` (the truth
    model's) as dashed ones. The first :data:`MAX_FIT_CHANNELS` channels are drawn.
    """
    from matplotlib.lines import Line2D

    measured = np.asarray(measured, dtype=float).reshape(len(f), -1)
    predicted = np.asarray(predicted, dtype=float).reshape(len(f), -1)
    k = min(measured.shape[1], MAX_FIT_CHANNELS)
    top = f_max if f_max is not None else float(f[-1])
    fig = new_figure(7.6, 2.3 * k + 0.9)
    axes = fig.subplots(k, 1, sharex=True, squeeze=False)[:, 0]
    for j, ax in enumerate(axes):
        ax.plot(f, measured[:, j], "k-", lw=0.9)
        ax.plot(f, predicted[:, j], "r--", lw=0.9)
        for mark in marks:
            if 0.0 < mark <= top:
                ax.axvline(mark, color="0.4", ls=":", lw=0.9)
        for mark in truth_marks:
            if 0.0 < mark <= top:
                ax.axvline(mark, color="C2", ls="--", lw=0.8)
        ax.set_ylabel(labels[j], fontsize=8)
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("frequency [Hz]")
    axes[-1].set_xlim(0.0, top)
    handles = [Line2D([], [], color="k", lw=0.9, label="measured"),
               Line2D([], [], color="r", ls="--", lw=0.9, label="predicted")]
    if len(marks):
        handles.append(Line2D([], [], color="0.4", ls=":", lw=0.9,
                              label="natural frequencies,\nbest model"))
    if len(truth_marks):
        handles.append(Line2D([], [], color="C2", ls="--", lw=0.8,
                              label="natural frequencies,\ntruth"))
    fig.legend(handles=handles, loc="outside right center", fontsize=7)
    more = f" (first {k} of {measured.shape[1]} channels)" if measured.shape[1] > k else ""
    fig.suptitle(title + more, fontsize=9)
    return fig


def plot_correlation(correlations: np.ndarray, names: Sequence[str]) -> Figure:
    """Heat map of the correlation matrix of the parameter estimates (−1 blue, +1 red)."""
    corr = np.asarray(correlations, dtype=float)
    # Rounding can put a correlation a hair outside [−1, 1]; a non-finite one is left blank.
    corr = np.where(np.isfinite(corr), np.clip(corr, -1.0, 1.0), np.nan)
    n = len(names)
    size = min(10.0, max(3.6, 0.55 * n + 2.0))
    fig = new_figure(size + 0.8, size)
    ax = fig.add_subplot()
    from matplotlib import colormaps

    cmap = colormaps["RdBu_r"].with_extremes(bad="0.8")
    image = ax.imshow(corr, cmap=cmap, vmin=-1.0, vmax=1.0, interpolation="nearest")
    idx, labels = _tick_labels(names)
    ax.set_xticks(idx, labels, rotation=45 if n > 4 else 0, fontsize=8 if n <= 20 else 6)
    ax.set_yticks(idx, labels, fontsize=8 if n <= 20 else 6)
    if n <= MAX_ANNOTATED:
        for i in range(n):
            for j in range(n):
                value = corr[i, j]
                ax.text(j, i, f"{value:.2f}", ha="center", va="center", fontsize=7,
                        color="w" if abs(value) > 0.6 else "k")
    fig.colorbar(image, ax=ax, shrink=0.8, label="correlation [−]")
    ax.set_title("correlation of the parameter estimates", fontsize=9)
    return fig


def plot_trial_nmse(trials: dict[str, dict[str, float]]) -> Figure:
    """NMSE (%) of every channel in each validation trial, bars grouped by trial (log)."""
    names = list(trials)
    channels = sorted({c for values in trials.values() for c in values})
    fig = new_figure(min(12.0, max(5.0, 0.6 * len(names) * max(1, len(channels)) + 2.0)), 3.8)
    ax = fig.add_subplot()
    width = 0.8 / max(1, len(channels))
    for c, channel in enumerate(channels):
        values = [trials[t].get(channel, np.nan) for t in names]
        ax.bar(np.arange(len(names)) + (c - (len(channels) - 1) / 2) * width, values, width,
               label=channel)
    ax.set_yscale("log")
    ax.set_xticks(np.arange(len(names)), names, fontsize=8)
    ax.set_ylabel("NMSE [%]")
    ax.set_title("validation: the best model on each trial", fontsize=9)
    if len(channels) <= MAX_ANNOTATED:
        ax.legend(fontsize=7, ncol=2)
    ax.grid(True, axis="y", which="both", alpha=0.3)
    return fig

"""The posterior's figures: the corner plot, predictive bands and frequency posteriors."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.ticker import MaxNLocator

from femupdate.report.canvas import new_figure
from femupdate.report.figures import MAX_FIT_CHANNELS

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: A corner plot of more parameters than this shows the first ones only (its panels grow as
#: the square of their number).
MAX_CORNER = 14


def plot_corner(samples: np.ndarray, names: Sequence[str],
                truth: Sequence[float] | None = None) -> Figure:
    """Marginals and pairs of the posterior samples (as ``corner`` draws them), with the
    truth's lines where known and the 5/50/95 % quantiles over each marginal."""
    from matplotlib.figure import Figure

    from femupdate._optional import require

    corner = require("corner", "posterior")

    n = min(len(names), MAX_CORNER)
    size = min(14.0, max(4.0, 1.6 * n))
    fig = Figure(figsize=(size, size))  # no layout engine: corner places its panels itself
    data = np.asarray(samples, dtype=float)[:, :n]
    # A column without spread (a parameter the data pin to rounding) has no histogram range.
    ranges = [(lo, hi) if hi > lo else (lo - 0.5 * abs(lo) - 1e-12, hi + 0.5 * abs(hi) + 1e-12)
              for lo, hi in zip(data.min(axis=0), data.max(axis=0), strict=True)]
    corner.corner(data, labels=list(names[:n]), fig=fig, range=ranges,
                  quantiles=[0.05, 0.5, 0.95], truths=None if truth is None else
                  list(truth[:n]), truth_color="#1b5e20", plot_datapoints=n <= 6,
                  label_kwargs={"fontsize": 8}, max_n_ticks=3)
    for ax in fig.axes:
        ax.tick_params(labelsize=6)
    return fig


def plot_bands(t: np.ndarray, measured: np.ndarray, bands: np.ndarray,
               channels: Sequence[str], unit: str, coverage: Sequence[float],
               title: str) -> Figure:
    """The measured record inside the 5–95 % predictive band (and the median prediction),
    one panel per channel (the first :data:`MAX_FIT_CHANNELS`)."""
    k = min(len(channels), MAX_FIT_CHANNELS)
    fig = new_figure(9.0, 2.2 * k + 0.6)
    axes = fig.subplots(k, 1, sharex=True, squeeze=False)[:, 0]
    for j, ax in enumerate(axes):
        ax.fill_between(t, bands[0][:, j], bands[2][:, j], color="#90caf9", lw=0,
                        label="5–95 % predictive band")
        ax.plot(t, bands[1][:, j], color="#0d47a1", lw=0.6, label="median prediction")
        ax.plot(t, measured[:, j], color="k", lw=0.5, label="measured")
        ax.set_ylabel(f"{channels[j]} [{unit}]", fontsize=8)
        ax.set_title(f"{channels[j]}: the band covers {100 * coverage[j]:.1f} % of the "
                     "measured samples", fontsize=8)
    axes[0].legend(fontsize=7, loc="upper right")
    axes[-1].set_xlabel("t [s]")
    fig.suptitle(title, fontsize=9)
    return fig


def plot_frequency_posteriors(freqs: np.ndarray, truth_hz: Sequence[float] | None = None
                              ) -> Figure:
    """Histograms of the natural frequencies over the posterior samples (truth as a line)."""
    freqs = np.atleast_2d(np.asarray(freqs, dtype=float))
    q = freqs.shape[1]
    fig = new_figure(min(12.0, 2.6 * q + 0.5), 2.6)
    axes = fig.subplots(1, q, squeeze=False)[0]
    for i, ax in enumerate(axes):
        col = freqs[:, i][np.isfinite(freqs[:, i])]
        if col.size:
            ax.hist(col, bins=30, color="#64b5f6")
        if truth_hz is not None and i < len(truth_hz):
            ax.axvline(truth_hz[i], color="#1b5e20", lw=1.2, label="truth")
        ax.set_xlabel(f"f{i + 1} [Hz]", fontsize=8)
        ax.tick_params(labelsize=7)
        # a narrow posterior (22.020 … 22.035 Hz) wants few ticks, else their labels run
        # into each other
        ax.xaxis.set_major_locator(MaxNLocator(nbins=3))
        ax.set_yticks([])
    fig.suptitle("natural frequencies over the posterior samples", fontsize=9)
    return fig

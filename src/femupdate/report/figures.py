"""The paper's figures, one function each, for the demo, ``femupdate validate`` and the report:

- :func:`plot_phi`: φ_m (best so far) against evaluations (Fig. 2);
- :func:`plot_beta`: the Beta parameters a, b and the step size σ against step (Fig. 3);
- :func:`plot_parameters`: the best-so-far parameters against evaluations (Fig. 4);
- :func:`plot_fit`: measured against predicted, with the residual under it (Fig. 5, and
  Figs. 13, 18, 19 of the bridge).

Each returns a matplotlib ``Figure`` (see :mod:`femupdate.report.canvas` to save it or embed it).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from femupdate.report.canvas import lines, new_figure, save_png  # noqa: F401  (cli's validate)
from femupdate.report.facts import bound_positions

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.gridspec import SubplotSpec

#: Above this many runs the φ plot shows no legend (it would hide the lines).
MAX_LEGEND_RUNS = 12
#: Above this many parameters a legend or a panel per parameter is not readable: the
#: parameters are drawn together (normalised to their bounds), without a legend.
MAX_PARAMETER_PANELS = 12
#: Channels drawn by :func:`plot_fit` (and the spectra): the first ones, in the case's order.
MAX_FIT_CHANNELS = 6
#: A record longer than this many samples also gets a detail window around its peak.
MAX_READABLE_SAMPLES = 1000
#: The detail window: at most this long (s) and this many samples.
DETAIL_SECONDS = 2.5
DETAIL_SAMPLES = 500


def best_so_far(fun: np.ndarray) -> np.ndarray:
    """Running minimum of φ over the evaluations (failed evaluations count as +inf)."""
    f = np.where(np.isfinite(fun), fun, np.inf)
    return np.minimum.accumulate(f)


def best_x_so_far(x: np.ndarray, fun: np.ndarray) -> np.ndarray:
    """The x of the running minimum of φ, per evaluation."""
    f = np.where(np.isfinite(fun), fun, np.inf)
    idx = np.arange(f.size)
    improving = np.r_[True, f[1:] < np.minimum.accumulate(f)[:-1]]
    last = np.maximum.accumulate(np.where(improving, idx, 0))
    return x[last]


def detail_window(t: np.ndarray, y: np.ndarray) -> tuple[float, float] | None:
    """The stretch of a long record drawn on its own: around its peak response.

    Parameters
    ----------
    t : ndarray, shape (m,)
        Times, s, evenly spaced.
    y : ndarray, shape (m, k)
        The channels; the peak is that of the sum of each channel's |y| over its maximum.

    Returns
    -------
    (float, float) or None
        Start and end, s: at most :data:`DETAIL_SECONDS` and :data:`DETAIL_SAMPLES` long and
        inside the record; None when the record has at most :data:`MAX_READABLE_SAMPLES`
        samples (one panel shows it).
    """
    t = np.asarray(t, dtype=float)
    if t.size <= MAX_READABLE_SAMPLES:
        return None
    y = np.abs(np.asarray(y, dtype=float).reshape(t.size, -1))
    peak = np.max(y, axis=0)
    weight = np.sum(y / np.where(peak > 0, peak, 1.0), axis=1)
    dt = float(t[1] - t[0])
    width = min(DETAIL_SECONDS, DETAIL_SAMPLES * dt)
    start = float(t[int(np.argmax(weight))]) - 0.4 * width
    start = min(max(start, float(t[0])), float(t[-1]) - width)
    return start, start + width


def plot_phi(histories: Sequence[np.ndarray], *, labels: Sequence[str] | None = None,
             highlight: int | None = None, title: str = "") -> Figure:
    """φ_m (best so far) of each run against evaluations, log scale (the paper's Fig. 2).

    Parameters
    ----------
    histories : sequence of ndarray
        φ of every evaluation of each run (non-finite values are failed evaluations).
    labels : sequence of str, optional
        One per run, for the legend (shown up to :data:`MAX_LEGEND_RUNS` runs).
    highlight : int or None
        Position in ``histories`` of the run drawn thick and black (the best).
    title : str
        Says which runs are shown.
    """
    fig = new_figure(6.8, 4.0)
    ax = fig.add_subplot()
    for i, fun in enumerate(histories):
        f = best_so_far(np.asarray(fun, dtype=float))
        # A log axis cannot show φ = 0 (an exact fit): those points are left out.
        f = np.where(f > 0, f, np.nan)
        style = {"color": "k", "lw": 1.8, "zorder": 3} if i == highlight else {"lw": 0.9}
        ax.plot(np.arange(1, f.size + 1), f, label=labels[i] if labels else None, **style)
    ax.set_yscale("log")
    ax.set_xlabel("evaluations")
    ax.set_ylabel("φ_m, best so far [−]")
    ax.set_title(title or "error function, best so far", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    if labels and len(histories) <= MAX_LEGEND_RUNS:
        ax.legend(fontsize=7, ncol=2)
    return fig


def plot_beta(history: dict[str, np.ndarray], names: Sequence[str], *, title: str = ""
              ) -> Figure:
    """The Beta parameters a and b of every parameter and the step size σ against step (Fig. 3).

    ``history`` holds ``a`` and ``b`` (steps × parameters) and, optionally, ``sigma``
    (steps,), as traced by the IB and AB searches. All are dimensionless: they live on the
    unit cube the search sees.
    """
    a = np.asarray(history["a"], dtype=float)
    has_sigma = "sigma" in history and np.size(history["sigma"]) > 0
    fig = new_figure(12.0 if has_sigma else 9.0, 4.0)
    axes = fig.subplots(1, 3 if has_sigma else 2)
    steps = np.arange(1, a.shape[0] + 1)
    labelled = len(names) <= MAX_PARAMETER_PANELS
    for key, ax in zip(("a", "b"), axes[:2], strict=True):
        ax.set_yscale("log")
        lines(ax, steps, np.asarray(history[key], dtype=float),
              labels=list(names) if labelled else None, lw=0.9)
        ax.set_ylabel(f"{key} [−]")
        ax.set_title(f"Beta parameter {key}, every parameter", fontsize=10)
    if has_sigma:
        sigma = np.asarray(history["sigma"], dtype=float)
        axes[2].semilogy(np.arange(1, sigma.size + 1), sigma, "k-", lw=0.9)
        axes[2].set_ylabel("σ [−] (unit cube)")
        axes[2].set_title("step size σ", fontsize=10)
    for ax in axes:
        ax.set_xlabel("step")
        ax.grid(True, which="both", alpha=0.3)
    if labelled:
        axes[1].legend(fontsize=7, ncol=2)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def plot_parameters(
    x: np.ndarray,
    fun: np.ndarray,
    names: Sequence[str],
    *,
    units: Sequence[str] | None = None,
    truth: Sequence[float] | None = None,
    bounds: Sequence[tuple[float, float]] | None = None,
    log: Sequence[bool] | None = None,
    title: str = "",
) -> Figure:
    """The parameters of the best-so-far solution against evaluations (Fig. 4).

    Up to :data:`MAX_PARAMETER_PANELS` parameters: a panel each, in physical units, the truth
    dashed. More: one panel of their positions between their bounds (0 lower, 1 upper; without
    ``bounds``, between the least and largest value drawn), the truth as ticks at the right
    edge. A panel per parameter is unreadable and slow (55 s for 200 parameters).

    Parameters
    ----------
    x : ndarray, shape (evaluations, n)
        Physical values of every evaluated point.
    fun : ndarray, shape (evaluations,)
        φ of every evaluation.
    units : sequence of str, optional
        Unit of each parameter ("" or "−" for none).
    truth : sequence of float, optional
        The true values (a virtual experiment).
    bounds, log : optional
        Physical bounds and log scale of each parameter, for the normalised panel.
    """
    best = best_x_so_far(np.asarray(x, dtype=float), np.asarray(fun, dtype=float))
    evals = np.arange(1, best.shape[0] + 1)
    n = len(names)
    if n > MAX_PARAMETER_PANELS:
        if bounds is None:
            lo, hi = best.min(axis=0), best.max(axis=0)
            bounds = list(zip(lo, np.where(hi > lo, hi, lo + 1.0), strict=True))
            log = None
        return _parameters_together(evals, best, names, bounds, log, truth, title)
    from matplotlib.lines import Line2D

    ncols = min(4, n)
    nrows = int(np.ceil(n / ncols))
    fig = new_figure(2.7 * ncols + 0.4, 2.2 * nrows + 0.9)
    axes = fig.subplots(nrows, ncols, squeeze=False)
    for j, name in enumerate(names):
        ax = axes.flat[j]
        ax.plot(evals, best[:, j], "C0-", lw=0.9)
        if truth is not None:
            ax.axhline(truth[j], color="k", ls="--", lw=0.8)
        unit = units[j] if units is not None and units[j] else "−"
        ax.set_ylabel(f"{name} [{unit}]", fontsize=8)
        ax.set_xscale("log")
        ax.tick_params(labelsize=7)
        ax.grid(True, which="both", alpha=0.3)
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    fig.supxlabel("evaluations", fontsize=9)
    handles = [Line2D([], [], color="C0", lw=0.9, label="best so far")]
    if truth is not None:
        handles.append(Line2D([], [], color="k", ls="--", lw=0.8, label="truth"))
    fig.legend(handles=handles, loc="outside right center", fontsize=8)
    fig.suptitle(title or "parameters of the best-so-far solution", fontsize=10)
    return fig


def _parameters_together(evals: np.ndarray, best: np.ndarray, names: Sequence[str],
                         bounds: Sequence[tuple[float, float]], log: Sequence[bool] | None,
                         truth: Sequence[float] | None, title: str) -> Figure:
    lower, upper = (np.array(b, dtype=float) for b in zip(*bounds, strict=True))
    scale = np.zeros(len(names), bool) if log is None else np.asarray(log, bool)
    fig = new_figure(9.0, 4.6)
    ax = fig.add_subplot()
    ax.set_xscale("log")
    lines(ax, evals, bound_positions(best, lower, upper, scale), lw=0.7)
    if truth is not None:
        ax.plot(np.full(len(names), evals[-1]), bound_positions(np.asarray(truth), lower, upper,
                                                                scale),
                "k_", ms=10, mew=1.2, label="truth (at the right edge)", clip_on=False)
        ax.legend(fontsize=8, loc="upper left")
    ax.set_ylim(-0.05, 1.05)
    ax.set_xlabel("evaluations")
    ax.set_ylabel("position between bounds [−] (0 lower, 1 upper)")
    ax.grid(True, which="both", alpha=0.3)
    ax.set_title((title or "parameters of the best-so-far solution")
                 + f": all {len(names)}, one line each", fontsize=10)
    return fig


def plot_fit(
    t: np.ndarray,
    measured: np.ndarray,
    predicted: np.ndarray,
    *,
    channels: Sequence[str],
    unit: str,
    nmse_percent: Sequence[float] | None = None,
    title: str = "",
) -> Figure:
    """Measured against predicted time histories with the residual (measured − predicted)
    under each channel (Fig. 5).

    A long record (over :data:`MAX_READABLE_SAMPLES` samples) gets a second column: the
    :func:`detail_window` around the peak response, shaded in the whole record. The first
    :data:`MAX_FIT_CHANNELS` channels are drawn; the title says when there are more.

    Parameters
    ----------
    t : ndarray, shape (m,)
        Times, s.
    measured, predicted : ndarray, shape (m,) or (m, k)
    channels : sequence of str
        Name of each channel.
    unit : str
        Unit of the values ("−" for none).
    nmse_percent : sequence of float, optional
        NMSE of each channel, %, shown in its title.
    """
    from matplotlib.lines import Line2D

    t = np.asarray(t, dtype=float)
    measured = np.asarray(measured, dtype=float).reshape(t.size, -1)
    predicted = np.asarray(predicted, dtype=float).reshape(t.size, -1)
    k = min(measured.shape[1], MAX_FIT_CHANNELS)
    window = detail_window(t, measured[:, :k])
    fig = new_figure(11.0 if window else 7.6, 3.1 * k + 0.8)
    grid = fig.add_gridspec(2 * k, 2 if window else 1, height_ratios=[3.0, 1.3] * k,
                            width_ratios=[2.0, 1.0] if window else [1.0])
    for j in range(k):
        name = channels[j] + (f" (NMSE {nmse_percent[j]:.3g} %)" if nmse_percent else "")
        top, bottom = _channel_panels(fig, grid[2 * j, 0], grid[2 * j + 1, 0], t,
                                      measured[:, j], predicted[:, j], channels[j], unit)
        top.set_title(name, fontsize=9, loc="left")
        top.set_xlim(t[0], t[-1])
        if window:
            for ax in (top, bottom):
                ax.axvspan(*window, color="0.9", zorder=0)
            detail = _channel_panels(fig, grid[2 * j, 1], grid[2 * j + 1, 1], t,
                                     measured[:, j], predicted[:, j], channels[j], unit)
            detail[0].set_title(f"detail {window[0]:.3g}–{window[1]:.3g} s", fontsize=9,
                                loc="left")
            detail[0].set_xlim(*window)
            _autoscale_y(detail[0], t, window, measured[:, j], predicted[:, j])
            _autoscale_y(detail[1], t, window, measured[:, j] - predicted[:, j])
            bottoms = (bottom, detail[1])
        else:
            bottoms = (bottom,)
    for ax in bottoms:  # those of the last channel
        ax.set_xlabel("time [s]")
    handles = [Line2D([], [], color="k", lw=0.9, label="measured"),
               Line2D([], [], color="r", ls="--", lw=0.9, label="predicted"),
               Line2D([], [], color="C0", lw=0.8, label="residual =\nmeasured − predicted")]
    fig.legend(handles=handles, loc="outside right center", fontsize=8)
    more = (f" (first {k} of {measured.shape[1]} channels)" if measured.shape[1] > k else "")
    fig.suptitle((title or "measured against predicted") + more, fontsize=10)
    return fig


def _channel_panels(fig: Figure, upper: SubplotSpec, lower: SubplotSpec, t: np.ndarray,
                    measured: np.ndarray, predicted: np.ndarray, channel: str, unit: str
                    ) -> tuple[Axes, Axes]:
    """Measured and predicted in ``upper``, their difference in ``lower`` (x shared)."""
    top = fig.add_subplot(upper)
    bottom = fig.add_subplot(lower, sharex=top)
    top.plot(t, measured, "k-", lw=0.9)
    top.plot(t, predicted, "r--", lw=0.9)
    bottom.plot(t, measured - predicted, color="C0", lw=0.8)
    top.set_ylabel(f"{channel} [{unit}]", fontsize=8)
    bottom.set_ylabel(f"residual [{unit}]", fontsize=8)
    top.tick_params(labelbottom=False, labelsize=7)
    bottom.tick_params(labelsize=7)
    for ax in (top, bottom):
        ax.grid(True, alpha=0.3)
    return top, bottom


def _autoscale_y(ax: Axes, t: np.ndarray, window: tuple[float, float], *ys: np.ndarray) -> None:
    """Fit the y limits to the data inside the window (matplotlib scales to the whole)."""
    inside = (t >= window[0]) & (t <= window[1])
    values = np.concatenate([np.asarray(y)[inside] for y in ys])
    values = values[np.isfinite(values)]
    if values.size:
        lo, hi = float(values.min()), float(values.max())
        pad = 0.05 * (hi - lo) if hi > lo else max(abs(hi), 1e-300)
        ax.set_ylim(lo - pad, hi + pad)

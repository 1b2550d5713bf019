"""The report's figures (PNG) beyond those of one run: every run's φ, the Beta trace, the spread
of the parameters, Fourier spectra and the correlation heat map. Matplotlib only in here and in
``figures``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from femupdate.report.figures import _pyplot, _save, best_so_far

#: Above this many runs the φ plot shows no legend (it would hide the lines).
MAX_LEGEND_RUNS = 12
#: Above this many parameters the heat map shows no numbers in its cells.
MAX_ANNOTATED = 12


def plot_phi_runs(
    histories: Sequence[np.ndarray],
    labels: Sequence[str],
    path: Path,
    *,
    highlight: int | None = None,
    title: str = "",
) -> Path:
    """φ_m (best so far) of every run against evaluations, log scale (the paper's Fig. 2).

    Parameters
    ----------
    histories : sequence of ndarray
        φ of every evaluation of each run (non-finite values are failed evaluations).
    labels : sequence of str
        One per run, for the legend.
    highlight : int or None
        Position in ``histories`` of the run drawn thick and black (the best).
    """
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.8, 4.0))
    for i, (fun, label) in enumerate(zip(histories, labels, strict=True)):
        f = best_so_far(np.asarray(fun, dtype=float))
        # A log axis cannot show φ = 0 (an exact fit): those points are left out.
        f = np.where(f > 0, f, np.nan)
        style = {"color": "k", "lw": 1.8, "zorder": 3} if i == highlight else {"lw": 0.9}
        ax.semilogy(np.arange(1, f.size + 1), f, label=label, **style)
    ax.set_xlabel("evaluation")
    ax.set_ylabel("φ_m")
    ax.set_title(title or "error function, best so far")
    ax.grid(True, which="both", alpha=0.3)
    if len(histories) <= MAX_LEGEND_RUNS:
        ax.legend(fontsize=7, ncol=2)
    return _save(fig, path)


def plot_beta_trace(history: dict[str, np.ndarray], names: Sequence[str], path: Path) -> Path:
    """Beta parameters a and b of every parameter and the step size σ against step (Fig. 3).

    ``history`` holds ``a`` and ``b`` (steps × parameters) and ``sigma`` (steps,) as traced by
    the IB and AB optimizers.
    """
    plt = _pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(12.0, 3.8))
    a = np.asarray(history["a"], dtype=float)
    steps = np.arange(1, a.shape[0] + 1)
    for key, ax in zip(("a", "b"), axes[:2], strict=True):
        values = np.asarray(history[key], dtype=float)
        for j, name in enumerate(names):
            ax.semilogy(steps, values[:, j], lw=0.9, label=name)
        ax.set_title(key)
    sigma = np.asarray(history["sigma"], dtype=float)
    axes[2].semilogy(np.arange(1, sigma.size + 1), sigma, "k-", lw=0.9)
    axes[2].set_title("σ")
    for ax in axes:
        ax.set_xlabel("step")
        ax.grid(True, which="both", alpha=0.3)
    axes[1].legend(fontsize=7, ncol=2)
    return _save(fig, path)


def plot_spread(
    positions: np.ndarray,
    names: Sequence[str],
    path: Path,
    *,
    success: np.ndarray | None = None,
    truth: np.ndarray | None = None,
) -> Path:
    """Box plots of the parameters over the successful runs, normalised to their bounds.

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
    plt = _pyplot()
    positions = np.atleast_2d(np.asarray(positions, dtype=float))
    ok = np.ones(positions.shape[0], bool) if success is None else np.asarray(success, bool)
    n = len(names)
    fig, ax = plt.subplots(figsize=(max(4.0, 0.9 * n + 1.5), 4.0))
    slots = np.arange(1, n + 1)
    good = positions[ok]
    if good.shape[0]:
        ax.boxplot(good, positions=slots, widths=0.5, showfliers=False)
        # Deterministic jitter: the runs of one parameter side by side, not on top.
        offsets = np.linspace(-0.12, 0.12, good.shape[0]) if good.shape[0] > 1 else np.zeros(1)
        for j in range(n):
            ax.plot(slots[j] + offsets, good[:, j], "o", ms=3.5, color="C0", alpha=0.7)
    bad = positions[~ok]
    for j in range(n):
        if bad.shape[0]:
            ax.plot(np.full(bad.shape[0], slots[j] + 0.25), bad[:, j], "x", color="C3", ms=5)
    if truth is not None:
        ax.plot(slots, truth, "D", color="k", ms=5, mfc="none", label="truth")
        ax.legend(fontsize=7, loc="upper right")
    ax.axhspan(-0.05, 0.0, color="0.85", zorder=0)
    ax.axhspan(1.0, 1.05, color="0.85", zorder=0)
    ax.set_ylim(-0.05, 1.05)
    ax.set_xticks(slots, list(names), rotation=45 if n > 6 else 0, fontsize=8)
    ax.set_ylabel("position between bounds (0 = lower, 1 = upper)")
    ax.grid(True, axis="y", alpha=0.3)
    return _save(fig, path)


def plot_spectra(
    f: np.ndarray,
    measured: np.ndarray,
    predicted: np.ndarray,
    path: Path,
    *,
    labels: Sequence[str],
    f_max: float | None = None,
    marks: Sequence[float] = (),
    ylabel: str = "Fourier amplitude",
) -> Path:
    """Fourier amplitude spectra of measured and predicted channels, one panel each.

    ``measured`` and ``predicted`` are (frequencies, channels), as
    :func:`femupdate.data.signal.fourier_amplitude` returns them; ``marks`` are frequencies
    (e.g. the model's natural frequencies) drawn as dotted vertical lines.
    """
    plt = _pyplot()
    measured = np.asarray(measured, dtype=float).reshape(len(f), -1)
    predicted = np.asarray(predicted, dtype=float).reshape(len(f), -1)
    k = measured.shape[1]
    top = f_max if f_max is not None else float(f[-1])
    fig, axes = plt.subplots(k, 1, figsize=(7.2, 2.4 * k + 0.6), sharex=True, squeeze=False)
    for j in range(k):
        ax = axes[j, 0]
        ax.plot(f, measured[:, j], "k-", lw=1.0, label="measured")
        ax.plot(f, predicted[:, j], "r--", lw=0.9, label="predicted")
        for mark in marks:
            if 0.0 < mark <= top:
                ax.axvline(mark, color="0.4", ls=":", lw=0.8)
        ax.set_ylabel(labels[j], fontsize=8)
        ax.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    axes[-1, 0].set_xlabel("frequency [Hz]")
    axes[-1, 0].set_xlim(0.0, top)
    fig.suptitle(ylabel, fontsize=9)
    return _save(fig, path)


def plot_correlation(correlations: np.ndarray, names: Sequence[str], path: Path) -> Path:
    """Heat map of the correlation matrix of the parameter estimates (−1 blue, +1 red)."""
    plt = _pyplot()
    corr = np.asarray(correlations, dtype=float)
    n = len(names)
    size = max(3.6, 0.55 * n + 2.0)
    fig, ax = plt.subplots(figsize=(size + 0.8, size))
    image = ax.imshow(corr, cmap="RdBu_r", vmin=-1.0, vmax=1.0)
    ax.set_xticks(range(n), list(names), rotation=45 if n > 4 else 0, fontsize=8)
    ax.set_yticks(range(n), list(names), fontsize=8)
    if n <= MAX_ANNOTATED:
        for i in range(n):
            for j in range(n):
                value = corr[i, j]
                ax.text(j, i, f"{value:.2f}", ha="center", va="center", fontsize=7,
                        color="w" if abs(value) > 0.6 else "k")
    fig.colorbar(image, ax=ax, shrink=0.8, label="correlation")
    ax.set_title("correlation of the parameter estimates", fontsize=9)
    return _save(fig, path)

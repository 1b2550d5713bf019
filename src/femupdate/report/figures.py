"""Figures (PNG) of one optimisation run and of its fit; matplotlib is imported only here."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from femupdate.workflow import UpdateResult


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


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


def _save(fig, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    _pyplot().close(fig)
    return path


def plot_phi(histories: Sequence[dict[str, np.ndarray]], path: Path, *, title: str = "") -> Path:
    """φ_m (best so far) against evaluations, log scale, one line per run (Fig. 2)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for hist in histories:
        f = best_so_far(np.asarray(hist["fun"]))
        ax.semilogy(np.arange(1, f.size + 1), f, lw=0.9)
    ax.set_xlabel("evaluation")
    ax.set_ylabel("φ_m")
    ax.set_title(title or "error function, best so far")
    ax.grid(True, which="both", alpha=0.3)
    return _save(fig, path)


def plot_beta(history: dict[str, np.ndarray], names: Sequence[str], path: Path) -> Path:
    """Beta parameters a and b of each parameter against step, log scale (Fig. 3)."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(9.6, 4.0), sharey=True)
    steps = np.arange(1, np.asarray(history["a"]).shape[0] + 1)
    for key, ax in zip(("a", "b"), axes, strict=True):
        values = np.asarray(history[key])
        for j, name in enumerate(names):
            ax.semilogy(steps, values[:, j], lw=0.9, label=name)
        ax.set_xlabel("step")
        ax.set_title(key)
        ax.grid(True, which="both", alpha=0.3)
    axes[1].legend(fontsize=7, ncol=2)
    return _save(fig, path)


def plot_parameters(
    history: dict[str, np.ndarray],
    names: Sequence[str],
    path: Path,
    *,
    truth: Sequence[float] | None = None,
) -> Path:
    """Each parameter of the best-so-far solution against evaluations (Fig. 4)."""
    plt = _pyplot()
    x = best_x_so_far(np.asarray(history["x"]), np.asarray(history["fun"]))
    ncols = 4 if len(names) > 4 else len(names)
    nrows = int(np.ceil(len(names) / ncols))
    fig, axes = plt.subplots(nrows, ncols, figsize=(2.6 * ncols, 2.2 * nrows), squeeze=False)
    evals = np.arange(1, x.shape[0] + 1)
    for j, name in enumerate(names):
        ax = axes.flat[j]
        ax.plot(evals, x[:, j], lw=0.9)
        if truth is not None:
            ax.axhline(truth[j], color="k", ls="--", lw=0.8)
        ax.set_title(name, fontsize=9)
        ax.set_xscale("log")
        ax.tick_params(labelsize=7)
    for ax in list(axes.flat)[len(names):]:
        ax.set_visible(False)
    fig.supxlabel("evaluation")
    return _save(fig, path)


def plot_fit(
    t: np.ndarray,
    measured: np.ndarray,
    predicted: np.ndarray,
    path: Path,
    *,
    labels: Sequence[str] | None = None,
    ylabel: str = "response",
) -> Path:
    """Measured (target) against predicted time histories, one panel per channel (Fig. 5)."""
    plt = _pyplot()
    measured = np.atleast_2d(np.asarray(measured).T).T
    predicted = np.atleast_2d(np.asarray(predicted).T).T
    n = measured.shape[1]
    fig, axes = plt.subplots(n, 1, figsize=(7.2, 2.4 * n + 0.6), sharex=True, squeeze=False)
    for j in range(n):
        ax = axes[j, 0]
        ax.plot(t, measured[:, j], "k-", lw=1.0, label="measured")
        ax.plot(t, predicted[:, j], "r--", lw=0.9, label="predicted")
        ax.set_ylabel(labels[j] if labels else ylabel, fontsize=8)
        ax.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    axes[-1, 0].set_xlabel("time [s]")
    return _save(fig, path)


def write_run_plots(result: UpdateResult, out_dir: Path) -> list[Path]:
    """The plots ``femupdate run`` writes: each channel's fit (``fit.png``), φ against
    evaluations of every run (``phi.png``) and the best run's parameters (``parameters.png``).

    ``result`` is a :class:`femupdate.workflow.UpdateResult` (its outcomes with histories
    for the last two).
    """
    summary, fit = result.summary, result.fit
    case = result.problem.case
    paths = [plot_fit(fit.t, fit.measured, fit.predicted, out_dir / "fit.png",
                      labels=[f"{c} [{fit.unit}]" for c in fit.channels])]
    histories = [o.history for o in result.outcomes if o.history is not None]
    if histories:
        paths.append(plot_phi(histories, out_dir / "phi.png",
                              title=f"{summary.name}: φ_m against evaluations"))
    best = next(o for o in result.outcomes if o.index == summary.best.run)
    if best.history is not None:
        hist = dict(best.history)
        hist["x"] = np.array([list(case.to_physical(x).values()) for x in hist["x"]])
        paths.append(plot_parameters(hist, case.parameter_names, out_dir / "parameters.png"))
    return paths

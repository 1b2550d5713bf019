"""The paper's Figs. 2–5 for one run of the two-mode benchmark (``femupdate demo``,
``femupdate bench dynamic --plots``), drawn by the functions of the HTML report."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from femupdate.paper.problems.dynamic import (
    LOWER,
    PARAMETER_NAMES,
    TRUTH,
    UPPER,
    DynamicProblem,
    two_mode_response,
)
from femupdate.report.canvas import save_png
from femupdate.report.figures import plot_beta, plot_fit, plot_parameters, plot_phi
from femupdate.runs.outcome import RunOutcome

#: Symbol and unit of each parameter of Eq. 17: ω rad/s, ζ and A dimensionless, θ rad.
SYMBOLS = {"w": ("ω", "rad/s"), "z": ("ζ", "−"), "A": ("A", "−"), "theta": ("θ", "rad")}


def parameter_labels() -> tuple[list[str], list[str]]:
    """Display names (``ω1``) and units of :data:`PARAMETER_NAMES`, in order."""
    names, units = [], []
    for name in PARAMETER_NAMES:
        stem, mode = name[:-1], name[-1]
        symbol, unit = SYMBOLS[stem]
        names.append(f"{symbol}{mode}")
        units.append(unit)
    return names, units


def run_label(outcome: RunOutcome, method: str) -> str:
    """Which run a figure shows: ``"AB, run 0 (root seed 0)"``."""
    entropy = outcome.seed.get("entropy", "?")
    return f"{method.upper()}, run {outcome.index} (root seed {entropy})"


def dynamic_figures(outcome: RunOutcome, out_dir: Path, method: str) -> list[Path]:
    """Draw Figs. 2–5 of a run of the two-mode benchmark (its ``history`` kept) as PNG."""
    hist = outcome.history
    if hist is None:
        raise ValueError("dynamic_figures needs the run's history (keep_history=True)")
    problem = DynamicProblem()
    out_dir = Path(out_dir)
    run = run_label(outcome, method)
    names, units = parameter_labels()
    paths = [save_png(plot_phi([hist["fun"]], title=f"Fig. 2 — {run}: φ_m against evaluations"),
                      out_dir / f"fig2_phi_{method}.png")]
    if "a" in hist:
        paths.append(save_png(plot_beta(hist, names, title=f"Fig. 3 — {run}: Beta parameters"),
                              out_dir / f"fig3_beta_{method}.png"))
    paths.append(save_png(plot_parameters(
        hist["x"], hist["fun"], names, units=units, truth=TRUTH.tolist(),
        bounds=list(zip(LOWER, UPPER, strict=True)),
        title=f"Fig. 4 — {run}: parameters of the best-so-far solution"),
        out_dir / f"fig4_parameters_{method}.png"))
    predicted = two_mode_response(np.asarray(outcome.x), problem.t)
    nmse = 100.0 * float(np.sum((problem.target - predicted) ** 2)) / problem.target_energy
    paths.append(save_png(plot_fit(
        problem.t, problem.target, predicted, channels=["y"], unit="−",
        nmse_percent=[nmse], title=f"Fig. 5 — {run}: y(t) of Eq. 17, target (measured) "
                                   "against the best solution (predicted)"),
        out_dir / f"fig5_response_{method}.png"))
    return paths

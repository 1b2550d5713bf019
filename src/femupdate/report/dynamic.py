"""The paper's Figs. 2–5 for one run of the two-mode benchmark."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from femupdate.problems.dynamic import PARAMETER_NAMES, TRUTH, DynamicProblem, two_mode_response
from femupdate.report.figures import plot_beta, plot_fit, plot_parameters, plot_phi
from femupdate.runs.outcome import RunOutcome


def dynamic_figures(outcome: RunOutcome, out_dir: Path, method: str) -> list[Path]:
    """Draw Figs. 2–5 of a run of the two-mode benchmark (its ``history`` kept) as PNG."""
    hist = outcome.history
    if hist is None:
        raise ValueError("dynamic_figures needs the run's history (keep_history=True)")
    problem = DynamicProblem()
    out_dir = Path(out_dir)
    paths = [plot_phi([hist], out_dir / f"fig2_phi_{method}.png",
                      title=f"{method}: φ_m against evaluations")]
    if "a" in hist:
        paths.append(plot_beta(hist, PARAMETER_NAMES, out_dir / f"fig3_beta_{method}.png"))
    paths.append(plot_parameters(hist, PARAMETER_NAMES, out_dir / f"fig4_parameters_{method}.png",
                                 truth=TRUTH.tolist()))
    paths.append(plot_fit(problem.t, problem.target[:, None],
                          two_mode_response(np.asarray(outcome.x), problem.t)[:, None],
                          out_dir / f"fig5_response_{method}.png", ylabel="y(t)"))
    return paths

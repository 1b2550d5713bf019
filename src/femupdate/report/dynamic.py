"""The paper's Figs. 2–5 for one run of the two-mode benchmark."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from femupdate.benchmarks.dynamic import (
    F_TARGET,
    MAX_EVALS,
    PARAMETER_NAMES,
    TRUTH,
    DynamicProblem,
    two_mode_response,
)
from femupdate.report.figures import plot_beta, plot_fit, plot_parameters, plot_phi
from femupdate.runs.runner import RunTask, run_seeds


def dynamic_figures(
    out_dir: Path,
    method: str = "ab",
    *,
    seed: int | None = 0,
    run_index: int = 0,
    options: dict[str, object] | None = None,
    max_evals: int = MAX_EVALS,
) -> list[Path]:
    """Repeat run ``run_index`` of a benchmark with its history and draw Figs. 2–5 as PNG.

    The run is the same one (same child seed) as run ``run_index`` of ``run_benchmark``.
    """
    problem = DynamicProblem()
    child = run_seeds(seed, run_index + 1)[run_index]
    outcome = RunTask(problem, problem.bounds, method, run_index, child, max_evals, F_TARGET,
                      dict(options or {}), keep_history=True)()
    hist = outcome.history
    assert hist is not None  # keep_history=True
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

"""A model-updating job end to end: case → repeated runs → summary.json, plots, table.

This is what ``femupdate run`` does; the bridge benchmark calls it too.
"""

from __future__ import annotations

import json
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from femupdate.case import Case, parse_case
from femupdate.experiment import Experiment, load_experiment
from femupdate.model.modes import natural_frequencies
from femupdate.optimize.minimize import RESIDUAL_METHODS
from femupdate.runs.runner import RunOutcome, run_all
from femupdate.runs.stats import at_bounds, evaluation_stats, spread
from femupdate.update import UpdateProblem

#: Without a target φ_s, a run counts as successful when its φ is within this factor of the
#: best run's: it reached the same minimum rather than an improper one at a bound.
NEAR_BEST = 1.05
N_FREQUENCIES = 6


def with_data_directory(case: Case, directory: Path) -> Case:
    """The same case reading its records from ``directory``."""
    data = case.to_dict()
    data["data"]["directory"] = str(Path(directory).resolve())
    return parse_case(data, source=case.source)


@dataclass
class UpdateResult:
    """What a job produced: the summary (as written to summary.json) and the run outcomes."""

    summary: dict[str, Any]
    outcomes: list[RunOutcome]
    problem: UpdateProblem


def _frequencies(problem: UpdateProblem, x: np.ndarray) -> list[float]:
    freqs, _ = natural_frequencies(problem.system(x))
    return freqs[:N_FREQUENCIES].tolist()


def summarize(problem: UpdateProblem, outcomes: Sequence[RunOutcome], wall_s: float,
              f_target: float | None, settings: dict[str, Any] | None = None) -> dict[str, Any]:
    """summary.json: every run, the best, and the spread over successful runs.

    The case is saved with its data directory made absolute, so that the results can be
    re-simulated (``femupdate report``) from anywhere.
    """
    case = problem.case
    case_dict = case.to_dict()
    if case_dict.get("data") is not None:
        case_dict["data"]["directory"] = str(case.data_directory().resolve())
    names = problem.names
    phis = np.array([o.fun for o in outcomes])
    best = outcomes[int(np.argmin(phis))]
    if f_target is not None:
        success = [o.success for o in outcomes]
        rule = f"reached f_target = {f_target:g}"
    else:
        success = [bool(o.fun <= NEAR_BEST * best.fun) for o in outcomes]
        rule = f"φ within {NEAR_BEST:g} × the best run's φ (no f_target given)"
    runs = []
    for o, ok in zip(outcomes, success, strict=True):
        row = o.to_dict(names)
        row["params"] = problem.values(o.x)
        row["success"] = ok
        row["at_bounds"] = at_bounds(o.x, problem.bounds, names)
        runs.append(row)
    good = [o for o, ok in zip(outcomes, success, strict=True) if ok]
    values = np.array([[r["params"][n] for n in names] for r, ok in zip(runs, success,
                                                                       strict=True) if ok])
    freqs = np.array([_frequencies(problem, o.x) for o in good])
    # With experimental parameters, each channel's NMSE is against the measurement corrected
    # by its fitted integration constants, as φ itself.
    prediction = problem.prediction(problem.simulate(best.x))
    per_channel = dict(zip(problem.experiment.channels,
                           problem.objective.per_channel(prediction).tolist(), strict=True))
    return {
        "case": case_dict,
        "case_file": str(case.source) if case.source is not None else None,
        "settings": settings or {},
        "delays_s": dict(problem.experiment.delays),
        "fingerprint": case.fingerprint(),
        "method": case.search.method,
        **evaluation_stats([o.nfev for o in outcomes], success),
        "success_rule": rule,
        "wall_s": wall_s,
        "runs": runs,
        "best": {
            "run": best.index,
            "phi": best.fun,
            "nmse_percent": 100.0 * best.fun,
            "params": problem.values(best.x),
            "frequencies_hz": _frequencies(problem, best.x),
            "nmse_per_channel": per_channel,
        },
        "spread": {
            "params": spread(values, names) if len(good) else {},
            "frequencies_hz": (spread(freqs, [f"f{i + 1}" for i in range(freqs.shape[1])])
                               if len(good) else {}),
        },
    }


def write_plots(result: UpdateResult, out_dir: Path) -> list[Path]:
    """Each channel's fit, φ against evaluations (all runs), the best run's parameters."""
    from femupdate.report.figures import plot_fit, plot_parameters, plot_phi

    problem = result.problem
    best_index = result.summary["best"]["run"]
    best = next(o for o in result.outcomes if o.index == best_index)
    exp = problem.experiment
    prediction = problem.prediction(problem.simulate(best.x))
    measured = problem.objective.corrected_target(prediction).reshape(prediction.shape)
    unit = "m" if exp.quantity == "displacement" else "m/s²"
    paths = [plot_fit(exp.t, measured, prediction, out_dir / "fit.png",
                      labels=[f"{c} [{unit}]" for c in exp.channels])]
    histories = [o.history for o in result.outcomes if o.history is not None]
    if histories:
        paths.append(plot_phi(histories, out_dir / "phi.png",
                              title=f"{problem.case.label}: φ_m against evaluations"))
    if best.history is not None:
        hist = dict(best.history)
        hist["x"] = np.array([list(problem.values(x).values()) for x in hist["x"]])
        paths.append(plot_parameters(hist, problem.names, out_dir / "parameters.png"))
    return paths


def optimizer_options(case: Case) -> dict[str, Any]:
    """The method options of the case's ``[search]``, with σ_s and Δφ_s when given."""
    search = case.search
    options = dict(search.options)
    if search.sigma_min is not None:
        options["sigma_min"] = search.sigma_min
    if search.f_change_min is not None:
        options["f_change_min"] = search.f_change_min
    return options


def run_case(
    case: Case,
    out_dir: Path | None = None,
    *,
    runs: int | None = None,
    workers: int = 1,
    plots: bool = True,
    seed: int | None = None,
    max_evals: int | None = None,
    resume: bool = False,
    scheduler: str | None = None,
    quiet: bool = True,
    log_json: Path | None = None,
    experiment: Experiment | None = None,
) -> UpdateResult:
    """Update the model of ``case`` from its data; write the results to ``out_dir``.

    ``out_dir`` receives the results store (``results.sqlite``: every evaluation and the
    optimizer checkpoints, written as they happen), ``summary.json`` and the plots; without it
    the store is kept in memory and nothing is written. ``runs``, ``seed`` and ``max_evals``
    override the case's ``[search]``. ``resume`` continues the unfinished runs of a store in
    ``out_dir`` (refused for a store of another case or other settings); ``scheduler`` runs on
    a Dask cluster; ``quiet=False`` shows a progress bar; ``log_json`` appends JSON lines.
    ``experiment`` is the case's processed data when the caller has already loaded it.
    """
    problem = UpdateProblem(case, experiment or load_experiment(case))
    search = case.search
    start = time.perf_counter()
    if out_dir is not None:
        out_dir.mkdir(parents=True, exist_ok=True)
    residuals = search.method in RESIDUAL_METHODS
    outcomes = run_all(
        problem.residuals if residuals else problem, problem.bounds, search.method,
        runs=runs or search.runs,
        seed=search.seed if seed is None else seed,
        max_evals=max_evals or search.max_evals,
        f_target=search.f_target,
        options=optimizer_options(case),
        store_dir=out_dir,
        resume=resume,
        workers=workers,
        scheduler=scheduler,
        quiet=quiet,
        log_json=log_json,
        case_dict=case.to_dict(),
        fingerprint=case.fingerprint(),
        names=problem.names,
        label=case.label,
        keep_history=plots,
        residuals=residuals,
    )
    settings = {"runs": runs or search.runs, "seed": search.seed if seed is None else seed,
                "max_evals": max_evals or search.max_evals, "f_target": search.f_target,
                "method": search.method, "options": optimizer_options(case),
                "workers": workers, "scheduler": scheduler}
    summary = summarize(problem, outcomes, time.perf_counter() - start, search.f_target,
                        settings)
    result = UpdateResult(summary, outcomes, problem)
    if out_dir is not None:
        (out_dir / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        if plots:
            write_plots(result, out_dir)
    return result

"""A set of runs' verdict: converged (the best found again) or m different minima, in words;
what success means without an f_target."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from femupdate.case import load_case
from femupdate.pipeline.run import summarize
from femupdate.problem.update import UpdateProblem
from femupdate.runs.outcome import RunOutcome
from femupdate.runs.verdict import minimum_groups, successes, verdict_of
from femupdate.trials.experiment import load_experiment
from femupdate.trials.virtual import virtual_experiment

CASE = """\
[case]
name = "one-storey"

[model.shear_building]
masses = [1.0]
stiffnesses = ["k"]
dampers = ["c"]

[[parameters]]
name = "k"
lower = 1000.0
upper = 10000.0
[[parameters]]
name = "c"
lower = 0.0
upper = 5.0

[data]
format = "csv"
directory = "data"
time_column = "t"

[data.input]
file = "table.csv"
column = "table"

[[data.outputs]]
file = "floors.csv"
column = "a1"
node = "F1"
dof = "ux"

[search]
runs = 3
max_evals = 100
"""
TRUTH = {"k": 4000.0, "c": 1.2}


@pytest.fixture(scope="module")
def problem(tmp_path_factory: pytest.TempPathFactory) -> UpdateProblem:
    folder = tmp_path_factory.mktemp("verdict")
    (folder / "case.toml").write_text(CASE)
    case = load_case(folder / "case.toml")
    virtual_experiment(case, TRUTH, folder / "data", seed=1, rate=200.0, duration=3.0,
                       snr=0.0, offset=0.0, drift=0.0)
    return UpdateProblem(case, load_experiment(case))


def _outcome(problem: UpdateProblem, index: int, values: dict[str, float],
             stop: dict | None = None) -> RunOutcome:
    x = problem.case.to_search(values)
    return RunOutcome(index=index, seed={"entropy": 0, "spawn_key": [index]}, x=x,
                      fun=float(problem(x)), nfev=100, nit=10, success=False, status=1,
                      message="max_evals reached", stop=stop or {"max_evals": 100}, wall_s=0.1)


def test_runs_in_two_minima_are_not_converged_and_not_successful(problem) -> None:
    # Two runs ended at two different points (two minima as far as the runs can tell).
    outcomes = [_outcome(problem, 0, {"k": 3980.0, "c": 1.1}),
                _outcome(problem, 1, {"k": 4030.0, "c": 1.4})]
    summary = summarize(problem, outcomes, 1.0, None)
    verdict = summary.verdict
    assert verdict is not None and not verdict.converged and verdict.minima == 2
    lo, hi = sorted(o.fun for o in outcomes)
    assert verdict.words == (f"not converged: the 2 runs ended in 2 different minima, "
                             f"φ {lo:.4g} … {hi:.4g}; the best was found once")
    # Without an f_target, being the best run is not success.
    assert summary.successes == 0 and not any(r.success for r in summary.runs)
    assert "found again" in summary.success_rule


def test_the_best_found_again_is_converged_and_successful(problem) -> None:
    outcomes = [_outcome(problem, 0, {"k": 5500.0, "c": 2.0}),
                _outcome(problem, 1, {"k": 4000.0, "c": 1.2}),
                _outcome(problem, 2, {"k": 4000.0 * (1 + 1e-9), "c": 1.2})]
    summary = summarize(problem, outcomes, 1.0, None)
    verdict = summary.verdict
    assert verdict is not None and verdict.converged and verdict.agreeing_runs == [1, 2]
    assert verdict.words.startswith("converged: 2 of 3 runs ended at the best minimum")
    assert verdict.words.endswith("; the 1 others in 1 other minima")
    assert [r.success for r in summary.runs] == [False, True, True]


def test_same_phi_far_apart_is_two_minima() -> None:
    labels = minimum_groups(np.array([1.0, 1.001, 1.002]),
                            np.array([[0.2, 0.2], [0.8, 0.8], [0.201, 0.2]]))
    assert labels.tolist() == [0, 1, 0]


def test_patience_of_the_best_run_confirms_it() -> None:
    verdict = verdict_of([0.05], np.array([[0.5, 0.5]]), [{"patience": 5}])
    assert verdict.converged and verdict.confirmations == 5
    assert verdict.words == "converged within run 0: 5 of its searches ended at its best φ"
    alone = verdict_of([0.05], np.array([[0.5, 0.5]]), [{"max_evals": 100}])
    assert not alone.converged and successes(alone, [0.05], None) == [False]


def test_nmse_of_100_percent_or_more_is_never_a_success() -> None:
    phis = [1.3, 1.3 * (1 + 1e-6)]
    verdict = verdict_of(phis, np.array([[0.5, 0.5], [0.5, 0.5]]), [{}, {}])
    assert verdict.converged and not verdict.fits
    assert "no fit: NMSE 130 % ≥ 100 %" in verdict.words
    assert successes(verdict, phis, None) == [False, False]
    assert successes(verdict, phis, [True, True]) == [False, False]  # even at an f_target
    assert successes(verdict, [0.2, 0.3], [True, False]) == [True, False]


def test_summary_json_keeps_the_verdict(problem, tmp_path: Path) -> None:
    from femupdate.pipeline.results import read_summary, write_summary

    outcomes = [_outcome(problem, 0, TRUTH), _outcome(problem, 1, TRUTH)]
    summary = summarize(problem, outcomes, 1.0, None)
    back = read_summary(write_summary(summary, tmp_path))
    assert back.verdict == summary.verdict and back.verdict.converged

"""A case with derived fields and constraints, fitted: a Bouc–Wen oscillator whose gamma is
derived from beta, and points outside the constraints as failed evaluations."""

from __future__ import annotations

import math
import pickle
from pathlib import Path

import numpy as np
import pytest

# the case is the benchmark's (benchmarks/ is on the tests' path)
from derived_fields import GAMMA_FREE, TRUTH, write_case

from femupdate.case import load_case
from femupdate.pipeline.run import run_case
from femupdate.problem.update import UpdateProblem
from femupdate.trials.experiment import load_experiments
from femupdate.trials.virtual import virtual_experiment


@pytest.fixture(scope="module")
def derived_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The derived case and its noise-free records (gamma = 0.5 * beta = 150)."""
    folder = tmp_path_factory.mktemp("derived")
    case = load_case(write_case(folder, '"0.5 * beta"'))
    virtual_experiment(case, TRUTH, folder / "data", seed=2, rate=200.0, duration=2.0, snr=0.0,
                       offset=0.0, drift=0.0, pga_g=0.35)
    return folder


def test_the_records_hold_the_derived_value(derived_dir: Path) -> None:
    # the same records as a model with gamma written as the number 150
    free = load_case(write_case(derived_dir / "number", "150.0"))
    free_problem = UpdateProblem(free, load_experiments(load_case(derived_dir / "case.toml")),
                                 compiled=False)
    problem = UpdateProblem(load_case(derived_dir / "case.toml"),
                            load_experiments(load_case(derived_dir / "case.toml")),
                            compiled=False)
    x = problem.case.to_search(TRUTH)
    assert problem(x) < 1e-20  # the truth, up to the rounding of k's log scale
    away = problem.case.to_search({"k": 3000.0, "beta": 300.0})
    assert problem(away) == free_problem(away) > 1e-3


def test_the_compiled_path_computes_the_derived_values(derived_dir: Path) -> None:
    case = load_case(derived_dir / "case.toml")
    experiments = load_experiments(case)
    compiled = UpdateProblem(case, experiments)
    reference = UpdateProblem(case, experiments, compiled=False)
    assert compiled.compiled and compiled.fitted[0].derived_fields == ("0.5 * beta",)
    rng = np.random.default_rng(4)
    X = np.column_stack([rng.uniform(3.31, 3.9, 8), rng.uniform(150.0, 450.0, 8)])
    assert compiled.fitted[0].compiled_rows(X)[0][:, 2].tolist() == (0.5 * X[:, 1]).tolist()
    batch = compiled.evaluate_batch(X)
    assert np.all(np.isfinite(batch)) and np.all(batch > 0.0)
    assert batch == pytest.approx([reference(x) for x in X], rel=1e-9)
    assert [compiled(x) for x in X] == batch.tolist()  # single calls: the batch's bits
    rows = compiled.residuals_batch(X)
    assert np.sum(rows**2, axis=1) == pytest.approx(batch, rel=1e-12)
    again = pickle.loads(pickle.dumps(compiled))  # as worker processes receive it
    assert again.evaluate_batch(X).tolist() == batch.tolist()


def test_a_derived_case_runs_and_recovers_beta(derived_dir: Path) -> None:
    result = run_case(load_case(derived_dir / "case.toml"), None, sensitivities=False)
    best = result.summary.best
    assert best.phi < 1e-10
    assert best.params["beta"] == pytest.approx(TRUTH["beta"], rel=1e-4)
    assert best.params["k"] == pytest.approx(TRUTH["k"], rel=1e-4)


def test_a_point_outside_the_constraints_is_a_failed_evaluation(derived_dir: Path) -> None:
    case = load_case(write_case(derived_dir / "free", '"gamma"', GAMMA_FREE))
    problem = UpdateProblem(case, load_experiments(load_case(derived_dir / "case.toml")))
    assert problem.compiled  # the constraints are checked before the compiled evaluator
    inside = case.to_search({"k": 4000.0, "beta": 300.0, "gamma": 150.0})
    outside = case.to_search({"k": 4000.0, "beta": 200.0, "gamma": 250.0})
    assert problem(inside) < 1e-20 and problem.last_failure is None
    assert problem(outside) == math.inf
    assert problem.last_failure == ("trial 'bouc-wen oscillator': constraint 'gamma <= beta' "
                                    "does not hold: gamma = 250, beta = 200")
    evaluation = problem.evaluate(outside)
    assert evaluation.phi == math.inf and "gamma <= beta" in evaluation.error
    rows = problem.residuals_batch(np.array([inside, outside]))
    assert np.all(np.abs(rows[0]) < 1e-10) and np.all(np.isinf(rows[1]))  # log L = -inf: prior zero


def test_a_derived_value_out_of_range_at_a_point_is_a_failed_evaluation(
        derived_dir: Path) -> None:
    problem = UpdateProblem(load_case(derived_dir / "case.toml"),
                            load_experiments(load_case(derived_dir / "case.toml")))
    assert problem({"k": 4000.0, "beta": -10.0}) == math.inf
    assert problem.last_failure == ("trial 'bouc-wen oscillator': bouc_wen 'bw1': beta = -10.0 "
                                    "(parameter 'beta') is out of range; allowed (0, inf)")

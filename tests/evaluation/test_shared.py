"""Score windows on the compiled path, and windows of one record simulated once
(femupdate.evaluation.shared).

Three fitted windows of one virtual record of the paper's bridge (Zapico-Valle et al. 2010,
§5), overlapping and not, with noise, offsets and drift. Each window's compiled φ and residual
vector must equal its step-by-step ones (the prediction processed over the whole record, then
sliced) to the tolerances tests/test_evaluation.py measured for whole records: 1e-12 relative
for the viscous model, 1e-10 for the frictional one; with a high-passed prediction integrated
twice, twice the reference's own 1-ulp sensitivity (a window's φ is a shorter sum than the
record's and moves more), capped at 5e-10. The three windows simulated once must give
the values of the three evaluated one by one, bit for bit.
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np
import pytest

from femupdate.case import parse_case
from femupdate.evaluation.shared import record_key, shared_groups
from femupdate.paper.problems import bridge
from femupdate.problem.update import TrialProblem, UpdateProblem
from femupdate.trials.experiment import load_experiments
from femupdate.trials.virtual import virtual_experiment

#: Record time of the three fitted windows (s; the record lasts 1 s).
WINDOWS = ([0.0, 0.45], [0.3, 0.7], [0.62, 0.98])
RTOL = {"viscous": 1e-12, "friction": 1e-10}
#: A high-passed prediction integrated twice amplifies the eigendecomposition's rounding: there
#: the tolerance is twice the reference's own change for one ulp of one parameter (the largest
#: over the parameters: a sample of the directions; 1.4 times it measured on the late window of
#: the viscous model, 1.36e-10 against 9.7e-11), up to this.
SENSITIVE_RTOL_CAP = 5e-10

OPTIONS = {
    "displacement": None,  # integrated twice, experimental parameters
    "acceleration": {"objective": {"quantity": "acceleration",
                                   "experimental_parameters": False}},
    "filtered-prediction": {"preprocess": {"highpass_hz": 0.5, "filter_prediction": True}},
}


@pytest.fixture(scope="module")
def specs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict[str, Any]]:
    out = {}
    for model in ("viscous", "friction"):
        data = tmp_path_factory.mktemp(model) / "data"
        spec = bridge.bridge_case(model, directory=str(data))
        virtual_experiment(parse_case(spec, source="b.toml"), bridge.truth(model), data,
                           seed=5, duration=1.0, snr=0.02)
        out[model] = spec
    return out


def _case(spec: dict[str, Any], option: str, trials: list[dict[str, Any]] | None = None
          ) -> Any:
    spec = copy.deepcopy(spec)
    for section, values in (OPTIONS[option] or {}).items():
        spec.setdefault(section, {}).update(values)
    spec["trials"] = trials or [{"name": f"w{i}", "score_window": window}
                                for i, window in enumerate(WINDOWS)]
    return parse_case(spec, source="case.toml")


def _points(problem: UpdateProblem, n: int) -> np.ndarray:
    low, high = np.array(problem.bounds).T
    return low + (high - low) * np.random.default_rng(3).random((n, low.size))


def _ulp_sensitivity(trial: TrialProblem, X: np.ndarray) -> float:
    """The largest relative change of the trial's step-by-step φ over the points when one
    parameter moves by one unit in the last place."""
    worst = 0.0
    for x in X:
        f0 = trial.phi_reference(x)
        for i in range(x.size):
            nudged = x.copy()
            nudged[i] = np.nextafter(nudged[i], np.inf)
            worst = max(worst, abs(trial.phi_reference(nudged) - f0) / abs(f0))
    return worst


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


@pytest.mark.slow
@pytest.mark.parametrize("option", OPTIONS)
@pytest.mark.parametrize("model", ["viscous", "friction"])
def test_a_window_scored_compiled_equals_the_step_by_step_path(
        specs: dict[str, dict[str, Any]], model: str, option: str) -> None:
    case = _case(specs[model], option)
    experiments = load_experiments(case)
    X = _points(UpdateProblem(case, experiments, compiled=False), 3)
    for experiment in experiments:
        trial = TrialProblem(case, experiment)
        assert trial.compiled
        n_scored = experiment.target[experiment.score].shape[0]
        assert 300 < n_scored < experiment.t.size
        phi = trial.phi_batch(X)
        reference = np.array([trial.phi_reference(x) for x in X])
        assert np.all(np.isfinite(reference))
        tolerance = RTOL[model]
        if option == "filtered-prediction":  # tests/test_evaluation.py's docstring
            tolerance = min(max(tolerance, 2 * _ulp_sensitivity(trial, X)), SENSITIVE_RTOL_CAP)
        assert _relative(phi, reference) <= tolerance, experiment.name
        for x, rows in zip(X, trial.residuals_rows(X), strict=True):
            want = trial.residuals(case.to_physical(x))
            assert rows.shape == want.shape == (n_scored * experiment.target.shape[1],)
            assert _relative(rows, want) <= 10 * tolerance, experiment.name
        # the compiled evaluator did them, not the step-by-step fallback
        assert trial.evaluator.residuals(X[0]) is not None


@pytest.mark.slow
@pytest.mark.parametrize("option", ["displacement", "acceleration", "filtered-prediction"])
@pytest.mark.parametrize("model", ["viscous", "friction"])
def test_windows_of_one_record_simulated_once_give_the_one_by_one_bits(
        specs: dict[str, dict[str, Any]], model: str, option: str) -> None:
    case = _case(specs[model], option)
    experiments = load_experiments(case)
    shared = UpdateProblem(case, experiments)
    assert shared.shared_records == [[0, 1, 2]]
    apart = UpdateProblem(case, experiments)
    apart.shared_records = [[0], [1], [2]]  # each window simulated by its own trial
    X = _points(shared, 5)  # with friction: four points in the SIMD lanes, one alone
    if model == "friction":
        assert shared.fitted[0].evaluator.lanes is not None
    np.testing.assert_array_equal(shared.evaluate_batch(X), apart.evaluate_batch(X))
    np.testing.assert_array_equal(shared.residuals_batch(X), apart.residuals_batch(X))
    assert shared(X[1]) == apart(X[1])
    np.testing.assert_array_equal(shared.residuals(X[2]), apart.residuals(X[2]))
    np.testing.assert_array_equal(shared._trial_phis(X), apart._trial_phis(X))


def test_windows_of_one_record_with_a_zero_phase_filter(specs: dict[str, dict[str, Any]]
                                                        ) -> None:
    spec = copy.deepcopy(specs["viscous"])
    spec["preprocess"].update(highpass_hz=0.5, zero_phase=True, filter_prediction=True)
    case = _case(spec, "displacement")
    experiments = load_experiments(case)
    shared = UpdateProblem(case, experiments)
    apart = UpdateProblem(case, experiments)
    apart.shared_records = [[0], [1], [2]]
    X = _points(shared, 3)
    np.testing.assert_array_equal(shared.evaluate_batch(X), apart.evaluate_batch(X))
    np.testing.assert_array_equal(shared.residuals_batch(X), apart.residuals_batch(X))
    reference = np.array([shared.phi_reference(x) for x in X])
    assert _relative(shared.evaluate_batch(X), reference) <= 1e-10


def test_which_trials_share_a_record(specs: dict[str, dict[str, Any]]) -> None:
    trials = [{"name": "a", "score_window": [0.0, 0.5]},
              {"name": "b", "score_window": [0.5, 0.9]},
              {"name": "cut", "window": [0.0, 0.9], "score_window": [0.1, 0.8]},  # other ag
              {"name": "held", "role": "validate", "score_window": [0.9, 1.0]},
              {"name": "whole"}]
    case = _case(specs["viscous"], "displacement", trials)
    experiments = load_experiments(case)
    problem = UpdateProblem(case, experiments)
    assert [t.name for t in problem.fitted] == ["a", "b", "cut", "whole"]
    assert problem.shared_records == [[0, 1, 3], [2]]
    # the step-by-step path shares nothing
    reference = UpdateProblem(case, experiments, compiled=False)
    assert reference.shared_records == [[0], [1], [2], [3]]
    assert record_key(reference.fitted[0]) is None
    # other output channels: another simulation
    spec = copy.deepcopy(specs["viscous"])
    case = _case(spec, "displacement",
                 [{"name": "all", "score_window": [0.0, 0.5]},
                  {"name": "one", "score_window": [0.5, 1.0],
                   "outputs": spec["data"]["outputs"][:1]}])
    problem = UpdateProblem(case, load_experiments(case))
    assert shared_groups(problem.fitted) == [[0], [1]]


def test_a_shared_record_on_threads_and_pickled(specs: dict[str, dict[str, Any]]) -> None:
    # femupdate run spreads a batch over threads (each with its own evaluators) or ships the
    # problem to worker processes: the same values either way.
    import pickle

    case = _case(specs["viscous"], "displacement")
    problem = UpdateProblem(case, load_experiments(case))
    X = _points(problem, 6)
    phi, rows = problem.evaluate_batch(X), problem.residuals_batch(X)
    np.testing.assert_array_equal(problem.evaluate_batch(X, threads=2), phi)
    np.testing.assert_array_equal(problem.residuals_batch(X, threads=2), rows)
    copy_ = pickle.loads(pickle.dumps(problem))
    assert copy_.shared_records == [[0, 1, 2]]
    np.testing.assert_array_equal(copy_.evaluate_batch(X), phi)

"""The compiled φ of multi-support cases (femupdate.evaluation.supports) against the
step-by-step path (CaseModel.support_response through TrialProblem.phi_reference).

The two-span beam of femupdate.paper.bench.multisupport_check (three supports, each its own
record; consistent beam mass and Rayleigh damping with α ≠ 0, so that the supports load the
deck through mass, damping and stiffness), with noisy records: at seeded points of the box
the compiled outputs, φ and residual vectors equal the reference's to 1e-10 (NMSE of the
outputs, relative φ), for absolute accelerations, accelerations relative to a group,
displacements integrated from them, displacements taken as they are, and a prediction
high-passed as the data were; score windows of one record simulated once give the values of
the windows evaluated one by one.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from femupdate.case import parse_case
from femupdate.evaluation.supports import SupportEvaluator
from femupdate.paper.bench.multisupport_check import TRUTH, two_span_case
from femupdate.problem.case_model import CaseModel
from femupdate.problem.released import released_structure
from femupdate.problem.update import TrialProblem, UpdateProblem
from femupdate.trials.experiment import load_experiment, load_experiments
from femupdate.trials.virtual import virtual_experiment

OPTIONS: dict[str, dict[str, Any]] = {
    "acceleration": {"objective": {"quantity": "acceleration"}},
    "acceleration-relative": {"objective": {"quantity": "acceleration"}, "relative": True},
    "displacement-integrated": {"relative": True},
    "displacement": {"objective": {"integrate_prediction": False}},
    "filtered-prediction": {"preprocess": {"highpass_hz": 1.0, "filter_prediction": True}},
}


def _case(tmp_path: Path, option: str, method: str = "exact") -> Any:
    data = copy.deepcopy(two_span_case(method).to_dict())
    data["data"]["directory"] = str(tmp_path)
    extra = dict(OPTIONS[option])
    if extra.pop("relative", False):
        data["data"]["outputs"][1]["relative_to"] = "pier"
    data.update(extra)
    return parse_case({k: v for k, v in data.items() if k != "posterior"}, source="c.toml")


@pytest.fixture(scope="module")
def records(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    out = {}
    for option in OPTIONS:
        path = tmp_path_factory.mktemp(option)
        virtual_experiment(_case(path, option), dict(TRUTH), path, seed=7, duration=1.5,
                           rate=200.0, snr=0.02)
        out[option] = path
    return out


def _points(case: Any, k: int = 6) -> np.ndarray:
    lo, hi = np.array(case.bounds).T
    return lo + (hi - lo) * np.random.default_rng(35).random((k, lo.size))


def _nmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.sum((a - b) ** 2, axis=-1) / np.sum(b**2, axis=-1)))


@pytest.mark.parametrize("option", list(OPTIONS))
def test_compiled_phi_and_residuals_equal_the_step_by_step_path(records, option):
    case = _case(records[option], option)
    trial = TrialProblem(case, load_experiment(case))
    assert trial.compiled and isinstance(trial.evaluator, SupportEvaluator)
    for x in _points(case):
        reference = trial.phi_reference(x)
        assert trial.evaluator(x) == pytest.approx(reference, rel=1e-10, abs=0.0)
        r_fast = trial.evaluator.residuals(x)
        r_ref = trial.residuals(case.to_physical(x))
        assert _nmse(r_fast, r_ref) <= 1e-10


@pytest.mark.parametrize("option", ["acceleration", "acceleration-relative", "displacement"])
def test_compiled_outputs_equal_the_step_by_step_prediction(records, option):
    """The raw outputs are the prediction when nothing integrates or filters them."""
    case = _case(records[option], option)
    trial = TrialProblem(case, load_experiment(case))
    for x in _points(case, 3):
        y, _ = trial.evaluator.simulated(x)
        reference = trial.prediction(trial.simulate(case.to_physical(x)))
        assert _nmse(y, reference.T) <= 1e-10


def test_released_structure_has_the_coupling_blocks_of_support_coupling():
    case = two_span_case("exact")
    model = CaseModel(case)
    twin, supports = released_structure(case.model)
    assert supports == [("A", "uy"), ("B", "uy"), ("C", "uy")]
    system = twin.assemble(TRUTH, sparse=True)
    index = {label: i for i, label in enumerate(system.dof_labels)}
    free = [index[label] for label in model.structure.dof_labels]
    cols = [index[f"{n}.{d}"] for n, d in supports]
    blocks = model.structure.support_coupling(TRUTH, supports)
    for released, own in zip((system.K, system.M, system.C), blocks, strict=True):
        dense = released.toarray()
        np.testing.assert_allclose(dense[np.ix_(free, cols)], own, rtol=1e-12,
                                   atol=1e-12 * np.abs(own).max())
    own = model.system(TRUTH)
    np.testing.assert_allclose(system.K.toarray()[np.ix_(free, free)], own.K, rtol=1e-12,
                               atol=1e-12 * np.abs(own.K).max())


def test_other_integrators_are_evaluated_step_by_step(records):
    case = _case(records["acceleration"], "acceleration", method="newmark")
    trial = TrialProblem(case, load_experiment(case))
    x = _points(case, 1)[0]
    assert not trial.evaluator.supported
    assert trial.evaluator(x) == trial.phi_reference(x)


def test_windows_of_one_record_are_simulated_once(records):
    """Two fitted score windows of one record share its simulation
    (femupdate.evaluation.shared): the values of the two evaluated one by one, and of the
    step-by-step path to 1e-10."""
    base = _case(records["acceleration"], "acceleration").to_dict()
    base.pop("posterior", None)
    base["trials"] = [{"name": "early", "score_window": [0.0, 0.8]},
                      {"name": "late", "score_window": [0.7, 1.45]}]
    case = parse_case(base, source="c.toml")
    shared = UpdateProblem(case, load_experiments(case))
    assert shared.shared_records == [[0, 1]]
    alone = [TrialProblem(case, e) for e in load_experiments(case)]
    X = _points(case, 3)
    phis = shared._trial_phis(X)
    for t, trial in enumerate(alone):
        for i, x in enumerate(X):
            assert phis[t, i] == trial.evaluator(x)
            assert phis[t, i] == pytest.approx(trial.phi_reference(x), rel=1e-10, abs=0.0)


def test_threads_share_a_batch(records):
    """A batch split over two threads (each with its own evaluator; the compiled simulation
    releases the GIL) gives the single calls' values."""
    case = _case(records["acceleration"], "acceleration")
    problem = UpdateProblem(case, load_experiments(case))
    assert problem.parallel_batches
    X = _points(case, 6)
    np.testing.assert_array_equal(problem.evaluate_batch(X, threads=2),
                                  [problem(x) for x in X])

"""The paper's bridge: example case files, the virtual experiment and one quick update."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

from femupdate.case import load_case, parse_case
from femupdate.model.modes import natural_frequencies
from femupdate.paper.problems import bridge
from femupdate.problem.update import UpdateProblem
from femupdate.trials.experiment import load_experiment
from femupdate.trials.virtual import virtual_experiment

EXAMPLES = Path(__file__).parents[1] / "examples" / "bridge"


@pytest.mark.parametrize("model", ["viscous", "friction"])
@pytest.mark.parametrize("band", ["narrow", "broad"])
def test_example_case_files_equal_the_embedded_cases(model: str, band: str) -> None:
    path = EXAMPLES / f"{model}-{band}.toml"
    with path.open("rb") as fh:
        assert tomllib.load(fh) == bridge.bridge_case(model, band, directory=f"data-{model}")
    case = load_case(path)
    assert len(case.parameter_names) == (9 if model == "viscous" else 13)
    truth = json.loads((EXAMPLES / f"truth-{model}.json").read_text())
    assert truth == bridge.truth(model)
    for p in case.parameters:  # the truth lies inside every band
        assert p.lower <= truth[p.name] <= p.upper


def test_truth_frequencies_near_the_papers() -> None:
    for model in ("viscous", "friction"):
        case = parse_case(bridge.bridge_case(model), source="bridge.toml")
        from femupdate.problem.case_model import build_structure

        system = build_structure(case.model).assemble(bridge.truth(model))
        freqs = natural_frequencies(system)[0][:4]
        np.testing.assert_allclose(freqs, bridge.PAPER_FREQUENCIES_HZ, rtol=0.02)


@pytest.fixture(scope="module")
def viscous_noise_free(tmp_path_factory: pytest.TempPathFactory) -> UpdateProblem:
    data = tmp_path_factory.mktemp("bridge") / "data"
    case = parse_case(bridge.bridge_case("viscous", directory=str(data)), source="b.toml")
    virtual_experiment(case, bridge.truth("viscous"), data, seed=3, duration=1.0, snr=0.0,
                       offset=0.0, drift=0.0)
    return UpdateProblem(case, load_experiment(case))


def test_truth_fits_noise_free_data_exactly(viscous_noise_free: UpdateProblem) -> None:
    # The prediction is processed like the data (causal high-pass, trapezoidal integration),
    # so the truth reproduces noise-free records to rounding; a 1 % change of E does not.
    problem = viscous_noise_free
    x = problem.case.to_search(bridge.truth("viscous"))
    assert problem(x) < 1e-15
    x[0] *= 1.01
    assert problem(x) > 1e-5


def test_friction_truth_fits_noise_free_data_when_the_prediction_is_filtered(
    tmp_path: Path,
) -> None:
    # The high-pass does not commute with friction: driving the model with the filtered table
    # record leaves a misfit of the truth itself; filtering its prediction as the data were
    # filtered (the default with frictions) removes it.
    data = tmp_path / "data"
    spec = bridge.bridge_case("friction", directory=str(data))
    case = parse_case(spec, source="f.toml")
    assert case.filters_prediction
    truth = bridge.truth("friction")
    virtual_experiment(case, truth, data, seed=3, duration=1.0, snr=0.0, offset=0.0, drift=0.0)
    problem = UpdateProblem(case, load_experiment(case))
    x = problem.case.to_search(truth)
    assert problem(x) < 1e-15
    x[problem.names.index("fu3")] *= 1.02
    assert problem(x) > 1e-5
    spec["preprocess"]["filter_prediction"] = False
    unfiltered = parse_case(spec, source="f.toml")
    misfit = UpdateProblem(unfiltered, load_experiment(unfiltered))(unfiltered.to_search(truth))
    assert misfit > 1e-2  # 2.6 % NMSE on this 1 s record: the old noise "floor"


def test_linear_models_give_the_same_fit_either_way(
    viscous_noise_free: UpdateProblem,
) -> None:
    # A causal filter commutes with a linear model: filtering the input or the prediction is
    # the same thing (the default keeps the input filtered).
    problem = viscous_noise_free
    assert not problem.case.filters_prediction
    spec = problem.case.model_dump(by_alias=True, exclude_none=True)
    spec["preprocess"]["filter_prediction"] = True
    filtered = parse_case(spec, source=problem.case.source)
    other = UpdateProblem(filtered, load_experiment(filtered))
    assert other.fitted[0].filter
    x = problem.case.to_search(bridge.truth("viscous"))
    x[0] *= 1.01
    assert other(x) == pytest.approx(problem(x), rel=1e-6)


def test_records_carry_offsets_drift_and_noise(tmp_path: Path) -> None:
    case = parse_case(bridge.bridge_case("viscous", directory=str(tmp_path)), source="b.toml")
    manifest = virtual_experiment(case, bridge.truth("viscous"), tmp_path, seed=1,
                                  duration=1.0, snr=0.02)
    assert manifest["samples"] == 1036
    problem = UpdateProblem(case, load_experiment(case))
    floor = problem(case.to_search(bridge.truth("viscous")))
    # 2 % noise on the accelerations leaves a small but non-zero floor after processing.
    assert 1e-6 < floor < 0.05


def _kp1_extrema(case_spec: dict, data: Path) -> int:
    """Local extrema of φ along kp1 (±5 % of its range around the truth, 101 points)."""
    case = parse_case(case_spec, source=data.parent / "b.toml")
    problem = UpdateProblem(case, load_experiment(case))
    truth = bridge.truth("viscous")
    (param,) = [p for p in case.parameters if p.name == "kp1"]
    kp1 = np.linspace(-0.05, 0.05, 101) * (param.upper - param.lower) + truth["kp1"]
    rows = np.array([case.to_search({**truth, "kp1": v}) for v in kp1])
    phi = problem.evaluate_batch(rows)
    return int(np.sum(np.diff(np.sign(np.diff(phi))) != 0))


@pytest.mark.slow
def test_a_low_pass_below_the_abutment_modes_takes_the_ripples_out_of_kp1s_valley(
        tmp_path: Path) -> None:
    # kp1 moves two abutment modes near 226 Hz whose damping ratio is 2–3e-4: their ringing's
    # phase over the record slides as kp1 changes, and φ ripples along kp1's valley
    # (docs/posterior.md, section 6). Filtered out of records and prediction alike, it is gone.
    data = tmp_path / "data"
    spec = bridge.bridge_case("viscous", "narrow", directory=str(data))
    bridge.ensure_records(parse_case(spec, source=tmp_path / "b.toml"), bridge.truth("viscous"),
                          data, seed=1, snr=0.02)
    assert _kp1_extrema(spec, data) > 10
    spec["preprocess"]["lowpass_hz"] = 100.0
    assert _kp1_extrema(spec, data) <= 1

"""Case files on the reduced (large-model) path: ``[simulation] method = "reduced"``.

A 150-storey shear building (above the dense-eigensolver limit of 120 DOFs, so the Lanczos
iteration and its warm start are what run) with 3 stiffness parameters and a noise-free
virtual experiment of 3 s at 100 Hz, built by examples/large/make_case.py.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from femupdate._parallel import single_blas_thread
from femupdate.case import load_case, parse_case
from femupdate.case.simulation_path import REDUCED_MIN_DOF
from femupdate.errors import ConfigError
from femupdate.model.modes import natural_frequencies
from femupdate.model.sparse import lowest_modes
from femupdate.paper.bench import large_building as MAKE
from femupdate.pipeline.run import run_case
from femupdate.problem.case_model import CaseModel
from femupdate.problem.reduced_path import (
    TRUNCATION_WARN,
    describe_simulation,
    lowest_case_modes,
    simulation_record,
)
from femupdate.problem.update import UpdateProblem
from femupdate.simulate.reduced import ReducedSimulator
from femupdate.trials.experiment import load_experiments
from femupdate.trials.virtual import virtual_experiment

REPO = Path(__file__).resolve().parents[2]
STOREYS = 150
GROUPS = 3




def _case(directory: Path, method: str | None = "reduced", extra: str = "",
          storeys: int = STOREYS):
    text = MAKE.case_text(storeys, GROUPS, method=method, data_directory=str(directory))
    if extra:
        text = text.replace("[search]", extra + "\n[search]")
    return parse_case(tomllib.loads(text), source=directory / "case.toml")


@pytest.fixture(scope="module", autouse=True)
def _one_blas_thread():
    """As the runs have (the dense full model here is many times slower with more)."""
    with single_blas_thread():
        yield


@pytest.fixture(scope="module")
def data_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The noise-free records of the truth model (simulated on the full exact path)."""
    directory = tmp_path_factory.mktemp("reduced-case")
    virtual_experiment(_case(directory, "exact"), MAKE.truth(STOREYS, GROUPS), directory,
                       seed=3, snr=0.0, offset=0.0, drift=0.0, duration=3.0, rate=100.0,
                       length_scale=1.0)
    return directory


@pytest.fixture(scope="module")
def reduced(data_dir: Path) -> UpdateProblem:
    case = _case(data_dir)
    return UpdateProblem(case, load_experiments(case))


@pytest.fixture(scope="module")
def exact(data_dir: Path) -> UpdateProblem:
    case = _case(data_dir, "exact")
    return UpdateProblem(case, load_experiments(case))


def _points(problem: UpdateProblem, k: int = 3) -> np.ndarray:
    rng = np.random.default_rng(7)
    lo, hi = np.array(problem.bounds).T
    return lo + (hi - lo) * rng.uniform(0.1, 0.9, (k, lo.size))


# ----------------------------------------------------------------------------- the path


def test_reduced_case_runs_step_by_step_on_a_sparse_model(reduced: UpdateProblem) -> None:
    trial = reduced.fitted[0]
    assert reduced.case.simulation_method == "reduced"
    assert not reduced.compiled  # the reference path, not the dense compiled evaluator
    sim = trial.model.simulator(reduced.case.nominal(), trial.experiment.dt)
    assert isinstance(sim, ReducedSimulator)
    assert 0 < sim.n_modes < STOREYS
    assert sim.cutoff_hz == pytest.approx(2.0 * 50.0)  # 2 × the Nyquist frequency of 100 Hz


def test_reduced_phi_agrees_with_the_full_model_to_the_truncation_error(
        reduced: UpdateProblem, exact: UpdateProblem) -> None:
    assert exact.compiled
    record = simulation_record(reduced)
    err = record["truncation_error"]
    assert 0.0 < err < TRUNCATION_WARN
    for x in _points(reduced):
        trial_r, trial_e = reduced.fitted[0], exact.fitted[0]
        values = reduced.values(x)
        got = trial_r.scored(trial_r.prediction(trial_r.simulate(values)))
        ref = trial_e.scored(trial_e.prediction(trial_e.simulate(values)))
        rel = np.sum((got - ref) ** 2) / np.sum(ref**2)
        assert rel < 10 * err  # the error at the nominal point holds over the box
        phi_r, phi_e = reduced(x), exact(x)
        # φ = ‖p - d‖²/‖d‖²: a prediction off by ε (relative) moves √φ by at most √ε
        assert abs(np.sqrt(phi_r) - np.sqrt(phi_e)) <= 2 * np.sqrt(rel) * np.sqrt(
            np.sum(ref**2) / np.sum(trial_e.objective.target**2)) + 1e-12


def test_summary_record_says_which_path_ran(reduced: UpdateProblem,
                                            exact: UpdateProblem) -> None:
    record = simulation_record(reduced)
    assert record["method"] == "reduced" and record["n_dof"] == STOREYS
    assert record["against"].startswith("the full model")
    line = describe_simulation(record)
    assert line.startswith(f"simulation: reduced: {record['n_modes']} modes ≤ 100 Hz of "
                           f"{STOREYS} DOFs; truncation error")
    assert simulation_record(exact) == {"method": "exact", "n_dof": STOREYS}


def test_the_warm_start_changes_phi_only_by_rounding(reduced: UpdateProblem) -> None:
    """The nominal modes start every eigensolution; without a start (or with another) the
    kept modes, and so φ, are the same to rounding."""
    trial = reduced.fitted[0]
    dt = trial.experiment.dt
    path = trial.model.reduced
    for x in _points(reduced):
        values = reduced.values(x)
        system = path._structure.assemble(values, direction=path._direction, sparse=True)
        cold = ReducedSimulator(system, dt, trial.model.outputs, band_hz=path.band_hz(dt))
        warm = path.simulator(values, dt, trial.model.outputs)
        assert warm.n_modes == cold.n_modes
        np.testing.assert_allclose(warm.modes.freqs_hz, cold.modes.freqs_hz, rtol=1e-12)
        a, b = warm.run(trial._ag).acceleration, cold.run(trial._ag).acceleration
        assert np.max(np.abs(a - b)) <= 1e-9 * np.max(np.abs(b))


def test_phi_at_a_point_does_not_depend_on_what_was_evaluated_before(data_dir: Path) -> None:
    """The eigensolver starts from the nominal modes, never from the previous evaluation's:
    the same point gives the same bits in any order (as workers and resumes need)."""
    points = _points(_fresh(data_dir), 4)
    forward = _fresh(data_dir)
    ahead = [forward(x) for x in points]
    backward = _fresh(data_dir)
    behind = [backward(x) for x in points[::-1]][::-1]
    assert ahead == behind  # bit for bit, not to a tolerance
    again = [forward(x) for x in points[[2, 0, 3, 1]]]
    assert again == [ahead[i] for i in (2, 0, 3, 1)]


def _fresh(data_dir: Path) -> UpdateProblem:
    case = _case(data_dir)
    return UpdateProblem(case, load_experiments(case))


def test_frequencies_come_from_the_sparse_eigensolver(reduced: UpdateProblem) -> None:
    x = _points(reduced, 1)[0]
    values = reduced.values(x)
    dense = natural_frequencies(reduced.system(x)).freqs_hz
    got = reduced.frequencies(x)
    np.testing.assert_allclose(got, dense[:got.size], rtol=1e-10)
    assert got[-1] <= 100.0 < dense[got.size]  # those kept below the cut-off
    modes, damped, labels = lowest_case_modes(reduced.model.reduced, values, count=5)
    np.testing.assert_allclose(modes.freqs_hz, dense[:5], rtol=1e-10)
    assert len(labels) == STOREYS and damped.freqs_hz.size == 5


def test_n_modes_keeps_that_many(data_dir: Path) -> None:
    case = _case(data_dir, extra="")
    case = parse_case({**case.to_dict(), "simulation": {"method": "reduced", "n_modes": 7}},
                      source=case.source)
    model = CaseModel(case)
    sim = model.simulator(case.nominal(), 0.01)
    assert sim.n_modes == 7 and sim.cutoff_hz is None
    system = model.structure.assemble(case.nominal(), sparse=True)
    np.testing.assert_allclose(sim.modes.freqs_hz,
                               lowest_modes(system.K, system.M, n_modes=7).freqs_hz, rtol=1e-12)


# ----------------------------------------------------------------------------- the default


def test_large_linear_models_take_the_reduced_path_by_default(tmp_path: Path) -> None:
    big = _case(tmp_path, None, storeys=REDUCED_MIN_DOF)
    small = _case(tmp_path, None, storeys=REDUCED_MIN_DOF - 1)
    assert big.simulation_method == "reduced"
    assert small.simulation_method == "exact"
    assert CaseModel(small).reduced is None
    # the reduced path's fields are saved only when given: fingerprints of older cases stay
    assert "cutoff_factor" not in small.to_dict()["simulation"]
    assert "n_modes" not in small.to_dict()["simulation"]


def test_small_example_cases_keep_their_path() -> None:
    """Small examples keep the full path, but for the linear ones whose floors carry all the
    mass (rigid diaphragms: DOFs without mass, which only the reduced path condenses); a
    nonlinear one integrates its full model."""
    for path in sorted((REPO / "examples").glob("*/*.toml")):
        case = load_case(path)
        if path.parent.name == "large" or (case.model.diaphragms
                                           and not case.model.has_nonlinear):
            assert case.simulation_method == "reduced", path
        elif case.model.external is None:
            assert case.simulation_method in ("exact", "nonlinear"), path


# ----------------------------------------------------------------------------- bad input


def _issue(data_dir: Path, simulation: dict, match: str, storeys: int = STOREYS) -> None:
    case = _case(data_dir, None, storeys=storeys)
    with pytest.raises(ConfigError, match=match):
        parse_case({**case.to_dict(), "simulation": simulation}, source=case.source)


@pytest.mark.parametrize(("simulation", "match"), [
    ({"method": "exact", "cutoff_factor": 3.0},
     r"simulation\.cutoff_factor: got 3\.0 but the simulation method is 'exact'.*reduced"),
    ({"method": "newmark", "n_modes": 5},
     r"simulation\.n_modes: got 5 but the simulation method is 'newmark'"),
    ({"method": "reduced", "cutoff_factor": 0.5}, r"simulation\.cutoff_factor.*0\.5"),
    ({"method": "reduced", "n_modes": 0}, r"simulation\.n_modes"),
    ({"method": "reduced", "n_modes": STOREYS + 1},
     rf"simulation\.n_modes: got {STOREYS + 1} but the model has {STOREYS} DOFs.*1 to "
     rf"{STOREYS}"),
    ({"method": "reduced", "n_modes": 5, "cutoff_factor": 2.0},
     r"simulation\.n_modes: given with cutoff_factor"),
])
def test_bad_reduced_options_are_refused_naming_the_field(
        tmp_path: Path, simulation: dict, match: str) -> None:
    _issue(tmp_path, simulation, match)


def test_options_of_the_default_path_follow_the_size(tmp_path: Path) -> None:
    _issue(tmp_path, {"cutoff_factor": 3.0},
           r"simulation\.cutoff_factor: got 3\.0 but the simulation method is 'exact'",
           storeys=10)


def test_a_nonlinear_model_takes_the_reduced_path_only_when_asked(tmp_path: Path) -> None:
    """A friction model: "reduced" is Craig–Bampton (tests/simulate/test_craig_bampton.py),
    never the default; a linear method is refused naming the allowed ones."""
    case = _case(tmp_path, None, storeys=10)
    data = case.to_dict()
    data["model"]["shear_building"]["frictions"] = {"k_r": 100.0, "f_u": 1.0}
    data.pop("simulation", None)
    assert parse_case(data, source=case.source).simulation_method == "nonlinear"
    data["simulation"] = {"method": "reduced"}
    assert parse_case(data, source=case.source).simulation_method == "reduced"
    data["simulation"] = {"method": "exact"}
    with pytest.raises(ConfigError, match=r"simulation\.method: got 'exact' but the model "
                                          "has friction or Bouc–Wen elements"):
        parse_case(data, source=case.source)


# ----------------------------------------------------------------------------- runs


def _runs(data_dir: Path, workers: int):
    return run_case(_case(data_dir), None, runs=2, seed=5, max_evals=40, workers=workers,
                    sensitivities=False)


def _assert_same_bits(first, second) -> None:
    for a, b in zip(first.outcomes, second.outcomes, strict=True):
        assert a.fun == b.fun and a.nfev == b.nfev
        assert np.array_equal(a.x, b.x)


@pytest.fixture(scope="module")
def one_worker(data_dir: Path):
    return _runs(data_dir, workers=1)


@pytest.mark.slow
def test_same_seed_same_bits(data_dir: Path, one_worker) -> None:
    _assert_same_bits(one_worker, _runs(data_dir, workers=1))


def test_two_workers_give_the_bits_of_one(data_dir: Path, one_worker) -> None:
    _assert_same_bits(one_worker, _runs(data_dir, workers=2))


def test_the_summary_holds_the_truncation_error(one_worker) -> None:
    record = one_worker.summary.simulation
    assert record["method"] == "reduced"
    assert 0.0 < record["truncation_error"] < TRUNCATION_WARN
    assert record["trials"][0]["n_modes"] == record["n_modes"]
    assert record["cutoff_hz"] == pytest.approx(100.0)


def test_the_report_modes_of_a_reduced_case_are_the_full_models(data_dir: Path) -> None:
    from femupdate.report.facts import modes_at

    values = _case(data_dir).nominal()
    got = modes_at(CaseModel(_case(data_dir)), values, 4)
    ref = modes_at(CaseModel(_case(data_dir, "exact")), values, 4)
    for a, b in zip((got.undamped_hz, got.pole_hz, got.damping_ratios),
                    (ref.undamped_hz, ref.pole_hz, ref.damping_ratios), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-10)
    assert got.proportional and ref.proportional  # Rayleigh damping


def test_above_the_full_check_size_the_reference_has_four_times_the_cutoff(
        reduced: UpdateProblem, monkeypatch: pytest.MonkeyPatch) -> None:
    import femupdate.problem.reduced_path as rp

    monkeypatch.setattr(rp, "FULL_CHECK_MAX_DOF", STOREYS - 1)
    record = simulation_record(reduced)
    assert record["against"].startswith("the reduced model with 4× the cut-off")
    assert 0.0 <= record["truncation_error"] < TRUNCATION_WARN


def test_a_large_truncation_error_is_warned_about(data_dir: Path) -> None:
    from femupdate.errors import FemupdateWarning

    case = _case(data_dir)
    case = parse_case({**case.to_dict(), "simulation": {"method": "reduced", "n_modes": 2}},
                      source=case.source)
    problem = UpdateProblem(case, load_experiments(case))
    with pytest.warns(FemupdateWarning, match=r"truncation error is .* above 1e-06.*raise "
                                              r"\[simulation\] cutoff_factor"):
        record = simulation_record(problem)
    assert record["truncation_error"] > TRUNCATION_WARN and record["n_modes"] == 2

"""The compiled evaluator (femupdate.evaluation) against the step-by-step reference.

Every objective option on virtual experiments with noise, offsets and drift (so that φ is a
real misfit, not rounding): φ must equal ``UpdateProblem.phi_reference`` to 1e-12 relative.

Three kinds of point are themselves defined less sharply than that, and there the tolerance
is the reference's own sensitivity to rounding, measured in the test: the largest relative
change of the reference's φ when one parameter moves by one unit in the last place (2e-16
relative, physically nothing), capped at 1e-10.

- A linear model whose prediction is high-passed, then integrated twice: it is driven by the
  raw record, offsets and drift included, and the double integration amplifies the
  eigendecomposition's rounding of ~1e-13 (sensitivity 2e-12 causal, 1e-11 zero-phase).
- Close to the minimum of noise-free records: φ (1e-6) is then a small difference of large
  signals and its relative rounding grows as 1/√φ for both paths; the normalised residual √φ
  agrees to 1e-14.
- The frictional bridge, compared to 1e-10 outright: stick-slip transitions amplify rounding
  along the record (one ulp of one parameter moves the reference's φ by up to 1.5e-11 on the
  paper-length record) and central differences at ten substeps form accelerations as second
  differences that cancel four digits (differences up to 7e-12 measured at eight points, 7e-11
  with a zero-phase filter of the prediction; 1e-12 and 5e-11 with the generic kernel).

A batch gives the single calls' values bit for bit. No timings here:
``benchmarks/evaluation_cost.py`` measures them.
"""

from __future__ import annotations

import copy
import pickle
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from femupdate.case import parse_case
from femupdate.errors import ModelError
from femupdate.evaluation.assembly import assemble
from femupdate.paper.problems import bridge
from femupdate.problem.update import UpdateProblem
from femupdate.trials.experiment import load_experiment
from femupdate.trials.virtual import virtual_experiment

RTOL = 1e-12
#: The cap on a tolerance set by the reference's own sensitivity (module docstring).
SENSITIVE_RTOL_CAP = 1e-10
#: The frictional bridge's tolerance (module docstring).
FRICTION_RTOL = 1e-10
N_POINTS = 10


def _points(problem: UpdateProblem, n: int = N_POINTS, seed: int = 0) -> np.ndarray:
    """Random points of the search box (a reproducible draw)."""
    low, high = np.array(problem.bounds).T
    return low + (high - low) * np.random.default_rng(seed).random((n, low.size))


def _max_relative_difference(problem: UpdateProblem, X: np.ndarray) -> float:
    compiled = problem.evaluate_batch(X)
    reference = np.array([problem.phi_reference(x) for x in X])
    assert np.all(np.isfinite(reference))
    return float(np.max(np.abs(compiled - reference) / np.abs(reference)))


def _ulp_sensitivity(problem: UpdateProblem, X: np.ndarray) -> float:
    """The largest relative change of the reference's φ over the points when one parameter
    moves by one unit in the last place."""
    worst = 0.0
    for x in X:
        f0 = problem.phi_reference(x)
        for i in range(x.size):
            nudged = x.copy()
            nudged[i] = np.nextafter(nudged[i], np.inf)
            worst = max(worst, abs(problem.phi_reference(nudged) - f0) / abs(f0))
    return worst


def _assert_within_its_sensitivity(problem: UpdateProblem, X: np.ndarray) -> None:
    difference = _max_relative_difference(problem, X)
    if difference <= RTOL:
        return
    sensitivity = _ulp_sensitivity(problem, X)
    assert difference <= min(max(RTOL, sensitivity), SENSITIVE_RTOL_CAP), (
        f"compiled vs reference {difference:.3g}, the reference's 1-ulp sensitivity "
        f"{sensitivity:.3g}")


def _problem(spec: dict[str, Any], edit: Callable[[dict[str, Any]], None] | None = None
             ) -> UpdateProblem:
    spec = copy.deepcopy(spec)
    if edit is not None:
        edit(spec)
    case = parse_case(spec, source="case.toml")
    return UpdateProblem(case, load_experiment(case))


# --------------------------------------------------------------------------- the bridge


@pytest.fixture(scope="module")
def viscous_spec(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    data = tmp_path_factory.mktemp("viscous") / "data"
    spec = bridge.bridge_case("viscous", directory=str(data))
    virtual_experiment(parse_case(spec, source="b.toml"), bridge.truth("viscous"), data,
                       seed=5, duration=1.0, snr=0.02)
    return spec


@pytest.fixture(scope="module")
def friction_spec(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    data = tmp_path_factory.mktemp("friction") / "data"
    spec = bridge.bridge_case("friction", directory=str(data))
    virtual_experiment(parse_case(spec, source="f.toml"), bridge.truth("friction"), data,
                       seed=5, duration=1.0, snr=0.02)
    return spec


def _set(path: str, value: Any) -> Callable[[dict[str, Any]], None]:
    section, key = path.split(".")

    def edit(spec: dict[str, Any]) -> None:
        spec.setdefault(section, {})[key] = value

    return edit


def _weights(spec: dict[str, Any]) -> None:
    for channel, weight in zip(spec["data"]["outputs"], (1.0, 2.5, 0.4), strict=True):
        channel["weight"] = weight


def _accelerations(spec: dict[str, Any]) -> None:
    spec["objective"] = {"quantity": "acceleration", "experimental_parameters": False}


def _zero_phase_filtered(spec: dict[str, Any]) -> None:
    spec["preprocess"]["zero_phase"] = True
    spec["preprocess"]["filter_prediction"] = True


VISCOUS_OPTIONS = {
    "default": None,  # displacements integrated twice, experimental parameters
    "no-experimental-parameters": _set("objective.experimental_parameters", False),
    "model-displacements": _set("objective.integrate_prediction", False),
    "accelerations": _accelerations,
    "weights": _weights,
    "low-passed": _set("preprocess.lowpass_hz", 100.0),
}
FILTERED_VISCOUS_OPTIONS = {
    "filtered-prediction": _set("preprocess.filter_prediction", True),
    "zero-phase-filtered-prediction": _zero_phase_filtered,
    "low-passed-prediction": lambda spec: (_set("preprocess.filter_prediction", True)(spec),
                                           _set("preprocess.lowpass_hz", 100.0)(spec)),
}


@pytest.mark.parametrize("option", VISCOUS_OPTIONS)
def test_viscous_bridge_matches_the_reference(viscous_spec: dict[str, Any],
                                              option: str) -> None:
    problem = _problem(viscous_spec, VISCOUS_OPTIONS[option])
    assert _max_relative_difference(problem, _points(problem)) <= RTOL


@pytest.mark.parametrize("option", FILTERED_VISCOUS_OPTIONS)
def test_viscous_bridge_with_filtered_prediction_matches_the_reference(
        viscous_spec: dict[str, Any], option: str) -> None:
    problem = _problem(viscous_spec, FILTERED_VISCOUS_OPTIONS[option])
    _assert_within_its_sensitivity(problem, _points(problem, 5))


FRICTION_OPTIONS = {
    "default": None,  # prediction high-passed (causal), integrated, experimental parameters
    "zero-phase": _set("preprocess.zero_phase", True),
    "unfiltered-accelerations": lambda spec: (
        _accelerations(spec), _set("preprocess.filter_prediction", False)(spec)),
    "weights-no-experimental-parameters": lambda spec: (
        _weights(spec), _set("objective.experimental_parameters", False)(spec)),
    "low-passed": _set("preprocess.lowpass_hz", 100.0),
}


@pytest.mark.parametrize("option", FRICTION_OPTIONS)
def test_friction_bridge_matches_the_reference(friction_spec: dict[str, Any],
                                               option: str) -> None:
    problem = _problem(friction_spec, FRICTION_OPTIONS[option])
    assert _max_relative_difference(problem, _points(problem, 4)) <= FRICTION_RTOL


def test_the_generic_friction_kernel_matches_the_reference(friction_spec: dict[str, Any],
                                                           monkeypatch: pytest.MonkeyPatch
                                                           ) -> None:
    # Beyond codegen.MAX_TERMS products per step (or with no place to write a kernel) the
    # friction recurrence runs in the generic loops of central._kernel.
    from femupdate.evaluation import codegen

    monkeypatch.setattr(codegen, "MAX_TERMS", 0)
    problem = _problem(friction_spec)
    assert problem.evaluator._written is None
    assert _max_relative_difference(problem, _points(problem, 4)) <= FRICTION_RTOL


def test_near_a_noise_free_minimum_the_residual_matches(tmp_path: Path) -> None:
    # Close to the truth of noise-free records φ is a small difference of large signals
    # (1e-6 here): its relative rounding grows as 1/√φ for the reference as much as for the
    # compiled path. The normalised residual √φ agrees to rounding, and φ to within the
    # reference's own one-ulp sensitivity.
    spec = bridge.bridge_case("viscous", directory=str(tmp_path))
    truth = bridge.truth("viscous")
    virtual_experiment(parse_case(spec, source="b.toml"), truth, tmp_path, seed=5,
                       duration=1.0, snr=0.0, offset=0.0, drift=0.0)
    problem = _problem(spec)
    x0 = problem.case.to_search(truth)
    X = x0 * (1.0 + 3e-4 * np.random.default_rng(2).standard_normal((4, x0.size)))
    compiled = problem.evaluate_batch(X)
    reference = np.array([problem.phi_reference(x) for x in X])
    assert np.all((reference > 1e-9) & (reference < 1e-4))
    assert np.max(np.abs(np.sqrt(compiled) - np.sqrt(reference))) < 1e-13
    _assert_within_its_sensitivity(problem, X)


def test_batches_give_the_single_values_bit_for_bit(viscous_spec: dict[str, Any],
                                                    friction_spec: dict[str, Any]) -> None:
    for spec, n in ((viscous_spec, 12), (friction_spec, 7)):  # friction: lanes of 4 and 3
        problem = _problem(spec)
        X = _points(problem, n, seed=1)
        single = np.array([problem(x) for x in X])
        batch = problem.evaluate_batch(X)
        assert np.array_equal(single, batch)
        assert np.array_equal(problem.evaluate_batch(X[::-1])[::-1], batch)  # order-free
        assert np.array_equal(problem.evaluate_batch(X, threads=2), batch)
        # the threads are kept with their evaluators: more threaded batches build no more
        for _ in range(3):
            assert np.array_equal(problem.evaluate_batch(X, threads=2), batch)
        assert len(problem.fitted[0]._evaluators) <= 3  # this thread's and the pool's two


def test_residual_batches_give_the_single_vectors_bit_for_bit(viscous_spec: dict[str, Any],
                                                              friction_spec: dict[str, Any]
                                                              ) -> None:
    for spec, n in ((viscous_spec, 6), (friction_spec, 7)):  # friction: lanes of 4, 3
        problem = _problem(spec)
        X = _points(problem, n, seed=3)
        single = np.vstack([problem.residuals(x) for x in X])
        assert np.array_equal(problem.residuals_batch(X), single)
        assert np.array_equal(problem.residuals_batch(X, threads=2), single)


def test_minimize_takes_the_jacobian_columns_as_one_residual_batch(
        viscous_spec: dict[str, Any]) -> None:
    from femupdate import minimize

    problem = _problem(viscous_spec)
    calls: list[int] = []
    batch = problem.residuals_batch

    def counted(X: np.ndarray, **kw: Any) -> np.ndarray:
        calls.append(len(X))
        return batch(X, **kw)

    problem.residuals_batch = counted  # type: ignore[method-assign]
    kw = dict(seed=4, max_evals=40, residuals=True)
    batched = minimize(problem.residuals, problem.bounds, "multistart-lm", **kw)
    one_by_one = minimize(lambda x: problem.residuals(x), problem.bounds, "multistart-lm", **kw)
    assert max(calls) > 1  # the Jacobian's points came in batches
    assert batched.nfev == one_by_one.nfev == 40
    assert batched.x.tobytes() == one_by_one.x.tobytes() and batched.fun == one_by_one.fun


def test_a_pickled_problem_evaluates_the_same(viscous_spec: dict[str, Any]) -> None:
    problem = _problem(viscous_spec)
    X = _points(problem, 3)
    before = problem.evaluate_batch(X)
    clone = pickle.loads(pickle.dumps(problem))
    assert not clone.fitted[0]._evaluators  # buffers are rebuilt where it is unpickled
    assert np.array_equal(clone.evaluate_batch(X), before)


def test_threads_get_their_own_buffers(viscous_spec: dict[str, Any]) -> None:
    from concurrent.futures import ThreadPoolExecutor

    problem = _problem(viscous_spec)
    X = _points(problem, 8, seed=3)
    expected = problem.evaluate_batch(X)
    with ThreadPoolExecutor(4) as pool:
        got = list(pool.map(problem, list(X) * 3))
    assert np.array_equal(np.array(got), np.tile(expected, 3))


@pytest.mark.parametrize("method", ["newmark", "central_difference"])
def test_what_the_compiled_path_leaves_is_the_reference_itself(
        viscous_spec: dict[str, Any], method: str) -> None:
    # Newmark is not compiled; central differences with discrete dashpots (damping the modes
    # do not diagonalise) run in physical coordinates in the simulator: both go to the
    # reference, whose values are then returned unchanged.
    def edit(spec: dict[str, Any]) -> None:
        spec["simulation"] = {"method": method}
        spec["preprocess"]["substeps"] = 10

    problem = _problem(viscous_spec, edit)
    X = _points(problem, 2)
    assert np.array_equal(problem.evaluate_batch(X),
                          [problem.phi_reference(x) for x in X])


def test_out_of_range_values_raise_the_reference_error(viscous_spec: dict[str, Any]) -> None:
    problem = _problem(viscous_spec)
    x = _points(problem, 1)[0]
    x[problem.names.index("kp2")] = -1.0  # a negative stiffness: the Structure's own message
    with pytest.raises(ModelError, match="out of range"):
        problem.phi_reference(x)
    with pytest.raises(ModelError, match="out of range"):
        problem(x)


@pytest.mark.slow
def test_an_unstable_step_is_a_failed_evaluation(tmp_path: Path) -> None:
    # Records at 200 Hz, simulated without substeps: h ω_max > 2, the simulator refuses it.
    spec = bridge.bridge_case("friction", directory=str(tmp_path))
    spec["preprocess"]["substeps"] = 60
    virtual_experiment(parse_case(spec, source="f.toml"), bridge.truth("friction"), tmp_path,
                       seed=5, duration=1.0, rate=200.0, snr=0.02)
    problem = _problem(spec, _set("preprocess.substeps", 1))
    x = _points(problem, 1)[0]
    assert problem.phi_reference(x) == np.inf
    assert problem(x) == np.inf

    # With 4 substeps the stiffer points are unstable: a residual batch whose failed row is
    # followed by a good one still says why the failed one failed.
    problem = _problem(spec, _set("preprocess.substeps", 4))
    X = _points(problem, 40)
    phi = problem.evaluate_batch(X)
    pair = np.array([X[np.flatnonzero(np.isinf(phi))[0]], X[np.flatnonzero(np.isfinite(phi))[0]]])
    rows = problem.residuals_batch(pair)
    assert np.all(np.isinf(rows[0])) and np.all(np.isfinite(rows[1]))
    assert "step" in (problem.last_failure or "")


def test_the_reference_switch(viscous_spec: dict[str, Any],
                              monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FEMUPDATE_EVALUATOR", "reference")
    problem = _problem(viscous_spec)
    assert not problem.compiled
    x = _points(problem, 1)[0]
    assert problem(x) == problem.phi_reference(x)


# --------------------------------------------------------------------------- other models


SHEAR_BUILDING = {
    "case": {"name": "three-storey"},
    "model": {
        "shear_building": {"masses": [1.0, "m2", 0.8], "stiffnesses": ["k1", "k2", "k3"]},
        "rayleigh": {"alpha": "alpha", "beta": "beta"},
    },
    "parameters": [
        {"name": "m2", "lower": 0.5, "upper": 2.0},
        {"name": "k1", "lower": 1e3, "upper": 1e4, "scale": "log"},
        {"name": "k2", "lower": 1e3, "upper": 1e4, "scale": "log"},
        {"name": "k3", "lower": 1e3, "upper": 1e4, "scale": "log"},
        {"name": "alpha", "lower": 0.0, "upper": 1.0},
        {"name": "beta", "lower": 0.0, "upper": 1e-3},
    ],
    "data": {
        "format": "csv", "directory": "data", "time_column": "t",
        "input": {"file": "table.csv", "column": "table"},
        "outputs": [{"file": "floors.csv", "column": f"a{i}", "node": f"F{i}", "dof": "ux"}
                    for i in (1, 2, 3)],
    },
    "preprocess": {"highpass_hz": 0.5},
    "objective": {"quantity": "acceleration", "experimental_parameters": False},
    "search": {"method": "ab", "runs": 1, "max_evals": 10},
}
SHEAR_TRUTH = {"m2": 1.1, "k1": 4000.0, "k2": 3000.0, "k3": 2000.0, "alpha": 0.3,
               "beta": 2e-4}


@pytest.fixture(scope="module")
def shear_spec(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    data = tmp_path_factory.mktemp("shear") / "data"
    spec = copy.deepcopy(SHEAR_BUILDING)
    spec["data"]["directory"] = str(data)
    virtual_experiment(parse_case(spec, source="s.toml"), SHEAR_TRUTH, data, seed=2,
                       duration=4.0, rate=200.0, snr=0.02)
    return spec


@pytest.mark.parametrize("method", ["exact", "central_difference"])
def test_shear_building_with_mass_and_rayleigh_parameters(shear_spec: dict[str, Any],
                                                          method: str) -> None:
    # A parameter in M (re-assembled and inverted at every evaluation) and Rayleigh damping
    # (which the modes diagonalise: central differences run in the compiled modal kernel).
    def edit(spec: dict[str, Any]) -> None:
        spec["simulation"] = {"method": method}
        spec["preprocess"]["substeps"] = 1 if method == "exact" else 4

    problem = _problem(shear_spec, edit)
    assert not problem.evaluator.plan.fixed_mass
    assert _max_relative_difference(problem, _points(problem)) <= RTOL


def test_shear_building_with_friction_under_rayleigh_beta(shear_spec: dict[str, Any]) -> None:
    # Rayleigh's β (a parameter) never multiplies the friction sliders' stuck stiffness k_r
    # (a penalty of the stick-slip model): C = α M + β K of the storey springs, the same
    # bit for bit in the compiled assembly and Structure.assemble
    def edit(spec: dict[str, Any]) -> None:
        spec["model"]["shear_building"]["frictions"] = {"k_r": [800.0, 0.0, 500.0],
                                                        "f_u": 0.5}
        spec["preprocess"]["substeps"] = 4

    problem = _problem(shear_spec, edit)
    assert not problem.evaluator.plan.rayleigh_links
    X = _points(problem)
    assert _max_relative_difference(problem, X) <= RTOL
    ev = problem.evaluator
    m = ev.mats
    assemble(ev.plan, X[0], m.p, m.M, m.minv, m.C, m.K, m.load, m.kr, m.fu)
    values = dict(zip(problem.case.parameter_names, m.p, strict=True))
    system = problem.trials[0].structure.assemble(values)
    np.testing.assert_array_equal(m.C, system.C)  # the same sums, bit for bit
    np.testing.assert_allclose(system.C, values["alpha"] * system.M + values["beta"] * system.K,
                               rtol=1e-14, atol=0)


FRAME = {
    "case": {"name": "braced-portal"},
    "model": {
        "dofs_per_node": 3,
        "nodes": [{"name": "A", "x": 0.0}, {"name": "B", "x": 4.0},
                  {"name": "C", "x": 0.0, "y": 3.0}, {"name": "D", "x": 4.0, "y": 3.0}],
        "beams": [
            {"nodes": ["A", "C"], "E": "E", "A": 4e-3, "I": 2e-5, "rho": 7850.0},
            {"nodes": ["B", "D"], "E": "E", "A": 4e-3, "I": 2e-5, "rho": 7850.0},
            {"nodes": ["D", "C"], "E": "E", "A": 5e-3, "I": 3e-5, "rho": 7850.0, "nu": 0.3},
            {"nodes": ["A", "D"], "E": 2.1e11, "A": "Ab", "I": 1e-6, "rho": 7850.0},
        ],
        "dampers": [{"node": "C", "dof": "ux", "c": "c"}],
        "masses": [{"node": "C", "m": 200.0}, {"node": "D", "m": 200.0}],
        "supports": [{"node": "A", "dofs": ["ux", "uy", "rz"]},
                     {"node": "B", "dofs": ["ux", "uy"]}],
    },
    "parameters": [
        {"name": "E", "lower": 1.5e11, "upper": 2.5e11},
        {"name": "Ab", "lower": 5e-4, "upper": 5e-3},
        {"name": "c", "lower": 10.0, "upper": 2000.0},
    ],
    "data": {
        "format": "csv", "directory": "data", "time_column": "t",
        "input": {"file": "table.csv", "column": "table"},
        "outputs": [{"file": "top.csv", "column": "c", "node": "C", "dof": "ux"},
                    {"file": "top.csv", "column": "d", "node": "D", "dof": "uy"}],
    },
    "preprocess": {"highpass_hz": 1.0},
    "objective": {"quantity": "displacement", "experimental_parameters": True},
    "search": {"method": "ab", "runs": 1, "max_evals": 10},
}


def test_frame_with_inclined_members_and_moving_supports(tmp_path: Path) -> None:
    # Rotated element matrices (Tᵀ k T), an area parameter inside the shear parameter and the
    # mass (M re-assembled), and consistent beam mass coupled from the moving supports.
    spec = copy.deepcopy(FRAME)
    spec["data"]["directory"] = str(tmp_path / "data")
    virtual_experiment(parse_case(spec, source="p.toml"), {"E": 2.1e11, "Ab": 2e-3, "c": 500.0},
                       tmp_path / "data", seed=4, duration=1.0, rate=500.0, snr=0.02)
    problem = _problem(spec)
    assert problem.evaluator.plan.coupling_rows.size  # supports carry beam mass
    assert _max_relative_difference(problem, _points(problem)) <= RTOL


def test_minimize_evaluates_a_population_as_one_batch(viscous_spec: dict[str, Any]) -> None:
    # CMA-ES asks 5 candidates a step: one evaluate_batch call each, the same run as one by one.
    from femupdate import minimize

    problem = _problem(viscous_spec)
    calls = []

    class Counting:
        def __call__(self, x: np.ndarray) -> float:
            return problem(x)

        def evaluate_batch(self, X: np.ndarray) -> np.ndarray:
            calls.append(len(X))
            return problem.evaluate_batch(X)

    batched = minimize(Counting(), problem.bounds, "cmaes", seed=2, max_evals=40)
    single = minimize(lambda x: problem(x), problem.bounds, "cmaes", seed=2, max_evals=40)
    assert calls and set(calls) == {5}
    assert np.array_equal(batched.history["fun"], single.history["fun"])
    assert np.array_equal(batched.history["x"], single.history["x"])


def test_frame_beam_without_shear_deformation(tmp_path: Path) -> None:
    # shear_deformation = false with nu given: the compiled assembly's Φ is 0, as the
    # Structure's (and the same beam with shear deformation gives another φ)
    spec = copy.deepcopy(FRAME)
    spec["model"]["beams"][2]["shear_deformation"] = False
    spec["data"]["directory"] = str(tmp_path / "data")
    virtual_experiment(parse_case(spec, source="p.toml"), {"E": 2.1e11, "Ab": 2e-3, "c": 500.0},
                       tmp_path / "data", seed=4, duration=1.0, rate=500.0, snr=0.02)
    problem = _problem(spec)
    assert not problem.evaluator.plan.beam_shear[2]  # rigid in shear
    assert _max_relative_difference(problem, _points(problem)) <= RTOL

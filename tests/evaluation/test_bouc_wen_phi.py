"""φ of a model with Bouc–Wen elements: the compiled path against the step-by-step reference."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from femupdate.case import load_case
from femupdate.evaluation import evaluator_for
from femupdate.problem.update import UpdateProblem
from femupdate.trials.experiment import load_experiments
from femupdate.trials.virtual import virtual_experiment
from two_storey_case import DATA

CASE = """\
[case]
name = "two storeys, Bouc-Wen links"

[model.shear_building]
masses = [1.0, 0.8]
stiffnesses = [500.0, 0.0]
DAMPERS

[model.shear_building.bouc_wen]
k = ["k1", "k2"]
alpha = 0.1
beta = ["b1", 1.0e6]
gamma = "g"
n = 2.0

[model.shear_building.frictions]
k_r = [0.0, 800.0]
f_u = 0.8

[[parameters]]
name = "k1"
lower = 2000.0
upper = 8000.0
[[parameters]]
name = "k2"
lower = 1500.0
upper = 6000.0
[[parameters]]
name = "b1"
lower = 3.0e5
upper = 3.0e6
scale = "log"
[[parameters]]
name = "g"
lower = -2.0e5
upper = 2.5e5

[preprocess]
substeps = 5

[objective]
quantity = "QUANTITY"

""" + DATA
TRUTH = {"k1": 4000.0, "k2": 3000.0, "b1": 7.5e5, "g": 2.0e5}


def _problem(folder: Path, quantity: str, dampers: str) -> UpdateProblem:
    text = CASE.replace("QUANTITY", quantity).replace("DAMPERS", dampers)
    (folder / "case.toml").write_text(text)
    case = load_case(folder / "case.toml")
    virtual_experiment(case, TRUTH, folder / "data", seed=7, rate=200.0, duration=1.5,
                       pga_g=0.35)
    return UpdateProblem(case, load_experiments(case))


def _points(problem: UpdateProblem, count: int) -> np.ndarray:
    lower, upper = (np.array(b) for b in zip(*problem.bounds, strict=True))
    rng = np.random.default_rng(1)
    return lower + (upper - lower) * rng.random((count, lower.size))


def _compiled_and_reference(problem: UpdateProblem, count: int):
    """The first trial's compiled evaluator, ``count`` points, φ of its compiled run at them
    (every point on the compiled path: asserted) and φ of the reference path."""
    trial = problem.trials[0]
    evaluator = evaluator_for(trial)
    X = _points(problem, count)
    phi = np.empty(len(X))
    status = np.ones(len(X), dtype=np.int64)
    evaluator._run(np.ascontiguousarray(X), False, phi, status)
    assert not status.any()  # every point on the compiled path
    return evaluator, X, phi, np.array([trial.phi_reference(x) for x in X])


@pytest.mark.parametrize("quantity", ["acceleration", "displacement"])
def test_compiled_phi_equals_the_reference(tmp_path: Path, quantity: str) -> None:
    """Same recurrence, same law: φ to rounding; a batch is its
    single calls bit for bit; the residuals give φ. Measured: 2.6e-14 (accelerations),
    1.1e-13 (displacements)."""
    problem = _problem(tmp_path, quantity, "[model.rayleigh]\nalpha = 0.6")
    trial = problem.trials[0]
    evaluator = evaluator_for(trial)
    assert evaluator.bouc_wen is not None
    X = _points(problem, 6)
    reference = np.array([trial.phi_reference(x) for x in X])
    batch = evaluator.batch(X)
    phi = np.empty(len(X))
    status = np.ones(len(X), dtype=np.int64)
    evaluator._run(np.ascontiguousarray(X), False, phi, status)
    assert not status.any()  # every point on the compiled path
    np.testing.assert_allclose(batch, reference, rtol=1e-10, atol=0)
    assert np.array_equal(batch, [evaluator(x) for x in X])
    r = evaluator.residuals(X[0])
    assert r is not None and r @ r == pytest.approx(batch[0], rel=1e-12)


def test_non_proportional_damping_runs_the_physical_kernel(tmp_path: Path) -> None:
    """Storey dashpots couple the undamped modes: the physical-coordinate recurrence runs,
    compiled, and agrees with the reference's physical kernel to rounding (measured 4.4e-13;
    9.6e-13 in displacements)."""
    problem = _problem(tmp_path, "acceleration", "dampers = [0.5, 0.4]")
    evaluator, X, _, reference = _compiled_and_reference(problem, 4)
    np.testing.assert_allclose(evaluator.batch(X), reference, rtol=1e-10, atol=0)


@pytest.mark.parametrize("bouc_wen", [True, False])
def test_rayleigh_beta_on_the_links_compiled(tmp_path: Path, bouc_wen: bool) -> None:
    """β K₀ with the Bouc–Wen elements' initial stiffness (the default) in the compiled
    assembly as in Structure.assemble: φ to rounding on every point, compiled (the damping
    couples the modes: the physical kernel); and without the links (bouc_wen = false)
    another φ."""
    links = "" if bouc_wen else "\nbouc_wen = false"
    problem = _problem(tmp_path, "acceleration",
                       "[model.rayleigh]\nalpha = 0.6\nbeta = 1e-3" + links)
    _, _, phi, reference = _compiled_and_reference(problem, 4)
    np.testing.assert_allclose(phi, reference, rtol=1e-10, atol=0)
    system = problem.trials[0].structure.assemble(TRUTH)
    links = system.C - 0.6 * system.M - 1e-3 * system.K
    assert (np.abs(links).max() > 1.0) == bouc_wen  # β k₀ of the links, or nothing


@pytest.mark.parametrize("dampers", ["[model.rayleigh]\nalpha = 0.6", "dampers = [0.5, 0.4]"])
def test_compiled_phi_with_degradation(tmp_path: Path, dampers: str) -> None:
    """Degrading elements, δ_ν a search parameter: the compiled path (modal kernel with
    Rayleigh damping, physical with storey dashpots) carries the hysteretic energy as the
    simulator does, φ to rounding on every point; δ_ν moves φ."""
    text = CASE.replace("QUANTITY", "acceleration").replace("DAMPERS", dampers).replace(
        "n = 2.0\n", 'n = 2.0\ndelta_a = 2.0\ndelta_nu = "dnu"\ndelta_eta = [1.0, 0.0]\n'
    ).replace("[preprocess]", '[[parameters]]\nname = "dnu"\nlower = 0.0\nupper = 8.0\n\n'
              "[preprocess]")
    (tmp_path / "case.toml").write_text(text)
    case = load_case(tmp_path / "case.toml")
    virtual_experiment(case, {**TRUTH, "dnu": 4.0}, tmp_path / "data", seed=7, rate=200.0,
                       duration=1.5, pga_g=0.35)
    problem = UpdateProblem(case, load_experiments(case))
    evaluator, X, phi, reference = _compiled_and_reference(problem, 4)
    np.testing.assert_allclose(phi, reference, rtol=1e-10, atol=0)
    column = problem.names.index("dnu")
    still = X.copy()
    still[:, column] = problem.bounds[column][0]  # δ_ν = 0
    assert np.all(np.abs(evaluator.batch(still) - phi) > 1e-3 * phi)

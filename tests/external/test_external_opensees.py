"""The OpenSeesPy adapter against femupdate's own model of the same structure."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from external_helpers import Space, problem_for

from femupdate.errors import ConfigError, MissingDependencyError
from femupdate.external import ExternalRunner, OpenSeesModel
from femupdate.external.openseespy import import_opensees
from femupdate.model.modes import natural_frequencies
from femupdate.model.structure import Structure
from femupdate.simulate import prepare
from femupdate.trials.experiment import Experiment

try:
    import_opensees()  # the BLAS its wheel needs, before the model module imports it
except MissingDependencyError as exc:
    pytest.skip(f"openseespy is not installed or does not import here: {exc}",
                allow_module_level=True)

import opensees_small as small

HERE = Path(__file__).resolve().parent
MODULE = HERE / "opensees_small.py"
DT = 1 / 500
VALUES = {"E": 2.0e11, "k": 4e5, "c": 150.0}
MIDDLE = (2, 2)  # node 2, uy


SPACE = Space(("E", "k", "c"), ((1e11, 3e11), (1e5, 1e6), (0.0, 500.0)))


def _motion(n: int = 300) -> np.ndarray:
    t = np.arange(n) * DT
    return np.sin(2 * np.pi * 7.0 * t) * np.sin(np.pi * t / t[-1]) ** 2


def _experiment(ag: np.ndarray) -> Experiment:
    t = np.arange(ag.size) * DT
    return Experiment(t=t, ag=ag, accelerations=ag[:, None] * 2, target=ag[:, None] * 2,
                      quantity="acceleration", channels=("mid",), weights=np.ones(1))


def _builtin(values: dict[str, float], beam_mass: bool = True):
    s = Structure(dofs_per_node=2)
    for i, name in enumerate("ABC"):
        s.add_node(name, x=i * small.SPAN)
        s.add_mass(name, m=small.NODE_MASS, J=small.NODE_J)
    for a, b in ("AB", "BC"):
        s.add_beam(a, b, E="E", nu=small.POISSON, A=small.AREA, I=small.INERTIA,
                   rho=small.DENSITY if beam_mass else 0.0, kappa=small.KAPPA)
    s.add_spring("A", "uy", k="k")
    s.add_spring("C", "uy", k="k")
    s.add_spring("B", "uy", k=small.MID_SPRING)
    s.add_damper("B", "uy", c="c")
    s.add_damper("A", "rz", c=small.END_DAMPER)
    return s, s.assemble(values, direction="y")


def _runner(build: str, ag: np.ndarray, **options) -> ExternalRunner:
    """The adapter for the middle node's two DOFs, in its own process, under ``ag``."""
    model = OpenSeesModel(f"{MODULE}:{build}" if build else str(MODULE), [MIDDLE, (2, 3)],
                          direction=2, n_modes=4, eigen_solver="-fullGenLapack", **options)
    return ExternalRunner(model, ag, DT)


def _problem(build: str, ag: np.ndarray, **options):
    """φ of the same model through a case file's [model.opensees]."""
    exp = _experiment(ag)
    exp = Experiment(t=exp.t, ag=exp.ag, accelerations=np.repeat(exp.accelerations, 2, 1),
                     target=np.repeat(exp.target, 2, 1), quantity="acceleration",
                     channels=("mid", "mid_rz"), weights=np.ones(2))
    section = {"build": f"{MODULE}:{build}", "outputs": [list(MIDDLE), [2, 3]],
               "direction": 2, "n_modes": 4, "eigen_solver": "-fullGenLapack", **options}
    return problem_for({"opensees": section}, exp, space=SPACE)


@pytest.mark.slow
@pytest.mark.parametrize("algorithm", ["linear", "newton"])
def test_accelerations_equal_builtin_newmark(algorithm: str) -> None:
    ag = _motion()
    problem = _runner("build", ag, excitation="nodal", substeps=2, algorithm=algorithm)
    try:
        theirs = problem.predict(VALUES)
    finally:
        problem.close()
    s, system = _builtin(VALUES)
    out = [s.dof_index("B", "uy"), s.dof_index("B", "rz")]
    ours = prepare(system, DT, method="newmark", outputs=out, substeps=2).run(ag).acceleration
    assert np.max(np.abs(theirs - ours)) <= 1e-8 * np.max(np.abs(ours))


def test_frequencies_equal_builtin() -> None:
    problem = _runner("build", _motion(), excitation="nodal")
    try:
        theirs = problem.frequencies(VALUES)
    finally:
        problem.close()
    ours = natural_frequencies(_builtin(VALUES)[1])[0][:4]
    np.testing.assert_allclose(theirs, ours, rtol=1e-9)


def test_uniform_excitation_with_element_mass_is_refused() -> None:
    problem = _runner("build", _motion(), excitation="uniform")
    with pytest.raises(ConfigError, match=r"model\.build: UniformExcitation loads this model "
                                          r"with more \(or less\) than its mass: .* output 2\.2 "
                                          r"starts with relative acceleration -1\.[0-9]+ instead "
                                          r"of -1 .*excitation = 'nodal'"):
        problem.predict(VALUES)
    problem.close()


def test_a_script_with_nodal_masses_runs_under_uniform_excitation(tmp_path: Path) -> None:
    script = tmp_path / "small_script.py"
    script.write_text(f"import sys\nsys.path.insert(0, {str(HERE)!r})\n"
                      "import opensees_small\nopensees_small.build_massless_beams(params)\n")
    ag = _motion()
    model = OpenSeesModel(str(script), [MIDDLE], direction=2, quantity="displacement")
    problem = ExternalRunner(model, ag, DT)
    try:
        theirs = problem.predict(VALUES)
    finally:
        problem.close()
    s, system = _builtin(VALUES, beam_mass=False)
    ours = prepare(system, DT, method="newmark", outputs=[s.dof_index("B", "uy")]).run(ag)
    assert np.max(np.abs(theirs[:, 0] - ours.displacement[:, 0])) <= 1e-8 * np.max(
        np.abs(ours.displacement))


def test_a_failing_build_is_one_failed_evaluation() -> None:
    problem = _problem("build_that_fails", _motion(), excitation="nodal")
    try:
        ev = problem.evaluate(np.array([2e11, 4e5, 100.0]))
    finally:
        problem.close()
    assert ev.phi == np.inf
    assert ev.error.startswith("trial 'user': EvaluationError: building the OpenSees model (")
    assert "raised ValueError: no section for E = 2e+11" in ev.error


def test_missing_openseespy_names_the_extra(tmp_path: Path, monkeypatch: pytest.MonkeyPatch
                                            ) -> None:
    # The model's process sees this folder first on its path: openseespy fails to import.
    fake = tmp_path / "openseespy"
    fake.mkdir()
    (fake / "__init__.py").write_text("raise ImportError('no OpenSees here')\n")
    monkeypatch.setattr(sys, "path", [str(tmp_path), *sys.path])
    problem = _runner("build", _motion(), excitation="nodal")
    with pytest.raises(MissingDependencyError, match=r"pip install 'femupdate\[opensees\]'"):
        problem.predict(VALUES)
    problem.close()


def test_an_output_the_model_lacks_is_a_config_error() -> None:
    model = OpenSeesModel(f"{MODULE}:build", [(9, 2)], direction=2, excitation="nodal")
    problem = ExternalRunner(model, _motion(), DT)
    with pytest.raises(ConfigError, match=r"model\.outputs: got node 9: the model built by .* "
                                          r"has no such node \(allowed: its nodes \[1, 2, 3, "
                                          r"11, 12, 13\]\)"):
        problem.predict(VALUES)
    problem.close()


def test_an_analysis_that_does_not_converge_is_one_failed_evaluation() -> None:
    # One Newton iteration cannot pass a displacement-increment test: every step fails.
    problem = _problem("build", _motion(), excitation="nodal", algorithm="newton",
                       max_iterations=1, tolerance=1e-12)
    try:
        ev = problem.evaluate(np.array([2e11, 4e5, 100.0]))
    finally:
        problem.close()
    assert ev.phi == np.inf
    assert ev.error.startswith("trial 'user': EvaluationError: OpenSees analysis failed at t = "
                               "0.002 s "
                               "(sample 1 of 300; algorithm 'newton')")
    assert "the Algorithm failed at time 0.002" in ev.error  # OpenSees, from the model log

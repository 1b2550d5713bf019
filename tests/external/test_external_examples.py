"""The bridge of examples/bridge-external through its case files: the user's Python function and
the OpenSeesPy model reproduce the built-in model's virtual experiment."""

from __future__ import annotations

from pathlib import Path

import pytest

from femupdate.case import load_case
from femupdate.paper.problems import bridge
from femupdate.pipeline.run import with_data_directory
from femupdate.problem.update import UpdateProblem
from femupdate.trials.experiment import load_experiments
from femupdate.trials.virtual import virtual_experiment

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture(scope="module")
def records(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A short noise-free virtual experiment of the built-in viscous bridge's truth."""
    data = tmp_path_factory.mktemp("bridge-records")
    case = with_data_directory(load_case(EXAMPLES / "bridge" / "viscous-narrow.toml"), data)
    virtual_experiment(case, bridge.truth("viscous"), data, seed=1, duration=0.6, snr=0.0,
                       offset=0.0, drift=0.0)
    return data


@pytest.mark.slow
@pytest.mark.parametrize(("name", "floor"), [("python", 1e-20), ("opensees", 1e-5)])
def test_the_external_bridge_fits_the_builtin_records(records: Path, name: str,
                                                      floor: float) -> None:
    if name == "opensees":
        pytest.importorskip("openseespy", reason="needs the 'opensees' extra")
    case = with_data_directory(load_case(EXAMPLES / "bridge-external" / f"{name}.toml"), records)
    problem = UpdateProblem(case, load_experiments(case))
    try:
        truth = case.to_search(bridge.truth("viscous"))
        assert problem(truth) < floor  # OpenSees: Newmark's error at 10 substeps, not 0
        moved = truth.copy()
        moved[case.parameter_names.index("E")] += 0.02 * (case.bounds[0][1] - case.bounds[0][0])
        assert problem(moved) > 100 * max(problem(truth), 1e-12)
        builtin = load_case(EXAMPLES / "bridge" / "viscous-narrow.toml")
        expected = UpdateProblem(builtin, load_experiments(with_data_directory(builtin,
                                                                                records)))
        ours = problem.frequencies(truth)[:4]
        assert ours == pytest.approx(expected.frequencies(truth)[:4], rel=1e-9)
    finally:
        problem.close()

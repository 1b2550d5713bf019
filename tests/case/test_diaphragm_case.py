"""3-D buildings with rigid floor diaphragms and floor masses in ``[model]``: the example case
against OpenSeesPy's model of it (``rigidDiaphragm``, ``Transformation``), its path, and its
update from a virtual experiment."""

from __future__ import annotations

import json
import shutil
import tomllib
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from femupdate._parallel import single_blas_thread
from femupdate.case import load_case
from femupdate.case.simulation_path import model_dof_count
from femupdate.model.sparse import lowest_modes
from femupdate.problem.case_model import CaseModel
from femupdate.problem.update import UpdateProblem
from femupdate.trials.experiment import load_experiment
from femupdate.trials.virtual import virtual_experiment

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "frame3d"
CASE = EXAMPLE / "building.toml"
TRUTH = json.loads((EXAMPLE / "truth.json").read_text())
DOFS = ("ux", "uy", "uz", "rx", "ry", "rz")


@pytest.fixture(autouse=True)
def _one_blas_thread() -> Iterator[None]:
    with single_blas_thread():
        yield


def _opensees_frequencies(values: dict[str, float], count: int) -> np.ndarray:
    """The lowest ``count`` frequencies (Hz) of the example built in OpenSeesPy from the case
    file's tables: ElasticTimoshenkoBeam (shear area 5/6 A, the Timoshenko coefficient
    femupdate's 3-D beams take by default), nodal masses on the DOFs listed, rigidDiaphragm
    with the Transformation handler, the full generalised eigensolver (the mass matrix is
    singular: only the floors carry mass)."""
    from femupdate.external.openseespy import import_opensees

    ops = import_opensees()
    model = tomllib.loads(CASE.read_text())["model"]
    ops.wipe()
    ops.model("basic", "-ndm", 3, "-ndf", 6)
    tag = {node["name"]: i + 1 for i, node in enumerate(model["nodes"])}
    for node in model["nodes"]:
        ops.node(tag[node["name"]], node["x"], node["y"], node["z"])
    for support in model["supports"]:
        ops.fix(tag[support["node"]], *[int(d in support["dofs"]) for d in DOFS])
    lumped: dict[str, np.ndarray] = {}
    for mass in model["masses"]:
        m = values[mass["m"]] if isinstance(mass["m"], str) else mass["m"]
        row = lumped.setdefault(mass["node"], np.zeros(6))
        row[[DOFS.index(d) for d in mass["dofs"]]] += m
    for node, row in lumped.items():
        ops.mass(tag[node], *row.tolist())
    for floor in model["diaphragms"]:
        ops.rigidDiaphragm(3, tag[floor["master"]], *[tag[n] for n in floor["nodes"]])
    for e, beam in enumerate(model["beams"], start=1):
        E = values[beam["E"]] if isinstance(beam["E"], str) else beam["E"]
        ops.geomTransf("Linear", e, *beam["vecxz"])
        shear = 5.0 / 6.0 * beam["A"]
        ops.element("ElasticTimoshenkoBeam", e, *[tag[n] for n in beam["nodes"]], E,
                    E / (2.0 * (1.0 + beam["nu"])), beam["A"], beam["J"], beam["Iy"],
                    beam["Iz"], shear, shear, e)
    ops.constraints("Transformation")
    ops.numberer("RCM")
    ops.system("FullGeneral")
    w2 = np.asarray(ops.eigen("-fullGenLapack", count))
    ops.wipe()
    return np.sqrt(w2) / (2.0 * np.pi)


def test_example_building_is_opensees_rigid_diaphragm_model() -> None:
    """Its 6 modes (3 per floor: its 24 massless DOFs condensed) are OpenSeesPy's."""
    pytest.importorskip("openseespy")
    structure = CaseModel(load_case(CASE)).structure
    system = structure.assemble(TRUTH, direction="x", sparse=True)
    assert system.n_dof == structure.n_dof == model_dof_count(load_case(CASE).model) == 30
    ours = lowest_modes(system.K, system.M, cutoff_hz=1e4)
    assert ours.freqs_hz.size == 6
    np.testing.assert_allclose(ours.freqs_hz, _opensees_frequencies(TRUTH, 6), rtol=1e-9)


def test_example_building_takes_the_reduced_path_and_fits_its_truth(tmp_path: Path) -> None:
    """No [simulation] method: the reduced path (a model with DOFs without mass); φ at the
    truth is zero on its noise-free records and positive away from it; nothing truncated."""
    from femupdate.problem.reduced_path import simulation_record

    shutil.copy(CASE, tmp_path / CASE.name)
    case = load_case(tmp_path / CASE.name)
    assert case.simulation_method == "reduced"
    virtual_experiment(case, TRUTH, tmp_path / case.data.directory, seed=0, duration=3.0,
                       rate=200.0, snr=0.0, offset=0.0, drift=0.0, length_scale=1.0)
    problem = UpdateProblem(case, load_experiment(case))
    assert problem(TRUTH) < 1e-20
    assert problem({**TRUTH, "E1": 1.05 * TRUTH["E1"]}) > 1e-4
    record = simulation_record(problem)
    assert record["n_modes"] == 6 and record["truncation_error"] == 0.0
    assert record["against"].startswith("nothing (no mode truncated")

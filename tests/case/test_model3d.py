"""3-D frames in ``[model]`` (dofs_per_node = 6): the example case against the same frame built
with ``Frame3D``, its update from a virtual experiment, and the checks of its fields."""

from __future__ import annotations

import json
import tomllib
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from femupdate._parallel import single_blas_thread
from femupdate.case import load_case
from femupdate.case.model3d import mechanism_dofs
from femupdate.cli.commands import app
from femupdate.errors import ConfigError, ModelError
from femupdate.model.frame3d import Frame3D
from femupdate.model.modes import natural_frequencies
from femupdate.pipeline.run import run_case
from femupdate.problem.case_model import CaseModel
from femupdate.problem.update import TrialProblem
from femupdate.simulate import simulate
from femupdate.trials.experiment import load_experiment
from femupdate.trials.virtual import virtual_experiment

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "frame3d"
CASE = EXAMPLE / "frame.toml"
TRUTH = json.loads((EXAMPLE / "truth.json").read_text())


@pytest.fixture(autouse=True)
def _one_blas_thread() -> Iterator[None]:
    """One BLAS thread, as runs have: the 48-DOF eigenproblems of the step-by-step path (and
    of a run's summary, evaluated in this process) are several times slower with more threads
    on a loaded machine."""
    with single_blas_thread():
        yield


def _frame3d(values: dict[str, float]) -> Frame3D:
    """The example's frame built with ``Frame3D`` from the case file's tables (its masses'
    ``J`` on each rotation, as ``[model]`` documents)."""
    model = tomllib.loads(CASE.read_text())["model"]
    f = Frame3D()
    for node in model["nodes"]:
        f.add_node(node["name"], node["x"], node["y"], node["z"])
    for beam in model["beams"]:
        props = {k: (values[v] if isinstance(v, str) else v) for k, v in beam.items()
                 if k not in ("nodes", "vecxz")}
        f.add_beam(*beam["nodes"], vecxz=beam["vecxz"], **props)
    for mass in model["masses"]:
        m = mass["m"]
        j = mass.get("J", 0.0)
        f.add_mass(mass["node"], values[m] if isinstance(m, str) else m, Jx=j, Jy=j, Jz=j)
    for support in model["supports"]:
        f.fix(support["node"], *support["dofs"])
    f.set_rayleigh(model["rayleigh"]["alpha"], model["rayleigh"]["beta"])
    return f


def test_example_modes_equal_frame3d(tmp_path: Path) -> None:
    out = tmp_path / "modes.json"
    result = CliRunner().invoke(app, ["modes", str(CASE), "--params", json.dumps(TRUTH),
                                      "--json", str(out)])
    assert result.exit_code == 0, result.output
    got = np.array(json.loads(out.read_text())["frequencies_hz"])
    expected, _ = natural_frequencies(_frame3d(TRUTH).assemble().system)
    assert got.shape == expected.shape == (48,)
    np.testing.assert_allclose(got, expected, rtol=1e-10)


def test_example_time_history_equals_frame3d() -> None:
    case = load_case(CASE)
    model = CaseModel(case)
    t = np.arange(600) * 0.005
    ag = np.sin(2 * np.pi * 2.5 * t) * np.exp(-t)
    got = model.simulate(TRUTH, ag, 0.005).acceleration
    system = _frame3d(TRUTH).assemble().uniform_system("x")
    outputs = [system.dof_labels.index(f"{c.node}.{c.dof}") for c in case.data.outputs]
    expected = simulate(system, 0.005, ag=ag, outputs=outputs).acceleration
    assert np.abs(expected[:, 2]).max() > 1e-3 * np.abs(expected[:, 1]).max()  # it twists
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * np.abs(expected).max())


def test_example_updates_from_its_virtual_experiment(tmp_path: Path) -> None:
    """multistart-lm from the case's bounds reaches φ < 1e-6 on noise-free records; a channel
    across the shaking (C2.uy) is fitted as its own motion, not relative to the table."""
    case = load_case(CASE)
    virtual_experiment(case, TRUTH, tmp_path, seed=0, duration=3.0, rate=200.0, snr=0.0,
                       offset=0.0, drift=0.0, length_scale=1.0)
    text = CASE.read_text().replace('directory = "data-synth"', f'directory = "{tmp_path}"')
    (tmp_path / "frame.toml").write_text(text)
    case = load_case(tmp_path / "frame.toml")
    problem = TrialProblem(case, load_experiment(case))
    assert not problem.compiled  # the compiled assembly is planar
    assert problem.phi(TRUTH) < 1e-20
    result = run_case(case, runs=1, seed=1, sensitivities=False)
    best = result.summary.best
    assert best.phi < 1e-6
    # The run stops at its first point below the target: there the parameters are within a
    # few 1e-3 of the truth, not closer (measured, seeds 1, 2, 3: worst 1.07e-3, 2.1e-4,
    # 2.1e-3 at φ = 3.3e-7, 2.2e-7, 2.7e-7; before multistart-lm's Broyden updates 9.9e-4,
    # 5.1e-4, 2e-5 at φ = 6.9e-8, 4.2e-8, 1.5e-10).
    for name, value in TRUTH.items():
        assert best.params[name] == pytest.approx(value, rel=3e-3)


NODES = """
[case]
name = "bad"
[model]
dofs_per_node = 6
nodes = [{ name = "A", x = 0.0 }, { name = "B", x = 0.0, z = 3.0 }]
supports = [{ node = "A", dofs = ["ux", "uy", "uz", "rx", "ry", "rz"] }]
masses = [{ node = "B", m = 100.0, J = 1.0 }]
"""
BEAM = ('[[model.beams]]\nnodes = ["A", "B"]\nE = 2e11\nA = 1e-3\nrho = 7850.0\n')


def _load(tmp_path: Path, text: str) -> object:
    path = tmp_path / "case.toml"
    path.write_text(text)
    return load_case(path)


@pytest.mark.parametrize(("beam", "field", "said"), [
    ('nu = 0.3\nI = 1e-6\nIy = 1e-6\nIz = 1e-6\nJ = 1e-6\nvecxz = [1.0, 0.0, 0.0]',
     "model.beams[0].I", "given with dofs_per_node = 6"),
    ('nu = 0.3\nIy = 1e-6\nvecxz = [1.0, 0.0, 0.0]', "model.beams[0].Iz", "Iz, J missing"),
    ('nu = 0.3\nIy = 1e-6\nIz = 1e-6\nJ = 1e-6', "model.beams[0].vecxz", "vecxz missing"),
    ('nu = 0.3\nIy = 1e-6\nIz = 1e-6\nJ = 1e-6\nvecxz = [0.0, 0.0, 2.0]',
     "model.beams[0].vecxz", "is parallel to the beam"),
    ('Iy = 1e-6\nIz = 1e-6\nJ = 1e-6\nvecxz = [1.0, 0.0, 0.0]', "model.beams[0].G",
     "neither G nor nu"),
])
def test_3d_beam_fields_checked(tmp_path: Path, beam: str, field: str, said: str) -> None:
    with pytest.raises(ConfigError) as err:
        _load(tmp_path, NODES + BEAM + beam + "\n")
    line = next(li for li in str(err.value).splitlines() if field + ":" in li)
    assert said in line and "(allowed: " in line


def test_planar_model_refuses_3d_fields(tmp_path: Path) -> None:
    text = NODES.replace("dofs_per_node = 6", "dofs_per_node = 3").replace(
        'dofs = ["ux", "uy", "uz", "rx", "ry", "rz"]', 'dofs = ["ux", "uy", "rz"]')
    with pytest.raises(ConfigError) as err:
        _load(tmp_path, text + BEAM + "I = 1e-6\nIy = 1e-6\nJ = 1e-6\n")
    said = str(err.value)
    assert "model.nodes[1].z: z = 3 with dofs_per_node = 3" in said
    assert "model.beams[0].Iy: Iy, J given with dofs_per_node = 3" in said
    with pytest.raises(ConfigError, match=r"model.beams\[0\].I: missing"):
        _load(tmp_path, text.replace("z = 3.0", "y = 3.0") + BEAM)


def test_mechanism_named(tmp_path: Path) -> None:
    """A column pinned at its foot (rotations free) is a mechanism: one line names it."""
    text = NODES.replace('dofs = ["ux", "uy", "uz", "rx", "ry", "rz"]',
                         'dofs = ["ux", "uy", "uz", "rz"]')
    case = _load(tmp_path, text + BEAM + 'nu = 0.3\nIy = 1e-6\nIz = 1e-6\nJ = 1e-6\n'
                 'vecxz = [1.0, 0.0, 0.0]\n')
    with pytest.raises(ModelError) as err:
        CaseModel(case)
    message = str(err.value)
    assert "\n" not in message and "the 3-D frame is a mechanism" in message
    assert "A.rx" in message and "A.ry" in message and "(allowed: " in message
    fixed = _load(tmp_path, NODES + BEAM + 'nu = 0.3\nIy = 1e-6\nIz = 1e-6\nJ = 1e-6\n'
                  'vecxz = [1.0, 0.0, 0.0]\n')
    assert mechanism_dofs(CaseModel(fixed).structure, {}, "x") == []


def test_links_on_any_of_six_dofs(tmp_path: Path) -> None:
    """Springs and dampers on rotations and uz, partial supports and parameters in 3-D fields
    reach the Structure as `Structure.add_*` would put them."""
    from femupdate.model.structure import Structure

    beam = ('nu = 0.3\nIy = "Iy"\nIz = 1e-6\nJ = 1e-6\nvecxz = [1.0, 0.0, 0.0]\n'
            '[[model.springs]]\nnode = "B"\ndof = "rz"\nk = "kt"\n'
            '[[model.dampers]]\nnode = "B"\ndof = "uz"\nc = 7.0\n'
            '[[parameters]]\nname = "Iy"\nlower = 1e-7\nupper = 1e-5\n'
            '[[parameters]]\nname = "kt"\nlower = 0.0\nupper = 1e6\n')
    case = _load(tmp_path, NODES + BEAM + beam)
    values = {"Iy": 2e-6, "kt": 3e5}
    got = CaseModel(case).system(values)
    s = Structure(dofs_per_node=6)
    s.add_node("A", 0.0)
    s.add_node("B", 0.0, z=3.0)
    s.add_beam("A", "B", E=2e11, A=1e-3, rho=7850.0, nu=0.3, Iy=2e-6, Iz=1e-6, J=1e-6,
               vecxz=(1.0, 0.0, 0.0))
    s.add_spring("B", "rz", 3e5)
    s.add_damper("B", "uz", 7.0)
    s.add_mass("B", m=100.0, J=1.0)
    s.fix("A")
    expected = s.assemble(direction="x")
    assert got.dof_labels == expected.dof_labels
    for name in ("M", "C", "K"):
        np.testing.assert_array_equal(getattr(got, name), getattr(expected, name))
    assert got.C[got.dof_labels.index("B.uz"), got.dof_labels.index("B.uz")] == 7.0

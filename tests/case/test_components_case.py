"""A uniform base motion with several components in case files: [[data.components]] and an
input's angle, their checks, linear identities (45° = two components, superposition), the
explicit and implicit integrators on a hysteretic 3-D frame, and femupdate synth → load."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from femupdate.case import load_case, parse_case
from femupdate.errors import ConfigError
from femupdate.problem.case_model import CaseModel
from femupdate.simulate.components import angle_split, component_forces

DT = 0.01

# A one-storey 3-D frame, four columns on a 4 × 4 m square (symmetric about x = y), a mass on
# every roof node; {feet} holds the feet (supports and, for the nonlinear frame, Bouc–Wen links)
FRAME = """\
[case]
name = "components"

[model]
dofs_per_node = 6
rayleigh = {{ alpha = 0.2, beta = 1e-4 }}
nodes = [
    {{ name = "A0", x = 0.0, y = 0.0, z = 0.0 }}, {{ name = "B0", x = 4.0, y = 0.0, z = 0.0 }},
    {{ name = "C0", x = 4.0, y = 4.0, z = 0.0 }}, {{ name = "D0", x = 0.0, y = 4.0, z = 0.0 }},
    {{ name = "A1", x = 0.0, y = 0.0, z = 3.0 }}, {{ name = "B1", x = 4.0, y = 0.0, z = 3.0 }},
    {{ name = "C1", x = 4.0, y = 4.0, z = 3.0 }}, {{ name = "D1", x = 0.0, y = 4.0, z = 3.0 }},
]
beams = [
{beams}
]
masses = [
    {{ node = "A1", m = 1000.0, J = 10.0 }}, {{ node = "B1", m = 1000.0, J = 10.0 }},
    {{ node = "C1", m = 1000.0, J = 10.0 }}, {{ node = "D1", m = 1000.0, J = 10.0 }},{extra}
]
{feet}

[[parameters]]
name = "E"
lower = 1e11
upper = 3e11

{parameters}

[data]
format = "csv"
time_column = "t"
{inputs}

[[data.outputs]]
file = "roof.csv"
column = "C1x"
node = "C1"
dof = "ux"
[[data.outputs]]
file = "roof.csv"
column = "C1y"
node = "C1"
dof = "uy"
{simulation}
"""

SECTION = 'E = "E", nu = 0.3, A = 5.4e-3, Iy = 2.5e-5, Iz = 2.5e-5, J = 3.1e-7, rho = 7850.0'
COLUMNS = [("A0", "A1"), ("B0", "B1"), ("C0", "C1"), ("D0", "D1")]
GIRDERS = [("A1", "B1"), ("B1", "C1"), ("C1", "D1"), ("D1", "A1")]
BEAMS = ",\n".join(
    [f'    {{ nodes = ["{a}", "{b}"], {SECTION}, vecxz = [1.0, 0.0, 0.0] }}' for a, b in COLUMNS]
    + [f'    {{ nodes = ["{a}", "{b}"], {SECTION}, vecxz = [0.0, 0.0, 1.0] }}'
       for a, b in GIRDERS])
FIXED = "supports = [\n" + ",\n".join(
    f'    {{ node = "{a}", dofs = ["ux", "uy", "uz", "rx", "ry", "rz"] }}'
    for a, _ in COLUMNS) + ",\n]"
# The feet slide on Bouc–Wen links along x and y (yield at 2 mm), the other DOFs fixed
LINKED = ("supports = [\n" + ",\n".join(
    f'    {{ node = "{a}", dofs = ["uz", "rx", "ry", "rz"] }}' for a, _ in COLUMNS) + ",\n]\n"
    + "bouc_wen = [\n" + ",\n".join(
        f'    {{ node = "{a}", dof = "{d}", k = "k", alpha = 0.1, beta = 375.0, '
        f'gamma = 125.0 }}' for a, _ in COLUMNS for d in ("ux", "uy")) + ",\n]\n"
    # a soft spring beside each link (1e3 N/m, negligible beside the links' k)
    + "springs = [\n" + ",\n".join(
        f'    {{ node = "{a}", dof = "{d}", k = 1e3 }}' for a, _ in COLUMNS
        for d in ("ux", "uy")) + ",\n]")
# equipment on one corner: the roof twists, and x and y meet in the links
ECCENTRIC = '\n    { node = "C1", m = 3000.0 },'
K_PARAMETER = '[[parameters]]\nname = "k"\nlower = 1e6\nupper = 1e8\nscale = "log"'

COMPONENTS = """\
[[data.components]]
direction = "x"
file = "base.csv"
column = "ax"
[[data.components]]
direction = "y"
file = "base.csv"
column = "ay\""""

ANGLE = """\
[data.input]
file = "base.csv"
column = "a"
angle = {angle}"""


def _text(inputs: str = COMPONENTS, *, nonlinear: bool = False, simulation: str = "") -> str:
    return FRAME.format(beams=BEAMS, feet=LINKED if nonlinear else FIXED,
                        extra=ECCENTRIC if nonlinear else "",
                        parameters=K_PARAMETER if nonlinear else "", inputs=inputs,
                        simulation=simulation)


def _case(inputs: str = COMPONENTS, *, nonlinear: bool = False, simulation: str = ""):
    return parse_case(tomllib.loads(_text(inputs, nonlinear=nonlinear, simulation=simulation)))


def _record(n: int = 300, seed: int = 1) -> np.ndarray:
    """A smooth random acceleration (m/s²) from a passed seed."""
    rng = np.random.default_rng(seed)
    a = np.convolve(rng.standard_normal(n + 20), np.hanning(21), mode="valid")[:n]
    return 2.0 * a / np.abs(a).max() * np.hanning(n)


def _nmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sum((a - b) ** 2) / np.sum(b ** 2))


VALUES = {"E": 2.1e11}


def test_angle_split_is_cos_and_sin():
    a = _record()
    both = angle_split(a, 30.0)
    assert both.shape == (a.size, 2)
    np.testing.assert_allclose(both[:, 0], a * math.cos(math.pi / 6), rtol=1e-15)
    np.testing.assert_allclose(both[:, 1], a * 0.5, rtol=1e-15)


def test_component_forces_is_minus_sum_of_loads():
    ag = np.array([[1.0, 2.0], [3.0, -1.0]])
    loads = np.array([[1.0, 0.0], [0.0, 10.0], [2.0, 1.0]])
    np.testing.assert_array_equal(component_forces(ag, loads),
                                  [[-1.0, -20.0, -4.0], [-3.0, 10.0, -5.0]])


def test_case_reads_components_and_angle():
    case = _case()
    assert case.data.base_directions == ("x", "y")
    assert [name for name, _, _ in case.data.input_channels()] == ["input.x", "input.y"]
    angled = _case(ANGLE.format(angle=45))
    assert angled.data.base_directions == ("x", "y") and angled.data.angle == 45.0
    assert [name for name, _, _ in angled.data.input_channels()] == ["input"]
    model = CaseModel(case)
    assert model.components == ("x", "y")
    # the roof's ux sensor moves with the x component, its uy sensor with the y one
    np.testing.assert_array_equal(model.component_influence, [[1.0, 0.0], [0.0, 1.0]])


@pytest.mark.parametrize("method", ["exact", "newmark", "central_difference"])
def test_45_degrees_is_two_components_of_a_over_root_2(method):
    """One record at 45° equals the two components a/√2 along x and y (to rounding)."""
    a = _record()
    sim = f'\n[simulation]\nmethod = "{method}"' if method != "exact" else ""
    subs = "\n[preprocess]\nsubsteps = 20" if method == "central_difference" else ""
    angled = CaseModel(_case(ANGLE.format(angle=45), simulation=sim + subs))
    split = CaseModel(_case(simulation=sim + subs))
    one = angled.simulate(VALUES, angle_split(a, 45.0), DT)
    two = split.simulate(VALUES, np.column_stack([a, a]) / math.sqrt(2.0), DT)
    scale = np.abs(two.displacement).max()
    assert scale > 1e-6
    np.testing.assert_allclose(one.displacement, two.displacement, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(one.acceleration, two.acceleration, rtol=0,
                               atol=1e-12 * np.abs(two.acceleration).max())


def test_superposition_of_components_on_a_linear_model():
    """Linear: the response to x and y together is the sum of the responses to each."""
    ax, ay = _record(seed=2), _record(seed=3)
    model = CaseModel(_case())
    both = model.simulate(VALUES, np.column_stack([ax, ay]), DT)
    only_x = model.simulate(VALUES, np.column_stack([ax, 0 * ay]), DT)
    only_y = model.simulate(VALUES, np.column_stack([0 * ax, ay]), DT)
    total = only_x.displacement + only_y.displacement
    np.testing.assert_allclose(both.displacement, total, rtol=0,
                               atol=1e-12 * np.abs(total).max())
    # and the x component alone is the one-record case along x
    single = CaseModel(_case('[data.input]\nfile = "base.csv"\ncolumn = "a"'))
    along_x = single.simulate(VALUES, ax, DT)
    np.testing.assert_allclose(only_x.displacement, along_x.displacement, rtol=0,
                               atol=1e-12 * np.abs(along_x.displacement).max())
    np.testing.assert_allclose(only_x.acceleration, along_x.acceleration, rtol=0,
                               atol=1e-12 * np.abs(along_x.acceleration).max())


def test_nonlinear_frame_explicit_and_implicit_agree():
    """Bouc–Wen feet under two components: central differences at a fine step and the
    implicit scheme agree (NMSE ≤ 1e-4); the response is not the sum of the components'."""
    values = {"E": 2.1e11, "k": 2e7}
    ag = np.column_stack([_record(200, seed=4), _record(200, seed=5)]) * 4.0
    explicit = CaseModel(_case(nonlinear=True, simulation=(
        '\n[simulation]\nmethod = "nonlinear"\n[preprocess]\nsubsteps = 50')))
    implicit = CaseModel(_case(nonlinear=True, simulation=(
        '\n[simulation]\nmethod = "implicit"\n[preprocess]\nsubsteps = 4')))
    ref = explicit.simulate(values, ag, DT)
    got = implicit.simulate(values, ag, DT)
    assert not ref.diverged and not got.diverged
    gaps = _nmse(got.displacement, ref.displacement), _nmse(got.acceleration, ref.acceleration)
    print(f"implicit against explicit: NMSE {gaps[0]:.2g} (displacement), "
          f"{gaps[1]:.2g} (acceleration)")
    assert max(gaps) <= 1e-4
    # the links yield: x and y alone do not add up to x and y together
    only_x = explicit.simulate(values, ag * [1.0, 0.0], DT).displacement
    only_y = explicit.simulate(values, ag * [0.0, 1.0], DT).displacement
    apart = _nmse(only_x + only_y, ref.displacement)
    print(f"x alone + y alone against x and y together: NMSE {apart:.2g}")
    assert apart > 1e-3


@pytest.mark.parametrize(("inputs", "field", "words"), [
    (COMPONENTS.replace('direction = "y"', 'direction = "x"'), "data.components[1].direction",
     "already the direction of components[0]"),
    (ANGLE.format(angle=360), "data.input.angle", "360"),
    (ANGLE.format(angle=-10), "data.input.angle", "-10"),
    (COMPONENTS.replace('direction = "y"', 'direction = "w"'), "data.components[1].direction",
     "'w'"),
    (COMPONENTS + '\n[data.input]\nfile = "base.csv"\ncolumn = "a"', "data.components",
     "both data.input and data.components"),
])
def test_bad_components_are_one_line_config_errors(tmp_path, inputs, field, words):
    path = tmp_path / "bad.toml"
    path.write_text(_text(inputs))
    with pytest.raises(ConfigError) as info:
        load_case(path)
    message = str(info.value)
    line = next(line for line in message.splitlines() if field in line)
    assert str(path.name) in line and words in line


def test_missing_component_channel_names_file_and_field(tmp_path):
    from femupdate.trials.experiment import load_experiment

    path = tmp_path / "case.toml"
    path.write_text(_text(COMPONENTS))
    t = np.arange(100) * DT
    np.savetxt(tmp_path / "base.csv", np.column_stack([t, np.sin(t)]), delimiter=",",
               header="t,ax", comments="")
    np.savetxt(tmp_path / "roof.csv", np.column_stack([t, np.sin(t), np.cos(t)]),
               delimiter=",", header="t,C1x,C1y", comments="")
    with pytest.raises(Exception) as info:
        load_experiment(load_case(path))
    message = str(info.value)
    assert "base.csv" in message and "ay" in message and len(message.splitlines()) == 1


def test_a_direction_the_model_lacks_is_refused():
    text = _text(COMPONENTS)
    data = tomllib.loads(text)
    data["model"]["direction"] = "x"
    with pytest.raises(ConfigError, match=r"model\.direction"):
        parse_case(data)


def test_synth_writes_every_component_and_the_case_reads_them_back(tmp_path):
    from femupdate.trials.experiment import load_experiment
    from femupdate.trials.virtual import virtual_experiment

    path = tmp_path / "case.toml"
    path.write_text(_text(COMPONENTS))
    case = load_case(path)
    virtual_experiment(case, VALUES, tmp_path, seed=3, duration=2.0, rate=100.0, snr=0.0,
                       offset=0.0, drift=0.0, length_scale=1.0)
    lines = (tmp_path / "base.csv").read_text().splitlines()
    assert lines[1].split(",") == ["t", "ax", "ay"]
    experiment = load_experiment(case)
    assert experiment.ag.shape[1] == 2
    assert np.abs(experiment.ag[:, 0] - experiment.ag[:, 1]).max() > 0.1  # independent
    # the records fit the truth: φ at the truth is 0 to rounding (noise-free, no filters)
    from femupdate.problem.update import TrialProblem

    problem = TrialProblem(case, experiment)
    assert problem.phi(VALUES) < 1e-12


def test_synth_with_an_angle_writes_one_record(tmp_path):
    from femupdate.problem.update import TrialProblem
    from femupdate.trials.experiment import load_experiment
    from femupdate.trials.virtual import virtual_experiment

    path = tmp_path / "case.toml"
    path.write_text(_text(ANGLE.format(angle=30)))
    case = load_case(path)
    virtual_experiment(case, VALUES, tmp_path, seed=3, duration=2.0, rate=100.0, snr=0.0,
                       offset=0.0, drift=0.0, length_scale=1.0)
    assert (tmp_path / "base.csv").read_text().splitlines()[1] == "t,a"
    experiment = load_experiment(case)
    assert experiment.ag.shape[1] == 2
    np.testing.assert_allclose(experiment.ag[:, 1], experiment.ag[:, 0] * math.tan(
        math.radians(30.0)), atol=1e-12)
    assert TrialProblem(case, experiment).phi(VALUES) < 1e-12


def test_the_report_says_the_components():
    from femupdate.report.sections_runs import _excitation_text

    assert _excitation_text(_case()) == ("uniform base motion with components along x and y, "
                                         "a record each")
    assert _excitation_text(_case(ANGLE.format(angle=30))).startswith(
        "base motion at 30° from x")
    assert _excitation_text(_case('[data.input]\nfile = "b.csv"\ncolumn = "a"')) == (
        "base motion in x")


def test_reduced_path_takes_the_components():
    """The reduced path (lowest modes and a static correction) with every mode kept is the
    exact solution under two components; with 6 of 24 modes it stays within 1e-9."""
    ag = np.column_stack([_record(seed=2), _record(seed=3)])
    exact = CaseModel(_case()).simulate(VALUES, ag, DT)
    for n, limit in ((24, 1e-20), (6, 1e-9)):
        reduced = CaseModel(_case(simulation=f'\n[simulation]\nmethod = "reduced"\n'
                                             f'n_modes = {n}')).simulate(VALUES, ag, DT)
        assert _nmse(reduced.displacement, exact.displacement) <= limit
        assert _nmse(reduced.acceleration, exact.acceleration) <= limit


def test_example_isolated_frame_under_the_recorded_components(tmp_path):
    """examples/frames: the two free-field components of Meloland 1979 read by the network
    reader drive the hysteretic frame; noise-free records are fitted exactly at the truth."""
    import json
    import shutil

    from femupdate.problem.update import TrialProblem
    from femupdate.trials.experiment import load_experiment
    from femupdate.trials.virtual import virtual_experiment

    folder, script = _make_records_script()
    motion = script.free_field(script.DATA, start=3.0, seconds=3.0, scale=10.0)
    assert motion.ag.shape == (300, 2) and motion.dt == 0.01
    shutil.copy(folder / "isolated-frame.toml", tmp_path)
    case = load_case(tmp_path / "isolated-frame.toml")
    truth = json.loads((folder / "truth.json").read_text())
    virtual_experiment(case, truth, tmp_path / "data-synth", motion=motion, snr=0.0,
                       offset=0.0, drift=0.0)
    problem = TrialProblem(case, load_experiment(case))
    assert problem.phi(truth) < 1e-12
    assert problem.phi({**truth, "alpha": 0.2}) > 1e-3


def test_trials_give_their_own_components_in_the_same_directions():
    trials = ('\n[[trials]]\nname = "first"\n[[trials]]\nname = "second"\n'
              '[[trials.components]]\ndirection = "x"\nfile = "b2.csv"\ncolumn = "ax"\n'
              '[[trials.components]]\ndirection = "y"\nfile = "b2.csv"\ncolumn = "ay"\n')
    case = parse_case(tomllib.loads(_text() + trials))
    second = case.trial_specs()[1].data
    assert [c.file for c in second.components] == ["b2.csv", "b2.csv"]
    assert second.input is None and second.base_directions == ("x", "y")
    swapped = trials.replace('"x"', '"t"').replace('"y"', '"x"').replace('"t"', '"y"')
    with pytest.raises(ConfigError, match=r"trials\[1\]\.components: the base motion's "
                                          r"directions \['y', 'x'\] differ"):
        parse_case(tomllib.loads(_text() + swapped))
    one = ('\n[[trials]]\nname = "first"\n[[trials]]\nname = "second"\n'
           '[trials.input]\nfile = "b2.csv"\ncolumn = "a"\n')
    with pytest.raises(ConfigError, match=r"trials\[1\]\.components: .* differ"):
        parse_case(tomllib.loads(_text() + one))


@pytest.mark.parametrize("kind", ["bouc_wen", "frictions"])
@pytest.mark.parametrize("method", ["nonlinear", "implicit"])
def test_one_component_is_the_one_record_case_on_nonlinear_models(kind, method):
    """The components reach the nonlinear integrators as nodal forces: x alone equals the
    one-record case along x (its ``-p a_g`` load) to rounding, for Bouc–Wen and friction."""
    feet = LINKED
    if kind == "frictions":  # elasto-slip links in place of the Bouc–Wen ones
        feet = LINKED.replace("bouc_wen = [", "frictions = [").replace(
            'k = "k", alpha = 0.1, beta = 375.0, gamma = 125.0', 'k_r = "k", f_u = 4e4')
    sim = f'\n[simulation]\nmethod = "{method}"\n[preprocess]\nsubsteps = ' + (
        "50" if method == "nonlinear" else "4")

    def case(inputs: str):
        return parse_case(tomllib.loads(FRAME.format(
            beams=BEAMS, feet=feet, extra=ECCENTRIC, parameters=K_PARAMETER, inputs=inputs,
            simulation=sim)))

    values = {"E": 2.1e11, "k": 2e7}
    ax = 4.0 * _record(200, seed=4)
    two = CaseModel(case(COMPONENTS)).simulate(values, np.column_stack([ax, 0 * ax]), DT)
    one = CaseModel(case('[data.input]\nfile = "base.csv"\ncolumn = "a"')).simulate(
        values, ax, DT)
    scale = np.abs(one.displacement).max()
    assert scale > 1e-4
    np.testing.assert_allclose(two.displacement, one.displacement, rtol=0, atol=1e-10 * scale)
    np.testing.assert_allclose(two.acceleration, one.acceleration, rtol=0,
                               atol=1e-10 * np.abs(one.acceleration).max())


def test_implicit_method_in_an_ordinary_case(tmp_path):
    """``[simulation] method = "implicit"`` on a planar Bouc–Wen building: evaluated step by
    step (the compiled evaluator has no implicit scheme), φ = 0 at the truth of its records
    and the same φ elsewhere as central differences at a fine step."""
    from femupdate.problem.update import TrialProblem
    from femupdate.trials.experiment import load_experiment
    from femupdate.trials.virtual import virtual_experiment
    from two_storey_case import DATA, MODEL

    law = "[model.shear_building.bouc_wen]\nk = 3000.0\nalpha = 0.1\nbeta = 150.0\ngamma = 50.0\n"
    params = "".join(f'[[parameters]]\nname = "{n}"\nlower = 1000.0\nupper = 10000.0\n'
                     for n in ("k1", "k2")) + "".join(
        f'[[parameters]]\nname = "{n}"\nlower = 0.0\nupper = 5.0\n' for n in ("c1", "c2"))
    truth = {"k1": 4000.0, "k2": 2500.0, "c1": 1.2, "c2": 0.6}
    problems = {}
    for method, substeps in (("implicit", 4), ("nonlinear", 40)):
        folder = tmp_path / method
        folder.mkdir()
        (folder / "case.toml").write_text(
            MODEL + law + params + DATA + f'\n[simulation]\nmethod = "{method}"\n'
            f"[preprocess]\nsubsteps = {substeps}\n")
        case = load_case(folder / "case.toml")
        virtual_experiment(case, truth, folder / "data", seed=2, duration=2.0, rate=200.0,
                           snr=0.0, offset=0.0, drift=0.0, length_scale=1.0)
        problems[method] = TrialProblem(case, load_experiment(case))
    implicit = problems["implicit"]
    assert not implicit.compiled and implicit.model.method == "implicit"
    assert implicit.phi(truth) < 1e-12
    other = {**truth, "k1": 5000.0}
    a, b = implicit.phi(other), problems["nonlinear"].phi(other)
    assert b > 1e-3 and abs(a - b) < 0.02 * b


def test_cli_synth_then_run_a_case_with_components(tmp_path):
    """``femupdate synth`` writes both components; ``femupdate run`` fits the case on them."""
    import json

    from typer.testing import CliRunner

    from femupdate.cli.commands import app

    path = tmp_path / "case.toml"
    path.write_text(_text().replace("[data]\n", '[data]\ndirectory = "records"\n')
                    + "\n[search]\nruns = 1\nseed = 1\nmax_evals = 40\n")
    runner = CliRunner()
    made = runner.invoke(app, ["synth", str(path), "--truth", json.dumps(VALUES), "--out",
                               str(tmp_path / "records"), "--snr", "0", "--duration", "2",
                               "--rate", "100", "--length-scale", "1"])
    assert made.exit_code == 0, made.output
    assert (tmp_path / "records" / "base.csv").read_text().splitlines()[1] == "t,ax,ay"
    run = runner.invoke(app, ["run", str(path), "--out", str(tmp_path / "res")])
    assert run.exit_code == 0, run.output
    best = json.loads((tmp_path / "res" / "summary.json").read_text())["best"]
    assert best["params"]["E"] == pytest.approx(VALUES["E"], rel=1e-4)
    assert best["phi"] < 1e-6  # noise-free records of the case's own model


@pytest.mark.parametrize("inputs", [COMPONENTS, ANGLE.format(angle=30)])
def test_a_saved_case_with_components_reads_back_as_itself(inputs):
    case = _case(inputs)
    again = parse_case(case.to_dict())
    assert again.fingerprint() == case.fingerprint()
    assert again.data.base_directions == ("x", "y") and again.data.angle == case.data.angle


def test_component_loads_are_assembled_once_when_no_parameter_moves_the_mass():
    model = CaseModel(_case(nonlinear=True))
    first = model.component_loads({"E": 2.1e11, "k": 1e7})
    second = model.component_loads({"E": 1.5e11, "k": 3e7})
    assert second is first  # E and k leave M, and so p, as they are
    fresh = np.column_stack([model.structure.assemble({"E": 1.5e11, "k": 3e7},
                                                      direction=d).seismic_load for d in "xy"])
    assert np.array_equal(second, fresh)


def test_component_loads_follow_a_mass_parameter():
    text = _text(nonlinear=True).replace('{ node = "C1", m = 3000.0 }', '{ node = "C1", m = "m" }')
    text = text.replace("[data]", '[[parameters]]\nname = "m"\nlower = 1e3\nupper = 1e4\n\n[data]')
    model = CaseModel(parse_case(tomllib.loads(text)))
    light, heavy = ({"E": 2.1e11, "k": 1e7, "m": m} for m in (2e3, 5e3))
    loads = model.component_loads(light)
    assert not np.array_equal(model.component_loads(heavy), loads)
    for values in (light, heavy):
        fresh = np.column_stack([model.structure.assemble(values, direction=d).seismic_load
                                 for d in "xy"])
        assert np.array_equal(model.component_loads(values), fresh)


@pytest.mark.slow
def test_example_frame_on_100_links_under_the_recorded_components(tmp_path):
    """examples/frames/links-frame-100.toml: 100 Bouc–Wen links; its substeps are stable over
    the whole box; noise-free records of its truth are fitted at the truth; its response is
    smooth in the parameters (a change of 1e-12 moves it by rounding only, as footings under
    the links make it: on feet without mass it jumped by NMSE 3e-6)."""
    import json
    import shutil

    from femupdate.problem.update import TrialProblem
    from femupdate.simulate.implicit import explicit_stable_step
    from femupdate.trials.experiment import load_experiment
    from femupdate.trials.virtual import virtual_experiment

    folder, script = _make_records_script()
    shutil.copy(folder / "links-frame-100.toml", tmp_path)
    case = load_case(tmp_path / "links-frame-100.toml")
    truth = json.loads((folder / "links-frame-100-truth.json").read_text())
    model = CaseModel(case)
    assert model.structure.assemble(truth, direction="x").n_bouc_wen == 100
    stiffest = {**truth, "k_scale": case.parameters[0].upper}
    assert case.parameters[0].name == "k_scale"
    assert 0.01 / case.preprocess.substeps < explicit_stable_step(model.system(stiffest))
    motion = script.free_field(script.DATA, start=3.0, seconds=1.0, scale=1.0)
    virtual_experiment(case, truth, tmp_path / "data-links-frame-100", motion=motion, snr=0.0,
                       offset=0.0, drift=0.0)
    problem = TrialProblem(case, load_experiment(case))
    assert problem.phi(truth) < 1e-20
    assert problem.phi({**truth, "n": 2.2}) > 1e-5
    base = problem.simulate(truth).acceleration
    nudged = problem.simulate({**truth, "alpha": truth["alpha"] * (1 + 1e-12)}).acceleration
    assert _nmse(nudged, base) < 1e-16


def test_synth_shakes_the_frame_with_two_channels_of_a_network_archive(tmp_path):
    import shutil
    from pathlib import Path

    from typer.testing import CliRunner

    from femupdate.cli.commands import app
    from femupdate.data.io import read_csv
    from femupdate.data.network import read_network_records
    from femupdate.trials.virtual import recorded_motion

    folder = Path(__file__).resolve().parents[2] / "examples" / "frames"
    archive = folder.parents[1].parent / "shared" / "data" / "cesmd_meloland" / \
        "imperialvalley1979_ce01336.zip"
    if not archive.exists():
        pytest.skip(f"the Meloland records are not in {archive.parent}")
    shutil.copy(folder / "isolated-frame.toml", tmp_path)
    result = CliRunner().invoke(app, [
        "synth", str(tmp_path / "isolated-frame.toml"), "--truth", str(folder / "truth.json"),
        "--out", str(tmp_path / "out"), "--motion", str(archive), "--channels", "15,24",
        "--motion-start", "3", "--motion-seconds", "1", "--motion-scale", "10",
        "--length-scale", "1", "--rate", "100", "--snr", "0"])
    assert result.exit_code == 0, result.output
    x, y = read_network_records(archive, (15, 24))
    base = read_csv(tmp_path / "out" / "base.csv", time="t").channels
    # the window of both channels, scaled, at their own rate (resampling by 1 leaves them)
    np.testing.assert_allclose(base["ax"], 10.0 * x.acceleration[300:400], rtol=1e-12)
    np.testing.assert_allclose(base["ay"], 10.0 * y.acceleration[300:400], rtol=1e-12)
    said = " ".join(result.output.split())
    assert "channel 15 (360 Deg) and channel 24 (270 Deg), 1 s from 3 s, ×10" in said
    with pytest.raises(ConfigError, match=r"26 channels .*--channels naming one per"):
        recorded_motion(archive, rate=100.0, length_scale=1.0)
    with pytest.raises(ConfigError, match="the window holds no samples"):
        recorded_motion(archive, rate=100.0, length_scale=1.0, channels=(15,), start=1e4)


def _make_records_script():
    """(examples/frames, its make_records.py as a module); skips without the Meloland
    records."""
    import importlib.util
    from pathlib import Path

    folder = Path(__file__).resolve().parents[2] / "examples" / "frames"
    spec = importlib.util.spec_from_file_location("make_records", folder / "make_records.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    if not (script.DATA / script.EVENT).exists():
        pytest.skip(f"the Meloland records are not in {script.DATA}")
    return folder, script

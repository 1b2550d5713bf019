"""Multi-support excitation in case files: [[model.support_groups]], [data.inputs], checks,
the uniform limit, OpenSeesPy's MultipleSupport, and femupdate synth → run through the CLI."""

from __future__ import annotations

import importlib.util
import json
import re
from pathlib import Path

import numpy as np
import pytest

from femupdate.case import load_case, parse_case
from femupdate.errors import ConfigError, ModelError
from femupdate.model.structure import Structure
from femupdate.paper.bench.frame3d_check import support_records
from femupdate.paper.bench.multisupport_check import TRUTH, run_check, two_span_case
from femupdate.problem.case_model import CaseModel
from femupdate.simulate.multisupport import integrate_record

DT = 0.01

# The two-span beam of femupdate.paper.bench.multisupport_check as a case file; {groups}, {inputs}
# and {outputs} are replaced by the tests.
CASE = """\
[case]
name = "two-span"

[model]
dofs_per_node = 2
nodes = [{{name = "A", x = 0.0}}, {{name = "AB", x = 1.0}}, {{name = "B", x = 2.0}},
         {{name = "BC", x = 3.0}}, {{name = "C", x = 4.0}}]
beams = [
  {{nodes = ["A", "AB"], E = "E", A = 1e-4, I = 1e-9, rho = 7850.0}},
  {{nodes = ["AB", "B"], E = "E", A = 1e-4, I = 1e-9, rho = 7850.0}},
  {{nodes = ["B", "BC"], E = "E", A = 1e-4, I = 1e-9, rho = 7850.0}},
  {{nodes = ["BC", "C"], E = "E", A = 1e-4, I = 1e-9, rho = 7850.0}},
]
masses = [{{node = "AB", m = 1.0}}, {{node = "BC", m = 1.5}}]
supports = [{{node = "A", dofs = ["uy"]}}, {{node = "B", dofs = ["uy"]}},
            {{node = "C", dofs = ["uy"]}}]
{groups}

[model.rayleigh]
beta = "beta"

[[parameters]]
name = "E"
lower = 1e11
upper = 4e11
scale = "log"

[[parameters]]
name = "beta"
lower = 1e-5
upper = 1e-2
scale = "log"

[data]
format = "csv"
directory = "records"
time_column = "t"
{inputs}
{outputs}

[search]
runs = 1
seed = 3
max_evals = 400
"""

GROUPS = """\
[[model.support_groups]]
name = "west"
nodes = ["A"]
[[model.support_groups]]
name = "pier"
nodes = ["B"]
[[model.support_groups]]
name = "east"
nodes = ["C"]"""

INPUTS = """\
[data.inputs.west]
file = "supports.csv"
column = "west"
[data.inputs.pier]
file = "supports.csv"
column = "pier"
[data.inputs.east]
file = "supports.csv"
column = "east\""""

OUTPUTS = """\
[[data.outputs]]
file = "deck.csv"
column = "AB"
node = "AB"
dof = "uy"
[[data.outputs]]
file = "deck.csv"
column = "BC"
node = "BC"
dof = "uy"
relative_to = "pier\""""


def _write(tmp_path, groups=GROUPS, inputs=INPUTS, outputs=OUTPUTS):
    path = tmp_path / "two-span.toml"
    path.write_text(CASE.format(groups=groups, inputs=inputs, outputs=outputs))
    return path


def test_support_coupling_blocks_of_the_released_structure():
    s = Structure(dofs_per_node=2)
    for i, x in enumerate((0.0, 1.0, 2.0, 3.0, 4.0)):
        s.add_node(f"N{i}", x)
    for i in range(4):
        s.add_beam(f"N{i}", f"N{i + 1}", E="E", A=1e-4, I=1e-9, rho=7850.0)
    s.add_spring("N1", "uy", 50.0, node2="N2")  # a spring to a support DOF couples it
    supports = [("N0", "uy"), ("N2", "uy"), ("N4", "uy")]
    for node, dof in supports:
        s.fix(node, dof)
    s.set_rayleigh(0.1, 1e-3)
    values = {"E": 2.1e11}
    system = s.assemble(values)
    k_fs, m_fs, c_fs = s.support_coupling(values, supports)
    assert k_fs.shape == m_fs.shape == c_fs.shape == (system.n_dof, 3)
    # a rigid translation of every support strains nothing, and moves the beam rigidly
    np.testing.assert_allclose(system.K @ system.r + k_fs.sum(axis=1), 0.0,
                               atol=1e-9 * np.abs(system.K).max())
    np.testing.assert_allclose(c_fs, 0.1 * m_fs + 1e-3 * k_fs, rtol=1e-12, atol=1e-12)
    n1 = system.dof_labels.index("N1.uy")
    assert k_fs[n1, 1] < -50.0 + 1e-9 * np.abs(k_fs).max()  # the spring's -k in N1–N2
    assert np.abs(m_fs).max() > 0.0  # consistent beam mass couples the supports' inertia
    with pytest.raises(ModelError, match=r"N1\.uy not fixed"):
        s.support_coupling(values, [("N1", "uy")])


def test_one_group_moving_every_support_is_the_uniform_excitation(tmp_path):
    """With α = 0 (C r = β K r = 0 for a rigid motion) one record at every support is the
    table's: the same absolute accelerations, total = relative + ground displacement."""
    one = ('[[model.support_groups]]\nname = "all"\nnodes = ["A", "B", "C"]')
    outputs = OUTPUTS.replace('relative_to = "pier"', "")
    multi = load_case(_write(tmp_path, groups=one, inputs='[data.inputs.all]\nfile = "s.csv"\n'
                             'column = "all"', outputs=outputs))
    (tmp_path / "u").mkdir()
    uniform = load_case(_write(tmp_path / "u", groups="", inputs='[data.input]\nfile = "s.csv"'
                               '\ncolumn = "all"', outputs=outputs))
    acc = support_records(300, DT)[:, :1]
    total = CaseModel(multi).simulate(TRUTH, acc, DT)
    relative = CaseModel(uniform).simulate(TRUTH, acc[:, 0], DT)
    _, ground = integrate_record(acc, DT)
    scale = np.abs(relative.acceleration).max()
    np.testing.assert_allclose(total.acceleration, relative.acceleration, atol=1e-10 * scale)
    np.testing.assert_allclose(total.displacement, relative.displacement + ground,
                               atol=1e-10 * np.abs(ground).max())


def test_different_records_move_the_beam_differently():
    model = CaseModel(two_span_case("exact"))
    acc = support_records(300, DT)
    same = CaseModel(two_span_case("exact")).simulate(TRUTH, acc[:, [0, 0, 0]], DT)
    assert model.groups == ("west", "pier", "east")
    differ = model.simulate(TRUTH, acc, DT)
    assert np.abs(differ.displacement - same.displacement).max() > 0.1 * np.abs(
        same.displacement).max()


@pytest.mark.parametrize("groups, inputs, outputs, field, match", [
    (GROUPS.replace('nodes = ["A"]', "nodes = []"), INPUTS, OUTPUTS,
     r"model\.support_groups\[0\]\.nodes", "support group 'west' is empty"),
    (GROUPS.replace('nodes = ["B"]', 'nodes = ["Q"]'), INPUTS, OUTPUTS,
     r"model\.support_groups\[1\]\.nodes\[0\]", "support node 'Q' is not in the model"),
    (GROUPS, INPUTS.split("[data.inputs.east]")[0], OUTPUTS,
     r"data\.inputs", "support group 'east' has no input channel"),
    (GROUPS.replace('nodes = ["C"]', 'nodes = ["C", "A"]'), INPUTS, OUTPUTS,
     r"model\.support_groups\[2\]\.nodes\[1\]", r"node 'A' \(uy\) is already in "
     r"model\.support_groups\[0\]"),
    (GROUPS.replace('nodes = ["C"]', 'nodes = ["BC"]'), INPUTS, OUTPUTS,
     r"model\.support_groups\[2\]\.nodes\[0\]", "BC.uy is not fixed"),
    (GROUPS, INPUTS, OUTPUTS.replace('"pier"', '"peir"'),
     r"data\.outputs\[1\]\.relative_to", "'peir' is not a support group; did you mean 'pier'"),
    (GROUPS, INPUTS + '\n[data.inputs.north]\nfile = "s.csv"\ncolumn = "n"', OUTPUTS,
     r"data\.inputs\.north", "'north' is not a support group"),
    (GROUPS, '[data.input]\nfile = "s.csv"\ncolumn = "x"', OUTPUTS,
     r"data\.input", "one table record given, but the model has"),
    ("", INPUTS, OUTPUTS.replace('relative_to = "pier"', ""),
     r"data\.inputs", r"given without \[\[model\.support_groups\]\]"),
    (GROUPS, "", OUTPUTS, r"data\.input", "missing"),
])
def test_bad_support_groups_are_one_line_naming_the_field(tmp_path, groups, inputs, outputs,
                                                          field, match):
    with pytest.raises(ConfigError) as info:
        load_case(_write(tmp_path, groups, inputs, outputs))
    lines = str(info.value).splitlines()
    assert any(re.search(f"two-span.toml: {field}: .*{match}", line) for line in lines), lines


def test_bad_model_choices_with_support_groups():
    base = two_span_case().model_dump(mode="json")
    base["simulation"]["method"] = "reduced"
    with pytest.raises(ConfigError, match=r"simulation\.method: got 'reduced' with "
                                          r"\[\[model\.support_groups\]\]"):
        parse_case(base)
    base = two_span_case().model_dump(mode="json")
    base["model"]["frictions"] = [{"node": "AB", "dof": "uy", "k_r": 10.0, "f_u": 1.0}]
    base["simulation"]["method"] = None
    with pytest.raises(ConfigError, match=r"model\.support_groups: given with friction"):
        parse_case(base)


def test_uniform_cases_save_as_before():
    """The multi-support fields stay out of a uniform case's saved form (its fingerprint)."""
    case = two_span_case()
    assert "support_groups" in case.to_dict()["model"]
    data = case.model_dump(mode="json")
    data["model"]["support_groups"] = []
    data["data"]["inputs"] = None
    data["data"]["input"] = {"file": "s.csv", "column": "x"}
    saved = parse_case(data).to_dict()
    assert "support_groups" not in saved["model"] and "inputs" not in saved["data"]
    assert all("relative_to" not in out for out in saved["data"]["outputs"])


@pytest.mark.skipif(importlib.util.find_spec("openseespy") is None,
                    reason="openseespy is not installed (pip install openseespy)")
def test_case_model_agrees_with_opensees_multiple_support():
    figures = run_check(400, DT)
    assert max(figures.values()) <= 1e-8, figures


@pytest.mark.slow
def test_synth_then_run_recovers_the_parameters(tmp_path):
    from typer.testing import CliRunner

    from femupdate.cli.commands import app

    path = _write(tmp_path)
    runner = CliRunner()
    made = runner.invoke(app, ["synth", str(path), "--truth", json.dumps(TRUTH), "--out",
                               str(tmp_path / "records"), "--snr", "0", "--rate", "200",
                               "--duration", "2"])
    assert made.exit_code == 0, made.output
    header = (tmp_path / "records" / "supports.csv").read_text().splitlines()[1]
    assert header == "t,west,pier,east"
    ran = runner.invoke(app, ["run", str(path), "--out", str(tmp_path / "out"), "--json",
                              str(tmp_path / "run.json")], catch_exceptions=False)
    assert ran.exit_code == 0, ran.output
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    best = summary["best"]["params"]
    for name, value in TRUTH.items():
        assert best[name] == pytest.approx(value, rel=1e-5), (name, best)


def test_example_case_file_reads():
    case = load_case(Path(__file__).parents[2] / "examples" / "multisupport" / "two-span.toml")
    assert [g.name for g in case.model.support_groups] == ["west", "pier", "east"]
    assert CaseModel(case).reference.tolist() == [[0.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    frame = load_case(Path(__file__).parents[2] / "examples" / "multisupport"
                      / "frame3d-foundations.toml")
    assert CaseModel(frame).groups == ("south", "north")


@pytest.mark.parametrize("quantity", ["displacement", "acceleration"])
def test_noise_free_records_fit_the_truth_only(tmp_path, quantity):
    """Records made by the truth (one channel absolute, one relative to the pier) are read and
    processed as the model's prediction is: φ is 0 at the truth, not elsewhere."""
    from femupdate.problem.update import TrialProblem
    from femupdate.trials.experiment import load_experiment
    from femupdate.trials.virtual import virtual_experiment

    text = _write(tmp_path).read_text() + f'\n[objective]\nquantity = "{quantity}"\n'
    path = tmp_path / "two-span.toml"
    path.write_text(text)
    case = load_case(path)
    virtual_experiment(case, dict(TRUTH), tmp_path / "records", seed=5, snr=0.0, offset=0.0,
                       drift=0.0, duration=1.5, rate=200.0)
    experiment = load_experiment(case)
    assert experiment.ag.shape == (experiment.t.size, 3)
    problem = TrialProblem(case, experiment)
    assert problem.compiled  # femupdate.evaluation.supports
    assert problem.phi(TRUTH) < 1e-20
    assert problem.phi({**TRUTH, "E": 1.05 * TRUTH["E"]}) > 1e-4
    x = case.to_search(TRUTH)
    assert problem.phi_at(x) < 1e-20  # compiled
    assert problem.phi_at(x * 1.001) == pytest.approx(problem.phi_reference(x * 1.001),
                                                      rel=1e-10)


def test_a_3d_case_with_vertical_groups_is_the_frame3d_solution():
    """The two-span 3-D beam of femupdate.paper.bench.frame3d_check written as a case (dofs_per_node
    = 6, support groups along z) gives Frame3D's multi-support response at its outputs."""
    from femupdate.paper.bench.frame3d_check import SUPPORT_GROUPS, two_span_beam
    from femupdate.simulate.multisupport import multi_support_response

    frame = two_span_beam()
    section = dict(E=3e10, nu=0.2, A=0.5, Iy=0.02, Iz=0.04, J=0.03, rho=2500.0)
    nodes = frame.nodes
    supports = {}
    for g in sorted(frame._fixed):
        supports.setdefault(nodes[g // 6], []).append(
            ("ux", "uy", "uz", "rx", "ry", "rz")[g % 6])
    groups = [lab[0].split(".")[0] for lab in SUPPORT_GROUPS]
    alpha, beta = frame._rayleigh
    case = parse_case({
        "case": {"name": "two-span 3-D"},
        "model": {
            "dofs_per_node": 6,
            "nodes": [{"name": n, "x": xyz[0], "y": xyz[1], "z": xyz[2]}
                      for n, xyz in zip(nodes, frame._xyz, strict=True)],
            "beams": [{"nodes": [nodes[a], nodes[b]], "vecxz": [0.0, 0.0, 1.0], **section}
                      for _, a, b, _ in frame._beams],
            "supports": [{"node": n, "dofs": d} for n, d in supports.items()],
            "support_groups": [{"name": f"g{i}", "nodes": [n], "direction": "z"}
                               for i, n in enumerate(groups)],
            "rayleigh": {"alpha": alpha, "beta": beta},
        },
        "data": {"format": "csv", "rate": 100.0,
                 "inputs": {f"g{i}": {"file": "s.csv", "column": f"g{i}"}
                            for i in range(len(groups))},
                 "outputs": [{"file": "o.csv", "column": n, "node": n, "dof": "uz"}
                             for n in ("P4", "P12")]},
    })
    acc = support_records(200, DT)
    ours = CaseModel(case).simulate({}, acc, DT)
    model = frame.assemble()
    theirs = multi_support_response(model, SUPPORT_GROUPS, acc, DT)
    columns = [model.system.dof_labels.index(f"{n}.uz") for n in ("P4", "P12")]
    scale = np.abs(theirs.total[:, columns]).max()
    np.testing.assert_allclose(ours.displacement, theirs.total[:, columns], atol=1e-9 * scale)
    np.testing.assert_allclose(ours.acceleration, theirs.acceleration[:, columns],
                               atol=1e-9 * np.abs(theirs.acceleration[:, columns]).max())


def _synth(tmp_path, **options):
    from femupdate.trials.virtual import virtual_experiment

    case = load_case(_write(tmp_path))
    virtual_experiment(case, dict(TRUTH), tmp_path / "records", seed=5, snr=0.0, offset=0.0,
                       drift=0.0, duration=1.5, rate=200.0, **options)
    return case


def test_each_group_record_is_checked_on_its_own(tmp_path):
    """A support record in the wrong unit (its peak far beyond any earthquake) is found on
    that group's channel."""
    from femupdate.trials.experiment import load_experiment

    case = _synth(tmp_path)
    path = tmp_path / "records" / "supports.csv"
    lines = path.read_text().splitlines()
    rows = [line.split(",") for line in lines[2:]]
    for row in rows:
        row[2] = repr(1000.0 * float(row[2]))  # the pier's record, in mm/s² declared m/s²
    path.write_text("\n".join(lines[:2] + [",".join(r) for r in rows]) + "\n")
    with pytest.warns(Warning, match=r"input\.pier"):
        experiment = load_experiment(case)
    units = [f for f in experiment.defects if f.kind == "unit"]
    assert [f.channel for f in units] == ["input.pier"], experiment.defects


def test_one_recorded_motion_cannot_drive_several_groups(tmp_path):
    from femupdate.trials.virtual import Motion, simulate_truth

    case = load_case(_write(tmp_path))
    motion = Motion(support_records(100, DT)[:, 0], DT, "one record")
    with pytest.raises(ConfigError, match=r"3 support groups .* 1 record"):
        simulate_truth(case, dict(TRUTH), motion)


def test_the_report_lists_each_group_input_and_input_noise_refuses(tmp_path):
    from types import SimpleNamespace

    from femupdate.inference.input_noise import path_responses
    from femupdate.problem.update import TrialProblem
    from femupdate.report.sections_runs import _data_items
    from femupdate.trials.experiment import load_experiment

    case = _synth(tmp_path)
    ctx = SimpleNamespace(res=SimpleNamespace(case=case), truth=SimpleNamespace(manifest={}))
    items = dict(_data_items(ctx))
    assert [k for k in items if k.startswith("input")] == [
        "input (west)", "input (pier)", "input (east)"]
    assert "supports.csv [pier]" in items["input (pier)"]
    trial = TrialProblem(case, load_experiment(case))
    with pytest.raises(ConfigError, match="input-noise error model takes one table record"):
        path_responses(trial, dict(TRUTH), np.ones(10))


def test_a_trial_gives_its_own_support_records(tmp_path):
    from femupdate.trials.experiment import load_experiments
    from femupdate.trials.virtual import virtual_experiment

    case = _synth(tmp_path)
    virtual_experiment(case, dict(TRUTH), tmp_path / "records2", seed=6, snr=0.0, offset=0.0,
                       drift=0.0, duration=1.5, rate=200.0)
    (tmp_path / "records2" / "supports.csv").rename(tmp_path / "records2" / "other.csv")
    own = "".join(f'[trials.inputs.{g}]\nfile = "other.csv"\ncolumn = "{g}"\n'
                  for g in ("west", "pier", "east"))
    trials = ('[[trials]]\nname = "first"\n[[trials]]\nname = "second"\nrole = "validate"\n'
              'directory = "records2"\n')
    path = tmp_path / "two-span.toml"
    path.write_text(path.read_text() + "\n" + trials + own)
    first, second = load_experiments(load_case(path))
    assert second.name == "second" and not np.allclose(first.ag, second.ag)
    path.write_text(path.read_text().split("[trials.inputs.east]")[0])
    with pytest.raises(ConfigError, match=r"trials\[1\]\.inputs: support group 'east' has no "
                                          "input channel"):
        load_case(path)


def test_auto_delays_are_refused_with_support_groups(tmp_path):
    path = _write(tmp_path)
    path.write_text(path.read_text().replace('column = "AB"\n', 'column = "AB"\ndelay = "auto"\n'))
    with pytest.raises(ConfigError, match=r"data\.outputs\[0\]\.delay: \"auto\" with "):
        load_case(path)
    path.write_text(path.read_text().replace('delay = "auto"', "delay = 0.01"))
    assert load_case(path).data.outputs[0].delay == 0.01

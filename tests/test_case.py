"""Case files: loading, one test per kind of bad input, fingerprints, and the Structure built."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import ValidationError

from femupdate.case import Case, format_value, load_case, parse_case
from femupdate.errors import ConfigError
from femupdate.problem.case_model import build_structure

ROOT = Path(__file__).resolve().parents[1]
MINISHAKE = ROOT / "examples" / "minishake-1story" / "elcentro.toml"
DOCS = ROOT / "docs" / "case-files.md"

# A small beam on springs: deck A1 - P1 - A2 (2 DOF/node), both ends on the same spring "ka".
BASE = """\
[case]
name = "beam on springs"

[model]
dofs_per_node = 2

[[model.nodes]]
name = "A1"
x = 0.0

[[model.nodes]]
name = "P1"
x = 1.0

[[model.nodes]]
name = "A2"
x = 2.0

[[model.beams]]
nodes = ["A1", "P1"]
E = "E"
nu = 0.3
A = 3.0e-4
I = 7.3e-8
rho = 7850.0

[[model.beams]]
nodes = ["P1", "A2"]
E = "E"
nu = 0.3
A = 3.0e-4
I = 7.3e-8
rho = 7850.0

[[model.springs]]
node = "A1"
dof = "uy"
k = "ka"

[[model.springs]]
node = "A2"
dof = "uy"
k = "ka"

[[model.springs]]
node = "P1"
dof = "uy"
k = "kp"

[[model.dampers]]
node = "P1"
dof = "uy"
c = 20.0

[[model.masses]]
node = "P1"
m = 1.5

[[parameters]]
name = "E"
lower = 1.0e11
upper = 3.0e11

[[parameters]]
name = "ka"
lower = 1.0e5
upper = 1.0e8
scale = "log"

[[parameters]]
name = "kp"
lower = 0.0
upper = 1.0e6

[data]
format = "csv"
time_column = "t"

[data.input]
file = "table.csv"
column = "a"

[[data.outputs]]
file = "deck.csv"
column = "p1"
node = "P1"
dof = "uy"
"""


def write(tmp_path: Path, text: str, name: str = "case.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def edit(old: str, new: str, text: str = BASE, count: int = 1) -> str:
    assert text.count(old) >= count, f"test setup: {old!r} not in the base case"
    return text.replace(old, new, count)


def problems(tmp_path: Path, text: str) -> str:
    path = write(tmp_path, text)
    with pytest.raises(ConfigError) as info:
        load_case(path)
    return str(info.value)


def line_for(message: str, field: str) -> str:
    """The one line of ``message`` about ``field`` (fails if none)."""
    lines = [line for line in message.splitlines() if f": {field}: " in line]
    assert lines, f"no line about {field} in:\n{message}"
    return lines[0]


def assert_names(message: str, path: Path, field: str, *values: str) -> str:
    """The message has a line ``<file>: <field>: ...`` that shows each value and what's allowed."""
    line = line_for(message, field)
    assert line.strip().startswith(f"{path}: {field}: "), line
    for value in values:
        assert value in line, f"{value!r} not in {line!r}"
    assert "(allowed: " in line, line
    return line


# ----------------------------------------------------------------------------- valid cases


def test_minishake_example_loads() -> None:
    """The smaller, real case that docs/case-files.md points to."""
    case = load_case(MINISHAKE)
    assert case.source == MINISHAKE
    assert case.parameter_names == ("k1", "c1")
    # k1 is log scale on [500, 20000]: the search bounds are the log10 of the bounds
    assert case.bounds[0] == pytest.approx((math.log10(500.0), math.log10(20000.0)))
    assert case.bounds[1] == (0.0, 5.0)
    assert case.simulation_method == "exact"
    assert case.model.excitation_direction == "x"
    assert case.data is not None
    assert case.data_path(case.data.input).name == "stiff1_elcentro_t1_ground.csv"
    assert case.data_path(case.data.input).parent.name == "minishake_1story"
    assert case.data.outputs[0].delay == "auto"
    assert case.preprocess.delay_band_hz == [1.0, 10.0]
    assert "examples/minishake-1story/elcentro.toml" in DOCS.read_text(encoding="utf-8")


def test_base_case_loads_and_defaults_are_filled(tmp_path: Path) -> None:
    case = load_case(write(tmp_path, BASE))
    assert case.parameter_names == ("E", "ka", "kp")
    assert case.search.method == "multistart-lm" and case.search.runs == 1
    assert case.preprocess.highpass_order == 4 and case.preprocess.zero_phase is False
    assert case.preprocess.delay_band_hz == [1.0, 10.0]
    assert case.data is not None and case.data.outputs[0].delay == 0.0
    assert case.objective.quantity == "displacement"
    assert case.model.beams[0].kappa == pytest.approx(5 / 6)
    assert case.model.excitation_direction == "y"


def complete_example() -> str:
    text = DOCS.read_text(encoding="utf-8")
    blocks = re.findall(r"```toml\n(.*?)```", text, flags=re.S)
    complete = [b for b in blocks if b.startswith("# complete example")]
    assert len(complete) == 1, "docs/case-files.md must hold one '# complete example' block"
    return complete[0]


def test_documented_complete_example_loads(tmp_path: Path) -> None:
    case = load_case(write(tmp_path, complete_example()))
    structure = build_structure(case.model)
    assert structure.n_dof == 10  # 5 nodes × (uy, rz), as in the paper
    assert len(case.parameters) == 9


@pytest.mark.parametrize(("first_line", "parameters", "n_dof"), [
    ("[model.shear_building]", ["k1", "k2", "k3"], 3),  # 3 floors, ux each
    ("[model]\ndofs_per_node = 3", ["kr", "fu"], 6),     # 2 free nodes × (ux, uy, rz)
])
def test_documented_model_snippets_are_valid(first_line: str, parameters: list[str],
                                             n_dof: int) -> None:
    import tomllib

    text = DOCS.read_text(encoding="utf-8")
    block = next(b for b in re.findall(r"```toml\n(.*?)```", text, flags=re.S)
                 if b.startswith(first_line))
    data = tomllib.loads('[case]\nname = "snippet"\n' + block)
    data["parameters"] = [{"name": n, "lower": 1.0, "upper": 1e4} for n in parameters]
    assert build_structure(parse_case(data).model).n_dof == n_dof


def test_documented_error_messages_are_the_real_ones(tmp_path: Path, monkeypatch) -> None:
    """The "Common errors" of docs/case-files.md, reproduced from the complete example."""
    docs = DOCS.read_text(encoding="utf-8")
    base = complete_example()

    def variant(*changes: tuple[str, str]) -> str:
        text = base
        for old, new in changes:
            text = edit(old, new, text)
        return text

    params = base[base.index("[[parameters]]"):base.index("[data]")]
    texts = [
        '[case]\nname = "x"\n\n[model]\ndofs_per_node = two\n',
        variant((params, '[parameters]\nname = "E"\nlower = 1e11\nupper = 3e11\n\n')),
        variant(('E = "E"                    # updated', "E = -2e11\nEe = 3"),
                ('nodes = ["P1", "P2"]\nE = "E"\nnu = 0.3\nA = 1.71e-4',
                 'nodes = ["P1", "P2"]\nE = "E"\nnu = 0.3\nA = "1.71e-4"')),
        variant(("lower = 1.0e11\nupper = 3.0e11", "lower = 3.0e11\nupper = 1.0e11"),
                ("lower = 1.0e7", "lower = 0.0")),
        variant(('nodes = ["P3", "A2"]', 'nodes = ["P3", "A3"]'),
                ('node = "P1"\ndof = "uy"\nk = "kp2"', 'node = "P1"\ndof = "ux"\nk = "kp2"')),
        variant(('c = "c4"', 'c = "c5"'),
                ('name = "c1"\nlower = 0.0', 'name = "c1"\nlower = -10.0')),
    ]
    monkeypatch.chdir(tmp_path)  # messages name the file as given: "bridge.toml"
    for text in texts:
        Path("bridge.toml").write_text(text, encoding="utf-8")
        with pytest.raises(ConfigError) as info:
            load_case("bridge.toml")
        for line in str(info.value).splitlines():
            assert line in docs, f"not in docs/case-files.md:\n{line}"


def test_every_field_is_documented() -> None:
    # The external models' sections are documented with them.
    text = DOCS.read_text(encoding="utf-8") + DOCS.with_name("external-models.md").read_text(
        encoding="utf-8")
    sections = {
        "case": Case.model_fields["case"].annotation,
        "model": Case.model_fields["model"].annotation,
    }
    missing = [
        f"{section}.{name}"
        for section, model in sections.items()
        for name in model.model_fields  # type: ignore[union-attr]
        if f"`{name}`" not in text
    ]
    from femupdate import case as c

    for model in (c.Node, c.Beam, c.Spring, c.Damper, c.Friction, c.Mass, c.Support,
                  c.SupportGroup,
                  c.Rayleigh, c.ShearBuilding, c.Parameter, c.Data, c.Channel,
                  c.OutputChannel, c.Trial, c.Preprocess, c.ObjectiveOptions, c.Simulation,
                  c.PythonModelSection, c.OpenSeesSection,
                  c.Search):
        missing += [f"{model.__name__}.{n}" for n in model.model_fields if f"`{n}`" not in text]
    assert not missing, f"fields not documented in docs/case-files.md: {missing}"


# ----------------------------------------------------------------------------- bad input


def test_toml_syntax_error_names_file_line_and_column(tmp_path: Path) -> None:
    text = '[case]\nname = "x"\n\n[model]\ndofs_per_node = two\n'
    message = problems(tmp_path, text)
    path = tmp_path / "case.toml"
    assert message.startswith(f"{path}:5:17: TOML syntax error")
    assert "line 5, column 17" in message
    assert "dofs_per_node = two" in message  # the offending line is shown


def test_missing_file() -> None:
    with pytest.raises(ConfigError, match=r"case file not found: .*nowhere\.toml"):
        load_case("nowhere.toml")


def test_unknown_field_is_refused(tmp_path: Path) -> None:
    message = problems(tmp_path, edit("rho = 7850.0\n", "rho = 7850.0\nEe = 3\n"))
    line = assert_names(message, tmp_path / "case.toml", "model.beams[0].Ee", "'Ee'")
    assert "did you mean 'E'?" in line
    assert "kappa" in line  # the allowed fields are listed


def test_unknown_section_is_refused(tmp_path: Path) -> None:
    message = problems(tmp_path, BASE + "\n[serach]\nruns = 3\n")
    line = assert_names(message, tmp_path / "case.toml", "serach", "'serach'")
    assert "did you mean 'search'?" in line


def test_out_of_range_value(tmp_path: Path) -> None:
    message = problems(tmp_path, edit('E = "E"', "E = -2e11"))
    assert_names(message, tmp_path / "case.toml", "model.beams[0].E", "-2e11", "[0, 1e13]",
                 "Pa")


def test_out_of_range_integer(tmp_path: Path) -> None:
    message = problems(tmp_path, BASE + "\n[preprocess]\nhighpass_order = 12\n")
    assert_names(message, tmp_path / "case.toml", "preprocess.highpass_order", "12",
                 "an integer in [1, 8]")


def test_wrong_type_and_quoted_number(tmp_path: Path) -> None:
    text = edit("I = 7.3e-8", 'I = "7.3e-8"', edit("rho = 7850.0", "rho = true"))
    message = problems(tmp_path, text)
    assert_names(message, tmp_path / "case.toml", "model.beams[0].rho", "true", "not a number")
    assert_names(message, tmp_path / "case.toml", "model.beams[0].I", "'7.3e-8'",
                 "remove the quotes")


def test_bad_choice_lists_the_choices(tmp_path: Path) -> None:
    message = problems(tmp_path, BASE + '\n[search]\nmethod = "pso"\n')
    assert_names(message, tmp_path / "case.toml", "search.method", "'pso'", "'ab'", "'cmaes'")


def test_reversed_bounds(tmp_path: Path) -> None:
    text = edit("lower = 1.0e11\nupper = 3.0e11", "lower = 3.0e11\nupper = 1.0e11")
    message = problems(tmp_path, text)
    line = assert_names(message, tmp_path / "case.toml", "parameters[0].upper", "'E'",
                        "3e11", "1e11", "lower < upper")
    assert "reversed bounds" in line


def test_log_scale_needs_positive_lower_bound(tmp_path: Path) -> None:
    text = edit("lower = 1.0e5\nupper = 1.0e8", "lower = 0.0\nupper = 1.0e8")
    message = problems(tmp_path, text)
    assert_names(message, tmp_path / "case.toml", "parameters[1].lower", "'ka'", "got 0",
                 "lower > 0")


def test_undeclared_parameter(tmp_path: Path) -> None:
    message = problems(tmp_path, edit("c = 20.0", 'c = "kpp"'))
    line = assert_names(message, tmp_path / "case.toml", "model.dampers[0].c", "'kpp'",
                        "not declared")
    assert "did you mean 'kp'?" in line
    assert "'E', 'ka', 'kp'" in line


def test_optional_properties_may_name_parameters(tmp_path: Path) -> None:
    text = edit("nu = 0.3", 'G = "G_deck"').replace(
        "[data]", '[[parameters]]\nname = "G_deck"\nlower = 5e10\nupper = 9e10\n\n[data]')
    assert "G_deck" in load_case(write(tmp_path, text)).parameter_names
    message = problems(tmp_path, edit("nu = 0.3", 'nu = "nu_deck"'))
    assert_names(message, tmp_path / "case.toml", "model.beams[0].nu", "'nu_deck'",
                 "not declared")


def test_declared_but_unused_parameter(tmp_path: Path) -> None:
    text = BASE.replace("[data]", '[[parameters]]\nname = "c9"\nlower = 0\nupper = 1\n\n[data]')
    message = problems(tmp_path, text)
    line = assert_names(message, tmp_path / "case.toml", "parameters[3].name", "'c9'")
    assert "never uses it" in line


def test_parameter_bounds_outside_the_property_range(tmp_path: Path) -> None:
    # a stiffness must be >= 0: searching it down to -1 would assemble negative stiffness
    message = problems(tmp_path, edit("lower = 0.0\nupper = 1.0e6", "lower = -1.0\nupper = 1e6"))
    assert_names(message, tmp_path / "case.toml", "parameters[2].lower", "'kp'", "[-1, 1e6]",
                 "model.springs[2].k", "bounds in [0, 1e15]")


def test_unknown_node(tmp_path: Path) -> None:
    message = problems(tmp_path, edit('nodes = ["P1", "A2"]', 'nodes = ["P1", "A3"]'))
    line = assert_names(message, tmp_path / "case.toml", "model.beams[1].nodes[1]", "'A3'",
                        "'A1', 'P1', 'A2'")
    assert "unknown node" in line


def test_unknown_output_node(tmp_path: Path) -> None:
    message = problems(tmp_path, edit('column = "p1"\nnode = "P1"', 'column = "p1"\nnode = "P2"'))
    assert_names(message, tmp_path / "case.toml", "data.outputs[0].node", "'P2'", "'P1'")


def test_dof_not_allowed_for_dofs_per_node(tmp_path: Path) -> None:
    message = problems(tmp_path, edit('node = "P1"\ndof = "uy"\nk = "kp"',
                                      'node = "P1"\ndof = "ux"\nk = "kp"'))
    assert_names(message, tmp_path / "case.toml", "model.springs[2].dof", "'ux'",
                 "dofs_per_node = 2", "'uy', 'rz'")


def test_dof_name_that_does_not_exist(tmp_path: Path) -> None:
    message = problems(tmp_path, edit('dof = "uy"\nc = 20.0', 'dof = "uw"\nc = 20.0'))
    assert_names(message, tmp_path / "case.toml", "model.dampers[0].dof", "'uw'", "'ux'", "'rz'")
    # a DOF of 3-D frames only: the model's own DOFs are named
    message = problems(tmp_path, edit('dof = "uy"\nc = 20.0', 'dof = "uz"\nc = 20.0'))
    assert_names(message, tmp_path / "case.toml", "model.dampers[0].dof", "'uz'",
                 "dofs_per_node = 2", "'uy', 'rz'")


def test_duplicate_names(tmp_path: Path) -> None:
    message = problems(tmp_path, edit('name = "A2"\nx = 2.0', 'name = "P1"\nx = 2.0'))
    assert_names(message, tmp_path / "case.toml", "model.nodes[2].name", "'P1'",
                 "model.nodes[1].name")
    # (the model is checked before the parameters: a second file for those)
    message = problems(tmp_path, BASE.replace('name = "kp"', 'name = "ka"'))
    assert_names(message, tmp_path / "case.toml", "parameters[2].name", "'ka'",
                 "parameters[1].name")


def test_shear_building_and_elements_together(tmp_path: Path) -> None:
    text = BASE.replace("[[model.nodes]]", "[model.shear_building]\nmasses = [1.0]\n"
                        "stiffnesses = [1e3]\n\n[[model.nodes]]", 1)
    message = problems(tmp_path, text)
    assert_names(message, tmp_path / "case.toml", "model.shear_building", "model.nodes",
                 "model.beams", "not both")


@pytest.mark.parametrize(("old", "new", "field", "shown"), [
    ("nu = 0.3\n", "nu = 0.3\nG = 8e10\n", "model.beams[0].nu", "G = 8e10"),
    ('nodes = ["A1", "P1"]', 'nodes = ["A1", "A1"]', "model.beams[0].nodes", "'A1'"),
    ('name = "A2"\nx = 2.0', 'name = "A2"\nx = 1.0', "model.beams[1].nodes", "same point"),
    ('name = "A2"\nx = 2.0', 'name = "A2"\nx = 2.0\ny = 0.5', "model.beams[1].nodes",
     "different y"),
    ('dof = "uy"\nc = 20.0', 'dof = "uy"\ndof2 = "rz"\nc = 20.0', "model.dampers[0].dof2",
     "without node2"),
    ('node = "A1"\ndof = "uy"\nk = "ka"', 'node = "A1"\ndof = "uy"\nnode2 = "A1"\nk = "ka"',
     "model.springs[0].node2", "A1.uy to itself"),
    ("dofs_per_node = 2", 'dofs_per_node = 2\ndirection = "x"', "model.direction", "'x'"),
])
def test_model_consistency(tmp_path: Path, old: str, new: str, field: str, shown: str) -> None:
    message = problems(tmp_path, edit(old, new))
    assert_names(message, tmp_path / "case.toml", field, shown)


def test_element_acting_only_on_fixed_dofs(tmp_path: Path) -> None:
    supports = '\n[[model.supports]]\nnode = "A1"\ndofs = ["uy", "rz"]\n'
    message = problems(tmp_path, BASE + supports)
    assert_names(message, tmp_path / "case.toml", "model.springs[0]", "A1.uy",
                 "model.supports[0]", "no effect")
    twice = supports + '\n[[model.supports]]\nnode = "A1"\ndofs = ["uy"]\n'
    message = problems(tmp_path, BASE + twice)
    assert_names(message, tmp_path / "case.toml", "model.supports[1].dofs[0]", "A1.uy",
                 "already fixed by model.supports[0]")


def test_shear_building_lengths(tmp_path: Path) -> None:
    text = ('[case]\nname = "sb"\n[model.shear_building]\nmasses = [1.0, 1.0]\n'
            "stiffnesses = [1e3]\ndampers = [1.0, 1.0, 1.0]\n")
    message = problems(tmp_path, text)
    assert_names(message, tmp_path / "case.toml", "model.shear_building.stiffnesses",
                 "1 values", "2 values, one per storey")
    assert_names(message, tmp_path / "case.toml", "model.shear_building.dampers", "3 values")


def test_output_at_a_fixed_dof(tmp_path: Path) -> None:
    text = edit('column = "p1"\nnode = "P1"\ndof = "uy"', 'column = "p1"\nnode = "A2"\ndof = "rz"')
    message = problems(tmp_path, text + '\n[[model.supports]]\nnode = "A2"\ndofs = ["rz"]\n')
    assert_names(message, tmp_path / "case.toml", "data.outputs[0].dof", "A2.rz",
                 "model.supports[0]")


def test_linear_integrator_with_friction(tmp_path: Path) -> None:
    text = BASE + ('\n[[model.frictions]]\nnode = "P1"\ndof = "uy"\nk_r = 1e5\nf_u = 1e4\n'
                   '\n[simulation]\nmethod = "newmark"\n')
    message = problems(tmp_path, text)
    assert_names(message, tmp_path / "case.toml", "simulation.method", "'newmark'",
                 "'nonlinear'")
    case = load_case(write(tmp_path, text.replace('method = "newmark"', ""), "ok.toml"))
    assert case.simulation_method == "nonlinear"
    assert build_structure(case.model).assemble(
        {"E": 2e11, "ka": 1e6, "kp": 3e5}).friction is not None
    # a slider that never slips is a spring; infinity is refused (JSON could not save it)
    message = problems(tmp_path, text.replace("f_u = 1e4", "f_u = inf"))
    assert_names(message, tmp_path / "case.toml", "model.frictions[0].f_u", "inf",
                 "not a finite number")


def test_time_axis_needs_exactly_one_of_time_column_and_rate(tmp_path: Path) -> None:
    message = problems(tmp_path, edit('time_column = "t"', 'time_column = "t"\nrate = 100.0'))
    assert_names(message, tmp_path / "case.toml", "data.rate", "both given")
    message = problems(tmp_path, edit('format = "csv"', 'format = "uff"'))
    assert_names(message, tmp_path / "case.toml", "data.time_column", "UFF")


OUTPUT = 'column = "p1"\nnode = "P1"\ndof = "uy"'


@pytest.mark.parametrize(("value", "shown", "what"), [
    ("12.5", "got 12.5", "out of range"),
    ("-10.5", "got -10.5", "out of range"),
    ('"soon"', "got 'soon'", 'not a number or "auto"'),
    ('"0.02"', "got '0.02'", "remove the quotes"),
    ("nan", "got nan", "not a finite number"),
    ("true", "got true", "not a number"),
])
def test_bad_channel_delay(tmp_path: Path, value: str, shown: str, what: str) -> None:
    message = problems(tmp_path, edit(OUTPUT, f"{OUTPUT}\ndelay = {value}"))
    line = assert_names(message, tmp_path / "case.toml", "data.outputs[0].delay", shown, what)
    assert 'a number in [-10, 10] (s), or "auto"' in line


@pytest.mark.parametrize("value", ["-10", "0.0231", "10.0", '"auto"'])
def test_channel_delay_accepts_numbers_in_range_and_auto(tmp_path: Path, value: str) -> None:
    case = load_case(write(tmp_path, edit(OUTPUT, f"{OUTPUT}\ndelay = {value}")))
    assert case.data is not None
    assert case.data.outputs[0].delay == ("auto" if value == '"auto"' else float(value))
    assert parse_case(case.to_dict()).to_dict() == case.to_dict()


def test_delay_band(tmp_path: Path) -> None:
    auto = edit(OUTPUT, f'{OUTPUT}\ndelay = "auto"')
    message = problems(tmp_path, auto + "\n[preprocess]\ndelay_band_hz = [10.0, 2.0]\n")
    assert_names(message, tmp_path / "case.toml", "preprocess.delay_band_hz", "[10, 2]",
                 "low is not below high")
    message = problems(tmp_path, auto + "\n[preprocess]\ndelay_band_hz = [0.0, 2.0]\n")
    assert_names(message, tmp_path / "case.toml", "preprocess.delay_band_hz[0]", "got 0")
    # with a known rate the band must lie below Nyquist, when a delay is "auto"
    at_100 = auto.replace('time_column = "t"', "rate = 100.0")
    message = problems(tmp_path, at_100 + "\n[preprocess]\ndelay_band_hz = [1.0, 50.0]\n")
    assert_names(message, tmp_path / "case.toml", "preprocess.delay_band_hz", "[1, 50]",
                 "100 Hz", "Nyquist frequency 50 Hz")
    fixed = edit('time_column = "t"', "rate = 100.0") + "\n[preprocess]\ndelay_band_hz = [1, 50]\n"
    assert load_case(write(tmp_path, fixed, "fixed.toml")).preprocess.delay_band_hz == [1, 50]


def test_all_problems_are_reported_together(tmp_path: Path) -> None:
    text = edit('E = "E"', "E = -1.0", edit("c = 20.0", "c = -3.0"))
    text = text.replace("[data]", '[search]\nruns = 0\n\n[data]')
    message = problems(tmp_path, text)
    assert message.splitlines()[0] == f"{tmp_path / 'case.toml'}: 3 problems in the case file:"
    for field in ("model.beams[0].E", "model.dampers[0].c", "search.runs"):
        line_for(message, field)


def test_parse_case_without_file_and_model_validate() -> None:
    import tomllib

    data = tomllib.loads(edit("c = 20.0", "c = -3.0"))
    with pytest.raises(ConfigError, match=r"^case: 1 problem.*\n  case: model\.dampers\[0\]\.c"):
        parse_case(data)
    with pytest.raises(ValidationError):  # the cross checks also guard the pydantic model
        Case.model_validate(tomllib.loads(edit('c = 20.0', 'c = "nope"')))


# ----------------------------------------------------------------------------- saving


def test_to_dict_and_fingerprint_round_trip(tmp_path: Path) -> None:
    case = load_case(write(tmp_path, BASE))
    data = case.to_dict()
    json.dumps(data, allow_nan=False)  # JSON-ready
    again = parse_case(json.loads(json.dumps(data)))
    assert again.to_dict() == data
    assert again.fingerprint() == case.fingerprint()
    assert re.fullmatch(r"[0-9a-f]{64}", case.fingerprint())


@pytest.mark.parametrize("change", [('time_column = "t"', "rate = 100.0"),
                                    ('format = "csv"\ntime_column = "t"', 'format = "npz"')],
                         ids=["rate", "npz"])
def test_a_saved_case_reads_back_whatever_its_time_axis(tmp_path: Path,
                                                         change: tuple[str, str]) -> None:
    # the saved case holds every default (time_unit, the CSV options): reading it back (a
    # report, --data) must not take them for fields given where they mean nothing
    case = load_case(write(tmp_path, BASE.replace(*change)))
    again = parse_case(json.loads(json.dumps(case.to_dict())))
    assert again.fingerprint() == case.fingerprint()


def test_fingerprint_ignores_layout_but_not_content(tmp_path: Path) -> None:
    reference = load_case(write(tmp_path, BASE)).fingerprint()
    # the same case: [data] written first, an integer for a float, comments, another file name
    head, data = BASE.split("[data]")
    same = "# a comment\n[data]" + data + "\n" + head.replace("m = 1.5", "m = 1.5  # kg")
    same = same.replace("c = 20.0", "c = 20")
    assert load_case(write(tmp_path, same, "other.toml")).fingerprint() == reference
    changed = edit("c = 20.0", "c = 21.0")
    assert load_case(write(tmp_path, changed, "changed.toml")).fingerprint() != reference


# ----------------------------------------------------------------------------- search space


def test_to_physical_undoes_the_log_scale(tmp_path: Path) -> None:
    case = load_case(write(tmp_path, BASE))
    values = case.to_physical([2e11, 6.0, 5e5])
    assert values == {"E": 2e11, "ka": pytest.approx(1e6, rel=1e-15), "kp": 5e5}
    assert case.to_search(values) == pytest.approx([2e11, 6.0, 5e5])
    with pytest.raises(ConfigError, match=r"shape \(2,\) for 3 parameters"):
        case.to_physical([1.0, 2.0])


@settings(max_examples=50, deadline=None)
@given(lower=st.floats(1e-6, 1e6), ratio=st.floats(1.01, 1e6), u=st.floats(0.0, 1.0))
def test_log_bounds_map_onto_the_physical_interval(lower: float, ratio: float, u: float) -> None:
    upper = lower * ratio
    case = parse_case({
        "case": {"name": "p"},
        "model": {"shear_building": {"masses": [1.0], "stiffnesses": ["k"]}},
        "parameters": [{"name": "k", "lower": lower, "upper": upper, "scale": "log"}],
    })
    (lo, hi), = case.bounds
    value = case.to_physical([lo + u * (hi - lo)])["k"]
    assert lower * (1 - 1e-12) <= value <= upper * (1 + 1e-12)
    assert case.to_physical([lo])["k"] == pytest.approx(lower, rel=1e-12)
    assert case.to_physical([hi])["k"] == pytest.approx(upper, rel=1e-12)


def test_data_directory_expands_environment_variables(tmp_path: Path, monkeypatch) -> None:
    text = edit('format = "csv"', 'format = "csv"\ndirectory = "${FEMUPDATE_TEST_DIR}/run1"')
    case = load_case(write(tmp_path, text))
    monkeypatch.setenv("FEMUPDATE_TEST_DIR", "/data/lab")
    assert case.data is not None
    assert case.data_path(case.data.input) == Path("/data/lab/run1/table.csv")
    monkeypatch.delenv("FEMUPDATE_TEST_DIR")
    with pytest.raises(ConfigError, match="FEMUPDATE_TEST_DIR is not set"):
        case.data_path(case.data.input)
    relative = load_case(write(tmp_path, edit('format = "csv"', 'format = "csv"\n'
                                                  'directory = "measured"'), "rel.toml"))
    assert relative.data_path(relative.data.input) == tmp_path / "measured" / "table.csv"


# ----------------------------------------------------------------------------- Structure


def test_build_structure_of_the_base_case(tmp_path: Path) -> None:
    case = load_case(write(tmp_path, BASE))
    structure = build_structure(case.model)
    assert structure.n_dof == 6  # 3 nodes × (uy, rz), no supports
    assert structure.nodes == case.model.node_names()
    assert structure.dof_names == case.model.dof_names()
    assert set(structure.parameters) == {"E", "ka", "kp"}
    values = {"E": 2.0e11, "ka": 1.0e6, "kp": 3.0e5}
    system = structure.assemble(values, direction=case.model.excitation_direction)
    # rigid translation: r M r is the whole translational mass (beams ρ A L + lumped)
    assert system.r @ system.M @ system.r == pytest.approx(7850.0 * 3.0e-4 * 2.0 + 1.5)
    # a rigid translation is resisted only by the springs to the base: 2 ka + kp
    assert system.r @ system.K @ system.r == pytest.approx(2 * 1.0e6 + 3.0e5, rel=1e-9)
    assert system.r @ system.C @ system.r == pytest.approx(20.0)


def test_build_structure_of_a_shear_building() -> None:
    case = parse_case({
        "case": {"name": "3 storeys"},
        "model": {"shear_building": {"masses": [2.0, 2.0, 1.0],
                                     "stiffnesses": ["k1", 800.0, 600.0]}},
        "parameters": [{"name": "k1", "lower": 100.0, "upper": 2000.0}],
    })
    structure = build_structure(case.model)
    system = structure.assemble({"k1": 1000.0}, direction=case.model.excitation_direction)
    assert system.n_dof == 3
    expected = np.array([[1800.0, -800.0, 0.0], [-800.0, 1400.0, -600.0], [0.0, -600.0, 600.0]])
    np.testing.assert_allclose(system.K, expected)
    np.testing.assert_allclose(system.M, np.diag([2.0, 2.0, 1.0]))
    np.testing.assert_allclose(system.r, 1.0)
    # the node and DOF names the case checks outputs against are the Structure's
    assert structure.nodes == case.model.node_names() == ("F1", "F2", "F3")
    assert structure.dof_names == case.model.dof_names() == ("ux",)


def test_build_structure_names_elements_by_their_place_in_the_file(tmp_path: Path) -> None:
    from femupdate.errors import ModelError

    structure = build_structure(load_case(write(tmp_path, BASE)).model)
    # a value out of range at assembly names the element as it is written in the case file
    with pytest.raises(ModelError, match=r"model\.springs\[2\]"):
        structure.assemble({"E": 2e11, "ka": 1e6, "kp": -1.0})


def test_format_value_writes_toml_like_numbers() -> None:
    assert format_value(-2e11) == "-2e11"
    assert format_value(0.25) == "0.25"
    assert format_value(1234.5) == "1234.5"
    assert format_value(math.inf) == "inf"
    assert format_value(True) == "true"


def test_a_low_pass_not_above_the_high_pass_is_refused(tmp_path: Path) -> None:
    message = problems(tmp_path, BASE + "\n[preprocess]\nhighpass_hz = 5.0\nlowpass_hz = 2.0\n")
    assert_names(message, tmp_path / "case.toml", "preprocess.lowpass_hz", "2",
                 "highpass_hz = 5", "a low-pass above the high-pass")


def test_a_case_without_a_low_pass_saves_none(tmp_path: Path) -> None:
    # so the fingerprints (and stores) of cases written before the low-pass existed hold
    plain = load_case(write(tmp_path, BASE)).to_dict()["preprocess"]
    assert "lowpass_hz" not in plain and "lowpass_order" not in plain
    given = load_case(write(tmp_path, BASE + "\n[preprocess]\nlowpass_hz = 80.0\n"))
    assert given.to_dict()["preprocess"]["lowpass_hz"] == 80.0


def test_agree_is_saved_when_not_the_default_and_left_out_of_the_fingerprint(
        tmp_path: Path) -> None:
    # [search] agree picks which runs are needed, never what a run computes: a store resumes
    # with another agree, and the fingerprints of cases written before it existed hold
    plain = load_case(write(tmp_path, BASE))
    assert plain.search.agree == 2 and "agree" not in plain.to_dict()["search"]
    every = load_case(write(tmp_path, BASE + "\n[search]\nagree = 0\n", "every.toml"))
    assert every.search.agree == 0 and every.to_dict()["search"]["agree"] == 0
    assert parse_case(json.loads(json.dumps(every.to_dict()))).search.agree == 0
    assert every.fingerprint() == plain.fingerprint()
    message = problems(tmp_path, BASE + "\n[search]\nagree = -1\n")
    assert "search.agree" in message and "[0, 10000]" in message

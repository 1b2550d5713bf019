"""Derived fields and ``[[constraints]]`` in case files: accepted boxes, refused ones, and
messages that name the file and the field."""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest

from femupdate.case import load_case, parse_case
from femupdate.case.derived import check_points
from femupdate.case.expressions import parse_constraint
from femupdate.errors import ConfigError

#: One Bouc–Wen element per storey of a shear building; BETA, GAMMA and the parameters vary.
CASE = """\
[case]
name = "links"

[model.shear_building]
masses = MASSES
stiffnesses = ZEROS
dampers = DAMPERS

[model.shear_building.bouc_wen]
k = 4000.0
alpha = 0.1
beta = BETA
gamma = GAMMA

PARAMETERS
"""


def _parameter(name: str, lower: float, upper: float) -> str:
    return f'[[parameters]]\nname = "{name}"\nlower = {lower}\nupper = {upper}\n'


BETA_BOX = _parameter("beta", 1.5, 4.5)  # beta = 3 ± 50 %


def _case(tmp_path: Path, beta: str = '"beta"', gamma: str = "2.0", storeys: int = 1,
          parameters: str = BETA_BOX, extra: str = "") -> Path:
    text = (CASE.replace("MASSES", str([1.0] * storeys)).replace("ZEROS", str([0.0] * storeys))
            .replace("DAMPERS", str([0.5] * storeys)).replace("BETA", beta)
            .replace("GAMMA", gamma).replace("PARAMETERS", parameters + extra))
    path = tmp_path / "case.toml"
    path.write_text(text, encoding="utf-8")
    return path


def _problems(path: Path) -> list[str]:
    with pytest.raises(ConfigError) as info:
        load_case(path)
    return str(info.value).splitlines()[1:]


def test_a_box_leaving_gamma_le_beta_is_refused_once_for_204_elements(tmp_path: Path) -> None:
    # beta = 3 ± 50 % with gamma = 2: below beta = 2 the loop has no hysteresis
    lines = _problems(_case(tmp_path, storeys=204))
    assert len(lines) == 1
    line = lines[0].strip()
    assert line.startswith(f"{tmp_path / 'case.toml'}: model.shear_building.bouc_wen.gamma "
                           "(storey 1): beta = 'beta' and gamma = 2 can leave -beta < gamma <= "
                           "beta within the parameters' bounds (no hysteresis there), e.g. at "
                           "beta = 1.5; the same for 203 more Bouc–Wen elements alike")
    assert "[[constraints]]" in line and '"0.5 * beta"' in line


def test_gamma_derived_from_beta_keeps_the_box_valid(tmp_path: Path) -> None:
    case = load_case(_case(tmp_path, gamma='"0.5 * beta"', storeys=204))
    assert case.model.shear_building.bouc_wen.gamma == "0.5 * beta"


def test_a_constraint_excludes_the_corners_that_leave_gamma_le_beta(tmp_path: Path) -> None:
    box = BETA_BOX + _parameter("gamma", 1.0, 3.0)
    refused = _problems(_case(tmp_path, gamma='"gamma"', parameters=box))
    assert "e.g. at beta = 1.5, gamma = 3" in refused[0]
    kept = _case(tmp_path, gamma='"gamma"', parameters=box,
                 extra='[[constraints]]\nrule = "gamma <= beta"\n')
    case = load_case(kept)
    assert [c.rule for c in case.constraints] == ["gamma <= beta"]
    # the constraint excludes the corner (1.5, 3); the other corners and the nominal stay
    points = check_points(case.parameters, ["beta", "gamma"],
                          [parse_constraint("gamma <= beta")])
    pairs = sorted(zip(points["beta"].tolist(), points["gamma"].tolist(), strict=True))
    assert pairs == [(1.5, 1.0), (3.0, 2.0), (4.5, 1.0), (4.5, 3.0)]


def test_a_constraint_that_does_not_cover_the_condition_is_not_enough(tmp_path: Path) -> None:
    box = BETA_BOX + _parameter("gamma", -3.0, 3.0)
    path = _case(tmp_path, gamma='"gamma"', parameters=box,
                 extra='[[constraints]]\nrule = "gamma <= beta"\n')
    lines = _problems(path)  # gamma = -3 <= -beta at beta = 1.5: still no hysteresis
    assert len(lines) == 1 and "e.g. at beta = 1.5, gamma = -3" in lines[0]


@pytest.mark.parametrize(("gamma", "expected"), [
    ('"0.5 * betta"', "model.shear_building.bouc_wen.gamma: '0.5 * betta' names 'betta', not "
                      "declared in [[parameters]]; did you mean 'beta'? (allowed: declared "
                      "parameters: 'beta')"),
    ('"beta.real"', "model.shear_building.bouc_wen.gamma: got 'beta.real': not a parameter "
                    "name (letters, digits and _, not starting with a digit) nor an expression "
                    "of parameters: attribute access (.) is not allowed (allowed: a number in "
                    "[-1e30, 1e30] (1/m^n, or 1/rad^n for a rotation) or a parameter name or "
                    "expression; an expression may contain numbers, parameter names, + - * / "
                    "**, parentheses and sqrt(), exp(), log(), abs(), min(), max())"),
    ('"__import__(\'os\')"', "model.shear_building.bouc_wen.gamma: got \"__import__('os')\": "
                             "not a parameter name (letters, digits and _, not starting with a "
                             "digit) nor an expression of parameters: calls __import__, which "
                             "is not an allowed function"),
    ('"1.5 * beta"', "model.shear_building.bouc_wen.gamma (storey 1): beta = 'beta' and gamma "
                     "= '1.5 * beta' can leave -beta < gamma <= beta"),
])
def test_messages_name_the_file_and_the_field(tmp_path: Path, gamma: str,
                                              expected: str) -> None:
    lines = _problems(_case(tmp_path, gamma=gamma))
    assert len(lines) == 1
    assert lines[0].strip().startswith(f"{tmp_path / 'case.toml'}: {expected}")


def test_a_derived_value_out_of_range_at_a_corner_is_refused(tmp_path: Path) -> None:
    # k = k1 - 3000 is negative for k1 < 3000
    path = _case(tmp_path, beta="3.0", gamma="1.0",
                 parameters=_parameter("k1", 1000.0, 9000.0))
    text = path.read_text().replace("k = 4000.0", 'k = "k1 - 3000"')
    path.write_text(text)
    lines = _problems(path)
    assert len(lines) == 1
    assert lines[0].strip() == (
        f"{path}: model.shear_building.bouc_wen.k: 'k1 - 3000' = -2000 at k1 = 1000: out of "
        "range within the parameters' bounds (allowed: in (0, 1e15] over the bounds (or "
        "[[constraints]] that exclude those points))")
    path.write_text(text.replace('upper = 9000.0\n', 'upper = 9000.0\n[[constraints]]\n'
                                 'rule = "k1 > 3000"\n'))
    assert load_case(path).model.shear_building.bouc_wen.k == "k1 - 3000"


@pytest.mark.parametrize(("rule", "expected"), [
    ("gamma == beta", "constraints[0].rule: got 'gamma == beta': the comparison Eq is not "
                      "allowed (use <, <=, >, >=)"),
    ("gamma", "constraints[0].rule: got 'gamma': not a comparison"),
    ("beta <= gama", "constraints[0].rule: 'beta <= gama' names 'gama', not declared in "
                     "[[parameters]]; did you mean 'gamma'?"),
    ("1 < 2", "constraints[0].rule: '1 < 2' names no parameter"),
    ("gamma >= beta", "constraints[0].rule: constraint 'gamma >= beta' does not hold: gamma = "
                      "2, beta = 3 at the nominal point"),
])
def test_bad_constraints_are_refused(tmp_path: Path, rule: str, expected: str) -> None:
    box = BETA_BOX + _parameter("gamma", 1.0, 3.0)
    path = _case(tmp_path, gamma='"gamma"', parameters=box,
                 extra=f'[[constraints]]\nrule = "{rule}"\n')
    lines = _problems(path)
    assert any(line.strip().startswith(f"{path}: {expected}") for line in lines), lines


def test_a_case_without_constraints_saves_as_before(tmp_path: Path) -> None:
    case = load_case(_case(tmp_path, gamma='"0.5 * beta"'))
    assert "constraints" not in case.to_dict()
    kept = load_case(_case(tmp_path, gamma='"0.5 * beta"',
                           extra='[[constraints]]\nrule = "beta <= 4"\n'))
    assert kept.to_dict()["constraints"] == [{"rule": "beta <= 4"}]
    assert kept.fingerprint() != case.fingerprint()


def test_expressions_in_any_numeric_model_field() -> None:
    case = parse_case({
        "case": {"name": "two storeys"},
        "model": {"shear_building": {"masses": [1.0, "m2"], "stiffnesses": ["k1", "0.6 * k1"],
                                     "dampers": ["sqrt(k1) / 50", 0.5]}},
        "parameters": [{"name": "k1", "lower": 1000.0, "upper": 9000.0},
                       {"name": "m2", "lower": 0.5, "upper": 1.0}]})
    from femupdate.problem.case_model import CaseModel

    system = CaseModel(case).system({"k1": 2500.0, "m2": 0.8})
    assert system.K.tolist() == [[2500.0 + 1500.0, -1500.0], [-1500.0, 1500.0]]
    assert system.M.tolist() == [[1.0, 0.0], [0.0, 0.8]]
    assert system.C[0, 0] == pytest.approx(1.0 + 0.5, rel=1e-15)


def test_beyond_12_parameters_the_check_points_are_one_bound_at_a_time() -> None:
    names = [f"p{i}" for i in range(13)]
    case = parse_case({
        "case": {"name": "chain"},
        "model": {"shear_building": {"masses": [1.0] * 13, "stiffnesses": names,
                                     "dampers": [0.5] * 13}},
        "parameters": [{"name": n, "lower": 1.0, "upper": 3.0} for n in names],
        "constraints": [{"rule": f"{a} <= 2 * {b}"} for a, b in itertools.pairwise(names)]})
    chain = [parse_constraint(c.rule) for c in case.constraints]
    points = check_points(case.parameters, ["p0"], chain)  # p0 tied to all 13 by the chain
    assert set(points) == set(names)
    assert points["p0"].size == 2 * 13 + 1  # each at either bound, then the nominal point
    small = check_points(case.parameters, ["p0"], chain[:1])  # p0, p1: their 4 corners
    assert sorted(zip(small["p0"].tolist(), small["p1"].tolist(), strict=True)) == [
        (1.0, 1.0), (1.0, 3.0), (2.0, 2.0), (3.0, 3.0)]  # (3, 1) excluded: 3 > 2 * 1

"""The degradation rates ``delta_a``, ``delta_nu``, ``delta_eta`` of ``[[model.bouc_wen]]`` and
``[model.shear_building.bouc_wen]``: numbers, parameter names or expressions, default 0, and
refused below 0 with the field named."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

from femupdate.case import parse_case
from femupdate.errors import ConfigError
from femupdate.problem.case_model import build_structure

CASE = """
[case]
name = "one storey on a degrading brace"

[model]
dofs_per_node = 2

[[model.nodes]]
name = "F1"
x = 0.0
y = 1.0

[[model.supports]]
node = "F1"
dofs = ["rz"]

[[model.masses]]
node = "F1"
m = 2.0

[[model.bouc_wen]]
node = "F1"
dof = "uy"
k = 1500.0
alpha = 0.1
beta = 300.0
gamma = 100.0
n = 2.0
RATES
"""
PARAMETER = """
[[parameters]]
name = "dnu"
lower = LOWER
upper = 5.0
nominal = 2.0
"""


def _case(rates: str, lower: float = 0.0):
    text = CASE.replace("RATES", rates)
    if "dnu" in rates:
        text += PARAMETER.replace("LOWER", str(lower))
    return parse_case(tomllib.loads(text))


def test_rates_are_numbers_names_or_expressions() -> None:
    case = _case('delta_a = 0.5\ndelta_nu = "dnu"\ndelta_eta = "0.25 * dnu"')
    table = build_structure(case.model).assemble(case.nominal()).bouc_wen.table
    np.testing.assert_array_equal(table, [[1500.0, 0.1, 1.0, 300.0, 100.0, 2.0, 0.5, 2.0, 0.5]])
    plain = _case("")
    table = build_structure(plain.model).assemble(plain.nominal()).bouc_wen.table
    assert table.shape == (1, 9) and not table[0, 6:].any()  # default: no degradation


@pytest.mark.parametrize("field", ["delta_a", "delta_nu", "delta_eta"])
def test_a_negative_rate_is_refused_naming_the_field(field: str) -> None:
    with pytest.raises(ConfigError, match=rf"model.bouc_wen\[0\].{field}: got -0.5: out of "
                                          r"range \(allowed: a number in \[0, ") as info:
        _case(f"{field} = -0.5")
    assert str(info.value).count("\n") == 1  # one problem, one line


def test_a_parameter_whose_bounds_reach_below_zero_is_refused() -> None:
    with pytest.raises(ConfigError, match=r"parameters\[0\].lower: parameter 'dnu' has bounds "
                                          r"\[-1, 5\] but is used at "
                                          r"model.bouc_wen\[0\].delta_nu \(allowed: bounds in "
                                          r"\[0, 1e30\]\)"):
        _case('delta_nu = "dnu"', lower=-1.0)


def test_per_storey_rates() -> None:
    text = """
[case]
name = "two degrading storeys"

[model.shear_building]
masses = [2.0, 1.5]
stiffnesses = [0.0, 0.0]

[model.shear_building.bouc_wen]
k = [1500.0, 1200.0]
alpha = 0.1
beta = 300.0
gamma = 100.0
n = 2.0
delta_a = [0.5, 0.0]
delta_nu = 1.0
"""
    case = parse_case(tomllib.loads(text))
    table = build_structure(case.model).assemble(case.nominal()).bouc_wen.table
    np.testing.assert_array_equal(table[:, 6:], [[0.5, 1.0, 0.0], [0.0, 1.0, 0.0]])
    with pytest.raises(ConfigError, match=r"bouc_wen.delta_a: storey 2: got -1: out of range"):
        parse_case(tomllib.loads(text.replace("[0.5, 0.0]", "[0.5, -1.0]")))

"""The per-storey shorthand of ``[model.shear_building]``: friction and Bouc–Wen elements in a
few lines, equal to the same building written from nodes, springs, sliders and supports."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

from femupdate.case import parse_case
from femupdate.errors import ConfigError
from femupdate.problem.case_model import build_structure
from femupdate.simulate import prepare

PARAMETERS = """
[[parameters]]
name = "k1"
lower = 100.0
upper = 1e4
nominal = 3000.0

[[parameters]]
name = "fu"
lower = 0.1
upper = 10.0
nominal = 1.5
"""

SHORTHAND = """
[case]
name = "three storeys, a slider in each"

[model.shear_building]
masses = [2.0, 2.0, 1.5]
stiffnesses = ["k1", 2500.0, 2000.0]
dampers = [0.5, 0.5, 0.5]

[model.shear_building.frictions]
k_r = [1500.0, 1200.0, 900.0]
f_u = "fu"
""" + PARAMETERS


def from_nodes(link: str) -> str:
    """The same building as a new user would write it: 2-DOF nodes, every rotation fixed, the
    storey elements between the uy of consecutive floors, a fixed base node."""
    lines = ['[case]\nname = "three storeys from nodes"\n\n[model]\ndofs_per_node = 2\n']
    for i in range(4):
        lines.append(f'[[model.nodes]]\nname = "{"G" if i == 0 else f"F{i}"}"\nx = 0.0\n'
                     f"y = {float(i)}\n")
    masses = [2.0, 2.0, 1.5]
    stiffness = ['"k1"', "2500.0", "2000.0"]
    for i in range(1, 4):
        below = "G" if i == 1 else f"F{i - 1}"
        ends = f'node = "F{i}"\ndof = "uy"\nnode2 = "{below}"\n'
        lines.append(f"[[model.springs]]\n{ends}k = {stiffness[i - 1]}\n")
        lines.append(f"[[model.dampers]]\n{ends}c = 0.5\n")
        lines.append(f"[[model.{link}]]\n{ends}" + STOREY[link][i - 1])
        lines.append(f'[[model.masses]]\nnode = "F{i}"\nm = {masses[i - 1]}\n')
        lines.append(f'[[model.supports]]\nnode = "F{i}"\ndofs = ["rz"]\n')
    lines.append('[[model.supports]]\nnode = "G"\ndofs = ["uy", "rz"]\n')
    return "\n".join(lines) + PARAMETERS


STOREY = {
    "frictions": [f'k_r = {k}\nf_u = "fu"\n' for k in (1500.0, 1200.0, 900.0)],
    "bouc_wen": [f'k = {k}\nalpha = 0.1\nbeta = 300.0\ngamma = "fu"\nn = 2.0\n'
                 for k in (1500.0, 1200.0, 900.0)],
}

# The same with a Bouc–Wen element per storey; its gamma is the second parameter.
BOUC_WEN_SHORTHAND = SHORTHAND.replace("""[model.shear_building.frictions]
k_r = [1500.0, 1200.0, 900.0]
f_u = "fu"
""", """[model.shear_building.bouc_wen]
k = [1500.0, 1200.0, 900.0]
alpha = 0.1
beta = 300.0
gamma = "fu"
n = 2.0
""").replace("upper = 10.0\nnominal = 1.5", "upper = 200.0\nnominal = 100.0")


def _response(text: str, dof: str, record: np.ndarray) -> tuple[object, np.ndarray]:
    case = parse_case(tomllib.loads(text))
    structure = build_structure(case.model)
    system = structure.assemble(case.nominal(), case.model.excitation_direction)
    outputs = [structure.dof_index(f"F{i}", dof) for i in (1, 2, 3)]
    sim = prepare(system, 0.01, method=case.simulation_method, outputs=outputs, substeps=10)
    return system, sim.run(record).acceleration


@pytest.fixture(scope="module")
def record() -> np.ndarray:
    t = np.arange(1500) * 0.01
    return 4.0 * np.sin(2.0 * np.pi * 2.1 * t) * np.sin(np.pi * t / 15.0) ** 2


@pytest.mark.parametrize("link", ["frictions", "bouc_wen"])
def test_shorthand_equals_the_building_from_nodes(link: str, record: np.ndarray) -> None:
    """Same matrices and elements, and the same response bit for bit (outputs F<i>.ux against
    F<i>.uy)."""
    short = SHORTHAND if link == "frictions" else BOUC_WEN_SHORTHAND
    sys_a, acc_a = _response(short, "ux", record)
    text = from_nodes(link)
    if link == "bouc_wen":
        text = text.replace("upper = 10.0\nnominal = 1.5", "upper = 200.0\nnominal = 100.0")
    sys_b, acc_b = _response(text, "uy", record)
    for name in ("M", "C", "K", "r"):
        np.testing.assert_array_equal(getattr(sys_a, name), getattr(sys_b, name))
    if link == "frictions":
        np.testing.assert_array_equal(sys_a.friction.k_r, sys_b.friction.k_r)
        np.testing.assert_array_equal(sys_a.friction.dof_j, sys_b.friction.dof_j)
    else:
        np.testing.assert_array_equal(sys_a.bouc_wen.table, sys_b.bouc_wen.table)
        np.testing.assert_array_equal(sys_a.bouc_wen.dof_j, sys_b.bouc_wen.dof_j)
    assert np.abs(acc_a).max() > 1.0
    np.testing.assert_array_equal(acc_a, acc_b)


@pytest.mark.parametrize(("edit", "message"), [
    (("f_u = \"fu\"", "f_u = [1.0, 2.0]"),
     "model.shear_building.frictions.f_u: has 2 values but masses has 3"),
    (("k_r = [1500.0, 1200.0, 900.0]", "k_r = [1500.0, -1.0, 900.0]"),
     "model.shear_building.frictions.k_r: storey 2: got -1: out of range"),
])
def test_per_storey_errors_name_the_field(edit: tuple[str, str], message: str) -> None:
    with pytest.raises(ConfigError, match=message.replace("[", r"\[")):
        parse_case(tomllib.loads(SHORTHAND.replace(*edit)))


@pytest.mark.parametrize(("edit", "message"), [
    (("n = 2.0", "n = 0.0"), r"bouc_wen.n: got 0: out of range \(allowed: a number in \(0, "),
    (('gamma = "fu"', "gamma = -400.0"),
     r"bouc_wen.gamma: gamma = -400 with beta = 300 gives no bounded hysteresis loop "
     r"\(allowed: -beta < gamma <= beta"),
    (("alpha = 0.1", "alpha = 1.5"), r"bouc_wen.alpha: got 1.5: out of range"),
    (("k = [1500.0, 1200.0, 900.0]", "k = [1500.0, 0.0, 900.0]"),
     r"bouc_wen.k: storey 2: got 0: out of range"),
])
def test_bouc_wen_without_hysteresis_is_refused(edit: tuple[str, str], message: str) -> None:
    with pytest.raises(ConfigError, match=message) as info:
        parse_case(tomllib.loads(BOUC_WEN_SHORTHAND.replace(*edit)))
    assert str(info.value).count("\n") == 1  # one problem, one line

"""A steel beam on springs with a friction damper at mid-span, as a case file: the check and
the benchmark of the Craig–Bampton path (tests/simulate/test_craig_bampton.py,
benchmarks/craig_bampton.py)."""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

__all__ = ["ELEMENTS", "TRUTH", "friction_beam_case"]

#: Beam elements (the model has 2 (ELEMENTS + 1) DOFs).
ELEMENTS = 60
#: The parameters' true values: the pier spring and the damper's slip force.
TRUTH = {"k_pier": 5e6, "f_u": 2e3}


def friction_beam_case(directory: Path, method: str, substeps: int = 200) -> Any:
    """The case (parsed) of the beam whose records are in ``directory``, simulated by
    ``method`` ("nonlinear": the full model; "reduced": Craig–Bampton)."""
    from femupdate.case import parse_case

    nodes = ", ".join(f'{{ name = "N{i}", x = {30.0 * i / ELEMENTS} }}'
                      for i in range(ELEMENTS + 1))
    beams = "\n".join(f'[[model.beams]]\nnodes = ["N{i}", "N{i + 1}"]\nE = 2.1e11\nA = 0.01\n'
                      f"I = 2e-4\nrho = 7850.0" for i in range(ELEMENTS))
    text = f"""
[case]
name = "friction-beam"
[model]
dofs_per_node = 2
rayleigh = {{ alpha = 0.2, beta = 1e-5 }}
nodes = [{nodes}]
springs = [{{ node = "N0", dof = "uy", k = 1e8 }}, {{ node = "N{ELEMENTS}", dof = "uy", k = 1e8 }},
           {{ node = "N{ELEMENTS // 3}", dof = "uy", k = "k_pier" }}]
frictions = [{{ node = "N{ELEMENTS // 2}", dof = "uy", k_r = 2e6, f_u = "f_u" }}]
{beams}
[[parameters]]
name = "k_pier"
lower = 1e6
upper = 1e7
[[parameters]]
name = "f_u"
lower = 500.0
upper = 5000.0
[data]
format = "csv"
directory = "{directory}"
time_column = "t"
unit = "m/s2"
input = {{ file = "accelerations.csv", column = "table" }}
outputs = [
  {{ file = "accelerations.csv", column = "mid", node = "N{ELEMENTS // 2}", dof = "uy" }},
  {{ file = "accelerations.csv", column = "quarter", node = "N{ELEMENTS // 4}", dof = "uy" }},
]
[preprocess]
substeps = {substeps}
[simulation]
method = "{method}"
"""
    return parse_case(tomllib.loads(text), source=directory / "case.toml")

"""The two-storey shear building that many tests update: its model, parameters and records,
as pieces a test file puts together with the [search], [objective] or edits it needs."""

from pathlib import Path
from typing import Any

TRUTH = {"k1": 4000.0, "k2": 2500.0, "c1": 1.2, "c2": 0.6}

MODEL = """\
[case]
name = "two-storey"

[model.shear_building]
masses = [1.0, 0.8]
stiffnesses = ["k1", "k2"]
dampers = ["c1", "c2"]
"""


def parameters(log_stiffness: bool = False) -> str:
    """``[[parameters]]`` of k1, k2 (on a log scale if asked) and c1, c2."""
    scale = 'scale = "log"\n' if log_stiffness else ""
    return "".join(f'[[parameters]]\nname = "{name}"\nlower = {low}\nupper = {high}\n'
                   + (scale if name.startswith("k") else "")
                   for name, low, high in (("k1", 1000.0, 10000.0), ("k2", 1000.0, 10000.0),
                                           ("c1", 0.0, 5.0), ("c2", 0.0, 5.0)))


#: ``[data]``: the table record and both floors' accelerations, CSV files in ``data/``.
DATA = """\
[data]
format = "csv"
directory = "data"
time_column = "t"

[data.input]
file = "table.csv"
column = "table"

[[data.outputs]]
file = "floors.csv"
column = "a1"
node = "F1"
dof = "ux"
[[data.outputs]]
file = "floors.csv"
column = "a2"
node = "F2"
dof = "ux"
"""

MODEL_AND_DATA = MODEL + "\n" + parameters(log_stiffness=True) + "\n" + DATA + "\n"


def model_section() -> dict:
    """``[model]`` of the building, as a case dict's."""
    return {"shear_building": {"masses": [1.0, 0.8], "stiffnesses": ["k1", "k2"],
                               "dampers": ["c1", "c2"]}}


def parameter_list(log_k2: bool = False) -> list[dict]:
    """``[[parameters]]``: k1 on a log scale, k2 too if asked, c1 and c2."""
    return [{"name": "k1", "lower": 1000.0, "upper": 10000.0, "scale": "log"},
            {"name": "k2", "lower": 1000.0, "upper": 10000.0,
             **({"scale": "log"} if log_k2 else {})},
            {"name": "c1", "lower": 0.0, "upper": 5.0},
            {"name": "c2", "lower": 0.0, "upper": 5.0}]


def data_section(directory: Path, **extra: Any) -> dict:
    """``[data]`` (the records of :data:`DATA`) in ``directory``, with ``extra`` fields."""
    return {"format": "csv", "directory": str(directory), "time_column": "t",
            "input": {"file": "table.csv", "column": "table"},
            "outputs": [{"file": "floors.csv", "column": "a1", "node": "F1", "dof": "ux"},
                        {"file": "floors.csv", "column": "a2", "node": "F2", "dof": "ux"}],
            **extra}


def two_storey_spec(directory: Path, **extra: Any) -> dict:
    """The same building fitted on displacements integrated from noisy accelerations
    (coloured errors: the error-model tests), as a case dict with its records in
    ``directory``; ``extra`` adds sections (``trials``)."""
    return {
        "case": {"name": "two-storey"},
        "model": model_section(),
        "parameters": parameter_list(),
        "data": data_section(directory),
        **extra,
        "preprocess": {"highpass_hz": 0.5},
        "objective": {"quantity": "displacement", "experimental_parameters": True},
    }

"""A small case for the posterior's wiring tests: the two-storey shear building of
tests/test_workflow.py, a noisy virtual experiment, and a [posterior] section."""

from __future__ import annotations

from pathlib import Path

from femupdate.case import load_case
from femupdate.virtual import virtual_experiment

TRUTH = {"k1": 4000.0, "k2": 2500.0, "c1": 1.2, "c2": 0.6}

CASE = """\
[case]
name = "two-storey"

[model.shear_building]
masses = [1.0, 0.8]
stiffnesses = ["k1", "k2"]
dampers = ["c1", "c2"]

[[parameters]]
name = "k1"
lower = 1000.0
upper = 10000.0
scale = "log"
[[parameters]]
name = "k2"
lower = 1000.0
upper = 10000.0
scale = "log"
[[parameters]]
name = "c1"
lower = 0.0
upper = 5.0
[[parameters]]
name = "c2"
lower = 0.0
upper = 5.0

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

[objective]
quantity = "acceleration"
experimental_parameters = false

[search]
method = "multistart-lm"
runs = 1
seed = 7
max_evals = 1500

[posterior]
samples = {samples}
seed = 5
modes_samples = 20
max_evals = {max_evals}
"""


def write_case(folder: Path, samples: int = 200, max_evals: int = 100_000) -> Path:
    """The case file in ``folder`` with its records (2 % noise, seed 3) in ``folder/data``."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "case.toml"
    path.write_text(CASE.replace("{samples}", str(samples)).replace("{max_evals}",
                                                                    str(max_evals)))
    if not (folder / "data").is_dir():
        virtual_experiment(load_case(path), TRUTH, folder / "data", seed=3, rate=100.0,
                           duration=3.0, snr=0.02, offset=0.0, drift=0.0)
    return path

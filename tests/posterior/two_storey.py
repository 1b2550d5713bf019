"""A small case for the posterior's wiring tests: the two-storey shear building of
tests/two_storey_case.py (as tests/test_workflow.py), a noisy virtual experiment, and a
[posterior] section."""

from __future__ import annotations

from pathlib import Path

from femupdate.case import load_case
from femupdate.virtual import virtual_experiment
from two_storey_case import MODEL_AND_DATA, TRUTH

CASE = MODEL_AND_DATA + """\
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

"""A small case for the posterior's wiring tests: the two-storey shear building of
tests/two_storey_case.py (as tests/test_workflow.py), a noisy virtual experiment, and a
[posterior] section."""

from __future__ import annotations

import sys
from pathlib import Path

from femupdate.case import load_case
from femupdate.trials.virtual import virtual_experiment
from kill_midway import kill_midway
from two_storey_case import MODEL_AND_DATA, TRUTH

SRC = str(Path(__file__).resolve().parents[2] / "src")
HERE = str(Path(__file__).resolve().parent)

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


# A posterior run in a child process on the same residuals slowed down (same values), so that
# a poller sees its checkpoints before it ends and can SIGKILL it midway.
SLOW_POSTERIOR = """
import sys, time
sys.path[:0] = [{src!r}, {here!r}]
from pathlib import Path
from femupdate.case import load_case
from femupdate.inference.method import SampledProblem
from femupdate.runs import Execution
from femupdate.pipeline.posterior.run import run_posterior

fast = SampledProblem.residuals_batch
def slow(self, X, **kw):
    time.sleep({delay} * len(X))
    return fast(self, X, **kw)
SampledProblem.residuals_batch = slow
run_posterior(load_case(Path(sys.argv[1])), Path(sys.argv[2]),
              execution=Execution(chunk_evals=100))
"""


def kill_posterior_when(case_path: Path, out: Path, store: Path, evals: int, delay: float,
                        timeout: float = 300.0) -> int:
    """Run the posterior of ``case_path`` into ``out`` in a child (its residuals slowed by
    ``delay`` s per row), SIGKILL it once ``store`` holds ``evals`` evaluations and a
    checkpoint, and return its exit code (−SIGKILL when it was killed midway)."""
    code = SLOW_POSTERIOR.format(src=SRC, here=HERE, delay=delay)
    return kill_midway([sys.executable, "-c", code, str(case_path), str(out)], store, evals,
                       1, timeout)

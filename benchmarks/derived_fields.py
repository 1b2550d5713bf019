"""The cost of one φ evaluation with a derived field or a constraint, beside the same model with
the number written out: a one-storey Bouc–Wen oscillator (2 s at 200 Hz, central differences)
whose ``gamma`` is ``"0.5 * beta"``, is ``150`` (the records' truth), or is a parameter kept by
``[[constraints]] rule = "gamma <= beta"``.

    python benchmarks/derived_fields.py [--points 300] [--repeat 3]

Each variant is timed at the same seeded points of the box (k on a log scale in [2000, 8000],
beta in [150, 450]), one call per point (what a search's single evaluations cost), and as one
batch of all the points (``UpdateProblem.evaluate_batch``); the median of ``--repeat`` passes,
after one warm-up pass (numba compiles its kernels at the first call). Prints ms per
evaluation and the load average (the machine may be shared).
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from femupdate.case import load_case
from femupdate.problem.update import UpdateProblem
from femupdate.trials.experiment import load_experiments
from femupdate.trials.virtual import virtual_experiment

# The case of tests/test_derived_update.py too.
#: One storey held by a Bouc–Wen element (γ = β/2 in the records' truth) and a dashpot.
CASE = """\
[case]
name = "bouc-wen oscillator"

[model.shear_building]
masses = [1.0]
stiffnesses = [0.0]
dampers = [0.5]

[model.shear_building.bouc_wen]
k = "k"
alpha = 0.1
beta = "beta"
gamma = GAMMA

[[parameters]]
name = "k"
lower = 2000.0
upper = 8000.0
scale = "log"

[[parameters]]
name = "beta"
lower = 150.0
upper = 450.0
EXTRA
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

[search]
runs = 2
seed = 3
max_evals = 400
"""
TRUTH = {"k": 4000.0, "beta": 300.0}
GAMMA_FREE = '''
[[parameters]]
name = "gamma"
lower = 50.0
upper = 400.0

[[constraints]]
rule = "gamma <= beta"
'''


def write_case(folder: Path, gamma: str, extra: str = "") -> Path:
    """``folder/case.toml``: :data:`CASE` with its gamma field and the extra sections."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "case.toml"
    path.write_text(CASE.replace("GAMMA", gamma).replace("EXTRA", extra), encoding="utf-8")
    return path


def _ms(call: object, X: np.ndarray, repeat: int, batch: bool) -> float:
    """Median ms per point over ``repeat`` passes (one warm-up pass first)."""
    times = []
    for _ in range(repeat + 1):
        start = time.perf_counter()
        if batch:
            call.evaluate_batch(X)  # type: ignore[attr-defined]
        else:
            for x in X:
                call(x)  # type: ignore[operator]
        times.append((time.perf_counter() - start) / X.shape[0] * 1e3)
    return statistics.median(times[1:])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=300)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="CI: 20 points, one pass")
    args = parser.parse_args(argv)
    if args.quick:
        args.points, args.repeat = 20, 1
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        case = load_case(write_case(folder, '"0.5 * beta"'))
        virtual_experiment(case, TRUTH, folder / "data", seed=2, rate=200.0, duration=2.0,
                           snr=0.0, offset=0.0, drift=0.0, pga_g=0.35)
        experiments = load_experiments(case)
        rng = np.random.default_rng(0)
        k = rng.uniform(np.log10(2000.0), np.log10(8000.0), args.points)
        beta = rng.uniform(150.0, 450.0, args.points)
        two = np.column_stack([k, beta])
        three = np.column_stack([k, beta, 0.5 * beta])  # inside the constraint
        variants = [
            ("gamma = 150 (a number)", write_case(folder / "n", "150.0"), two, None),
            ('gamma = "0.5 * beta"', write_case(folder / "d", '"0.5 * beta"'), two, None),
            ('gamma = "0.5 * beta", step by step', write_case(folder / "d", '"0.5 * beta"'), two,
             False),
            ('gamma free, rule = "gamma <= beta"', write_case(folder / "c", '"gamma"', GAMMA_FREE),
             three, None),
        ]
        print(f"{args.points} points, median of {args.repeat} passes; load average "
              f"{os.getloadavg()[0]:.1f}")
        print(f"{'variant':40s} {'ms/call':>8s} {'ms/point in a batch':>20s}")
        for label, path, X, compiled in variants:
            problem = UpdateProblem(load_case(path), experiments, compiled=compiled)
            single = _ms(problem, X, args.repeat, batch=False)
            batch = _ms(problem, X, args.repeat, batch=True)
            print(f"{label:40s} {single:8.3f} {batch:20.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Where the reduced path pays through a case file: φ of shear buildings of 50 to 1,000 DOFs.

The case of examples/large/make_case.py (floors of 1 kg, first mode near 2 Hz, modes about
4 Hz apart, Rayleigh damping, 3 acceleration sensors, 10 stiffness parameters) with a
noise-free virtual experiment of 5,000 samples at 100 Hz (the reduced path keeps the modes up
to 2 × 50 Hz: 25 of them). φ through ``UpdateProblem`` as ``femupdate run`` evaluates it, at
7 points of the box (each a new model: assembly, modes, simulation, error function):

- ``exact``: ``[simulation] method = "exact"``, the compiled evaluator (the full model's
  dense 2n × 2n eigen-decomposition, then the modal recursion);
- ``reduced``: ``method = "reduced"``, step by step on the sparse model's lowest modes.

Prints the median time of each (one BLAS thread, the load average beside: wall times on a
shared machine are upper bounds), their ratio, and the truncation error the run would report.
``REDUCED_MIN_DOF`` in femupdate/case/simulation_path.py is the size from which ``reduced`` wins.

Run from the repository root: ``python benchmarks/reduced_case.py`` (``--quick``: 50 and
200 DOFs, 1,000 samples).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy loads (one BLAS thread)

import argparse
import tempfile
import time
import tomllib
from pathlib import Path

import numpy as np

from femupdate.case import parse_case
from femupdate.case.simulation_path import REDUCED_MIN_DOF
from femupdate.paper.bench import large_building as MAKE
from femupdate.problem.reduced_path import simulation_record
from femupdate.problem.update import UpdateProblem
from femupdate.trials.experiment import load_experiments
from femupdate.trials.virtual import virtual_experiment

GROUPS = 10
RATE_HZ = 100.0
POINTS = 7




def load() -> str:
    return "load {:.1f} {:.1f} {:.1f}".format(*os.getloadavg())


def problem(storeys: int, method: str, directory: Path) -> UpdateProblem:
    text = MAKE.case_text(storeys, GROUPS, method=method, data_directory=str(directory))
    case = parse_case(tomllib.loads(text), source=directory / "case.toml")
    return UpdateProblem(case, load_experiments(case))


def phi_time(prob: UpdateProblem, points: np.ndarray) -> float:
    """Median seconds of φ over the points (after one call that compiles and warms)."""
    prob(points[0])
    times = []
    for x in points:
        t0 = time.perf_counter()
        prob(x)
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="50 and 200 DOFs, 1,000 samples")
    args = parser.parse_args()
    sizes = [50, 200] if args.quick else [50, 100, 200, 400, 1000]
    samples = 1000 if args.quick else 5000
    print(f"φ through a case, {samples} samples at {RATE_HZ:g} Hz, 3 sensors, {GROUPS} "
          f"parameters; medians of {POINTS} points; REDUCED_MIN_DOF = {REDUCED_MIN_DOF}")
    print(f"{'DOFs':>6} {'exact (compiled)':>17} {'reduced':>10} {'exact/reduced':>14} "
          f"{'modes':>6} {'truncation':>11}  load")
    rng = np.random.default_rng(2022)
    for n in sizes:
        with tempfile.TemporaryDirectory() as tmp:
            directory = Path(tmp)
            text = MAKE.case_text(n, GROUPS, method="reduced", data_directory=str(directory))
            case = parse_case(tomllib.loads(text), source=directory / "case.toml")
            virtual_experiment(case, MAKE.truth(n, GROUPS), directory, seed=1, snr=0.0,
                               offset=0.0, drift=0.0, duration=(samples - 1) / RATE_HZ,
                               rate=RATE_HZ, length_scale=1.0)
            reduced = problem(n, "reduced", directory)
            lo, hi = np.array(reduced.bounds).T
            points = lo + (hi - lo) * rng.uniform(0.1, 0.9, (POINTS, lo.size))
            t_red = phi_time(reduced, points)
            record = simulation_record(reduced)
            if n <= 400:
                exact = problem(n, "exact", directory)
                assert exact.compiled
                t_ex = phi_time(exact, points)
                ratio = f"{t_ex / t_red:.2f}"
                ex = f"{1e3 * t_ex:.1f} ms"
            else:
                ex, ratio = "not run", "–"  # seconds per call: the dense 2n × 2n state
            print(f"{n:>6} {ex:>17} {1e3 * t_red:>7.1f} ms {ratio:>14} "
                  f"{record['n_modes']:>6} {record['truncation_error']:>11.2g}  {load()}")


if __name__ == "__main__":
    main()

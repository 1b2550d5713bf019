"""Nonlinear models on the reduced path (Craig–Bampton): accuracy against the cut-off, and φ
against the full nonlinear model, in one run (issue 22).

The case of ``femupdate.paper.bench.friction_beam``: a 30 m steel beam on springs (122 DOFs), a
friction damper at mid-span, two acceleration sensors, a virtual experiment of the full model
(EC8 accelerogram, 4 s at 200 Hz, noise-free), 200 substeps. Prints:

1. For cut-off factors 4, 8, 16 (the default) and 32 × the band (Nyquist, 100 Hz): the reduced
   model's DOFs and its truncation error at the truth (φ of its prediction with the full
   model's as the target: ``trial_truncation``).
2. φ at a point off the truth, full model (the compiled evaluator) and reduced (default
   cut-off): median wall time of repeated calls, one BLAS thread, the load average beside.

    python benchmarks/craig_bampton.py [--quick]

``--quick`` (CI): factors 8 and 16, 3 calls each.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy loads (pitfall: BLAS threads)

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from femupdate.paper.bench.friction_beam import TRUTH, friction_beam_case
from femupdate.problem.reduced_path import trial_truncation
from femupdate.problem.update import UpdateProblem
from femupdate.trials.experiment import load_experiment
from femupdate.trials.virtual import virtual_experiment


def load() -> str:
    return "load " + " ".join(f"{x:.1f}" for x in os.getloadavg())


def median_ms(problem: UpdateProblem, values: dict[str, float], repeat: int) -> float:
    problem(values)  # compile / warm up
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        problem(values)
        times.append(time.perf_counter() - start)
    return 1e3 * statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="two factors, for CI")
    args = parser.parse_args()
    factors = (8.0, 16.0) if args.quick else (4.0, 8.0, 16.0, 32.0)
    repeat = 3 if args.quick else 15
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        virtual_experiment(friction_beam_case(work, "nonlinear"), TRUTH, work, seed=1, snr=0.0,
                           offset=0.0, drift=0.0, duration=4.0, rate=200.0, length_scale=1.0)
        full = UpdateProblem(friction_beam_case(work, "nonlinear"),
                             load_experiment(friction_beam_case(work, "nonlinear")))
        case = friction_beam_case(work, "reduced")
        reduced = UpdateProblem(case, load_experiment(case))
        n = reduced.model.structure.n_dof
        print(f"femupdate benchmarks/craig_bampton.py: a {n}-DOF beam with a friction damper, "
              f"200 substeps; {load()}", flush=True)
        print("\n1. truncation error at the truth against the cut-off (× the band, 100 Hz)")
        path = reduced.model.reduced
        default = path.cutoff_factor
        for factor in factors:
            path.cutoff_factor = factor
            record = trial_truncation(reduced.fitted[0], TRUTH)
            print(f"  factor {factor:4g}: {record['n_modes']:3d} reduced DOFs of {n}, "
                  f"truncation error {record['truncation_error']:.2e}", flush=True)
        path.cutoff_factor = default
        off = {name: 1.04 * value for name, value in TRUTH.items()}
        full_ms = median_ms(full, off, repeat)
        reduced_ms = median_ms(reduced, off, repeat)
        print(f"\n2. φ off the truth: full {full_ms:.1f} ms (compiled: {full.fitted[0].compiled}),"
              f" reduced (factor {default:g}) {reduced_ms:.1f} ms; full / reduced "
              f"{full_ms / reduced_ms:.2f} ({load()})")


if __name__ == "__main__":
    main()

"""φ of a multi-support case per evaluation: step by step against compiled, in one run.

    python benchmarks/multisupport_evaluation.py [--data DIR] [--repeat N] [--points K]
    python benchmarks/multisupport_evaluation.py --quick   # 3 points once (CI)

The case is ``examples/meloland/multisupport.toml``: the Meloland Road Overcrossing's deck
(10 free DOFs) driven by three support records (footing, two embankments) of the 2010 event,
4,001 samples of 5 channels (the records: ``../shared/data/cesmd_meloland``, or ``--data``).
The fitted trial's φ is evaluated at ``--points`` seeded points of the search box (the soft
corner, every parameter at its lower bound, among them: the cost of a modal path depends on the
point) by

- the step-by-step path (``compiled=False``: ``CaseModel.support_response``, what
  ``FEMUPDATE_EVALUATOR=reference`` selects), and
- the compiled path (:class:`femupdate.evaluation.supports.SupportEvaluator`),

cycling through the points ``--repeat`` times, one BLAS thread; it prints the median wall time
per evaluation of each, their ratio, and the largest differences of φ (relative) and of the
residual vectors (NMSE) between the two. The load average is printed at the start and the end:
on a shared machine the wall times are inflated.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

REPO = Path(__file__).resolve().parents[1]
CASE = REPO / "examples" / "meloland" / "multisupport.toml"
SEED = 35


def load() -> str:
    return f"load average {', '.join(f'{v:.2f}' for v in os.getloadavg())}"


def median_ms(phi: Callable[[np.ndarray], float], points: np.ndarray, repeat: int) -> float:
    """Median wall time (ms) of one call, cycling through ``points`` ``repeat`` times."""
    phi(points[0])  # compiled code and caches warmed
    times = []
    for _ in range(repeat):
        for x in points:
            start = time.perf_counter()
            phi(x)
            times.append(time.perf_counter() - start)
    return 1e3 * float(np.median(times))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=REPO.parent / "shared" / "data")
    parser.add_argument("--repeat", type=int, default=10)
    parser.add_argument("--points", type=int, default=8)
    parser.add_argument("--quick", action="store_true", help="3 points, once")
    args = parser.parse_args()
    if args.quick:
        args.repeat, args.points = 1, 3
    from femupdate.case import load_case
    from femupdate.problem.update import TrialProblem
    from femupdate.trials.experiment import load_experiment

    if not (args.data / "cesmd_meloland" / "calexico2010_ce01336.zip").is_file():
        print(f"records not found under {args.data} (--data DIR): skipped")
        return 0
    text = CASE.read_text().replace('directory = "../../../shared/data/cesmd_meloland"',
                                    f'directory = "{args.data / "cesmd_meloland"}"')
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder) / "multisupport.toml"
        work.write_text(text)
        case = load_case(work)
    fitted = case.trial_specs()[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the records' warnings are the example's, not timed
        experiment = load_experiment(case, fitted)
    compiled = TrialProblem(case, experiment, compiled=True)
    reference = TrialProblem(case, experiment, compiled=False)
    lo, hi = np.array(case.bounds).T
    rng = np.random.default_rng(SEED)
    points = np.vstack([lo, lo + (hi - lo) * rng.random((args.points - 1, lo.size))])
    print(f"{CASE.relative_to(REPO)}: trial {experiment.name!r}, {experiment.t.size} samples, "
          f"{experiment.target.shape[1]} channels, {compiled.model.structure.n_dof} free DOFs, "
          f"{len(compiled.model.groups)} support records; {load()}")
    with threadpool_limits(1):
        worst_phi = worst_r = 0.0
        for x in points:
            a, b = compiled.phi_at(x), reference.phi_reference(x)
            worst_phi = max(worst_phi, abs(a - b) / abs(b))
            ra = compiled.evaluator.residuals(x)
            rb = reference.residuals(case.to_physical(x))
            worst_r = max(worst_r, float(np.sum((ra - rb) ** 2) / np.sum(rb**2)))
        step = median_ms(reference.phi_reference, points, args.repeat)
        fast = median_ms(compiled.phi_at, points, args.repeat)
    print(f"step by step: {step:8.3f} ms per evaluation (median of {args.repeat} x "
          f"{len(points)} points, one BLAS thread)")
    print(f"compiled:     {fast:8.3f} ms per evaluation")
    print(f"speed-up:     {step / fast:8.1f} x")
    print(f"largest difference: phi {worst_phi:.1e} (relative), residuals {worst_r:.1e} (NMSE)")
    print(load())
    return 0


if __name__ == "__main__":
    sys.exit(main())

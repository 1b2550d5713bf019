"""The friction recurrence: the written-out SIMD kernel against the generic numba kernel.

    python benchmarks/friction_kernels.py [--repeat N] [--quick] [--table]

One run, one process, the same points: the friction bridge of the paper (central differences,
10 substeps, 47,680 steps), evaluated the way the product's default search (multistart-lm)
asks: residual vectors of a finite-difference Jacobian's n + 1 points as one batch, and single
calls of φ. Each figure is the median wall time per point, with one BLAS thread, for

- ``written``: the compiled evaluator as the product builds it (the recurrence generated for
  this problem's size, :mod:`femupdate.evaluation.codegen`, in SIMD lanes,
  :mod:`femupdate.evaluation.lanes`);
- ``generic``: the same evaluator bound to the generic numba kernel
  (:func:`femupdate.evaluation.evaluator._central_batch`), no lanes.

Both must give the same residuals to rounding (checked). The ratio generic / written is the
measured reason to keep the hand-written kernel (kept only if ≥ 1.5×). ``--table`` also
writes the figures to ``docs/tables/friction-kernels.md``, which docs/benchmarks.md includes.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
from doc_tables import write_table
from evaluation_cost import friction_bridge  # the same case, built once in the benchmarks
from threadpoolctl import threadpool_limits

from femupdate.evaluation import evaluator as evaluator_module
from femupdate.problem.update import UpdateProblem


def use_generic_kernel(problem: UpdateProblem) -> None:
    """Bind the problem's evaluator to the generic numba kernel (no written kernel, no lanes)."""
    ev = problem.evaluator
    ev._central_batch = evaluator_module._central_batch
    ev._written = None
    ev.lanes = None
    ev._bind()


def median_ms(fn, repeat: int) -> float:
    times = []
    for i in range(repeat):
        start = time.perf_counter()
        fn(i)
        times.append(time.perf_counter() - start)
    return 1e3 * statistics.median(times)


def measure(problem: UpdateProblem, X: np.ndarray, repeat: int) -> dict[str, float]:
    k = len(problem.bounds) + 1
    blocks = [X[j * k:(j + 1) * k] for j in range(len(X) // k)]
    batch = median_ms(lambda i: list(problem.residuals_batch(blocks[i % len(blocks)])),
                      repeat) / k
    single = median_ms(lambda i: problem(X[i % len(X)]), repeat)
    return {"jacobian batch, per point": batch, "single phi": single}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=15)
    parser.add_argument("--quick", action="store_true", help="3 repeats (CI)")
    parser.add_argument("--table", action="store_true",
                        help="write the figures to docs/tables/friction-kernels.md")
    args = parser.parse_args()
    repeat = 3 if args.quick else args.repeat
    load = os.getloadavg()[0]
    print(f"load average at start: {load:.1f}")
    with tempfile.TemporaryDirectory() as tmp, threadpool_limits(1):
        written = friction_bridge(Path(tmp))
        generic = friction_bridge(Path(tmp))
        use_generic_kernel(generic)
        if written.evaluator.lanes is None:
            raise SystemExit("the product built no written kernel for the friction bridge")
        rng = np.random.default_rng(0)
        low, high = np.array(written.bounds).T
        k = len(written.bounds) + 1
        X = low + (high - low) * rng.random((4 * k, len(low)))
        a = list(written.residuals_batch(X[:k]))
        b = list(generic.residuals_batch(X[:k]))
        worst = max(float(np.max(np.abs(p - q)) / max(np.max(np.abs(q)), 1e-300))
                    for p, q in zip(a, b, strict=True) if p is not None and q is not None)
        for problem in (written, generic):  # compile and warm both before timing
            measure(problem, X, 1)
        rows = {name: measure(p, X, repeat) for name, p in (("written", written),
                                                             ("generic", generic))}
    print(f"friction bridge, {X.shape[1]} parameters, batches of {k}; residuals agree to "
          f"{worst:.1e} (relative)")
    print(f"{'':28s}{'written ms':>12s}{'generic ms':>12s}{'generic/written':>17s}")
    table = []
    for label in rows["written"]:
        w, g = rows["written"][label], rows["generic"][label]
        print(f"{label:28s}{w:12.3f}{g:12.3f}{g / w:17.2f}")
        table.append((label, f"{w:.3f}", f"{g:.3f}", f"{g / w:.2f}×"))
    end = os.getloadavg()[0]
    print(f"load average at end: {end:.1f}")
    if args.table:
        path = write_table(
            "friction-kernels",
            ("friction bridge, median per point", "written-out, SIMD lanes (ms)",
             "generic numba (ms)", "generic / written"),
            table, f"python benchmarks/friction_kernels.py --table --repeat {repeat}",
            f"{X.shape[1]} parameters, batches of {k}, one BLAS thread; residuals agree to "
            f"{worst:.1e} (relative); the 1-minute load average of the 2-core machine was "
            f"{load:.1f} at the start and {end:.1f} at the end.")
        print(f"table written to {path}")


if __name__ == "__main__":
    main()

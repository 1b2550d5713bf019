"""Multi-support excitation of a case file's model against OpenSeesPy: print the figures.

Usage (repo root): ``python benchmarks/multisupport_opensees.py [--samples N]``. Each line is the
largest relative difference between femupdate (a ``[[model.support_groups]]`` case on the
built-in ``Structure`` path) and OpenSeesPy's ``MultipleSupport`` pattern (target 1e-8); see
docs/case-files.md.
"""

from __future__ import annotations

import argparse
import sys
import time

from femupdate.paper.bench.multisupport_check import run_check


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=400, help="samples of each record")
    parser.add_argument("--quick", action="store_true", help="100 samples (CI)")
    args = parser.parse_args()
    start = time.perf_counter()
    figures = run_check(100 if args.quick else args.samples)
    for name, value in figures.items():
        print(f"{name:48s} {value:.2e}")
    worst = max(figures.values())
    print(f"worst {worst:.2e} (target 1e-8); {time.perf_counter() - start:.1f} s")
    return 0 if worst < 1e-8 else 1


if __name__ == "__main__":
    sys.exit(main())

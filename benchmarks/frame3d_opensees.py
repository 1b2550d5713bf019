"""femupdate's 3-D frames and multi-support excitation against OpenSeesPy: print the figures.

Usage (repo root): ``python benchmarks/frame3d_opensees.py [--quick]``. Each line is the largest
relative difference between the two codes (target 1e-8); see docs/frames-3d.md.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

from femupdate.paper.bench.frame3d_check import run_checks


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="shorter records, fewer modes (CI)")
    args = parser.parse_args()
    start = time.perf_counter()
    figures = run_checks(quick=args.quick)
    worst = 0.0
    for name, value in figures.items():
        print(f"{name:56s} {value:.2e}")
        worst = max(worst, value)
    print(f"worst {worst:.2e} (target 1e-8); {time.perf_counter() - start:.1f} s, "
          f"load average {os.getloadavg()[0]:.2f}")
    return 0 if worst < 1e-8 else 1


if __name__ == "__main__":
    sys.exit(main())

"""Time every integrator on the paper's bridge, with OpenSeesPy side by side when installed.

    python benchmarks/simulate_kernels.py [--repeat N] [--no-opensees] [--json PATH]
    python benchmarks/simulate_kernels.py --quick   # 2 runs per row, no OpenSeesPy (CI)

The same as ``femupdate bench simulate``: see :mod:`femupdate.paper.bench.simulate` for what is
timed (the prepared simulator's run, preparation separately, one BLAS thread) and how the
ratios against OpenSeesPy are taken.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from femupdate.paper.bench.simulate import print_simulate_rows, run_simulate_benchmark


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=20, help="timed runs per femupdate row")
    parser.add_argument("--opensees-repeat", type=int, default=None,
                        help="timed runs per OpenSeesPy row (default min(repeat, 5))")
    parser.add_argument("--no-opensees", action="store_true", help="skip OpenSeesPy")
    parser.add_argument("--json", type=Path, default=None, help="write the rows to this file")
    parser.add_argument("--quick", action="store_true",
                        help="2 timed runs per row, no OpenSeesPy (a smoke run)")
    args = parser.parse_args()
    if args.quick:
        args.repeat, args.no_opensees = 2, True
    rows = run_simulate_benchmark(
        args.repeat, opensees=False if args.no_opensees else None,
        opensees_repeat=args.opensees_repeat, progress=lambda text: print(text, flush=True),
    )
    print_simulate_rows(rows)
    if args.json is not None:
        args.json.write_text(json.dumps(rows, indent=2) + "\n")


if __name__ == "__main__":
    main()

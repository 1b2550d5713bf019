"""Update the one-storey mini shake-table model from El Centro, check it, validate it on a sine.

    python examples/minishake-1story/validate.py [--data DIR] [--out DIR] [--runs N]

DIR is the shared data directory holding ``minishake_1story/`` (default: ``$FEMUPDATE_DATA``,
else ``../shared/data`` beside the repository). The logic is in
``study.py`` beside this script; this script parses the options and prints the table.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from study import DATA_ENV, find_data, format_table, run_minishake

from femupdate.errors import FemupdateError

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
DEFAULT_DATA = REPO.parent / "shared" / "data"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=None,
                        help=f"shared data directory (default: ${DATA_ENV}, else {DEFAULT_DATA})")
    parser.add_argument("--out", type=Path, default=None,
                        help="write summary.json, plots and minishake.json here")
    parser.add_argument("--runs", type=int, default=None, help="runs (default: the case's)")
    parser.add_argument("--max-evals", type=int, default=None,
                        help="evaluations per run (default: the case's)")
    parser.add_argument("--seed", type=int, default=None, help="root seed (default: the case's)")
    parser.add_argument("--workers", type=int, default=1, help="parallel processes")
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    args = parser.parse_args(argv)
    data = args.data or Path(os.environ.get(DATA_ENV) or DEFAULT_DATA)
    try:
        result = run_minishake(
            HERE / "elcentro.toml", HERE / "sine.toml", data_dir=find_data(data),
            runs=args.runs, seed=args.seed, max_evals=args.max_evals, workers=args.workers,
            out_dir=args.out,
        )
    except FemupdateError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(json.dumps(result, indent=2) if args.json else format_table(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

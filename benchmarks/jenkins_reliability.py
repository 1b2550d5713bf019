"""Is the search reliable on real records? The 1-storey specimen with the Jenkins model.

The shared mini shake-table specimen (examples/minishake-1story), storey k + Jenkins slider
(k_r, f_u) + c, fitted to El Centro 1 and Northridge 1 together (the study's fit set b):
``--runs`` independent runs (children of one SeedSequence) of ``--method`` at ``--max-evals``
each. Prints each run's best φ, how far the runs' best φ lie apart ((max − min) / min: the
goal is below 1 %), the verdict (docs/verdicts.md) and the wall time beside the load average
(other jobs on the machine inflate it; the evaluation counts do not depend on it).

    python benchmarks/jenkins_reliability.py [--data DIR] [--runs 10] [--max-evals 3000]
        [--seed 20250402] [--workers 2] [--options '{"patience": 5}'] [--json out.json]

``--quick`` (for CI): two runs of 600 evaluations on one worker; its spread says nothing of the
goal.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "examples" / "minishake-1story"))
import study  # noqa: E402

from femupdate.pipeline.run import run_case  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=None, help="shared data directory")
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--max-evals", type=int, default=3000)
    parser.add_argument("--seed", type=int, default=20250402)
    parser.add_argument("--method", default="multistart-lm")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--options", default=None, help="method options as JSON")
    parser.add_argument("--fit-set", default="b", choices=sorted(study.FIT_SETS))
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--quick", action="store_true",
                        help="2 runs of 600 evaluations on one worker (a smoke run for CI)")
    args = parser.parse_args(argv)
    if args.quick:
        args.runs, args.max_evals, args.workers = 2, 600, 1
    data = study.find_data(args.data if args.data is not None
                           else os.environ.get(study.DATA_ENV) or ROOT.parent / "shared" / "data")
    # agree = 0: the study is how reliably every run finds the best, so none stops early
    search = {"runs": args.runs, "max_evals": args.max_evals, "seed": args.seed,
              "method": args.method, "agree": 0}
    if args.options:
        search["options"] = json.loads(args.options)
    case = study.study_case("jenkins", args.fit_set, data, search=search)
    start = time.perf_counter()
    result = run_case(case, None, workers=args.workers)
    wall = time.perf_counter() - start
    load = os.getloadavg()
    summary = result.summary
    phis = [r.phi for r in summary.runs]
    lo, hi = min(phis), max(phis)
    for r in summary.runs:
        print(f"run {r.index}: φ {r.phi:.6g} ({r.phi / lo - 1:+.3%} of the best), "
              f"{r.nfev} evaluations, stop {', '.join(r.stop)}, "
              + ", ".join(f"{k} {v:.4g}" for k, v in r.params.items()))
    spread = hi / lo - 1.0
    print(f"best φ of {len(phis)} runs within {spread:.3%} of each other "
          f"({'within' if spread <= 0.01 else 'NOT within'} 1 %); "
          f"evaluations {sum(r.nfev for r in summary.runs):,} in all, at most "
          f"{args.max_evals:,} a run")
    print(f"verdict: {summary.verdict.words if summary.verdict else '-'}")
    print(f"wall {wall:.1f} s, load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} "
          f"(2 cores shared with other jobs: wall times inflated)")
    if args.json:
        args.json.write_text(json.dumps({"phis": phis, "spread": spread,
                                         "runs": summary.runs_as_dicts(),
                                         "verdict": summary.verdict.model_dump()
                                         if summary.verdict else None, "wall_s": wall,
                                         "load": load}, indent=2, allow_nan=True))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

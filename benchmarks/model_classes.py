"""Model-class selection on the real 1-storey specimen: evidence and posterior probabilities of
three model forms fitted to El Centro trial 1, and the best class's predictive bands on the
five trials it was not fitted to.

    python benchmarks/model_classes.py [--data DIR] [--models linear,jenkins,table]
        [--samples 1000] [--seed 1] [--error-model KIND] [--workers 2] [--out DIR]
        [--json PATH]

The classes are those of ``examples/minishake-1story/study.py`` (its fit set "a": El Centro 1
fitted, the five other trials validated): the linear viscous storey (k, c), the paper's
Jenkins slider (k, c, k_r, f_u) and the table-damped storey (k, c0, cv). Each: the case's
search (multistart-lm, 4 runs), then TMCMC (``femupdate posterior``: ``--samples`` per run,
its default 4 independent runs, and their verdict) with the default error model (or
``--error-model``), its effective counts measured at the first class's best fit and shared
(see :mod:`femupdate.pipeline.posterior.classes`). Prints the table of log-evidences and posterior
probabilities (equal prior probabilities), then the coverage of the best class's 5–95 %
predictive bands on every trial, with the evaluation counts, wall times and load average.
Data: Chern & Perez (mdof project, BSD-2-Clause), from the shared data directory.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "examples" / "minishake-1story"))

from study import MODELS, find_data, study_case  # noqa: E402

from femupdate.case import parse_case  # noqa: E402
from femupdate.case.posterior_section import DEFAULT_POSTERIOR  # noqa: E402
from femupdate.pipeline.posterior.classes import compare_classes, format_classes  # noqa: E402
from femupdate.runs import Execution  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", default=os.environ.get("FEMUPDATE_DATA",
                                                         str(REPO.parent / "shared" / "data")))
    parser.add_argument("--models", default=",".join(MODELS))
    parser.add_argument("--samples", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--error-model", default=DEFAULT_POSTERIOR.error_model)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--quick", action="store_true",
                        help="200 samples a class (a smoke run for CI)")
    args = parser.parse_args(argv)
    if args.quick:
        args.samples = 200
    data = find_data(args.data)
    cases = {}
    for model in args.models.split(","):
        spec = study_case(model, "a", data).to_dict()
        spec["posterior"] = {"samples": args.samples, "seed": args.seed, "modes_samples": 200,
                             "error_model": args.error_model}
        cases[model] = parse_case(spec, source=REPO / "examples" / "minishake-1story"
                                  / "trials.toml")
    out = args.out or Path(tempfile.mkdtemp(prefix="femupdate-classes-"))
    start = time.perf_counter()
    rows, results = compare_classes(cases, out, workers=args.workers,
                                    execution=Execution(label="classes"))
    wall = time.perf_counter() - start
    print(format_classes(rows))
    print(f"\nall classes: {wall:.1f} s wall (search + TMCMC + modes + bands), load average "
          f"{os.getloadavg()[0]:.2f} (other jobs share the machine)")
    reached = [r for r in rows if r.log_evidence is not None]
    if not reached:
        print("no class reached its posterior")
        return 1
    best = max(reached, key=lambda r: r.log_evidence)
    print(f"\nbest class: {best.name}; its 5–95 % predictive bands "
          f"(share of each measured record inside):")
    print("| trial | role | covered |\n|---|---|---|")
    for b in results[best.name].bands:
        cover = ", ".join(f"{c} {100 * v:.1f} %" for c, v in zip(b.channels, b.coverage,
                                                                  strict=True))
        print(f"| {b.trial} | {b.role} | {cover} |")
    for r in rows:
        q = r.record.frequencies_hz.get("f1")
        f1 = "" if q is None else f"; f1 {q.q50:.3f} Hz [{q.q05:.3f}, {q.q95:.3f}]"
        print(f"{r.name}: {r.record.message}{f1}; verdict: {r.record.agreement}; "
              + "; ".join([*(f"start: {w}" for w in r.record.start_warnings),
                           *r.record.sentences]))
    if args.json is not None:
        args.json.write_text(json.dumps({
            "classes": [{"name": r.name, "log_evidence": r.log_evidence,
                         "probability": r.probability, "nfev": r.nfev, "wall_s": r.wall_s,
                         "posterior": r.record.model_dump()} for r in rows],
            "best": best.name,
            "coverage": {b.trial: dict(zip(b.channels, b.coverage.tolist(), strict=True))
                         for b in results[best.name].bands}}, indent=2))
    print(f"results in {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""What the agreement stop does on the posterior's calibration records: every planned run of
each record's own search, then the runs each rule would have needed.

    python benchmarks/agreement_stop.py --model friction --replicates 20
    python benchmarks/agreement_stop.py --model viscous --replicates 50 [--prior]
    python benchmarks/agreement_stop.py --quick     # CI: one viscous record, 4 runs

Each replicate is a record of benchmarks/posterior.py's product calibration (the same truth,
noise and search seed: ``--only calibration --product --fit-runs 0``, at the example's truth
or with ``--prior`` at a truth drawn from the prior), searched with the example's
``[search]`` (``f_target`` removed) and ``agree = 0``: every planned run. Then, on the runs'
φ in index order (:func:`femupdate.runs.verdict.runs_needed`), the runs needed by agreement
alone (two runs at the best φ) and by the product's stop (agreement, and no more than half
of the runs alone at their φ), and the best φ each ends at beside the lowest of all the runs.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from posterior import SEED, bridge_replicate, own_search, replicate_seeds

from femupdate.case import parse_case
from femupdate.paper.problems import bridge
from femupdate.pipeline.run import run_case
from femupdate.runs import Execution
from femupdate.runs.verdict import AGREE, UNSEEN_SHARE, runs_needed


def all_runs(model: str, i: int, root: Path, prior_truth: bool, runs: int | None = None
             ) -> list[float]:
    """Each run's φ, by index, of replicate ``i``'s own search with every planned run
    (``runs``: that many instead of the example's)."""
    child = np.random.SeedSequence(SEED).spawn(i + 1)[i]
    work = root / f"replicate-{i}"
    spec, _, _ = bridge_replicate(model, child, work, None if prior_truth else bridge.truth(model))
    spec["search"] = own_search(spec["search"], replicate_seeds(child)[0], agree=0,
                                **({} if runs is None else {"runs": runs}))
    case = parse_case(spec, source=work / f"{model}.toml")
    result = run_case(case, work / "out", execution=Execution(quiet=True), sensitivities=False)
    return [float(o.fun) for o in result.outcomes]


def stops(phis: list[float]) -> dict[str, Any]:
    """The runs each rule needs and the best φ it ends at (every run when it never stops)."""
    out: dict[str, Any] = {"lowest": min(phis), "runs": len(phis)}
    for rule, unseen in (("agreement", 1.0), ("product", UNSEEN_SHARE)):
        needed = runs_needed(phis, AGREE, unseen)
        k = len(phis) if needed is None else needed
        out[rule] = {"runs": k, "best": min(phis[:k])}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--model", choices=("viscous", "friction"), default="friction")
    parser.add_argument("--replicates", type=int, default=20)
    parser.add_argument("--prior", action="store_true",
                        help="truths drawn from the prior (default: the example's truth)")
    parser.add_argument("--hits", type=Path, help="JSON lines of each replicate's φ (resumes)")
    parser.add_argument("--quick", action="store_true",
                        help="CI: one viscous record, 4 runs planned")
    args = parser.parse_args()
    runs = None
    if args.quick:
        args.model, args.replicates, args.prior, args.hits, runs = "viscous", 1, False, None, 4
    done: dict[int, list[float]] = {}
    if args.hits is not None and args.hits.exists():
        for line in args.hits.read_text().splitlines():
            row = json.loads(line)
            done[row["replicate"]] = row["phis"]
    start = time.perf_counter()
    truths = "truths drawn from the prior" if args.prior else "the example's truth"
    print(f"## The agreement stop: {args.model} bridge, 2 % noise, {truths}, "
          f"{args.replicates} records, every planned run of the example's [search]")
    print(f"{'record':>6s} {'runs':>5s} {'lowest φ':>10s} {'agreement':>18s} {'product':>18s}")
    totals = {"agreement": 0, "product": 0}
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.replicates):
            if i not in done:
                done[i] = all_runs(args.model, i, Path(tmp), args.prior, runs)
                if args.hits is not None:
                    with args.hits.open("a") as f:
                        f.write(json.dumps({"replicate": i, "phis": done[i]}) + "\n")
            row = stops(done[i])
            for rule in totals:
                totals[rule] += row[rule]["runs"]
            print(f"{i:6d} {row['runs']:5d} {row['lowest']:10.4g} "
                  + " ".join(f"{row[r]['runs']:3d} runs {row[r]['best']:9.4g}"
                             for r in ("agreement", "product")), flush=True)
    print(f"runs needed over the {args.replicates} records: agreement alone "
          f"{totals['agreement']}, the product's stop {totals['product']} "
          f"({time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main()

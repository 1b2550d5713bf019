"""Wall time of N independent runs: local processes against a Dask LocalCluster.

Runs ``run_all`` three ways on the same φ and seeds: in this process (1 worker), on local
worker processes, and on a ``dask.distributed.LocalCluster`` with the same number of worker
processes (one thread each); and, for the cost of the store and the chunks, the store-less
``repeat()`` on local processes. Prints the wall time, evaluations per second and whether the
results agree bit for bit with the in-process ones. Each way writes its own results store in a
temporary directory, as ``femupdate run`` does.

φ is given as an import path ``module:attribute``; a class is instantiated without arguments,
and ``module:factory()`` calls a factory, e.g. ``femupdate.paper.problems.bridge:viscous_problem()``
(the viscous bridge on its noise-free virtual experiment).
The bounds come from its ``bounds`` attribute (or ``--bounds``, a JSON list of pairs).

    python benchmarks/dask_runs.py [--fun femupdate.paper.problems.dynamic:DynamicProblem]
        [--method ab] [--runs 25] [--workers 2] [--max-evals 50000] [--f-target 1e-10]
        [--seed 0] [--skip-inline]
    python benchmarks/dask_runs.py --quick     # 2 runs of 300 evaluations: a smoke run (CI)
"""

from __future__ import annotations

import argparse
import importlib
import json
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from femupdate.runs import Execution, RunOutcome, repeat, run_all


def load_fun(path: str) -> Any:
    """The object at ``module:attribute`` (a class is instantiated, ``factory()`` called)."""
    module, _, attr = path.partition(":")
    call = attr.endswith("()")
    obj = getattr(importlib.import_module(module), attr.removesuffix("()"))
    return obj() if call or isinstance(obj, type) else obj


def timed(label: str, out: Path, fun: Any, bounds: Any, args: argparse.Namespace,
          **where: Any) -> tuple[float, list[RunOutcome]]:
    options = json.loads(args.options)
    start = time.perf_counter()
    outcomes = run_all(fun, bounds, args.method, runs=args.runs, seed=args.seed,
                       max_evals=args.max_evals, f_target=args.f_target, options=options,
                       store_dir=out / label, execution=Execution(**where))
    wall = time.perf_counter() - start
    evals = sum(o.nfev for o in outcomes)
    print(f"{label:>10}: {wall:7.2f} s  {evals:>9,} evals  {evals / wall:>9,.0f} evals/s",
          flush=True)
    return wall, outcomes


def same(a: list[RunOutcome], b: list[RunOutcome]) -> bool:
    return all(np.array_equal(x.x, y.x) and x.fun == y.fun and x.nfev == y.nfev
               for x, y in zip(a, b, strict=True))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fun", default="femupdate.paper.problems.dynamic:DynamicProblem")
    parser.add_argument("--bounds", default=None, help="JSON list of [low, high] pairs")
    parser.add_argument("--method", default="ab")
    parser.add_argument("--options", default="{}", help="JSON object of method options")
    parser.add_argument("--runs", type=int, default=25)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--max-evals", type=int, default=50_000)
    parser.add_argument("--f-target", type=float, default=1e-10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--skip-inline", action="store_true", help="skip the 1-process run")
    parser.add_argument("--quick", action="store_true",
                        help="2 runs of at most 300 evaluations (a smoke run)")
    args = parser.parse_args()
    if args.quick:
        args.runs, args.max_evals = 2, 300

    from dask.distributed import LocalCluster

    fun = load_fun(args.fun)
    bounds = json.loads(args.bounds) if args.bounds else fun.bounds
    print(f"{args.runs} runs of {args.method} on {args.fun}, {args.workers} workers")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        results: dict[str, list[RunOutcome]] = {}
        if not args.skip_inline:
            _, results["inline"] = timed("1 process", out, fun, bounds, args, workers=1)
        _, results["local"] = timed("processes", out, fun, bounds, args, workers=args.workers)
        start = time.perf_counter()
        repeat(fun, bounds, args.method, runs=args.runs, seed=args.seed, workers=args.workers,
               max_evals=args.max_evals, f_target=args.f_target, **json.loads(args.options))
        print(f"{'no store':>10}: {time.perf_counter() - start:7.2f} s  (repeat(), processes, "
              f"whole runs as tasks)", flush=True)
        start = time.perf_counter()
        with LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                          dashboard_address=None) as cluster:
            print(f"  (LocalCluster started in {time.perf_counter() - start:.1f} s)")
            _, results["dask"] = timed("dask", out, fun, bounds, args,
                                       scheduler=cluster.scheduler_address)
        ref_name = "inline" if "inline" in results else "local"
        for name, outcomes in results.items():
            if name != ref_name:
                print(f"  {name} results identical to {ref_name}: "
                      f"{same(results[ref_name], outcomes)}")


if __name__ == "__main__":
    main()

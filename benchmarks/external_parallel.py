"""Wall time of OpenSeesPy-model evaluations: 1 and 2 local processes, a Dask LocalCluster.

The viscous bridge written as an OpenSeesPy script (examples/bridge-external/bridge_opensees.py,
nodal base load, Newmark with ``--substeps``) on its noise-free virtual experiment. The same
workload three ways: in this process (one model process), over 2 local worker processes, and
on a ``dask.distributed.LocalCluster`` of 2 single-threaded workers. Each evaluation runs in a
child process holding the model (one per worker; femupdate.external.isolation).

Workload ``batch`` (default): ``--candidates`` parameter vectors drawn uniformly in the narrow
bounds from ``--seed``: the first batch starts the model processes (cold), ``--repeats`` more
reuse them (warm: the shortest is reported). Workload ``search``: one update (``run_all``,
``--method``, default multistart-lm, until φ ≤ ``--f-target`` or ``--max-evals``) whose
batches (its pools and Jacobians; cmaes: its populations) are spread over the workers.
Prints the wall times, the ratios to one process and whether the results (φ, or the update's
best x and φ) are bit-identical across the three.

    python benchmarks/external_parallel.py [--workload batch|search] [--candidates 24]
        [--substeps 10] [--seed 0] [--workers 2] [--repeats 2] [--method multistart-lm]
        [--max-evals 2000] [--f-target 1e-6] [--json out.json]
    python benchmarks/external_parallel.py --quick  # 4 candidates, 1 substep, 1 warm batch (CI)
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from femupdate.case import parse_case
from femupdate.optimize.minimize import objective_for
from femupdate.paper.problems import bridge
from femupdate.problem.update import UpdateProblem
from femupdate.runs import Execution, run_all
from femupdate.runs.batch import evaluate_batch
from femupdate.runs.executors import RunExecutor, open_executor

SCRIPT = Path(__file__).resolve().parents[1] / "examples" / "bridge-external" / "bridge_opensees.py"


def bridge_problem(substeps: int) -> UpdateProblem:
    """φ of the OpenSeesPy bridge (the case's [model.opensees]) on the viscous virtual
    experiment (noise-free)."""
    ref = bridge.viscous_problem()
    spec = ref.case.to_dict()
    spec["model"] = {"opensees": {"build": f"{SCRIPT}:build", "outputs": [[2, 2], [3, 2], [4, 2]],
                                  "direction": 2, "excitation": "nodal", "algorithm": "linear"}}
    spec["preprocess"]["substeps"] = substeps
    spec["simulation"].pop("method", None)  # an external model integrates itself
    return UpdateProblem(parse_case(spec, source=ref.case.source), ref.experiment)


def candidates(problem: UpdateProblem, n: int, seed: int) -> np.ndarray:
    low, high = np.array(problem.bounds).T
    return low + (high - low) * np.random.default_rng(seed).random((n, low.size))


def time_batches(problem: UpdateProblem, xs: np.ndarray, ex: RunExecutor, repeats: int
                 ) -> tuple[float, float, np.ndarray]:
    """Wall time of evaluating ``xs`` cold, the shortest of ``repeats`` warm ones, and φ."""
    t0 = time.perf_counter()
    cold = evaluate_batch(problem, xs, ex)
    cold_s = time.perf_counter() - t0
    phi = np.array([e.phi for e in cold])
    warm_s = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        warm = evaluate_batch(problem, xs, ex)
        warm_s = min(warm_s, time.perf_counter() - t0)
        failed = [e.error for e in cold + warm if e.failed]
        if failed:
            raise RuntimeError(f"{len(failed)} evaluations failed, e.g. {failed[0]}")
        if not np.array_equal(phi, [e.phi for e in warm]):
            raise RuntimeError("two batches of the same candidates differ")
    return cold_s, warm_s, phi


def time_search(problem: UpdateProblem, args: argparse.Namespace, execution: Execution
                ) -> tuple[float, float, np.ndarray]:
    """Wall time of one update (``--method``, to φ ≤ ``--f-target``), its evaluation count,
    and its best x followed by φ."""
    fun, residuals = objective_for(problem, args.method)
    options = {"popsize": args.popsize} if args.method == "cmaes" else {}
    t0 = time.perf_counter()
    (outcome,) = run_all(fun, problem.bounds,
                         args.method, runs=1, seed=args.seed, max_evals=args.max_evals,
                         f_target=args.f_target, options=options, execution=execution,
                         residuals=residuals)
    wall = time.perf_counter() - t0
    return wall, float(outcome.nfev), np.append(outcome.x, outcome.fun)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workload", choices=("batch", "search"), default="batch")
    parser.add_argument("--candidates", type=int, default=24)
    parser.add_argument("--substeps", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--method", default="multistart-lm", help="search workload's method")
    parser.add_argument("--popsize", type=int, default=6, help="with --method cmaes")
    parser.add_argument("--max-evals", type=int, default=2000)
    parser.add_argument("--f-target", type=float, default=1e-6)
    parser.add_argument("--repeats", type=int, default=2, help="warm batches (the shortest)")
    parser.add_argument("--json", type=Path)
    parser.add_argument("--quick", action="store_true",
                        help="batch of 4 candidates, 1 substep, 1 warm batch (a smoke run)")
    args = parser.parse_args()
    if args.quick:
        args.workload, args.candidates, args.substeps, args.repeats = "batch", 4, 1, 1

    from dask.distributed import LocalCluster

    problem = bridge_problem(args.substeps)
    xs = candidates(problem, args.candidates, args.seed)
    rows: dict[str, dict[str, Any]] = {}
    results: dict[str, np.ndarray] = {}
    print(f"workload {args.workload}: OpenSeesPy bridge, Newmark with {args.substeps} substeps",
          flush=True)

    def record(label: str, first: float, second: float, result: np.ndarray) -> None:
        results[label] = result
        if args.workload == "batch":
            rows[label] = {"cold_s": first, "warm_s": second,
                           "warm_per_eval_s": second / len(xs)}
            print(f"{label:>22}: cold {first:6.2f} s, warm {second:6.2f} s "
                  f"({second / len(xs):.3f} s per evaluation)", flush=True)
        else:
            rows[label] = {"wall_s": first, "evaluations": int(second)}
            print(f"{label:>22}: {first:6.2f} s, {int(second)} evaluations", flush=True)

    labels = ("1 process", f"{args.workers} local processes", f"Dask, {args.workers} workers")
    for label, where in zip(labels[:2], (1, args.workers), strict=True):
        if args.workload == "batch":
            with open_executor(where) as ex:
                record(label, *time_batches(problem, xs, ex, args.repeats))
        else:
            record(label, *time_search(problem, args, Execution(workers=where)))
        problem.close()  # this process's model process; pool workers take theirs along
    with LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster:
        if args.workload == "batch":
            with open_executor(scheduler=cluster.scheduler_address) as ex:
                record(labels[2], *time_batches(problem, xs, ex, args.repeats))
        else:
            record(labels[2], *time_search(problem, args,
                                          Execution(scheduler=cluster.scheduler_address)))

    key = "warm_s" if args.workload == "batch" else "wall_s"
    base = rows[labels[0]][key]
    for label in labels[1:]:
        rows[label]["speedup"] = base / rows[label][key]
        print(f"{label:>22}: {base / rows[label][key]:.2f}× the 1-process {key}")
    identical = all(np.array_equal(results[labels[0]], results[k]) for k in labels[1:])
    print(f"results identical across the three: {identical}")
    if args.json:
        args.json.write_text(json.dumps({"args": vars(args) | {"json": str(args.json)},
                                         "rows": rows, "identical": identical}, indent=2) + "\n")


if __name__ == "__main__":
    main()

"""COCO bbob, d = 5: multistart-lm's scalar mode beside AB and pycma (IPOP restarts), same run.

Functions f1–f24, instances 1–2 (48 problems), a budget of 1,000·d evaluations each, target
f − f_opt < 1e-8; prints per function which problems each method solved and the counts out of
48. multistart-lm and ab run through ``femupdate.minimize`` on the bbob box [−5, 5]^d (with
``f_target = f_opt + 1e-8``, f_opt = f(x_opt) as cocoex writes x_opt, so a run stops when it
hits); pycma runs ``cma.fmin2`` with IPOP restarts (λ default, doubled at each restart,
σ0 = 2, x0 uniform in [−4, 4]^d) on the same budget.

    pip install coco-experiment cma
    python benchmarks/coco_bbob.py [--methods multistart-lm,ab,pycma] [--dim 5]
    python benchmarks/coco_bbob.py --quick    # f1–f4, instance 1, d = 2, 100·d: a smoke run

The scalar mode's local method was chosen with this script: ``--methods`` also accepts
``multistart-lm:OPTIONS_JSON`` to compare settings.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import tempfile
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

import femupdate

DELTA = 1e-8


def problems(dim: int, instances: str = "1-2", functions: str = "1-24") -> Iterator[Any]:
    """The bbob problems of dimension ``dim`` (default: all 24 functions, instances 1 and 2),
    one at a time (cocoex frees a problem when the suite hands out the next)."""
    try:
        import cocoex
    except ImportError:
        raise SystemExit("coco_bbob.py needs COCO's Python package: pip install "
                         "coco-experiment") from None

    suite = cocoex.Suite("bbob", f"instances: {instances}",
                         f"dimensions: {dim} function_indices: {functions}")
    yield from suite


def f_opt(problem: Any) -> float:
    """f_opt of a bbob problem: f at the x_opt that cocoex writes to a file (it has no
    accessor for either)."""
    cached = F_OPT.get(problem.id)
    if cached is None:
        here = os.getcwd()
        with tempfile.TemporaryDirectory() as tmp:
            os.chdir(tmp)
            try:
                problem._best_parameter("print")
                x_opt = np.loadtxt("._bbob_problem_best_parameter.txt")
            finally:
                os.chdir(here)
        cached = F_OPT[problem.id] = float(problem(x_opt))
    return cached


F_OPT: dict[str, float] = {}


def run_femupdate(method: str, options: dict[str, Any], problem: Any, budget: int,
                  seed: int) -> float:
    """Best f − f_opt of one run of ``method`` on ``problem``."""
    target = f_opt(problem) + DELTA
    low, high = problem.lower_bounds, problem.upper_bounds
    res = femupdate.minimize(lambda x: float(problem(x)), list(zip(low, high, strict=True)),
                             method, seed=seed, max_evals=budget, f_target=target, **options)
    return res.fun - f_opt(problem)


def run_pycma(problem: Any, budget: int, seed: int) -> float:
    """Best f − f_opt of ``cma.fmin2`` with IPOP restarts."""
    import cma

    rng = np.random.default_rng(seed)
    target = f_opt(problem) + DELTA
    best = [np.inf]

    def fun(x: np.ndarray) -> float:
        f = float(problem(x))
        best[0] = min(best[0], f)
        return f

    opts = {"maxfevals": budget, "ftarget": target, "verbose": -9, "seed": int(rng.integers(2**31)),
            "bounds": [list(problem.lower_bounds), list(problem.upper_bounds)]}
    x0 = rng.uniform(-4.0, 4.0, problem.dimension)
    cma.fmin2(fun, x0, 2.0, opts, restarts=9, incpopsize=2, eval_initial_x=False)
    return best[0] - f_opt(problem)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--methods", default="multistart-lm,ab,pycma")
    parser.add_argument("--dim", type=int, default=5)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--quick", action="store_true",
                        help="f1–f4, instance 1, d = 2, 100·d evaluations (a smoke run)")
    args = parser.parse_args()
    instances, functions, budget = "1-2", "1-24", 1000 * args.dim
    if args.quick:
        args.dim, instances, functions = 2, "1", "1-4"
        budget = 100 * args.dim
    runners: dict[str, Callable[[Any], float]] = {}
    for spec in re.split(r",(?![^{]*})", args.methods):  # commas outside JSON options
        name, _, opts = spec.partition(":")
        if name == "pycma":
            runners[spec] = lambda p: run_pycma(p, budget, args.seed)
        else:
            options = json.loads(opts) if opts else {}
            runners[spec] = (lambda p, n=name, o=options:
                             run_femupdate(n, o, p, budget, args.seed))
    hits = {name: 0 for name in runners}
    start = time.perf_counter()
    rows = []
    for problem in problems(args.dim, instances, functions):
        cells = []
        for name, run in runners.items():
            gap = run(problem)
            ok = gap < DELTA
            hits[name] += ok
            cells.append(f"{name}={'hit' if ok else f'{gap:.1e}'}")
        rows.append(f"{problem.id}: " + "  ".join(cells))
        print(rows[-1], flush=True)
    total = len(rows)
    print(f"# bbob d={args.dim}, functions {functions}, instances {instances}, budget {budget} "
          f"evaluations, target f - f_opt < {DELTA:g}, {time.perf_counter() - start:.0f} s")
    for name, count in hits.items():
        print(f"{name}: {count}/{total} targets hit")


if __name__ == "__main__":
    main()

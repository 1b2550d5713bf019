"""Overhead of the optimizers themselves, with a trivial φ (the sphere), for n = 8.

Prints µs per ask+tell step for ib and ab (the optimizer alone, and per evaluation through
``minimize``, which adds the loop, the history and the bounds map) and µs per evaluation for
cmaes, de and ga (their steps evaluate a population). The residual methods (multistart-lm,
scipy-lsq) get the sphere's residual vector r = x − 0.3 (φ = r·r), as ``run_case`` gives them
a problem's residuals. Runs restart with a new seed whenever an optimizer's own criterion
stops them, until the requested number of evaluations is done.

    python benchmarks/optimizer_overhead.py [--evals 20000] [--n 8]
    python benchmarks/optimizer_overhead.py --quick     # 500 evaluations: a smoke run (CI)
    python benchmarks/optimizer_overhead.py --table     # writes docs/tables/optimizer-overhead.md
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
from doc_tables import write_table
from plugins import register_optimizers

from femupdate.optimize import METHODS, minimize
from femupdate.optimize.minimize import RESIDUAL_METHODS

register_optimizers()  # the comparison optimizers are timed beside the product's


def sphere(x: np.ndarray) -> float:
    d = x - 0.3
    return float(d @ d)


def sphere_residuals(x: np.ndarray) -> np.ndarray:
    """r with φ = r·r = sphere(x), for the methods that take residual vectors."""
    return x - 0.3


def optimizer_alone(method: str, n: int, evals: int) -> tuple[float, float]:
    """(µs per step, µs per evaluation) of ask + tell alone, φ excluded from the timing."""
    seeds = np.random.SeedSequence(0).spawn(10_000)
    steps = done = 0
    spent = 0.0
    run = 0
    while done < evals:
        opt = METHODS[method](n, np.random.default_rng(seeds[run]))
        run += 1
        try:
            while done < evals:
                t0 = time.perf_counter()
                xs = opt.ask()
                spent += time.perf_counter() - t0
                fs = np.array([sphere(x) for x in xs])
                rs = (np.array([sphere_residuals(x) for x in xs])
                      if method in RESIDUAL_METHODS else None)
                t0 = time.perf_counter()
                opt.tell(xs, fs, rs)
                stop = opt.stop()
                spent += time.perf_counter() - t0
                steps += 1
                done += len(xs)
                if stop:
                    break
        finally:
            opt.close()
    return 1e6 * spent / steps, 1e6 * spent / done


def through_minimize(method: str, n: int, evals: int) -> float:
    """µs per evaluation of minimize (loop + optimizer + trivial φ)."""
    seeds = np.random.SeedSequence(1).spawn(10_000)
    done = run = 0
    t0 = time.perf_counter()
    while done < evals:
        residuals = method in RESIDUAL_METHODS
        res = minimize(sphere_residuals if residuals else sphere, [(0.0, 1.0)] * n, method,
                       seed=seeds[run], max_evals=evals - done, residuals=residuals)
        run += 1
        done += res.nfev
    return 1e6 * (time.perf_counter() - t0) / done


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--evals", type=int, default=20_000)
    parser.add_argument("--n", type=int, default=8)
    parser.add_argument("--quick", action="store_true",
                        help="500 evaluations per method, short warm-up (a smoke run)")
    parser.add_argument("--table", action="store_true",
                        help="write the figures to docs/tables/optimizer-overhead.md")
    args = parser.parse_args()
    if args.quick:
        args.evals = 500
    load = os.getloadavg()[0]
    for method in METHODS:  # one warm-up run each: numba's cache, imports
        through_minimize(method, args.n, 50 if args.quick else 200)
    t0 = time.perf_counter()
    for _ in range(10_000):
        sphere(np.zeros(args.n))
    phi_us = 1e2 * (time.perf_counter() - t0)
    print(f"n = {args.n}, {args.evals} evaluations per method; trivial φ costs {phi_us:.2f} µs")
    print(f"{'method':13s} {'alone µs/step':>14s} {'alone µs/eval':>14s} {'minimize µs/eval':>17s}")
    rows = []
    for method in METHODS:
        per_step, per_eval = optimizer_alone(method, args.n, args.evals)
        total = through_minimize(method, args.n, args.evals)
        print(f"{method:13s} {per_step:14.1f} {per_eval:14.1f} {total:17.1f}")
        rows.append((f"`{method}`", f"{per_step:.1f}", f"{per_eval:.1f}", f"{total:.1f}"))
    if args.table:
        path = write_table(
            "optimizer-overhead",
            ("method", "alone, µs per step", "alone, µs per evaluation",
             "through `minimize`, µs per evaluation"),
            rows, f"python benchmarks/optimizer_overhead.py --table --evals {args.evals} "
                  f"--n {args.n}",
            f"One process; the 1-minute load average of the 2-core machine was {load:.1f} at "
            f"the start and {os.getloadavg()[0]:.1f} at the end.")
        print(f"table written to {path}")


if __name__ == "__main__":
    main()

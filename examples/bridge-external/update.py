"""Update the viscous bridge through each model: built-in, Python function, OpenSeesPy.

    PYTHONPATH=src python examples/bridge-external/update.py [--models builtin,python,opensees]
        [--snr 0] [--workers 2] [--substeps 10] [--json out.json]

The same virtual experiment (femupdate.problems.bridge, viscous, narrow bounds), the same
start (the truth moved by 10–30 % per parameter, inside the bounds) and the same solver
(scipy's least_squares on the residuals whose sum of squares is φ, forward-difference Jacobian
computed in ``--workers`` threads, each with its own model process) for the three models; then
the identified parameters and natural frequencies are compared with the built-in model's. The
frequencies of each identified model are its own (the function's ``frequencies``, OpenSees's
``eigen``).
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
from compare import external, opensees_model, python_model
from scipy.optimize import least_squares

from femupdate.problems import bridge

#: Start: the truth times these factors (E, kp1, kp2, kp3, kp4, c1, c2, c3, c4).
START_FACTORS = np.array([1.1, 1.3, 1.3, 0.8, 1.2, 0.7, 0.8, 1.2, 1.3])
#: Forward-difference step, as a fraction of each bound's width.
FD_STEP = 1e-7


def unit_residuals(fun: Callable[[np.ndarray], np.ndarray], low: np.ndarray, high: np.ndarray
                   ) -> Callable[[np.ndarray], np.ndarray]:
    """Residuals on the unit cube (the solver's variables all of order 1)."""
    return lambda u: fun(low + (high - low) * u)


def parallel_jacobian(res: Callable[[np.ndarray], np.ndarray], pool: ThreadPoolExecutor
                      ) -> Callable[[np.ndarray], np.ndarray]:
    """Forward differences, the columns evaluated concurrently (forward unless at 1)."""
    def jac(u: np.ndarray) -> np.ndarray:
        steps = np.where(u + FD_STEP <= 1.0, FD_STEP, -FD_STEP)
        points = [u] + [u + steps[j] * np.eye(u.size)[j] for j in range(u.size)]
        r = list(pool.map(res, points))
        return np.column_stack([(r[j + 1] - r[0]) / steps[j] for j in range(u.size)])

    return jac


def identify(fun: Callable[[np.ndarray], np.ndarray], low: np.ndarray, high: np.ndarray,
             x0: np.ndarray, workers: int) -> tuple[np.ndarray, dict[str, Any]]:
    res = unit_residuals(fun, low, high)
    t0 = time.perf_counter()
    with ThreadPoolExecutor(workers) as pool:
        sol = least_squares(res, (x0 - low) / (high - low), jac=parallel_jacobian(res, pool),
                            bounds=(0.0, 1.0), ftol=1e-12, xtol=1e-12, gtol=1e-12,
                            x_scale="jac", max_nfev=100)
    x = low + (high - low) * sol.x
    info = {"phi": float(2 * sol.cost), "iterations": int(sol.nfev),
            "evaluations": int(sol.nfev + sol.njev * (x.size + 1)), "status": int(sol.status),
            "wall_s": time.perf_counter() - t0}
    return x, info


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--models", default="builtin,python,opensees")
    parser.add_argument("--snr", type=float, default=0.0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--substeps", type=int, default=10, help="OpenSees Newmark substeps")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()

    ref = bridge.viscous_problem(snr=args.snr)
    case = ref.case
    names = case.parameter_names
    truth = bridge.truth("viscous")
    low, high = np.array(case.bounds).T
    x0 = np.clip(case.to_search(truth) * START_FACTORS, low, high)
    problems: dict[str, Any] = {
        "builtin": ref,
        "python": external(ref, python_model()),
        "opensees": external(ref, opensees_model(args.substeps)),
    }
    out: dict[str, Any] = {"snr": args.snr, "start": dict(zip(names, x0.tolist(), strict=True)),
                           "truth": truth, "models": {}}
    for name in args.models.split(","):
        problem = problems[name]
        x, info = identify(problem.residuals, low, high, x0, args.workers)
        info["params"] = dict(zip(names, x.tolist(), strict=True))
        info["frequencies_hz"] = problem.frequencies(x)[:4].tolist()
        out["models"][name] = info
        problem.close()
        print(f"{name:>9}: φ = {info['phi']:.3e}, {info['evaluations']} evaluations, "
              f"{info['wall_s']:.1f} s", flush=True)
    base = out["models"].get("builtin")
    for name, info in out["models"].items():
        row = {n: info["params"][n] / truth[n] - 1 for n in names}
        info["error_vs_truth"] = row
        if base is not None:
            info["difference_vs_builtin"] = {n: info["params"][n] / base["params"][n] - 1
                                             for n in names}
            info["frequency_difference_vs_builtin"] = (
                np.array(info["frequencies_hz"]) / np.array(base["frequencies_hz"]) - 1).tolist()
        print(f"{name:>9}: vs truth " + " ".join(f"{n} {v:+.2e}" for n, v in row.items()))
        if base is not None and name != "builtin":
            print(f"{'':>9}  vs builtin " + " ".join(
                f"{n} {v:+.2e}" for n, v in info["difference_vs_builtin"].items()))
            print(f"{'':>9}  frequencies vs builtin " + " ".join(
                f"{v:+.2e}" for v in info["frequency_difference_vs_builtin"]))
    if args.json:
        args.json.write_text(json.dumps(out, indent=2) + "\n")


if __name__ == "__main__":
    main()

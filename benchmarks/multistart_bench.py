"""The figures of multistart-lm beside ab, cmaes and scipy-lsq, through the package's benchmarks.

Each scenario runs ``femupdate.bench.bridge.run_bridge_benchmark`` or
``femupdate.bench.dynamic.run_benchmark`` (the same machinery as ``femupdate bench``)
and prints one row per method: successes, evaluations per success with the failed runs'
evaluations included (``evals_per_success``), wall time and, for noisy data, the worst φ over
the noise floor and how many runs are within 1.05× and 1.5× of it.

    python benchmarks/multistart_bench.py viscous-narrow --seed 1 --methods multistart-lm,ab
    python benchmarks/multistart_bench.py all --runs 25 --workers 2

Scenarios: viscous-narrow (noise-free, φ < 1e-6 within 20,000), viscous-broad (the same,
bounds from 0), viscous-noisy (2 % noise, target 1.05× the noise floor), friction (2 % noise,
5,000 evaluations, target 1.05× the floor), dynamic (the paper's Table 1, 100 runs,
φ < 1e-10 within 50,000). cmaes runs with λ = 5 and ``restarts=20, stall_window=1000``.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path
from typing import Any

SCENARIOS = ("viscous-narrow", "viscous-broad", "viscous-noisy", "friction", "dynamic")
OPTIONS: dict[str, dict[str, Any]] = {
    "cmaes": {"popsize": 5, "restarts": 20, "stall_window": 1000},
}


def bridge_row(scenario: str, method: str, runs: int, seed: int, workers: int,
               work: Path) -> dict[str, Any]:
    """One method on one bridge scenario: the summary's figures."""
    from femupdate.bench.bridge import run_bridge_benchmark

    model = "friction" if scenario == "friction" else "viscous"
    band = "broad" if scenario == "viscous-broad" else "narrow"
    snr = 0.02 if scenario in ("viscous-noisy", "friction") else 0.0
    max_evals = 5_000 if model == "friction" else 20_000
    start = time.perf_counter()
    summary = run_bridge_benchmark(model, band, method, runs=runs, seed=seed, snr=snr,
                                   workers=workers, max_evals=max_evals,
                                   options=OPTIONS.get(method), work_dir=work)
    wall = time.perf_counter() - start
    bench = summary.benchmark
    ratios = [r.phi / bench.noise_floor for r in summary.runs] if snr > 0 else []
    return {
        "scenario": scenario, "method": method, "seed": seed, "runs": len(summary.runs),
        "successes": summary.successes, "evals_per_success": summary.evals_per_success,
        "evals_mean_success": summary.evals_mean, "wall_s": wall,
        "worst_over_floor": max(ratios) if ratios else None,
        "within_1_05": sum(q <= 1.05 for q in ratios) if ratios else None,
        "within_1_5": sum(q <= 1.5 for q in ratios) if ratios else None,
        "f1_f2_within_1pct": sum(all(abs(e) <= 0.01 for e in f[:2])
                                 for f in bench.frequency_errors),
        "at_bounds": sum(bool(r.at_bounds) for r in summary.runs),
    }


def dynamic_row(method: str, runs: int, workers: int) -> dict[str, Any]:
    """One method on benchmark 1 (Table 1/2)."""
    from femupdate.bench.dynamic import run_benchmark

    res = run_benchmark(method, runs=runs, workers=workers, options=OPTIONS.get(method))
    return {"scenario": "dynamic", "method": method, "seed": 0, "runs": res["runs"],
            "successes": res["successes"], "evals_per_success": res["evals_per_success"],
            "evals_mean_success": res["evals_mean"], "wall_s": res["wall_s"]}


def show(row: dict[str, Any]) -> None:
    def fmt(v: Any) -> str:
        return f"{v:,.0f}" if isinstance(v, float) and v >= 10 else (
            f"{v:.3f}" if isinstance(v, float) else str(v))

    print("  ".join(f"{k}={fmt(v)}" for k, v in row.items()), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("scenario", choices=(*SCENARIOS, "all"))
    parser.add_argument("--methods", default="multistart-lm",
                        help="comma-separated, e.g. multistart-lm,ab,cmaes,scipy-lsq")
    parser.add_argument("--runs", type=int, default=None, help="25 (bridge), 100 (dynamic)")
    parser.add_argument("--seed", type=int, default=0, help="the bridge's accelerogram")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--work-dir", default=None)
    parser.add_argument("--json", default=None, help="append the rows as JSON lines here")
    args = parser.parse_args()
    work = Path(args.work_dir or tempfile.mkdtemp(prefix="multistart-bench-"))
    scenarios = SCENARIOS if args.scenario == "all" else (args.scenario,)
    print(f"# load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores", flush=True)
    for scenario in scenarios:
        for method in args.methods.split(","):
            if scenario == "dynamic":
                row = dynamic_row(method, args.runs or 100, args.workers)
            else:
                row = bridge_row(scenario, method, args.runs or 25, args.seed, args.workers,
                                 work / f"seed{args.seed}")
            row["load"] = os.getloadavg()[0]
            show(row)
            if args.json:
                with open(args.json, "a") as fh:
                    fh.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()

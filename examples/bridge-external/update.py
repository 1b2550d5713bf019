"""Update the viscous bridge through each model — built-in, Python function, OpenSeesPy — from
their case files, as ``femupdate run CASE --method multistart-lm`` does.

    python examples/bridge-external/update.py [--models builtin,python,opensees] [--snr 0]
        [--runs 1] [--workers 2] [--json out.json]

The same virtual experiment (femupdate.paper.problems.bridge, viscous, seed 0, noise ``--snr``) is
read by the three case files — ``examples/bridge/viscous-narrow.toml`` (the built-in model),
``python.toml`` and ``opensees.toml`` — and each is updated with the same method and seed
(femupdate's default, multistart-lm: space-filling starts, a bounded Levenberg–Marquardt on
the residuals, restarts). The identified parameters and natural frequencies (each model's own:
the function's ``frequencies``, OpenSees's ``eigen``) are compared with the truth and with the
built-in model's.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from femupdate.case import load_case
from femupdate.paper.problems import bridge
from femupdate.pipeline.run import run_case, with_data_directory, with_method

HERE = Path(__file__).resolve().parent
CASES = {"builtin": HERE.parent / "bridge" / "viscous-narrow.toml",
         "python": HERE / "python.toml", "opensees": HERE / "opensees.toml"}


def update(model: str, data: Path, runs: int, seed: int, workers: int) -> dict[str, Any]:
    """One model's case on the records in ``data``: the best run's parameters, φ,
    frequencies, evaluations and wall time."""
    case, _ = with_method(with_data_directory(load_case(CASES[model]), data), "multistart-lm")
    start = time.perf_counter()
    result = run_case(case, runs=runs, seed=seed, workers=workers, sensitivities=False)
    wall = time.perf_counter() - start
    result.problem.close()
    best = result.summary.best
    return {"params": best.params, "phi": best.phi, "frequencies_hz": best.frequencies_hz[:4],
            "evaluations": sum(r.nfev for r in result.summary.runs), "wall_s": wall,
            "runs": runs}


def relative(a: dict[str, float], b: dict[str, float]) -> dict[str, float]:
    return {n: a[n] / b[n] - 1.0 for n in b}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--models", default="builtin,python,opensees")
    parser.add_argument("--snr", type=float, default=0.0)
    parser.add_argument("--runs", type=int, default=1)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()

    truth = bridge.truth("viscous")
    data = Path(tempfile.gettempdir()) / f"femupdate-bridge-viscous-0-{args.snr:g}"
    bridge.viscous_problem(data, snr=args.snr).close()  # writes the records once
    out: dict[str, Any] = {"snr": args.snr, "truth": truth, "models": {}}
    for name in args.models.split(","):
        info = out["models"][name] = update(name, data, args.runs, args.seed, args.workers)
        print(f"{name:>9}: φ = {info['phi']:.3e}, {info['evaluations']} evaluations, "
              f"{info['wall_s']:.1f} s", flush=True)
    base = out["models"].get("builtin")
    for name, info in out["models"].items():
        info["error_vs_truth"] = relative(info["params"], truth)
        print(f"{name:>9}: vs truth " + " ".join(
            f"{n} {v:+.1e}" for n, v in info["error_vs_truth"].items()))
        if base is None or name == "builtin":
            continue
        info["difference_vs_builtin"] = relative(info["params"], base["params"])
        info["frequency_difference_vs_builtin"] = (
            np.array(info["frequencies_hz"]) / np.array(base["frequencies_hz"]) - 1).tolist()
        print(f"{'':>9}  vs builtin " + " ".join(
            f"{n} {v:+.1e}" for n, v in info["difference_vs_builtin"].items()))
        print(f"{'':>9}  frequencies vs builtin " + " ".join(
            f"{v:+.1e}" for v in info["frequency_difference_vs_builtin"]))
    if args.json:
        args.json.write_text(json.dumps(out, indent=2) + "\n")


if __name__ == "__main__":
    main()

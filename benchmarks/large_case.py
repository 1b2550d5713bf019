"""The 1,000-storey building through ``femupdate run``: ms per evaluation at the margin and
the fixed cost of a run, as a user gets them.

The case is examples/large/shear-building-1000.toml with every default (the reduced path, 25
modes up to twice the Nyquist frequency of records at 100 Hz, multistart-lm, its 2 runs), its
records a noise-free virtual experiment of 20 s at 100 Hz (``femupdate synth``, as the case
file says) written to a temporary directory. ``femupdate run`` runs in a subprocess (a fresh
interpreter: imports included) with two budgets, ``--max-evals`` 5 and 30 per run (10 and
60 evaluations in all); the evaluations counted are those ``summary.json`` reports, and

- the margin is (wall time at 60 − wall time at 10) / (evaluations at 60 − at 10);
- the fixed cost is the wall time at 10 less 10 evaluations at that margin: imports, reading
  and checking the records, the modes at the nominal point, the truncation check, the Laplace
  analysis and identifiability at the best fit, the summary.

``--before SRC`` times another checkout's code the same way in the same session (default:
/work/main/src when it exists, the main branch), so that the two figures share the machine's
load; the load average is printed beside each. One untimed run per code first (numba's cache).

Run from the repository root: ``python benchmarks/large_case.py`` (``--repeats 2`` for two
timings of each budget, the smaller kept).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "examples" / "large" / "shear-building-1000.toml"
TRUTH = ROOT / "examples" / "large" / "truth.json"
BUDGETS = (5, 50)  # per run; the case's 2 runs make 10 and 100 evaluations
DEFAULT_BEFORE = Path("/work/main/src")


def load() -> str:
    return "load {:.1f} {:.1f} {:.1f}".format(*os.getloadavg())


def femupdate(src: Path, *args: str) -> float:
    """Wall seconds of ``python -m femupdate ARGS`` with ``src`` first on the path."""
    env = {**os.environ, "PYTHONPATH": str(src)}
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "femupdate", *args], env=env, check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


def evaluations(out: Path) -> int:
    """The evaluations of the runs, as summary.json counts them."""
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    return sum(int(run["nfev"]) for run in summary["runs"])


def measure(src: Path, case: Path, work: Path, repeats: int) -> dict[str, float]:
    """Margin (ms per evaluation) and fixed cost (s) of ``femupdate run`` with ``src``'s code."""
    femupdate(src, "run", str(case), "--out", str(work / "warm"), "--max-evals", "1",
              "--quiet", "--restart")
    wall, nfev = {}, {}
    for budget in BUDGETS:
        out = work / f"out-{budget}"
        wall[budget] = min(femupdate(src, "run", str(case), "--out", str(out), "--max-evals",
                                     str(budget), "--quiet", "--restart")
                           for _ in range(repeats))
        nfev[budget] = evaluations(out)
    low, high = BUDGETS
    margin = (wall[high] - wall[low]) / (nfev[high] - nfev[low])
    return {"margin_ms": 1e3 * margin, "fixed_s": wall[low] - nfev[low] * margin,
            "wall_low_s": wall[low], "wall_high_s": wall[high],
            "nfev_low": nfev[low], "nfev_high": nfev[high]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", type=Path,
                        default=DEFAULT_BEFORE if DEFAULT_BEFORE.is_dir() else None,
                        help="another checkout's src directory, timed the same way first")
    parser.add_argument("--repeats", type=int, default=1)
    args = parser.parse_args()
    codes = [("after (this checkout)", ROOT / "src")]
    if args.before is not None:
        codes.insert(0, (f"before ({args.before})", args.before))
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        case = work / "case.toml"
        shutil.copy(CASE, case)  # its [data] directory "data" is then beside it, here
        femupdate(ROOT / "src", "synth", str(case), "--truth", str(TRUTH), "--out",
                  str(work / "data"), "--snr", "0", "--rate", "100", "--duration", "20",
                  "--length-scale", "1")
        print(f"femupdate run {CASE.relative_to(ROOT)} (1,000 DOFs, 100 Hz, every default), "
              f"--max-evals {BUDGETS[0]} and {BUDGETS[1]} per run; min of {args.repeats}")
        for label, src in codes:
            before = load()
            got = measure(src, case, work / label.split()[0], args.repeats)
            print(f"{label}: {got['margin_ms']:.1f} ms per evaluation at the margin, "
                  f"fixed cost {got['fixed_s']:.2f} s ({got['nfev_low']} evaluations in "
                  f"{got['wall_low_s']:.2f} s, {got['nfev_high']} in {got['wall_high_s']:.2f} "
                  f"s; {before} → {load()})")


if __name__ == "__main__":
    main()

"""The 1,000-storey building through ``femupdate run``: ms per evaluation at the margin and
the fixed cost of a run, as a user gets them.

The case is examples/large/shear-building-1000.toml with every default (the reduced path, 25
modes up to twice the Nyquist frequency of records at 100 Hz, multistart-lm, its 2 runs), its
records a noise-free virtual experiment of 20 s at 100 Hz (``femupdate synth``, as the case
file says) written to a temporary directory. ``femupdate run`` runs in a subprocess (a fresh
interpreter: imports included) with two budgets, ``--max-evals`` 200 and 300 per run (400 and
600 evaluations in all: multistart-lm evaluates its pool of 20 n = 200 points in batches of
64 whatever the budget, so a budget inside the pool times the same work twice); the
evaluations counted are those ``summary.json`` reports, and

- the margin is (time at 600 − time at 400) / (evaluations at 600 − at 400);
- the fixed cost is the time at 400 less 400 evaluations at that margin: imports, reading and
  checking the records, the modes at the nominal point, the truncation check, the Laplace
  analysis and identifiability at the best fit (61 more evaluations), the summary; and,
  directly, the process's wall time less the searches' (``wall_s`` of ``summary.json``).

Both in wall time and in CPU time (user + system of the subprocess, ``RUSAGE_CHILDREN``): on a
shared machine the CPU time is the steadier of the two.

``--before SRC`` times another checkout's code the same way in the same session (default:
/work/main/src when it exists, the main branch), so that the two figures share the machine's
load; the load average is printed beside each. One untimed run per code first (numba's cache).

Run from the repository root: ``python benchmarks/large_case.py`` (``--repeats 2`` for two
timings of each budget, the smaller kept; ``--quick``, for CI: a 120-storey building, 5 s of
records, budgets of 3 and 6 per run inside the first pool batch, this checkout only: it shows
that the script runs, not a cost).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "examples" / "large" / "shear-building-1000.toml"
TRUTH = ROOT / "examples" / "large" / "truth.json"
BUDGETS = (200, 300)  # per run; the case's 2 runs make 400 and 600 evaluations
QUICK_BUDGETS = (3, 6)
QUICK_STOREYS = 120
DEFAULT_BEFORE = Path("/work/main/src")


def load() -> str:
    return "load {:.1f} {:.1f} {:.1f}".format(*os.getloadavg())


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def femupdate(src: Path, *args: str) -> tuple[float, float]:
    """Wall and CPU seconds of ``python -m femupdate ARGS`` with ``src`` first on the path."""
    env = {**os.environ, "PYTHONPATH": str(src)}
    t0, c0 = time.perf_counter(), _children_cpu()
    subprocess.run([sys.executable, "-m", "femupdate", *args], env=env, check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0, _children_cpu() - c0


def evaluations(out: Path) -> tuple[int, float]:
    """The evaluations of the runs, as summary.json counts them, and the searches' wall time."""
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    return sum(int(run["nfev"]) for run in summary["runs"]), float(summary["wall_s"])


def measure(src: Path, case: Path, work: Path, repeats: int,
            budgets: tuple[int, int] = BUDGETS) -> dict[str, float]:
    """Margin (ms per evaluation) and fixed cost (s), wall and CPU, of ``femupdate run`` with
    ``src``'s code."""
    femupdate(src, "run", str(case), "--out", str(work / "warm"), "--max-evals", "1",
              "--quiet", "--restart")
    times, nfev, search = {}, {}, {}
    for budget in budgets:
        out = work / f"out-{budget}"
        got = [femupdate(src, "run", str(case), "--out", str(out), "--max-evals", str(budget),
                         "--quiet", "--restart") for _ in range(repeats)]
        times[budget] = (min(w for w, _ in got), min(c for _, c in got))
        nfev[budget], search[budget] = evaluations(out)
    low, high = budgets
    result: dict[str, float] = {"nfev_low": nfev[low], "nfev_high": nfev[high],
                                "outside_searches_s": times[low][0] - search[low]}
    for i, kind in enumerate(("wall", "cpu")):
        margin = (times[high][i] - times[low][i]) / (nfev[high] - nfev[low])
        result[f"{kind}_margin_ms"] = 1e3 * margin
        result[f"{kind}_fixed_s"] = times[low][i] - nfev[low] * margin
        result[f"{kind}_low_s"], result[f"{kind}_high_s"] = times[low][i], times[high][i]
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", type=Path,
                        default=DEFAULT_BEFORE if DEFAULT_BEFORE.is_dir() else None,
                        help="another checkout's src directory, timed the same way first")
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--quick", action="store_true",
                        help=f"a {QUICK_STOREYS}-storey building, this checkout only (CI)")
    args = parser.parse_args()
    codes = [("after (this checkout)", ROOT / "src")]
    if args.before is not None and not args.quick:
        codes.insert(0, (f"before ({args.before})", args.before))
    budgets = QUICK_BUDGETS if args.quick else BUDGETS
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        case, truth = work / "case.toml", TRUTH
        if args.quick:
            from femupdate.paper.bench import large_building

            case.write_text(large_building.case_text(QUICK_STOREYS, 3), encoding="utf-8")
            truth = work / "truth.json"
            truth.write_text(json.dumps(large_building.truth(QUICK_STOREYS, 3)),
                             encoding="utf-8")
        else:
            shutil.copy(CASE, case)  # its [data] directory "data" is then beside it, here
        femupdate(ROOT / "src", "synth", str(case), "--truth", str(truth), "--out",
                  str(work / "data"), "--snr", "0", "--rate", "100", "--duration",
                  "5" if args.quick else "20", "--length-scale", "1")
        what = (f"a {QUICK_STOREYS}-storey building (--quick)" if args.quick else
                f"{CASE.relative_to(ROOT)} (1,000 DOFs)")
        print(f"femupdate run {what}, 100 Hz, every default; --max-evals {budgets[0]} and "
              f"{budgets[1]} per run; min of {args.repeats}")
        for label, src in codes:
            before = load()
            got = measure(src, case, work / label.split()[0], args.repeats, budgets)
            print(f"{label} ({before} → {load()}), {got['nfev_low']} and {got['nfev_high']} "
                  "evaluations:")
            for kind in ("wall", "cpu"):
                print(f"  {kind:4s}: {got[f'{kind}_margin_ms']:6.1f} ms per evaluation at the "
                      f"margin, fixed cost {got[f'{kind}_fixed_s']:5.2f} s "
                      f"({got[f'{kind}_low_s']:.2f} s and {got[f'{kind}_high_s']:.2f} s)")
            print(f"  wall time outside the searches at {got['nfev_low']} evaluations: "
                  f"{got['outside_searches_s']:.2f} s")


if __name__ == "__main__":
    main()

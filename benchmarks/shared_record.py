"""Three fitted windows of one record: step by step, compiled trial by trial, compiled once.

    python benchmarks/shared_record.py [--data DIR] [--repeat N] [--json PATH]
    python benchmarks/shared_record.py --quick   # few calls, a short run, 2 memory sizes (CI)
    python benchmarks/shared_record.py --only-memory   # part 3 alone (e.g. on an older checkout)

1. φ per evaluation of the real one-storey shake-table test
   (``examples/minishake-1story/elcentro.toml``, El Centro trial 1, 2,546 samples at 120 Hz,
   absolute accelerations) split into three fitted ``score_window`` trials of its one record:
   the step-by-step path (``compiled=False``, what ``FEMUPDATE_EVALUATOR=reference`` selects,
   and what a case with score windows ran on before), the compiled path with each window's trial
   simulated by itself, and the compiled path with the three simulated once
   (``femupdate.evaluation.shared``); beside them the same record as one trial scored whole.
   Medians over ``--repeat`` calls cycling through random points of the search box, one BLAS
   thread, wall and process CPU time; the residual vectors of a finite-difference Jacobian's
   n + 1 points (multistart-lm's batch) the same way. The values are checked: the shared path
   equals the trial-by-trial one bit for bit, and the step-by-step one to rounding.
   Skipped when the records are not found (``--data`` or ``FEMUPDATE_DATA``).
2. ``femupdate run`` of that three-window case end to end (multistart-lm, one worker), with
   ``FEMUPDATE_EVALUATOR=reference`` and without: wall time of the command, evaluations, φ.
3. Peak memory of multistart-lm on a 48-storey shear building (virtual experiment, 6,000
   samples, 3 channels) with 12, 24 and 48 stiffness parameters, each in a fresh process, with
   a budget of the pool (20 n points) and 400 evaluations more (so that each run reaches its
   Jacobians): the resident set's peak (``ru_maxrss``, imports and compiled code included) and
   the peak of the memory numpy and Python allocate during the run (``tracemalloc``).

The load average is printed at the start and the end: on a machine shared with other jobs the
wall times are inflated (the CPU times less so).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

REPO = Path(__file__).resolve().parents[1]
EXAMPLE = REPO / "examples" / "minishake-1story"
#: Record time (s) of the three fitted windows of El Centro trial 1 (0.06 to 21.27 s).
WINDOWS = ((0.1, 7.0), (7.0, 14.0), (14.0, 21.2))
SEED = 20251126


def load() -> str:
    return f"load average {', '.join(f'{v:.2f}' for v in os.getloadavg())}"


def three_window_case(folder: Path, work: Path) -> Path:
    """The example's case file with its data directory made absolute and three fitted
    windows of its one record, written into ``work``."""
    text = (EXAMPLE / "elcentro.toml").read_text()
    line = 'directory = "../../../shared/data/minishake_1story"'
    if line not in text:
        raise SystemExit(f"{EXAMPLE / 'elcentro.toml'}: its [data] directory line changed")
    text = text.replace(line, f"directory = {json.dumps(str(folder))}")
    for i, (low, high) in enumerate(WINDOWS):
        text += f'\n[[trials]]\nname = "part{i + 1}"\nscore_window = [{low}, {high}]\n'
    path = work / "three-windows.toml"
    path.write_text(text)
    return path


def find_records(data_dir: str | None) -> Path | str:
    """The minishake records' folder, or why they are not there."""
    sys.path.insert(0, str(EXAMPLE))
    from study import find_data  # the real case's data finder, beside its example

    try:
        return find_data(data_dir)
    except Exception as exc:  # any reason to skip is printed
        return f"skipped: {exc}"


def median_times(fn: Callable[[Any], object], args: list[Any], repeat: int
                 ) -> tuple[float, float]:
    """Median wall and process CPU seconds of ``fn(args[i % len(args)])`` (after one call)."""
    fn(args[0])
    wall, cpu = [], []
    for i in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        fn(args[i % len(args)])
        wall.append(time.perf_counter() - w0)
        cpu.append(time.process_time() - c0)
    return float(np.median(wall)), float(np.median(cpu))


def phi_rows(case_file: Path, records: Path, repeat: int) -> dict[str, Any]:
    """Part 1: φ and Jacobian residual batches per evaluation on the four paths."""
    from femupdate.case import load_case
    from femupdate.pipeline.run import with_data_directory
    from femupdate.problem.update import UpdateProblem
    from femupdate.trials.experiment import load_experiment, load_experiments

    case = load_case(case_file)
    experiments = load_experiments(case)
    step = UpdateProblem(case, experiments, compiled=False)
    apart = UpdateProblem(case, experiments, compiled=True)
    apart.shared_records = [[i] for i in range(len(apart.fitted))]  # trial by trial
    shared = UpdateProblem(case, experiments, compiled=True)
    whole_case = with_data_directory(load_case(EXAMPLE / "elcentro.toml"), records)
    whole = UpdateProblem(whole_case, load_experiment(whole_case), compiled=True)
    assert shared.shared_records == [[0, 1, 2]], shared.shared_records
    low, high = np.array(case.bounds).T
    X = low + (high - low) * np.random.default_rng(SEED).random((16, low.size))
    phi_shared = shared.evaluate_batch(X)
    bitwise = bool(np.array_equal(phi_shared, apart.evaluate_batch(X))
                   and np.array_equal(shared.residuals_batch(X), apart.residuals_batch(X)))
    reference = np.array([step(x) for x in X])
    rounding = float(np.max(np.abs(phi_shared - reference) / reference))
    n = low.size
    jacobians = [x + np.vstack([np.zeros(n), np.diag(np.full(n, 1e-6))]) for x in X]
    rows: dict[str, Any] = {"samples": int(experiments[0].t.size),
                            "scored": [int(e.target[e.score].shape[0]) for e in experiments],
                            "shared_equals_trial_by_trial_bitwise": bitwise,
                            "compiled_vs_step_by_step_max_rel": rounding, "paths": {}}
    paths = {"step by step (reference)": step, "compiled, trial by trial": apart,
             "compiled, one simulation": shared, "one trial, whole record": whole}
    with threadpool_limits(1):
        for label, problem in paths.items():
            phi = median_times(problem, list(X), repeat)
            jac = median_times(problem.residuals_batch, jacobians, max(3, repeat // n))
            rows["paths"][label] = {"phi_s": phi[0], "phi_cpu_s": phi[1],
                                    "jacobian_row_s": jac[0] / (n + 1),
                                    "jacobian_row_cpu_s": jac[1] / (n + 1)}
    return rows


def run_rows(case_file: Path, work: Path, runs: int, max_evals: int) -> dict[str, Any]:
    """Part 2: ``femupdate run`` wall time, step by step and compiled."""
    out: dict[str, Any] = {}
    for label, evaluator in (("step by step", "reference"), ("compiled", "compiled")):
        folder = work / f"run-{evaluator}"
        env = dict(os.environ, FEMUPDATE_EVALUATOR=evaluator, OPENBLAS_NUM_THREADS="1")
        cmd = [sys.executable, "-m", "femupdate", "run", str(case_file), "--out", str(folder),
               "--runs", str(runs), "--max-evals", str(max_evals), "--seed", "7",
               "--workers", "1", "--quiet"]
        start = time.perf_counter()
        proc = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=work)
        seconds = time.perf_counter() - start
        if proc.returncode != 0:
            raise SystemExit(f"femupdate run failed ({evaluator}):\n{proc.stderr[-3000:]}")
        summary = json.loads((folder / "summary.json").read_text())
        result = summary["runs"]
        out[label] = {"seconds": seconds, "runs_wall_s": sum(float(r["wall_s"]) for r in result),
                      "summary_wall_s": float(summary["wall_s"]),
                      "nfev": sum(int(r["nfev"]) for r in result),
                      "best_phi": min(float(r["phi"]) for r in result), "load": os.getloadavg()[0]}
    return out


# ----------------------------------------------------------------------------- memory

STOREYS = 48
MEMORY_SAMPLES = 6000
MEMORY_RATE = 100.0


def building_spec(n_params: int, directory: Path) -> dict[str, Any]:
    """A 48-storey shear building whose storey stiffnesses form ``n_params`` groups."""
    names = [f"k{g + 1}" for g in range(n_params)]
    storeys = [names[i * n_params // STOREYS] for i in range(STOREYS)]
    k0 = 16.0 * STOREYS**2
    return {
        "case": {"name": f"building-{n_params}"},
        "model": {"shear_building": {"masses": [1.0] * STOREYS, "stiffnesses": storeys,
                                     "dampers": [2.0] * STOREYS}},
        "parameters": [{"name": name, "lower": 0.5 * k0, "upper": 1.5 * k0, "nominal": k0}
                       for name in names],
        "data": {"format": "csv", "directory": str(directory), "time_column": "t",
                 "input": {"file": "table.csv", "column": "table"},
                 "outputs": [{"file": "floors.csv", "column": f"a{s}", "node": f"F{s}",
                              "dof": "ux"} for s in (16, 32, 48)]},
        "objective": {"quantity": "acceleration", "experimental_parameters": False},
    }


def memory_child(n_params: int, extra: int) -> dict[str, Any]:
    """Part 3, in this (fresh) process: the peaks of one multistart-lm run of the pool and
    ``extra`` evaluations."""
    import tracemalloc

    from femupdate import minimize
    from femupdate.case import parse_case
    from femupdate.problem.update import UpdateProblem
    from femupdate.trials.experiment import load_experiment
    from femupdate.trials.virtual import virtual_experiment

    with tempfile.TemporaryDirectory() as tmp:
        spec = building_spec(n_params, Path(tmp))
        case = parse_case(spec, source=Path(tmp) / "case.toml")
        truth = dict(zip(case.parameter_names, np.random.default_rng(SEED).uniform(
            0.8, 1.2, n_params) * 16.0 * STOREYS**2, strict=True))
        virtual_experiment(case, truth, Path(tmp), seed=1, rate=MEMORY_RATE,
                           duration=(MEMORY_SAMPLES - 1) / MEMORY_RATE, snr=0.0, offset=0.0,
                           drift=0.0)
        problem = UpdateProblem(case, load_experiment(case))
        problem.residuals_batch(np.array([case.to_search(case.nominal())]))  # compile
        before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        tracemalloc.start()
        start = time.perf_counter()
        res = minimize(problem.residuals, problem.bounds, method="multistart-lm",
                       seed=np.random.SeedSequence(SEED), max_evals=20 * n_params + extra,
                       residuals=True)
        seconds = time.perf_counter() - start
        _, traced = tracemalloc.get_traced_memory()
        tracemalloc.stop()
    m = MEMORY_SAMPLES * 3
    return {"parameters": n_params, "residuals": m, "nfev": int(res.nfev),
            "phi": float(res.fun), "seconds": seconds, "maxrss_before_run_mb": before,
            "maxrss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
            "traced_peak_mb": traced / 2**20,
            "jacobian_batch_mb": (n_params + 1) * m * 8 / 2**20}


def memory_rows(sizes: list[int], extra: int) -> list[dict[str, Any]]:
    rows = []
    for n_params in sizes:
        code = (f"import sys, json; sys.path.insert(0, {str(Path(__file__).parent)!r}); "
                "import shared_record; "
                f"print(json.dumps(shared_record.memory_child({n_params}, {extra})))")
        env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              env=env)
        if proc.returncode != 0:
            raise SystemExit(f"memory child ({n_params} parameters) failed:\n"
                             f"{proc.stderr[-3000:]}")
        rows.append(json.loads(proc.stdout.strip().splitlines()[-1]))
    return rows


# ----------------------------------------------------------------------------- output


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="few calls, short run (CI)")
    parser.add_argument("--data", default=None,
                        help="shared data directory (holding minishake_1story/)")
    parser.add_argument("--repeat", type=int, default=200, help="calls per median")
    parser.add_argument("--json", type=Path, default=None, help="write the figures here")
    parser.add_argument("--only-memory", action="store_true", help="part 3 alone")
    args = parser.parse_args()
    repeat = 10 if args.quick else args.repeat
    report: dict[str, Any] = {"load_start": os.getloadavg()}
    print(f"shared_record.py: {load()}")
    records = find_records(args.data if args.data else os.environ.get("FEMUPDATE_DATA")
                           or str(REPO.parent / "shared" / "data"))
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        if args.only_memory:
            pass
        elif isinstance(records, str):
            print(f"1-2. three windows of the one-storey record: {records}")
        else:
            case_file = three_window_case(records, work)
            rows = phi_rows(case_file, records, repeat)
            report["phi"] = rows
            print(f"\n1. φ of three fitted windows of one record ({rows['samples']} samples; "
                  f"scored {rows['scored']}), medians of {repeat} calls, one BLAS thread")
            print(f"   {'path':<28} {'φ wall ms':>10} {'φ cpu ms':>9} "
                  f"{'Jacobian row wall/cpu ms':>25}")
            base = rows["paths"]["step by step (reference)"]
            for label, r in rows["paths"].items():
                print(f"   {label:<28} {r['phi_s'] * 1e3:>10.3f} {r['phi_cpu_s'] * 1e3:>9.3f} "
                      f"{r['jacobian_row_s'] * 1e3:>16.3f} {r['jacobian_row_cpu_s'] * 1e3:>8.3f}"
                      f"   step by step ÷ this: "
                      f"{base['phi_cpu_s'] / r['phi_cpu_s']:.1f}× (cpu)")
            print(f"   one simulation equals trial by trial bit for bit: "
                  f"{rows['shared_equals_trial_by_trial_bitwise']}; compiled vs step by step "
                  f"max relative φ difference {rows['compiled_vs_step_by_step_max_rel']:.2g}")
            runs, evals = (1, 40) if args.quick else (4, 600)
            run = run_rows(case_file, work, runs, evals)
            report["run"] = run
            print(f"\n2. femupdate run, the three windows, multistart-lm, {runs} runs of up to "
                  f"{evals} evaluations, 1 worker")
            for label, r in run.items():
                print(f"   {label:<14} {r['seconds']:7.2f} s the command, "
                      f"{r['runs_wall_s']:6.2f} s its runs  {r['nfev']:5d} evaluations  "
                      f"best φ {r['best_phi']:.6g}  (load {r['load']:.2f})")
            before, after = run["step by step"], run["compiled"]
            print(f"   step by step ÷ compiled: the command "
                  f"{before['seconds'] / after['seconds']:.2f}×, its runs "
                  f"{before['runs_wall_s'] / after['runs_wall_s']:.2f}×")
    sizes, extra = ([12, 24], 60) if args.quick else ([12, 24, 48], 400)
    mem = memory_rows(sizes, extra)
    report["memory"] = mem
    print(f"\n3. multistart-lm on a {STOREYS}-storey building, {MEMORY_SAMPLES} samples × 3 "
          f"channels, the pool (20 n) and {extra} evaluations, each in a fresh process")
    print(f"   {'parameters':>10} {'evaluations':>12} {'peak RSS MB':>12} {'RSS before run':>15} "
          f"{'traced peak MB':>15} {'Jacobian batch MB':>18} {'φ':>10}")
    for r in mem:
        print(f"   {r['parameters']:>10} {r['nfev']:>12} {r['maxrss_mb']:>12.1f} "
              f"{r['maxrss_before_run_mb']:>15.1f} {r['traced_peak_mb']:>15.1f} "
              f"{r['jacobian_batch_mb']:>18.1f} {r['phi']:>10.3g}")
    report["load_end"] = os.getloadavg()
    print(f"\nshared_record.py: {load()}")
    if args.json is not None:
        args.json.write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()

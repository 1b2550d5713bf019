"""What one evaluation of φ(x) costs and where it goes (issue 14), before and after.

    python benchmarks/evaluation_cost.py [--repeat N] [--no-run | --only-run] [--no-opensees]
                                         [--data DIR] [--json PATH]
    python benchmarks/evaluation_cost.py --quick   # 3 calls per stage, no run rows (CI)

Four cases: the paper's viscous bridge (10 DOF, exact discretisation, 4,768 samples), the
friction bridge (central differences with 10 substeps: 47,680 steps), the real one-storey
shake-table test (``examples/minishake-1story/elcentro.toml``; skipped when its records are not
found: ``--data`` or ``FEMUPDATE_DATA``) and a 3-DOF shear building on a synthetic record of
7,500 samples compared in absolute accelerations.

For each case: one evaluation by the step-by-step reference path
(``UpdateProblem.phi_reference``: assembly, the simulator's preparation, its run, the
prediction's processing, the objective) and by the compiled evaluator (``femupdate.evaluation``:
the same stages, each timed alone with its own call overhead, then the whole φ); the physical
floor beside them (the bare modal recursion over the record, or the linear part of the friction
recurrence, a lower bound, compiled, at the case's own coefficients); φ of batches of k points,
per evaluation, on one thread and on two (a kept thread pool, each thread with its own
evaluator); the residual vectors of a finite-difference Jacobian's n + 1 points, one call per
point and as one batch on one and two threads. Times are medians over ``--repeat`` calls
cycling through random points of the search box, with one BLAS thread (threadpoolctl), wall
time with the process's CPU time beside it: on a machine shared with other jobs, preemption
inflates the first and not the second.

Then (unless ``--no-run``) ``femupdate run`` end to end: the viscous bridge, AB, one worker,
6,000 evaluations, noise-free records; wall time per evaluation from summary.json, for the
reference path (``FEMUPDATE_EVALUATOR=reference``) and the compiled one, whose runs must end
alike (same evaluations and end point, φ to rounding); and the run machinery alone (a trivial
φ, same settings). The friction row is compared with OpenSeesPy's central differences at the
same substep when it is installed, each OpenSeesPy simulation paired with compiled φ's timed
right after it. The load average is printed at the start and the end.

The script runs against an older femupdate too (without ``femupdate.evaluation``): it then
times the reference path only (``PYTHONPATH=<old checkout>/src python
benchmarks/evaluation_cost.py --only-run`` gives the end-to-end "before").
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit
from threadpoolctl import threadpool_limits

from femupdate.case import Case, load_case, parse_case
from femupdate.paper.problems import bridge
from femupdate.problem.update import UpdateProblem
from femupdate.simulate import prepare
from femupdate.trials.experiment import load_experiment

try:
    import femupdate.evaluation as compiled_path
except ImportError:  # a femupdate before issue 14: the reference path only
    compiled_path = None

REPO = Path(__file__).resolve().parents[1]
BATCHES = (1, 10, 100)
#: At least this many timed batches (heavy cases have few): a median of three is at the mercy
#: of one slow moment of the host.
MIN_BATCH_REPS = 9
N_POINTS = 64

# --------------------------------------------------------------------------- the cases

SHEAR_BUILDING = {
    "case": {"name": "shear-building-3dof"},
    "model": {"shear_building": {"masses": [1.2, 1.0, 0.8], "stiffnesses": ["k1", "k2", "k3"],
                                 "dampers": ["c1", "c2", "c3"]}},
    "parameters": (
        [{"name": f"k{i}", "lower": 1e3, "upper": 2e4, "scale": "log"} for i in (1, 2, 3)]
        + [{"name": f"c{i}", "lower": 0.0, "upper": 10.0} for i in (1, 2, 3)]),
    "data": {"format": "csv", "directory": "data", "time_column": "t",
             "input": {"file": "table.csv", "column": "table"},
             "outputs": [{"file": "floors.csv", "column": f"a{i}", "node": f"F{i}",
                          "dof": "ux"} for i in (1, 2, 3)]},
    "preprocess": {"highpass_hz": 0.5},
    "objective": {"quantity": "acceleration", "experimental_parameters": False},
    "search": {"method": "ab", "runs": 1, "max_evals": 100},
}
SHEAR_TRUTH = {"k1": 6000.0, "k2": 5000.0, "k3": 4000.0, "c1": 2.0, "c2": 1.5, "c3": 1.0}
SHEAR_SAMPLES, SHEAR_RATE = 7500, 250.0


def viscous_bridge(work: Path) -> UpdateProblem:
    return bridge.viscous_problem(work / "viscous", seed=0, snr=0.0)


def friction_bridge(work: Path) -> UpdateProblem:
    data = work / "friction"
    case = parse_case(bridge.bridge_case("friction", "narrow", directory=str(data)),
                      source=data / "friction-narrow.toml")
    bridge.ensure_records(case, bridge.truth("friction"), data, seed=0, snr=0.0)
    return UpdateProblem(case, load_experiment(case))


def shear_building(work: Path) -> UpdateProblem:
    from femupdate.trials.virtual import virtual_experiment

    data = work / "shear"
    spec = json.loads(json.dumps(SHEAR_BUILDING))
    spec["data"]["directory"] = str(data)
    case = parse_case(spec, source=data / "shear.toml")
    if not (data / "floors.csv").exists():
        virtual_experiment(case, SHEAR_TRUTH, data, seed=1, rate=SHEAR_RATE,
                           duration=(SHEAR_SAMPLES - 1) / SHEAR_RATE, snr=0.02)
    return UpdateProblem(case, load_experiment(case))


def minishake(data_dir: Path | None) -> UpdateProblem | str:
    """The real case, or why it is skipped."""
    import sys

    sys.path.insert(0, str(REPO / "examples" / "minishake-1story"))
    from study import find_data  # the real case's data finder, beside its example

    from femupdate.pipeline.run import with_data_directory

    try:
        folder = find_data(data_dir)
    except Exception as exc:  # any reason to skip is printed
        return f"skipped: {exc}"
    case: Case = with_data_directory(load_case(REPO / "examples/minishake-1story/elcentro.toml"),
                                     folder)
    return UpdateProblem(case, load_experiment(case))


# --------------------------------------------------------------------------- timing


#: Process CPU time beside the wall time of every measurement: on a machine shared with other
#: jobs, preemption inflates wall times but not the CPU time a call takes.
_CPU: dict[int, float] = {}


def median_us(fn: Callable[[int], object], repeat: int) -> float:
    """Median wall time (µs) of ``fn(i)`` over ``repeat`` calls, i cycling the points; the
    median process CPU time goes to ``last_cpu_us()``."""
    fn(0)
    times = np.empty(repeat)
    cpu = np.empty(repeat)
    for i in range(repeat):
        c0 = time.process_time()
        t0 = time.perf_counter()
        fn(i)
        times[i] = time.perf_counter() - t0
        cpu[i] = time.process_time() - c0
    _CPU[0] = float(np.median(cpu) * 1e6)
    return float(np.median(times) * 1e6)


def last_cpu_us() -> float:
    """The median CPU time (µs) of the last :func:`median_us`."""
    return _CPU[0]


def points(problem: UpdateProblem, n: int = N_POINTS, seed: int = 0) -> np.ndarray:
    low, high = np.array(problem.bounds).T
    return low + (high - low) * np.random.default_rng(seed).random((n, low.size))


def reference_stages(problem: UpdateProblem, X: np.ndarray, repeat: int) -> dict[str, float]:
    """Median µs of each stage of the step-by-step path, and of the whole φ."""
    n = len(X)
    systems = [problem.system(x) for x in X]
    kw = {"method": problem.fitted[0].method, "outputs": problem.fitted[0].outputs,
          "substeps": problem.fitted[0].substeps}
    sims = [prepare(s, problem.experiment.dt, **kw) for s in systems]
    responses = [sim.run(problem.fitted[0]._ag) for sim in sims]
    predictions = [problem.fitted[0].prediction(r) for r in responses]
    heavy = max(1, repeat // (10 if problem.fitted[0].method != "exact" else 1))
    # (a femupdate before issue 14 has no phi_reference: its __call__ is that path)
    reference = getattr(problem, "phi_reference", problem)
    return {
        "assembly": median_us(lambda i: problem.system(X[i % n]), repeat),
        "prepare": median_us(lambda i: prepare(systems[i % n], problem.experiment.dt, **kw),
                             repeat),
        "simulation": median_us(lambda i: sims[i % n].run(problem.fitted[0]._ag), heavy),
        "processing": median_us(lambda i: problem.fitted[0].prediction(responses[i % n]), repeat),
        "objective": median_us(lambda i: problem.fitted[0].objective(predictions[i % n]), repeat),
        "total": median_us(lambda i: reference(X[i % n]), heavy),
        "total_cpu": last_cpu_us(),
    }


def compiled_stages(problem: UpdateProblem, X: np.ndarray, repeat: int) -> dict[str, float]:
    """Median µs of each compiled stage called alone (each with its own call overhead:
    ``Evaluator.stages``), and of the whole φ through ``UpdateProblem.__call__``."""
    ev = problem.evaluator
    n = len(X)
    stages = [ev.stages(x) for x in X[: min(n, 16)]]
    heavy = max(1, repeat // (10 if ev.method != "exact" else 1))

    def timed(name: str, reps: int) -> float:
        return median_us(lambda i: stages[i % len(stages)][name](), reps)

    copy_us = timed("copy", repeat)
    return {
        "assembly": timed("assembly", repeat),
        "prepare": timed("prepare", repeat) - timed("assembly", repeat),
        "simulation": timed("simulation", heavy),
        "processing+objective": timed("compare", repeat) - copy_us,
        "total": median_us(lambda i: problem(X[i % n]), heavy),
        "total_cpu": last_cpu_us(),
    }


def batch_rows(problem: UpdateProblem, X: np.ndarray, repeat: int
               ) -> dict[int | str, tuple[float, float]]:
    """Median µs per evaluation of φ over batches of k points, and of residual vectors over
    a Jacobian's points: (wall, CPU)."""
    heavy = problem.fitted[0].method != "exact"
    out: dict[int | str, tuple[float, float]] = {}
    for k in BATCHES:
        if heavy and k > 10:
            continue
        reps = max(MIN_BATCH_REPS, repeat // k // (10 if heavy else 1))
        blocks = [np.roll(np.resize(X, (max(k, len(X)), X.shape[1])), -j * k, axis=0)[:k]
                  for j in range(4)]
        wall = median_us(lambda i, blocks=blocks: problem.evaluate_batch(blocks[i % 4]), reps)
        out[k] = (wall / k, last_cpu_us() / k)
        if k == 10:  # the same batches split over two threads (CPU: both threads)
            wall = median_us(lambda i, blocks=blocks: problem.evaluate_batch(blocks[i % 4],
                                                                             threads=2), reps)
            out["10 x 2 threads"] = (wall / k, last_cpu_us() / k)
    # Residual vectors (what multistart-lm's finite-difference Jacobian asks, n + 1 points a
    # batch): one call per point, then the batch on one and on two threads.
    k = len(problem.bounds) + 1
    reps = max(MIN_BATCH_REPS, repeat // k // (10 if heavy else 1))
    blocks = [np.roll(X, -j * k, axis=0)[:k] for j in range(4)]
    for label, run in (
            (f"r, {k} single calls", lambda b: [problem.residuals(x) for x in b]),
            (f"r, batch of {k}", problem.residuals_batch),
            (f"r, batch of {k} x 2 threads", lambda b: problem.residuals_batch(b, threads=2))):
        wall = median_us(lambda i, run=run: run(blocks[i % 4]), reps)
        out[label] = (wall / k, last_cpu_us() / k)
    return out


@njit(cache=True)
def _modal_floor(a: np.ndarray, er: np.ndarray, ei: np.ndarray, g: np.ndarray) -> float:
    """The bare modal recursion: m complex first-order filters over the record."""
    m = er.shape[0]
    xr = np.zeros(m)
    xi = np.zeros(m)
    for k in range(a.shape[0]):
        ak = a[k]
        for j in range(m):
            r = er[j] * xr[j] - ei[j] * xi[j] + g[j] * ak
            xi[j] = er[j] * xi[j] + ei[j] * xr[j] + g[j] * ak
            xr[j] = r
    return xr[0]


@njit(cache=True)
def _central_floor(a: np.ndarray, substeps: int, coef: np.ndarray) -> float:
    """The bare linear part of the modal central-difference recurrence over every step (the
    friction elements only add to it: a lower bound)."""
    n = coef.shape[1]
    prev = np.zeros(n)
    cur = np.zeros(n)
    nxt = np.zeros(n)
    for k in range(a.shape[0] - 1):
        for j in range(substeps):
            u = a[k] + j * (a[k + 1] - a[k]) / substeps
            for i in range(n):
                nxt[i] = coef[0, i] * cur[i] - coef[1, i] * prev[i] + coef[2, i] * u
            prev, cur, nxt = cur, nxt, prev
    return cur[0]


def physical_floor(problem: UpdateProblem, x: np.ndarray, repeat: int) -> tuple[float, str]:
    """(µs, what) of the bare recurrence of the case at point ``x``: its modal filters (or the
    linear part of its modal central differences, a lower bound) over the record, coefficients
    as the evaluator prepares them; no outputs, no processing, no comparison."""
    ev = problem.evaluator
    prepared = ev.stages(x)["prepare"]()  # the point, prepared in the evaluator's buffers
    ag = np.ascontiguousarray(problem.fitted[0]._ag, dtype=float)
    w = ev.work
    if problem.fitted[0].method == "exact":
        size = prepared[1]
        m = int(np.count_nonzero(w.coef[0, :size]))  # the kept modes (zero ones pad)
        args = (ag, w.coef[0, :m].copy(), w.coef[1, :m].copy(), w.coef[2, :m].copy())
        return (median_us(lambda i: _modal_floor(*args), repeat),
                f"{m} complex modal recursions x {ag.size:,} samples")
    args = (ag, problem.fitted[0].substeps, w.modal.copy())
    n = w.modal.shape[1]
    return (median_us(lambda i: _central_floor(*args), max(3, repeat // 10)),
            f"{n} modal central-difference recursions x "
            f"{(ag.size - 1) * problem.fitted[0].substeps:,} "
            f"steps, without the {prepared[2]} friction elements")


def opensees_ratio(problem: UpdateProblem, X: np.ndarray, repeat: int
                   ) -> dict[str, Any] | None:
    """OpenSeesPy's central differences on the friction bridge at the case's substep, each
    simulation paired with a median of compiled φ's timed right after it: the ratio is the
    median of the pairs' ratios (this shared machine's speed drifts by tens of per cent over
    a minute; a pair sees the same state)."""
    try:
        from femupdate.paper.bench.opensees import OpenSeesPeer, import_opensees

        ops = import_opensees()
    except Exception:  # not installed: no comparison
        return None
    values = problem.values(problem.case.to_search(bridge.truth("friction")))
    peer = OpenSeesPeer(problem.case.model, values, ops=ops)
    ag = np.ascontiguousarray(problem.fitted[0]._ag, dtype=float)
    trial = problem.fitted[0]
    reps = max(3, min(7, repeat // 20))
    n = X.shape[0]
    pairs = np.array([(median_us(lambda i: peer.run(ag, problem.experiment.dt,
                                                    method="central_difference",
                                                    substeps=trial.substeps,
                                                    outputs=list(trial.outputs)), 1),
                       median_us(lambda i: problem(X[i % n]), 30)) for _ in range(reps)])
    return {"opensees_cd_us": float(np.median(pairs[:, 0])),
            "compiled_phi_us": float(np.median(pairs[:, 1])),
            "ratio_to_compiled_phi": float(np.median(pairs[:, 0] / pairs[:, 1])),
            "substeps": trial.substeps, "repeat": reps}


# --------------------------------------------------------------------------- end to end


def end_to_end(work: Path, evaluator: str) -> dict[str, Any]:
    """``femupdate run`` (``workflow.run_case``) on the viscous bridge: AB, 1 worker, 6,000
    evaluations, noise-free records, f_target 1e-6 (as ``femupdate bench bridge --snr 0``)."""
    from femupdate.pipeline.run import run_case

    data = work / "e2e-data"
    spec = bridge.bridge_case("viscous", "narrow", directory=str(data))
    spec["search"].update({"method": "ab", "max_evals": 6000, "runs": 1, "f_target": 1e-6})
    case = parse_case(spec, source=data / "viscous-narrow.toml")
    bridge.ensure_records(case, bridge.truth("viscous"), data, seed=0, snr=0.0)
    experiment = load_experiment(case)
    out = work / f"e2e-{evaluator}"
    shutil.rmtree(out, ignore_errors=True)
    os.environ["FEMUPDATE_EVALUATOR"] = evaluator
    try:
        c0 = time.process_time()
        run_case(case, out, workers=1, sensitivities=False, experiments=[experiment])
        cpu = time.process_time() - c0
    finally:
        os.environ.pop("FEMUPDATE_EVALUATOR", None)
    summary = json.loads((out / "summary.json").read_text())
    shutil.rmtree(out, ignore_errors=True)
    nfev = sum(r["nfev"] for r in summary["runs"])
    run = summary["runs"][0]
    return {"evaluator": evaluator, "wall_s": summary["wall_s"], "evaluations": nfev,
            "ms_per_evaluation": 1e3 * summary["wall_s"] / nfev, "cpu_s": cpu,
            "cpu_ms_per_evaluation": 1e3 * cpu / nfev, "phi": run["phi"], "nfev": run["nfev"],
            "x": run["x"], "stop": run["stop"]}


def _sphere(x: np.ndarray) -> float:
    d = x - 0.3
    return float(d @ d)


def machinery_alone(work: Path) -> dict[str, Any]:
    """The run machinery with a trivial φ: AB, 9 parameters, one worker, a results store,
    6,000 evaluations in one run (restarted on the optimizer's own stop until done)."""
    from femupdate.runs import run_all

    store = work / "machinery"
    shutil.rmtree(store, ignore_errors=True)
    c0 = time.process_time()
    t0 = time.perf_counter()
    out = run_all(_sphere, [(0.0, 1.0)] * 9, "ab", runs=1, seed=0, max_evals=6000,
                  options={"restarts": 1000}, store_dir=store)
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0
    shutil.rmtree(store, ignore_errors=True)
    return {"evaluations": out[0].nfev, "us_per_evaluation": 1e6 * wall / out[0].nfev,
            "cpu_us_per_evaluation": 1e6 * cpu / out[0].nfev}


# --------------------------------------------------------------------------- report


def _fmt(us: float | None) -> str:
    if us is None:
        return "–"
    return f"{us / 1e3:,.2f} ms" if us >= 1e3 else f"{us:,.1f} µs"


def print_case(name: str, samples: str, ref: dict[str, float], new: dict[str, float] | None,
               floor: tuple[float, str],
               batches: dict[int | str, tuple[float, float]] | None
               ) -> None:
    print(f"\n{name} ({samples})")
    cols = ("assembly", "prepare", "simulation", "processing", "objective", "total")
    print(f"  {'path':10s}" + "".join(f"{c:>14s}" for c in cols))
    print(f"  {'reference':10s}" + "".join(f"{_fmt(ref[c]):>14s}" for c in cols)
          + f"   (CPU {_fmt(ref['total_cpu'])})")
    if new is not None and floor[1]:
        row = [new["assembly"], new["prepare"], new["simulation"],
               new["processing+objective"], None, new["total"]]
        print(f"  {'compiled':10s}" + "".join(f"{_fmt(v):>14s}" for v in row)
              + f"   (CPU {_fmt(new['total_cpu'])}; processing and objective fused)")
        print(f"  speed-up {ref['total'] / new['total']:.1f}x; floor {_fmt(floor[0])} "
              f"({floor[1]}); compiled total / floor {new['total'] / floor[0]:.1f}")
    if batches:
        print("  batches, per evaluation: " + ", ".join(
            f"{'k = ' if isinstance(k, int) or k[0].isdigit() else ''}{k}: {_fmt(wall)} "
            f"(CPU {_fmt(cpu)})" for k, (wall, cpu) in batches.items()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=400, help="timed calls per stage")
    parser.add_argument("--no-run", action="store_true", help="skip the femupdate run rows")
    parser.add_argument("--only-run", action="store_true",
                        help="only the femupdate run rows (e.g. against an older femupdate)")
    parser.add_argument("--no-opensees", action="store_true", help="skip OpenSeesPy")
    parser.add_argument("--data", type=Path, default=None,
                        help="shared data directory (holding minishake_1story/)")
    parser.add_argument("--work", type=Path, default=None, help="where records are written")
    parser.add_argument("--json", type=Path, default=None, help="write the results here")
    parser.add_argument("--quick", action="store_true",
                        help="3 timed calls per stage, no run rows, no OpenSeesPy (a smoke run)")
    args = parser.parse_args()
    if args.quick:
        args.repeat, args.no_run, args.no_opensees = 3, True, True
    work = args.work or Path(tempfile.gettempdir()) / "femupdate-evaluation-cost"
    work.mkdir(parents=True, exist_ok=True)
    results: dict[str, Any] = {"load_start": os.getloadavg(), "cases": {}}
    print(f"load average at start: {results['load_start']}; one BLAS thread; medians")
    with threadpool_limits(1):
        cases: dict[str, Callable[[], UpdateProblem | str]] = {
            "viscous bridge": lambda: viscous_bridge(work),
            "friction bridge": lambda: friction_bridge(work),
            "minishake 1-storey (real)": lambda: minishake(args.data),
            "3-DOF shear building": lambda: shear_building(work),
        }
        for name, build in cases.items():
            if args.only_run:
                break
            problem = build()
            if isinstance(problem, str):
                print(f"\n{name}: {problem}")
                results["cases"][name] = problem
                continue
            X = points(problem)
            samples = f"{problem.fitted[0]._ag.size:,} samples, {problem.fitted[0].method}"
            if problem.fitted[0].method != "exact":
                samples += f", {problem.fitted[0].substeps} substeps"
            ref = reference_stages(problem, X, args.repeat)
            new = batches = None
            floor: tuple[float, str] = (np.nan, "")
            if compiled_path is not None:
                new = compiled_stages(problem, X, args.repeat)
                batches = batch_rows(problem, X, args.repeat)
                floor = physical_floor(problem, X[0], args.repeat)
            print_case(name, samples, ref, new, floor, batches)
            trial = problem.fitted[0]
            row: dict[str, Any] = {"samples": int(trial._ag.size), "method": trial.method,
                                   "reference_us": ref, "compiled_us": new,
                                   "batch_us_per_evaluation": batches,
                                   "floor_us": floor[0], "floor": floor[1]}
            if name == "friction bridge" and not args.no_opensees:
                peer = opensees_ratio(problem, X, args.repeat) if new is not None else None
                if peer is not None:
                    print(f"  OpenSeesPy central differences x{peer['substeps']}: "
                          f"{_fmt(peer['opensees_cd_us'])} per simulation, one compiled φ "
                          f"{_fmt(peer['compiled_phi_us'])} timed beside each: "
                          f"{peer['ratio_to_compiled_phi']:,.0f}x (median of "
                          f"{peer['repeat']} pairs)")
                row["opensees"] = peer
            results["cases"][name] = row
        if not args.no_run:
            print("\nfemupdate run, viscous bridge, AB, 1 worker, 6,000 evaluations:")
            runs = [end_to_end(work, "reference")] if compiled_path is None else [
                end_to_end(work, "reference"), end_to_end(work, "compiled")]
            for r in runs:
                print(f"  {r['evaluator']:10s} wall {r['wall_s']:.2f} s / {r['evaluations']} "
                      f"evaluations = {r['ms_per_evaluation']:.3f} ms per evaluation "
                      f"(CPU {r['cpu_ms_per_evaluation']:.3f} ms; φ {r['phi']:.10g}, "
                      f"nfev {r['nfev']})")
            if len(runs) == 2:
                a, b = runs
                same = a["nfev"] == b["nfev"] and a["x"] == b["x"]
                rel = abs(a["phi"] - b["phi"]) / abs(a["phi"])
                print(f"  same evaluations and end point: {same}; φ relative difference "
                      f"{rel:.2e}; speed-up {a['wall_s'] / b['wall_s']:.1f}x")
            results["end_to_end"] = runs
            alone = machinery_alone(work)
            print(f"  the run machinery alone (trivial φ, same settings): "
                  f"{alone['us_per_evaluation']:.1f} µs per evaluation "
                  f"(CPU {alone['cpu_us_per_evaluation']:.1f} µs)")
            results["machinery_alone"] = alone
    results["load_end"] = os.getloadavg()
    print(f"\nload average at end: {results['load_end']}")
    if args.json is not None:
        args.json.write_text(json.dumps(results, indent=2, default=float) + "\n")


if __name__ == "__main__":
    main()

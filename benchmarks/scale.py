"""Cost that grows like the model: φ of shear buildings of 10 to 10,000 DOFs (issue 22).

Prints, in one run (one BLAS thread; wall times are inflated when other processes share the
cores, so the load average is printed beside them):

1. φ of a linear shear building, 5,000 samples, 3 acceleration sensors, at 10, 100, 1,000 and
   10,000 DOFs: femupdate on the path ``prepare_linear`` chooses (full exact up to
   ``FULL_PATH_MAX_DOF``, reduced above), the reduced path at every size, and OpenSeesPy's
   transient analysis (Newmark, the same model) timed in the same run; the growth exponent of
   the reduced φ above 100 DOFs (least-squares slope of log time on log DOFs).
2. The truncation error at the default cut-off: φ of the reduced prediction against the full
   model's (both filtered to the fitted band), where the full model is affordable.
3. multistart-lm on a 1,000-DOF building with 10 stiffness parameters (virtual experiment,
   noise-free): runs reaching φ < 1e-6 out of 10 (repeated runs: SeedSequence.spawn).
4. Peak memory (resource.getrusage maxrss of a fresh child process) of a multistart-lm run
   with 48 parameters on the reduced path.

Run from the repository root: ``python benchmarks/scale.py`` (``--quick`` for CI: smaller
models, fewer runs, no 10,000-DOF OpenSees).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy loads (pitfall: BLAS threads)

import argparse
import json
import resource
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import scipy.signal as ss

from femupdate import minimize
from femupdate.model import shear_building
from femupdate.problem.objective import nmse
from femupdate.simulate.exact import ExactSimulator
from femupdate.simulate.reduced import (
    FULL_PATH_MAX_DOF,
    ReducedSimulator,
    prepare_linear,
)

DT = 0.005  # 200 Hz
N_SAMPLES = 5000
BAND_HZ = 25.0  # the fitted band: a 4th-order Butterworth low-pass, forward and backward
SEED = 2022


def load() -> str:
    return "load {:.1f} {:.1f} {:.1f}".format(*os.getloadavg())


def ground_motion(seed: int = SEED) -> np.ndarray:
    """Band-limited noise (to 25 Hz, 4th-order Butterworth), starting from rest."""
    sos = ss.butter(4, BAND_HZ, fs=1 / DT, output="sos")
    ag = ss.sosfilt(sos, np.random.default_rng(seed).standard_normal(N_SAMPLES))
    ag[0] = 0.0
    return ag


class FilteredNmse:
    """φ and its residuals from ``self.prediction(x)`` (the filtered sensors) and
    ``self.target``: the NMSE averaged over channels (the benchmarks' problems share it)."""

    target: np.ndarray

    def prediction(self, x: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def __call__(self, x: np.ndarray) -> float:
        return nmse(self.prediction(x), self.target)

    def residuals(self, x: np.ndarray) -> np.ndarray:
        d = self.prediction(x) - self.target
        scale = np.sqrt(np.sum(self.target**2, axis=0) * self.target.shape[1])
        return (d / scale).ravel()  # r·r = the NMSE averaged over channels = φ


class BuildingPhi(FilteredNmse):
    """φ(x) of a uniform shear building of ``n`` storeys with ``groups`` stiffness parameters.

    Floor masses 1; storey stiffness ``x_g · 16 n²`` in group g of consecutive storeys (the
    first mode near 1 Hz at every size, modes about 2 Hz apart); Rayleigh damping α = 0.2,
    β = 1e-3; absolute accelerations at storeys n/3, 2n/3 and n, low-passed to the band; φ the
    NMSE (mean over channels) against ``target``.
    """

    def __init__(self, n: int, groups: int, ag: np.ndarray, *, reduced: bool | None = None,
                 target: np.ndarray | None = None) -> None:
        self.n = n
        self.names = [f"k{g + 1}" for g in range(groups)]
        self.structure = shear_building([1.0] * n,
                                        [self.names[i * groups // n] for i in range(n)])
        self.structure.set_rayleigh(0.2, 1e-3)
        self.k0 = 16.0 * n * n
        self.outputs = [max(n // 3 - 1, 0), max(2 * n // 3 - 1, 0), n - 1]
        self.ag = ag
        self.sos = ss.butter(4, BAND_HZ, fs=1 / DT, output="sos")
        self.reduced = reduced  # None: prepare_linear chooses by size
        self.target = target
        self.previous = None

    def system(self, x: np.ndarray, sparse: bool = True):
        values = {name: float(v) * self.k0 for name, v in zip(self.names, x, strict=True)}
        return self.structure.assemble(values, sparse=sparse)

    def simulator(self, x: np.ndarray):
        system = self.system(x)
        if self.reduced is None:  # the path chosen by size; the previous modes start it
            sim = prepare_linear(system, DT, self.outputs, band_hz=BAND_HZ,
                                 previous=self.previous)
            self.previous = getattr(sim, "modes", None)
            return sim
        if self.reduced:  # modes of the previous evaluation start the eigensolver
            sim = ReducedSimulator(system, DT, self.outputs, band_hz=BAND_HZ,
                                   previous=self.previous)
            self.previous = sim.modes
            return sim
        return ExactSimulator(self.system(x, sparse=False), DT, self.outputs)

    def prediction(self, x: np.ndarray) -> np.ndarray:
        acc = self.simulator(x).run(self.ag).acceleration
        return ss.sosfiltfilt(self.sos, acc, axis=0)



def median_time(fn: Callable[[], object], repeat: int) -> float:
    fn()  # compile and warm caches
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def opensees_time(n: int, ag: np.ndarray, outputs: list[int]) -> float:
    """OpenSeesPy: the same building (zeroLength springs, nodal masses, Rayleigh damping),
    UniformExcitation with the record as a Path series, Newmark average acceleration, banded
    solver, the three sensors' displacements read at every step. Build + analysis time."""
    from femupdate.external.openseespy import import_opensees

    ops = import_opensees()
    t0 = time.perf_counter()
    ops.wipe()
    ops.model("basic", "-ndm", 1, "-ndf", 1)
    ops.node(0, 0.0)
    ops.fix(0, 1)
    k = 16.0 * n * n
    ops.uniaxialMaterial("Elastic", 1, k)
    for i in range(1, n + 1):
        ops.node(i, 0.0)  # zero length: springs between coincident nodes
        ops.mass(i, 1.0)
        ops.element("zeroLength", i, i - 1, i, "-mat", 1, "-dir", 1)
    ops.rayleigh(0.2, 1e-3, 0.0, 0.0)
    ops.timeSeries("Path", 1, "-dt", DT, "-values", *np.append(ag, ag[-1]).tolist())
    ops.pattern("UniformExcitation", 1, 1, "-accel", 1)
    ops.constraints("Plain")
    ops.numberer("Plain")
    ops.system("BandSPD")
    ops.algorithm("Linear", "-factorOnce")
    ops.integrator("Newmark", 0.5, 0.25)
    ops.analysis("Transient")
    disp = np.zeros((ag.size, len(outputs)))
    tags = [o + 1 for o in outputs]
    for step in range(1, ag.size):
        if ops.analyze(1, DT) != 0:
            raise RuntimeError(f"OpenSees failed at step {step}")
        for j, tag in enumerate(tags):
            disp[step, j] = ops.nodeDisp(tag, 1)
    elapsed = time.perf_counter() - t0
    ops.wipe()
    return elapsed


def phi_rows(sizes: list[int], opensees_max: int, full_max: int, repeat: int) -> list[dict]:
    ag = ground_motion()
    x = np.full(10, 1.0)
    x_eval = x * np.linspace(0.95, 1.05, 10)
    rows = []
    for n in sizes:
        groups = min(10, n)
        probe = BuildingPhi(n, groups, ag, reduced=False if n <= full_max else True)
        reference = probe.prediction(x[:groups])  # the full model's where affordable
        row: dict = {"dofs": n, "full_reference": n <= full_max}
        for label, reduced in (("auto", None), ("reduced", True)):
            problem = BuildingPhi(n, groups, ag, reduced=reduced, target=reference)
            row[f"phi_{label}_s"] = median_time(lambda p=problem, g=groups: p(x_eval[:g]), repeat)
        problem = BuildingPhi(n, groups, ag, reduced=True, target=reference)
        sim = problem.simulator(x[:groups])
        row["modes"] = sim.n_modes
        row["truncation_phi"] = problem(x[:groups]) if n <= full_max else None
        if n <= full_max:
            full = BuildingPhi(n, groups, ag, reduced=False, target=reference)
            row["phi_full_s"] = median_time(lambda p=full, g=groups: p(x_eval[:g]),
                                            max(1, repeat // 3) if n > 300 else repeat)
        row["opensees_s"] = opensees_time(n, ag, problem.outputs) if n <= opensees_max else None
        row["load"] = os.getloadavg()[0]
        rows.append(row)
        print(json.dumps(row), f"({load()})", flush=True)
    return rows


def growth_exponent(rows: list[dict], key: str = "phi_reduced_s") -> float:
    sel = [r for r in rows if r["dofs"] >= 100]
    return float(np.polyfit(np.log([r["dofs"] for r in sel]), np.log([r[key] for r in sel]),
                            1)[0])


def virtual_runs(problem: object, n_params: int, runs: int, max_evals: int,
                 progress: bool = False) -> dict:
    """multistart-lm on a noise-free virtual experiment of ``problem`` (its ``target`` set
    from a truth drawn in [0.7, 1.3] of nominal, bounds [0.5, 1.5]): φ < 1e-6 reached in how
    many of ``runs`` runs (seeds spawned), with their evaluations."""
    truth = np.random.default_rng(SEED).uniform(0.7, 1.3, n_params)
    problem.target = problem.prediction(truth)
    seeds = np.random.SeedSequence(SEED).spawn(runs)
    found, evals, best = 0, [], []
    t0 = time.perf_counter()
    for ss_ in seeds:
        res = minimize(problem.residuals, [(0.5, 1.5)] * n_params, method="multistart-lm",
                       seed=ss_, max_evals=max_evals, f_target=1e-12, residuals=True)
        found += res.fun < 1e-6
        evals.append(int(res.nfev))
        best.append(float(res.fun))
        if progress:
            print(f"  run {len(evals)}: φ {res.fun:.2e} after {res.nfev} evaluations, "
                  f"{time.perf_counter() - t0:.0f} s so far ({load()})", flush=True)
    return {"parameters": n_params, "runs": runs, "reached_1e-6": int(found), "nfev": evals,
            "best_phi": best, "seconds": time.perf_counter() - t0,
            "load": os.getloadavg()[0]}


def multistart(n: int, n_params: int, runs: int, max_evals: int) -> dict:
    """Noise-free virtual experiment on an ``n``-DOF building (:func:`virtual_runs`)."""
    problem = BuildingPhi(n, n_params, ground_motion(), reduced=True)
    return {"dofs": n, **virtual_runs(problem, n_params, runs, max_evals)}


def peak_memory_child(n: int, n_params: int, max_evals: int) -> dict:
    """Peak resident memory of a fresh process running a 48-parameter multistart-lm."""
    code = (
        f"import sys, resource, json; sys.path.insert(0, {str(Path(__file__).parent)!r}); "
        "import scale; "
        f"r = scale.multistart({n}, {n_params}, 1, {max_evals}); "
        "r['maxrss_mb'] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024; "
        "print(json.dumps(r))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def phi_table(args: argparse.Namespace) -> None:
    if args.quick:
        rows = phi_rows([10, 100, 1000], opensees_max=1000, full_max=300, repeat=3)
    else:
        sizes = [n for n in (10, 100, 1000, 10_000) if n <= args.max_dofs]
        rows = phi_rows(sizes, opensees_max=10_000, full_max=1000, repeat=7)
    print(f"growth exponent of the reduced φ above 100 DOFs: {growth_exponent(rows):.2f}")
    for r in rows:
        if r["opensees_s"]:
            print(f"{r['dofs']:>6} DOFs: φ {r['phi_auto_s'] * 1e3:.2f} ms (reduced "
                  f"{r['phi_reduced_s'] * 1e3:.2f} ms), OpenSeesPy {r['opensees_s'] * 1e3:.0f} ms"
                  f", ratio {r['opensees_s'] / r['phi_auto_s']:.0f}x")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes, for CI (~1 min)")
    parser.add_argument("--skip-optimize", action="store_true", help="φ timings only")
    parser.add_argument("--skip-phi", action="store_true", help="multistart and memory only")
    parser.add_argument("--runs", type=int, default=None, help="multistart-lm runs (10)")
    parser.add_argument("--max-dofs", type=int, default=10_000, help="largest φ model")
    args = parser.parse_args()
    print(f"femupdate benchmarks/scale.py, {N_SAMPLES} samples, 3 sensors, band {BAND_HZ} Hz, "
          f"full path up to {FULL_PATH_MAX_DOF} DOFs; {load()}; maxrss now "
          f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB", flush=True)
    if not args.skip_phi:
        phi_table(args)
    if args.skip_optimize:
        return
    if args.quick:
        ms = multistart(300, 10, args.runs or 2, 3000)
    else:
        ms = multistart(1000, 10, args.runs or 10, 5000)
    print(json.dumps(ms), f"({load()})", flush=True)
    mem = peak_memory_child(300 if args.quick else 1000, 48, 400 if args.quick else 2000)
    print(f"peak memory of a 48-parameter multistart-lm run ({mem['dofs']} DOFs, "
          f"{sum(mem['nfev'])} evaluations): {mem['maxrss_mb']:.0f} MB ({load()})", flush=True)


if __name__ == "__main__":
    main()

"""The Bouc–Wen element and the per-storey shorthand (issue 22): every figure the issue asks for.

    python benchmarks/hysteresis.py [--quick] [--seeds N] [--json PATH]

1. **Loop against an independent solution.** One element (k = 1e4 N/m, α = 0.1, A = 1,
   β = 150, γ = 50, n = 1.5: z_u = 29 mm) driven through a growing sine from rest (4 s, 1.1 Hz,
   peaks between samples), sampled with N steps; its force against
   ``k (α u + (1 − α) z)`` with z from ``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-10, atol
   1e-14) at the same instants; the largest error over the history relative to the yield force
   ``(1 − α) k z_u``, and the observed order (least-squares slope of log error on log N).
2. **Against OpenSeesPy's ``BoucWen`` material** (``testUniaxialMaterial``/``setStrain``, the same
   history): OpenSees's own error against solve_ivp, and its distance to femupdate, per N.
   Then in a structure: the two-storey building of 3 (truth values) under a 4 s sine burst at
   200 Hz, in OpenSees as ``zeroLength`` elements with the ``BoucWen`` material, node masses
   (no beam, so no beam-mass trap), mass-proportional Rayleigh damping, ``UniformExcitation``
   and its ``CentralDifference`` integrator at the same substep as femupdate's; the largest
   floor-displacement difference per substep count, relative to the peak, and femupdate's own
   distance to its solution at 640 substeps.
3. **Identification.** A two-storey shear building (masses 1.0 and 0.8 kg, mass-proportional
   damping 0.6/s, known) whose storeys are Bouc–Wen links (α = 0.1, γ = 2.5e5 m⁻², n = 2, known;
   k1, k2, β1, β2 updated), shaken by one EC8 artificial accelerogram (0.35 g, 1:50 scale,
   4 s at 200 Hz); the floors' absolute accelerations recorded with 2 % noise (rms, no offset or
   drift), one noise seed per repetition (children of one SeedSequence); multistart-lm, 2 runs of
   at most 1,500 evaluations each, per seed. The table: truth, mean and standard deviation of
   the estimates over the seeds, the largest deviation from the truth in units of that
   spread, and the mean bias in units of the standard error of the mean.
4. **The per-storey shorthand.** A three-storey building with a slider (and a viscous damper)
   in every storey, as ``[model.shear_building]`` with ``[model.shear_building.frictions]`` and
   as the same building written from nodes (2-DOF nodes, rotations fixed, outputs ``uy``): the
   lines of each ``[model]``, and the largest difference of their responses.

``--quick`` (for CI): fewer steps in 1–2, two seeds and 600 evaluations per run in 3. The load
average is printed at the start and the end (times only in 3, as context: they are inflated
when other jobs share the machine). Everything runs with one BLAS thread (threadpoolctl).
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp
from threadpoolctl import threadpool_limits

from femupdate.case import load_case, parse_case
from femupdate.errors import MissingDependencyError
from femupdate.model.hysteresis import bouc_wen_loop
from femupdate.pipeline.run import run_case
from femupdate.problem.case_model import build_structure
from femupdate.simulate import prepare
from femupdate.trials.virtual import ec8_motion, virtual_experiment

LAW = (1e4, 0.1, 1.0, 150.0, 50.0, 1.5)  # k, alpha, A, beta, gamma, n
DURATION = 4.0
OMEGA = 2.0 * np.pi * 1.1


def history(t: np.ndarray) -> np.ndarray:
    return 0.02 * (0.3 + t / DURATION) * np.sin(OMEGA * t)


def history_rate(t: np.ndarray) -> np.ndarray:
    return 0.02 * (np.sin(OMEGA * t) / DURATION + (0.3 + t / DURATION) * OMEGA
                   * np.cos(OMEGA * t))


def reference_z(t: np.ndarray) -> np.ndarray:
    """z at ``t`` by solve_ivp on ż = (A − (β sign(u̇ z) + γ)|z|^n) u̇(t)."""
    _, _, A, beta, gamma, n = LAW

    def rate(time_: float, z: np.ndarray) -> list[float]:
        v = history_rate(time_)
        return [(A - (beta * np.sign(v * z[0]) + gamma) * abs(z[0]) ** n) * v]

    sol = solve_ivp(rate, (0.0, DURATION), [0.0], method="DOP853", rtol=1e-10, atol=1e-14,
                    dense_output=True, max_step=0.01)
    return sol.sol(t)[0]


def yield_force() -> float:
    k, alpha, A, beta, gamma, n = LAW
    return (1.0 - alpha) * k * (A / (beta + gamma)) ** (1.0 / n)


def order(steps: list[int], errors: list[float]) -> float:
    return float(-np.polyfit(np.log(steps), np.log(errors), 1)[0])


def loop_checks(steps: list[int]) -> dict[str, Any]:
    """Sections 1 and 2."""
    k, alpha, A, beta, gamma, n = LAW
    try:
        from femupdate.paper.bench.opensees import import_opensees

        ops = import_opensees()
    except MissingDependencyError as exc:
        ops = None
        print(f"OpenSeesPy not available ({exc}): section 2 skipped")
    rows = []
    for count in steps:
        t = np.linspace(0.0, DURATION, count + 1)
        y = history(t)
        exact = k * (alpha * y + (1.0 - alpha) * reference_z(t))
        ours, _ = bouc_wen_loop(y, *LAW)
        row = {"steps": count, "femupdate_vs_ivp": float(np.max(np.abs(ours - exact)))
               / yield_force()}
        if ops is not None:
            ops.wipe()
            ops.uniaxialMaterial("BoucWen", 1, alpha, k, n, gamma, beta, A, 0.0, 0.0, 0.0)
            ops.testUniaxialMaterial(1)
            theirs = np.array([(ops.setStrain(float(v)), ops.getStress())[1] for v in y])
            ops.wipe()
            row["opensees_vs_ivp"] = float(np.max(np.abs(theirs - exact))) / yield_force()
            row["femupdate_vs_opensees"] = float(np.max(np.abs(ours - theirs))) / yield_force()
        rows.append(row)
    print("\n1-2. One element, growing sine from rest; largest force error / yield force "
          f"({yield_force():.4g} N)")
    head = f"{'steps':>7} {'femupdate vs solve_ivp':>24}"
    if ops is not None:
        head += f" {'OpenSees vs solve_ivp':>23} {'femupdate vs OpenSees':>23}"
    print(head)
    for row in rows:
        line = f"{row['steps']:>7} {row['femupdate_vs_ivp']:>24.3e}"
        if ops is not None:
            line += (f" {row['opensees_vs_ivp']:>23.3e}"
                     f" {row['femupdate_vs_opensees']:>23.3e}")
        print(line)
    out: dict[str, Any] = {"rows": rows}
    for key in rows[0]:
        if key != "steps":
            out[f"order_{key}"] = order(steps, [r[key] for r in rows])
    print("observed order: " + ", ".join(f"{key[6:]} {value:.2f}"
                                         for key, value in out.items() if key != "rows"))
    return out


def structure_check(substeps: list[int]) -> dict[str, Any] | None:
    """Section 2, the structure: femupdate against OpenSees's transient analysis."""
    from femupdate.model.structure import shear_building
    from femupdate.simulate import simulate

    try:
        from femupdate.paper.bench.opensees import import_opensees

        ops = import_opensees()
    except MissingDependencyError:
        return None
    masses = (1.0, 0.8)
    laws = [{"k": TRUTH["k1"], "alpha": 0.1, "A": 1.0, "beta": TRUTH["b1"], "gamma": 2.5e5,
             "n": 2.0},
            {"k": TRUTH["k2"], "alpha": 0.1, "A": 1.0, "beta": TRUTH["b2"], "gamma": 2.5e5,
             "n": 2.0}]
    dt = 1.0 / RATE
    t = np.arange(800) * dt
    ag = 8.0 * np.sin(2.0 * np.pi * 3.0 * t) * np.sin(np.pi * t / t[-1]) ** 2
    s = shear_building(list(masses), [0.0, 0.0], bouc_wen=laws)
    s.set_rayleigh(alpha=0.6)
    system = s.assemble()

    def opensees(count: int) -> np.ndarray:
        ops.wipe()
        ops.model("basic", "-ndm", 1, "-ndf", 1)
        for node in (1, 2, 3):
            ops.node(node, 0.0)
        ops.fix(1, 1)
        ops.mass(2, masses[0])
        ops.mass(3, masses[1])
        for tag, law in enumerate(laws, start=1):
            ops.uniaxialMaterial("BoucWen", tag, law["alpha"], law["k"], law["n"],
                                 law["gamma"], law["beta"], law["A"], 0.0, 0.0, 0.0)
            ops.element("zeroLength", tag, tag, tag + 1, "-mat", tag, "-dir", 1)
        ops.rayleigh(0.6, 0.0, 0.0, 0.0)
        ops.timeSeries("Path", 1, "-dt", dt, "-values", *ag.tolist())
        ops.pattern("UniformExcitation", 1, 1, "-accel", 1)
        for command, arg in (("constraints", "Plain"), ("numberer", "Plain"),
                             ("system", "FullGeneral"), ("algorithm", "Linear"),
                             ("integrator", "CentralDifference"), ("analysis", "Transient")):
            getattr(ops, command)(arg)
        out = np.zeros((ag.size, 2))
        for k in range(1, ag.size):
            ops.analyze(count, dt / count)
            out[k] = ops.nodeDisp(2, 1), ops.nodeDisp(3, 1)
        ops.wipe()
        return out

    fine = simulate(system, dt, ag=ag, method="nonlinear", substeps=640).displacement
    peak = float(np.abs(fine).max())
    rows = []
    for count in substeps:
        ours = simulate(system, dt, ag=ag, method="nonlinear", substeps=count).displacement
        theirs = opensees(count)
        rows.append({"substeps": count,
                     "femupdate_vs_640": float(np.abs(ours - fine).max()) / peak,
                     "femupdate_vs_opensees": float(np.abs(ours - theirs).max()) / peak})
    print("\n2. The two-storey Bouc–Wen building against OpenSees (zeroLength + BoucWen, "
          "CentralDifference); largest floor-displacement difference / peak "
          f"({1e3 * peak:.3g} mm)")
    print(f"{'substeps':>9} {'femupdate vs its 640 substeps':>30} {'femupdate vs OpenSees':>23}")
    for row in rows:
        print(f"{row['substeps']:>9} {row['femupdate_vs_640']:>30.3e} "
              f"{row['femupdate_vs_opensees']:>23.3e}")
    out: dict[str, Any] = {"rows": rows, "peak_m": peak}
    for key in ("femupdate_vs_640", "femupdate_vs_opensees"):
        out[f"order_{key}"] = order(substeps, [r[key] for r in rows])
    print(f"observed order: vs 640 substeps {out['order_femupdate_vs_640']:.2f}, vs OpenSees "
          f"{out['order_femupdate_vs_opensees']:.2f}")
    return out


IDENTIFICATION_CASE = """\
[case]
name = "two storeys with Bouc-Wen links"

[model.shear_building]
masses = [1.0, 0.8]
stiffnesses = [0.0, 0.0]

[model.rayleigh]
alpha = 0.6                    # 1/s: mass-proportional, about 0.5 % of critical at 10 Hz

[model.shear_building.bouc_wen]
k = ["k1", "k2"]
alpha = 0.1
beta = ["b1", "b2"]
gamma = 2.5e5
n = 2.0

[[parameters]]
name = "k1"
lower = 2000.0
upper = 8000.0
[[parameters]]
name = "k2"
lower = 1500.0
upper = 6000.0
[[parameters]]
name = "b1"
lower = 3.0e5
upper = 3.0e6
scale = "log"
[[parameters]]
name = "b2"
lower = 3.0e5
upper = 3.0e6
scale = "log"

[preprocess]
substeps = 5

[objective]
quantity = "acceleration"      # white sensor noise, not integrated into drift

[data]
format = "csv"
directory = "data"
time_column = "t"

[data.input]
file = "table.csv"
column = "table"

[[data.outputs]]
file = "floors.csv"
column = "a1"
node = "F1"
dof = "ux"
[[data.outputs]]
file = "floors.csv"
column = "a2"
node = "F2"
dof = "ux"

[search]
method = "multistart-lm"
runs = 2
seed = 22
max_evals = MAX_EVALS
workers = 1
"""
TRUTH = {"k1": 4000.0, "k2": 3000.0, "b1": 7.5e5, "b2": 1.0e6}
RATE = 200.0


def identification(seeds: int, max_evals: int) -> dict[str, Any]:
    """Section 3."""
    motion = ec8_motion(np.random.default_rng(2026), rate=RATE, duration=4.0, pga_g=0.35)
    names = list(TRUTH)
    estimates, phis, walls, yielded = [], [], [], []
    costs: dict[str, float] = {}
    for child in np.random.SeedSequence(22).spawn(seeds):
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp)
            (folder / "case.toml").write_text(
                IDENTIFICATION_CASE.replace("MAX_EVALS", str(max_evals)))
            case = load_case(folder / "case.toml")
            noise_seed = int(child.generate_state(1)[0])
            virtual_experiment(case, TRUTH, folder / "data", seed=noise_seed, motion=motion,
                               snr=0.02, offset=0.0, drift=0.0)
            if not yielded:
                from femupdate.problem.case_model import CaseModel

                response = CaseModel(case).simulate(TRUTH, motion.ag, motion.dt)
                structure = build_structure(case.model)
                system = structure.assemble(TRUTH, "x")
                sim = prepare(system, motion.dt, method="nonlinear", substeps=5)
                z = sim.run(motion.ag).hysteretic_z
                z_u = [(1.0 / (TRUTH[b] + 2.5e5)) ** 0.5 for b in ("b1", "b2")]
                yielded = [float(np.abs(z[:, i]).max() / z_u[i]) for i in range(2)]
                del response
            if not costs:
                costs.update(phi_cost(case))
                dashpots = (folder / "case.toml").read_text().replace(
                    "[model.rayleigh]\nalpha = 0.6", "dampers = [0.5, 0.4]")
                (folder / "dashpots.toml").write_text(dashpots)
                costs.update({f"dashpots_{key}": value for key, value in
                              phi_cost(load_case(folder / "dashpots.toml")).items()})
            start = time.perf_counter()
            result = run_case(case, None, sensitivities=False)
            walls.append(time.perf_counter() - start)
            best = result.summary.best
            estimates.append([best.params[n] for n in names])
            phis.append(best.phi)
    est = np.array(estimates)
    truth = np.array([TRUTH[n] for n in names])
    mean, std = est.mean(axis=0), est.std(axis=0, ddof=1)
    worst = np.max(np.abs(est - truth), axis=0) / std
    bias = (mean - truth) / (std / np.sqrt(seeds))
    print(f"\n3. Identification: 2 storeys, Bouc–Wen links, 2 % noise, {seeds} noise seeds, "
          f"multistart-lm (2 runs × ≤ {max_evals} evaluations)")
    print(f"   peak |z| / z_u of the truth: storey 1 {yielded[0]:.2f}, storey 2 "
          f"{yielded[1]:.2f}")
    print(f"{'parameter':>10} {'truth':>11} {'mean':>11} {'std':>10} {'rel. std':>9} "
          f"{'max|e|/std':>11} {'bias/sem':>9}")
    for i, name in enumerate(names):
        print(f"{name:>10} {truth[i]:>11.5g} {mean[i]:>11.5g} {std[i]:>10.3g} "
              f"{std[i] / truth[i]:>9.2%} {worst[i]:>11.2f} {bias[i]:>9.2f}")
    print("   per seed: " + "; ".join(
        ", ".join(f"{n}={v:.5g}" for n, v in zip(names, row, strict=True))
        + f" (φ {phi:.3e})" for row, phi in zip(est, phis, strict=True)))
    print(f"   wall per seed: {np.median(walls):.1f} s (median), load {os.getloadavg()}")
    print(f"   φ per evaluation: compiled {1e3 * costs['compiled_s']:.2f} ms, step-by-step "
          f"reference {1e3 * costs['reference_s']:.2f} ms (medians of {costs['calls']:.0f} "
          "points; the two agree to "
          f"{costs['max_relative_difference']:.1e} relative); with storey dashpots instead "
          f"(physical coordinates): compiled {1e3 * costs['dashpots_compiled_s']:.2f} ms, "
          f"reference {1e3 * costs['dashpots_reference_s']:.2f} ms (agreeing to "
          f"{costs['dashpots_max_relative_difference']:.1e})")
    return {"names": names, "truth": truth.tolist(), "estimates": est.tolist(),
            "phi": phis, "mean": mean.tolist(), "std": std.tolist(),
            "max_error_over_std": worst.tolist(), "bias_over_sem": bias.tolist(),
            "peak_z_over_zu": yielded, "wall_s": walls, "phi_cost": costs}


def phi_cost(case: Any, calls: int = 30) -> dict[str, float]:
    """Median time of φ at random points by the compiled evaluator and by the reference."""
    from femupdate.evaluation import evaluator_for
    from femupdate.problem.update import UpdateProblem
    from femupdate.trials.experiment import load_experiments

    trial = UpdateProblem(case, load_experiments(case)).trials[0]
    evaluator = evaluator_for(trial)
    lower, upper = (np.array(b) for b in zip(*case.bounds, strict=True))
    X = lower + (upper - lower) * np.random.default_rng(0).random((calls, lower.size))
    evaluator(X[0])  # compile or load from the cache
    times: dict[str, list[float]] = {"compiled_s": [], "reference_s": []}
    values = {"compiled_s": [], "reference_s": []}
    for x in X:  # interleaved
        for key, fun in (("compiled_s", evaluator), ("reference_s", trial.phi_reference)):
            start = time.perf_counter()
            values[key].append(fun(x))
            times[key].append(time.perf_counter() - start)
    diff = np.max(np.abs(np.subtract(values["compiled_s"], values["reference_s"]))
                  / np.abs(values["reference_s"]))
    return {key: float(np.median(v)) for key, v in times.items()} | {
        "calls": float(calls), "max_relative_difference": float(diff)}


SHORTHAND = """\
[case]
name = "three storeys, a slider in each"

[model.shear_building]
masses = [2.0, 2.0, 1.5]
stiffnesses = [3000.0, 2500.0, 2000.0]
dampers = [0.5, 0.5, 0.5]
[model.shear_building.frictions]
k_r = [1500.0, 1200.0, 900.0]
f_u = [1.5, 1.2, 1.0]
"""


def from_nodes() -> str:
    """The same building from nodes, as a user had to write it before the shorthand."""
    parts = ['[case]\nname = "three storeys from nodes"\n\n[model]\ndofs_per_node = 2\n']
    for i in range(4):
        parts.append(f'[[model.nodes]]\nname = "{"G" if i == 0 else f"F{i}"}"\nx = 0.0\n'
                     f"y = {float(i)}\n")
    k, m = (3000.0, 2500.0, 2000.0), (2.0, 2.0, 1.5)
    kr, fu = (1500.0, 1200.0, 900.0), (1.5, 1.2, 1.0)
    for i in range(1, 4):
        ends = f'node = "F{i}"\ndof = "uy"\nnode2 = "{"G" if i == 1 else f"F{i - 1}"}"\n'
        parts += [f"[[model.springs]]\n{ends}k = {k[i - 1]}\n",
                  f"[[model.dampers]]\n{ends}c = 0.5\n",
                  f"[[model.frictions]]\n{ends}k_r = {kr[i - 1]}\nf_u = {fu[i - 1]}\n",
                  f'[[model.masses]]\nnode = "F{i}"\nm = {m[i - 1]}\n',
                  f'[[model.supports]]\nnode = "F{i}"\ndofs = ["rz"]\n']
    parts.append('[[model.supports]]\nnode = "G"\ndofs = ["uy", "rz"]\n')
    return "\n".join(parts)


def shorthand_check() -> dict[str, Any]:
    """Section 4."""
    t = np.arange(1500) * 0.01
    ag = 4.0 * np.sin(2.0 * np.pi * 2.1 * t) * np.sin(np.pi * t / 15.0) ** 2
    out = {}
    for label, text, dof in (("shorthand", SHORTHAND, "ux"), ("nodes", from_nodes(), "uy")):
        case = parse_case(tomllib.loads(text))
        structure = build_structure(case.model)
        system = structure.assemble({}, case.model.excitation_direction)
        outputs = [structure.dof_index(f"F{i}", dof) for i in (1, 2, 3)]
        sim = prepare(system, 0.01, method="nonlinear", outputs=outputs, substeps=10)
        body = text[text.index("[model"):]
        out[label] = {"lines": sum(1 for line in body.splitlines() if line.strip()),
                      "acceleration": sim.run(ag).acceleration}
    a, b = out["shorthand"]["acceleration"], out["nodes"]["acceleration"]
    diff = float(np.max(np.abs(a - b)))
    print("\n4. Three storeys, a slider per storey: [model] lines "
          f"{out['shorthand']['lines']} (shorthand) against {out['nodes']['lines']} (from "
          f"nodes); largest difference of the floor accelerations {diff:.3g} m/s² "
          f"(peak {np.abs(a).max():.3g} m/s²)")
    return {"lines_shorthand": out["shorthand"]["lines"], "lines_nodes": out["nodes"]["lines"],
            "max_difference": diff, "peak": float(np.abs(a).max())}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer steps, seeds, evaluations")
    parser.add_argument("--seeds", type=int, default=None, help="noise seeds (default 6; 2)")
    parser.add_argument("--json", type=Path, default=None, help="write the figures here")
    args = parser.parse_args()
    print(f"load average at start: {os.getloadavg()}")
    steps = [200, 400, 800, 1600] if args.quick else [200, 400, 800, 1600, 3200, 6400, 12800]
    seeds = args.seeds or (2 if args.quick else 6)
    with threadpool_limits(1):  # small dense algebra: one BLAS thread (the pitfall of many)
        figures = {"loop": loop_checks(steps),
                   "structure": structure_check([10, 20, 40] if args.quick
                                                else [10, 20, 40, 80, 160]),
                   "identification": identification(seeds, 600 if args.quick else 1500),
                   "shorthand": shorthand_check()}
    print(f"load average at end: {os.getloadavg()}")
    if args.json is not None:
        args.json.write_text(json.dumps(figures, indent=2) + "\n")


if __name__ == "__main__":
    main()

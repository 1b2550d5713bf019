"""Large 3-D frames on the reduced path: φ from 24 to 10,000 DOFs, OpenSeesPy beside it, and
multistart-lm on a 1,000-DOF frame (issue 22).

The frames are buildings of ``bays × bays`` bays (6 m) and ``storeys`` storeys (3.5 m) of 3-D
Timoshenko beam-columns (6 DOFs per node, ``Structure(dofs_per_node=6)``), columns fixed at the
base. The beams are massless and every floor node carries a lumped mass (translations and a
rotary inertia), with one corner of each floor twice as heavy so that the floors twist: then
OpenSeesPy's ``UniformExcitation`` and femupdate's ``-M r a_g`` are the same load, and the two
codes integrate the same equations. Rayleigh damping, 2 % at the first mode and at 10 Hz.

Prints, in one run (one BLAS thread; the load average beside every wall time: the machine may
be shared):

1. At each size: φ of the model (sparse assembly of the frame at the parameter point, its
   modes up to twice the 25 Hz band by shift-invert Lanczos started from the nominal point's,
   the exact discretisation of the reduced model with the static correction, the fitted band's
   filter and the NMSE at 3 sensors, 5,000 samples), the modes kept, the truncation error
   against the full exact model (up to 1,000 DOFs), and OpenSeesPy's transient analysis of the
   same frame (``ElasticTimoshenkoBeam`` 3-D, Newmark average acceleration, banded SPD solver
   with RCM numbering, the sensors read every step), build + analysis, up to 1,000 DOFs.
   At the smallest size the two codes' Newmark displacements are compared as a check that
   they simulate the same model. Then the growth exponent of φ above 100 DOFs.
2. multistart-lm on the 1,050-DOF frame with 10 parameters (the columns' E of each of the 7
   storeys, the beams' E of three floor groups), noise-free virtual experiment: the runs that
   reach φ < 1e-6 out of 10 (repeated runs: SeedSequence.spawn), their evaluations.

    python benchmarks/frame3d_scale.py [--quick] [--skip-optimize] [--runs 10]

``--quick`` (CI): frames of 24 and 96 DOFs, OpenSeesPy at 96, 2 runs on the 96-DOF frame.
The 10,200-DOF frame runs with ``--max-dofs 10200`` only: without rigid diaphragms, every
floor node's own modes lie below the cut-off (670 of the 1,050-DOF frame's 1,050 modes are
below 50 Hz), so the modes kept grow with the model, and their count decides the cost.
``benchmarks/building3d_scale.py`` measures the same frames with rigid floors and floor masses,
as buildings are modelled.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy loads (pitfall: BLAS threads)

import argparse
import json
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.signal as ss
from scale import BAND_HZ, DT, FilteredNmse, ground_motion, load, median_time, virtual_runs

from femupdate.model import Structure
from femupdate.model.modes import NaturalModes
from femupdate.model.sparse import lowest_modes
from femupdate.problem.objective import nmse
from femupdate.simulate import prepare
from femupdate.simulate.exact import ExactSimulator
from femupdate.simulate.reduced import ReducedSimulator

BAY_M = 6.0
STOREY_M = 3.5
E_CONCRETE = 30e9
NU = 0.2
COLUMN = {"A": 0.25, "Iy": 5.2e-3, "Iz": 5.2e-3, "J": 8.8e-3}  # 0.5 × 0.5 m
BEAM = {"A": 0.18, "Iy": 5.4e-3, "Iz": 1.35e-3, "J": 3.7e-3}  # 0.3 × 0.6 m
NODE_MASS = 36_000.0  # kg: 6 × 6 m of floor at 1 t/m²
ROTARY = 0.1  # kg m² per kg of a node's mass (rotations need some inertia)
#: The sizes: (bays, storeys) → 6 (bays + 1)² storeys DOFs.
SIZES = {24: (1, 1), 96: (1, 4), 1050: (4, 7), 10_200: (9, 17)}
OPENSEES_MAX = 1050
FULL_MAX = 1050


@dataclass(frozen=True)
class FrameSpec:
    """A building frame: its size, parameter groups and sensors."""

    bays: int
    storeys: int
    column_groups: int
    beam_groups: int

    @property
    def dofs(self) -> int:
        return 6 * (self.bays + 1) ** 2 * self.storeys

    @property
    def names(self) -> list[str]:
        return ([f"Ec{g + 1}" for g in range(self.column_groups)]
                + [f"Eb{g + 1}" for g in range(self.beam_groups)])

    def column_param(self, storey: int) -> str:
        return f"Ec{storey * self.column_groups // self.storeys + 1}"

    def beam_param(self, storey: int) -> str:
        return f"Eb{storey * self.beam_groups // self.storeys + 1}"


def node_name(i: int, j: int, level: int) -> str:
    return f"n{i}_{j}_{level}"


def members(spec: FrameSpec) -> list[tuple[str, str, str, dict, list[float]]]:
    """Every member: (node 1, node 2, its E parameter, section, vecxz)."""
    out = []
    n = spec.bays + 1
    for s in range(spec.storeys):
        for i in range(n):
            for j in range(n):
                out.append((node_name(i, j, s), node_name(i, j, s + 1), spec.column_param(s),
                            COLUMN, [1.0, 0.0, 0.0]))
        for i in range(n):
            for j in range(n):
                if i + 1 < n:
                    out.append((node_name(i, j, s + 1), node_name(i + 1, j, s + 1),
                                spec.beam_param(s), BEAM, [0.0, 0.0, 1.0]))
                if j + 1 < n:
                    out.append((node_name(i, j, s + 1), node_name(i, j + 1, s + 1),
                                spec.beam_param(s), BEAM, [0.0, 0.0, 1.0]))
    return out


def floor_masses(spec: FrameSpec) -> dict[str, float]:
    """Each floor node's mass; the (0, 0) corner twice as heavy (the floors twist)."""
    n = spec.bays + 1
    return {node_name(i, j, s): NODE_MASS * (2.0 if i == j == 0 else 1.0)
            for s in range(1, spec.storeys + 1) for i in range(n) for j in range(n)}


def sensors(spec: FrameSpec) -> list[tuple[str, str]]:
    """Roof corners (0, 0) and (bays, bays) along x, mid-height corner (bays, 0) along y."""
    b, top = spec.bays, spec.storeys
    return [(node_name(0, 0, top), "ux"), (node_name(b, b, top), "ux"),
            (node_name(b, 0, max(top // 2, 1)), "uy")]


def build_structure(spec: FrameSpec, alpha: float, beta: float) -> Structure:
    s = Structure(dofs_per_node=6)
    n = spec.bays + 1
    for level in range(spec.storeys + 1):
        for i in range(n):
            for j in range(n):
                s.add_node(node_name(i, j, level), x=i * BAY_M, y=j * BAY_M, z=level * STOREY_M)
    for a, b, param, sec, vecxz in members(spec):
        s.add_beam(a, b, E=param, nu=NU, A=sec["A"], Iy=sec["Iy"], Iz=sec["Iz"], J=sec["J"],
                   vecxz=vecxz)
    for node, m in floor_masses(spec).items():
        s.add_mass(node, m=m, J=ROTARY * m)
    for i in range(n):
        for j in range(n):
            s.fix(node_name(i, j, 0), "ux", "uy", "uz", "rx", "ry", "rz")
    s.set_rayleigh(alpha, beta)
    return s


def rayleigh(f1: float, f2: float = 10.0, zeta: float = 0.02) -> tuple[float, float]:
    w1, w2 = 2 * np.pi * f1, 2 * np.pi * f2
    return 2 * zeta * w1 * w2 / (w1 + w2), 2 * zeta / (w1 + w2)


class FramePhi(FilteredNmse):
    """φ(x) of a frame: ``x`` scales the nominal E of each group (truth near 1)."""

    def __init__(self, spec: FrameSpec, ag: np.ndarray) -> None:
        self.spec = spec
        undamped = build_structure(spec, 0.0, 0.0)
        nominal = {name: E_CONCRETE for name in spec.names}
        f1 = float(lowest_modes(*_km(undamped, nominal), n_modes=1).freqs_hz[0])
        self.alpha, self.beta = rayleigh(f1)
        self.structure = build_structure(spec, self.alpha, self.beta)
        self.outputs = [self.structure.dof_index(node, dof) for node, dof in sensors(spec)]
        self.ag = ag
        self.sos = ss.butter(4, BAND_HZ, fs=1 / DT, output="sos")
        system = self.structure.assemble(nominal, sparse=True, direction="x")
        # the start of every eigensolve: the nominal point's modes (repeatable bits)
        self.start: NaturalModes = ReducedSimulator(system, DT, self.outputs,
                                                    band_hz=BAND_HZ).modes
        self.target: np.ndarray | None = None

    def values(self, x: np.ndarray) -> dict[str, float]:
        return {name: float(v) * E_CONCRETE for name, v in zip(self.spec.names, x, strict=True)}

    def simulator(self, x: np.ndarray) -> ReducedSimulator:
        system = self.structure.assemble(self.values(x), sparse=True, direction="x")
        return ReducedSimulator(system, DT, self.outputs, band_hz=BAND_HZ, previous=self.start)

    def prediction(self, x: np.ndarray, sim: object = None) -> np.ndarray:
        sim = sim or self.simulator(x)
        return ss.sosfiltfilt(self.sos, sim.run(self.ag).acceleration, axis=0)



def _km(structure: Structure, values: dict[str, float]) -> tuple:
    system = structure.assemble(values, sparse=True, direction="x")
    return system.K, system.M


def opensees_grid(ops: object, spec: FrameSpec) -> dict[str, int]:
    """The frame's nodes in OpenSeesPy (the base fixed): their tags by name."""
    n = spec.bays + 1
    tags: dict[str, int] = {}
    for level in range(spec.storeys + 1):
        for i in range(n):
            for j in range(n):
                tag = tags[node_name(i, j, level)] = len(tags) + 1
                ops.node(tag, i * BAY_M, j * BAY_M, level * STOREY_M)
                if level == 0:
                    ops.fix(tag, 1, 1, 1, 1, 1, 1)
    return tags


def opensees_members(ops: object, spec: FrameSpec, values: dict[str, float],
                     tags: dict[str, int]) -> None:
    """Every member as an ``ElasticTimoshenkoBeam`` (shear areas 5/6 A, G from ν)."""
    transforms: dict[tuple[float, ...], int] = {}
    for e, (a, b, param, sec, vecxz) in enumerate(members(spec), start=1):
        key = tuple(vecxz)
        if key not in transforms:
            transforms[key] = len(transforms) + 1
            ops.geomTransf("Linear", transforms[key], *vecxz)
        E = values[param]
        shear_area = 5 / 6 * sec["A"]
        ops.element("ElasticTimoshenkoBeam", e, tags[a], tags[b], E, E / (2 * (1 + NU)),
                    sec["A"], sec["J"], sec["Iy"], sec["Iz"], shear_area, shear_area,
                    transforms[key])


def opensees_transient(ops: object, problem: FramePhi, reads: list[tuple[int, int]],
                       substeps: int = 1) -> np.ndarray:
    """Rayleigh damping, the base motion, Newmark (average acceleration, a linear model
    factored once) on the analysis already set up; the ``reads`` (tag, DOF) displacements at
    every sample."""
    ops.rayleigh(problem.alpha, problem.beta, 0.0, 0.0)
    ag = problem.ag
    ops.timeSeries("Path", 1, "-dt", DT, "-values", *np.append(ag, ag[-1]).tolist())
    ops.pattern("UniformExcitation", 1, 1, "-accel", 1)
    ops.algorithm("Linear", "-factorOnce")
    ops.integrator("Newmark", 0.5, 0.25)
    ops.analysis("Transient")
    disp = np.zeros((ag.size, len(reads)))
    for step in range(1, ag.size):
        if ops.analyze(substeps, DT / substeps) != 0:
            raise RuntimeError(f"OpenSees failed at step {step}")
        for k, (tag, d) in enumerate(reads):
            disp[step, k] = ops.nodeDisp(tag, d)
    return disp


def sensor_reads(tags: dict[str, int], sensor_list: list[tuple[str, str]]
                 ) -> list[tuple[int, int]]:
    return [(tags[node], "ux uy uz".split().index(dof) + 1) for node, dof in sensor_list]


def opensees_run(problem: FramePhi, x: np.ndarray) -> tuple[float, np.ndarray]:
    """OpenSeesPy's transient analysis of the same frame at ``x``: (build + analysis seconds,
    the sensors' displacements relative to the base)."""
    from femupdate.external.openseespy import import_opensees

    ops = import_opensees()
    spec, values = problem.spec, problem.values(x)
    t0 = time.perf_counter()
    ops.wipe()
    ops.model("basic", "-ndm", 3, "-ndf", 6)
    tags = opensees_grid(ops, spec)
    for node, m in floor_masses(spec).items():
        ops.mass(tags[node], m, m, m, ROTARY * m, ROTARY * m, ROTARY * m)
    opensees_members(ops, spec, values, tags)
    ops.constraints("Plain")
    ops.numberer("RCM")
    ops.system("BandSPD")
    disp = opensees_transient(ops, problem, sensor_reads(tags, sensors(spec)))
    elapsed = time.perf_counter() - t0
    ops.wipe()
    return elapsed, disp


def same_model_check(problem: FramePhi, x: np.ndarray) -> float:
    """Relative difference of the two codes' Newmark displacements at the sensors."""
    system = problem.structure.assemble(problem.values(x), direction="x")
    ours = prepare(system, DT, method="newmark", outputs=problem.outputs).run(problem.ag)
    _, theirs = opensees_run(problem, x)
    return float(np.linalg.norm(ours.displacement - theirs) / np.linalg.norm(theirs))


def timed_phi(problem: FramePhi, repeat: int) -> tuple[np.ndarray, dict]:
    """(x, the row): the problem's target made its own prediction at the
    nominal point x (all ones), and φ timed beside it, ±5 % off, ``repeat`` times."""
    x = np.ones(len(problem.spec.names))
    x_eval = x * np.linspace(0.95, 1.05, x.size)
    sim = problem.simulator(x)
    problem.target = problem.prediction(x, sim)
    row: dict = {"dofs": problem.structure.n_dof, "modes": sim.n_modes,
                 "phi_s": median_time(lambda: problem(x_eval), repeat)}
    return x, row


def phi_rows(sizes: list[int], repeat: int) -> list[dict]:
    ag = ground_motion()
    rows = []
    for dofs in sizes:
        bays, storeys = SIZES[dofs]
        spec = FrameSpec(bays, storeys, min(storeys, 7), min(storeys, 3))
        problem = FramePhi(spec, ag)
        x, row = timed_phi(problem, repeat)
        if row["dofs"] <= FULL_MAX:
            system = problem.structure.assemble(problem.values(x), direction="x")
            full = ExactSimulator(system, DT, problem.outputs)
            reference = ss.sosfiltfilt(problem.sos, full.run(ag).acceleration, axis=0)
            row["truncation_phi"] = nmse(problem.target, reference)
        if row["dofs"] <= OPENSEES_MAX:
            row["opensees_s"] = opensees_run(problem, x)[0]
        if dofs == sizes[0]:
            row["newmark_vs_opensees"] = same_model_check(problem, x)
        row["load"] = os.getloadavg()[0]
        rows.append(row)
        print(json.dumps(row), f"({load()})", flush=True)
    return rows


def print_rows(rows: list[dict]) -> None:
    """A line per size: φ, the modes kept (and whether that was all of them), the truncation
    error, OpenSeesPy's time and the ratio."""
    for r in rows:
        storeys = f" ({r['storeys']} storeys)" if "storeys" in r else ""
        line = f"{r['dofs']:>6} DOFs{storeys}: φ {r['phi_s'] * 1e3:.1f} ms, {r['modes']} modes"
        if r.get("all_modes_kept"):
            line += " (all: nothing truncated)"
        elif "truncation_phi" in r:
            line += f", truncation error {r['truncation_phi']:.1e}"
        if "opensees_s" in r:
            line += (f", OpenSeesPy {r['opensees_s'] * 1e3:.0f} ms, ratio "
                     f"{r['opensees_s'] / r['phi_s']:.0f}x")
        print(line)


def growth_exponent(rows: list[dict], min_dofs: int = 96) -> float | None:
    """The slope of log φ against log DOFs over the rows from ``min_dofs`` up."""
    sel = [r for r in rows if r["dofs"] >= min_dofs]
    if len(sel) < 2:
        return None
    return float(np.polyfit(np.log([r["dofs"] for r in sel]), np.log([r["phi_s"] for r in sel]),
                            1)[0])


def multistart(dofs: int, runs: int, max_evals: int, sizes: dict = SIZES,
               spec_type: type = FrameSpec, phi_type: type = FramePhi) -> dict:
    """Noise-free virtual experiment on a frame (``scale.virtual_runs``); ``spec_type`` and
    ``phi_type`` make another kind of frame (benchmarks/building3d_scale.py's)."""
    bays, storeys = sizes[dofs]
    spec = spec_type(bays, storeys, min(storeys, 7), min(storeys, 3))
    problem = phi_type(spec, ground_motion())
    return {"dofs": problem.structure.n_dof,
            **virtual_runs(problem, len(spec.names), runs, max_evals, progress=True)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small frames, for CI")
    parser.add_argument("--skip-optimize", action="store_true", help="φ timings only")
    parser.add_argument("--skip-phi", action="store_true", help="multistart only")
    parser.add_argument("--runs", type=int, default=None, help="multistart-lm runs (10)")
    parser.add_argument("--max-dofs", type=int, default=1050,
                        help="largest frame (10200 possible: thousands of modes below the "
                             "cut-off, a dense eigen-decomposition of minutes)")
    args = parser.parse_args()
    print(f"femupdate benchmarks/frame3d_scale.py: 3-D frames, {ground_motion().size} samples, "
          f"3 sensors, band {BAND_HZ} Hz, modes to {2 * BAND_HZ} Hz; {load()}", flush=True)
    report(args, phi_rows, [24, 96] if args.quick else [n for n in SIZES if n <= args.max_dofs],
           multistart, 96 if args.quick else 1050)


def report(args: argparse.Namespace, rows_of: Callable[..., list[dict]], sizes: list[int],
           optimize: Callable[[int, int, int], dict], dofs: int, min_dofs: int = 96) -> None:
    """The φ rows of ``sizes`` with their growth exponent from ``min_dofs`` up (unless
    ``--skip-phi``), then multistart-lm on the ``dofs`` model (unless ``--skip-optimize``):
    2 runs of 2,000 evaluations with ``--quick``, else 10 of 5,000 (``--runs`` overrides)."""
    if not args.skip_phi:
        rows = rows_of(sizes, repeat=3 if args.quick else 7)
        exponent = growth_exponent(rows, min_dofs=min_dofs)
        if exponent is not None:
            print(f"growth exponent of φ above 100 DOFs: {exponent:.2f}")
        print_rows(rows)
    if args.skip_optimize:
        return
    ms = optimize(dofs, args.runs or (2 if args.quick else 10), 2000 if args.quick else 5000)
    print(json.dumps(ms), f"({load()})", flush=True)


if __name__ == "__main__":
    main()

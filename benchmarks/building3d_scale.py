"""3-D buildings with rigid floor diaphragms on the reduced path: φ from 15 to 10,000 DOFs,
OpenSeesPy beside it, and multistart-lm on a 1,000-DOF building (issue 22).

The frames of ``benchmarks/frame3d_scale.py`` (6 m bays, 3.5 m storeys, concrete Timoshenko
beam-columns, fixed bases) modelled as building engineers model them: every floor rigid in its
plane (``Structure.add_diaphragm``: the floor's nodes follow a master node in ux, uy, rz) and
the floor's mass lumped in its horizontal motion (each node's 36 t on ux and uy only, one
corner twice as heavy so the floors twist; the diaphragm carries it to the master as the
floor's mass and moment of inertia). The vertical translations and the rotations have no mass:
they follow the floors statically (static condensation, exact), so a building of S storeys has
3 S modes whatever its number of DOFs. Rayleigh damping, 2 % at the first mode and at 10 Hz.

Prints, in one run (one BLAS thread; the load average beside every wall time):

1. At each size: φ (sparse assembly at the parameter point, the diaphragms' transformation, the
   modes up to twice the 25 Hz band by condensation onto the floors, the exact discretisation
   with the static correction, the band's filter and the NMSE at 3 sensors on the floors'
   masters, 5,000 samples); the modes kept; the truncation error against the model with all
   its modes (the exact model: its massless DOFs condensed); OpenSeesPy's transient analysis
   of the same building (``rigidDiaphragm`` with the ``Transformation`` handler, the same
   nodal masses, Newmark, the sensors read every step) up to 1,000 DOFs, and the ratio. Then
   the growth exponent of φ above 100 DOFs.
2. The same model in both codes, at the smallest size: natural frequencies (OpenSeesPy's
   ``eigen -fullGenLapack``) and time histories (OpenSeesPy's Newmark with the sample interval
   cut 20 and 40 times, against femupdate's exact discretisation: their difference falls as
   Newmark's error does, ∝ h²).
3. multistart-lm on the 999-DOF building with 10 parameters (the columns' E of 7 storey groups,
   the beams' E of 3), noise-free virtual experiment: runs reaching φ < 1e-6 out of 10.

    python benchmarks/building3d_scale.py [--quick] [--skip-optimize] [--runs 10]

``--quick`` (CI): buildings of 15 and 105 DOFs, OpenSeesPy at 105, 2 runs on the 105-DOF one.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy loads (pitfall: BLAS threads)

import argparse
import json
import time

import numpy as np
import scipy.signal as ss
from frame3d_scale import (
    BAY_M,
    NODE_MASS,
    NU,
    STOREY_M,
    FramePhi,
    FrameSpec,
    floor_masses,
    members,
    node_name,
    opensees_grid,
    opensees_members,
    opensees_transient,
    report,
    sensor_reads,
    timed_phi,
)
from frame3d_scale import multistart as frame_multistart
from scale import BAND_HZ, DT, ground_motion, load

from femupdate.model import Structure
from femupdate.model.sparse import lowest_modes
from femupdate.problem.objective import nmse
from femupdate.simulate.reduced import ReducedSimulator

#: The sizes: model DOFs → (bays, storeys); a building has S (3 (bays + 1)² + 3) DOFs.
SIZES = {15: (1, 1), 105: (1, 7), 999: (5, 9), 9999: (9, 33)}
OPENSEES_MAX = 1000


def master(spec: FrameSpec, level: int) -> str:
    """The floor's master: its middle node."""
    return node_name(spec.bays // 2, spec.bays // 2, level)


class Building(FrameSpec):
    """A frame with rigid floors and masses in the floors' plane."""

    def sensors(self) -> list[tuple[str, str]]:
        top = self.storeys
        return [(master(self, top), "ux"), (master(self, top), "uy"),
                (master(self, max(top // 2, 1)), "ux")]

    def build(self, alpha: float, beta: float) -> Structure:
        s = Structure(dofs_per_node=6)
        n = self.bays + 1
        for level in range(self.storeys + 1):
            for i in range(n):
                for j in range(n):
                    s.add_node(node_name(i, j, level), x=i * BAY_M, y=j * BAY_M,
                               z=level * STOREY_M)
        for a, b, param, sec, vecxz in members(self):
            s.add_beam(a, b, E=param, nu=NU, A=sec["A"], Iy=sec["Iy"], Iz=sec["Iz"],
                       J=sec["J"], vecxz=vecxz)
        for node, m in floor_masses(self).items():
            s.add_mass(node, m=m, dofs=("ux", "uy"))
        for i in range(n):
            for j in range(n):
                s.fix(node_name(i, j, 0))
        for level in range(1, self.storeys + 1):
            s.add_diaphragm(master(self, level), [
                node_name(i, j, level) for i in range(n) for j in range(n)
                if node_name(i, j, level) != master(self, level)])
        s.set_rayleigh(alpha, beta)
        return s


class BuildingPhi(FramePhi):
    """φ of a :class:`Building` (``frame3d_scale.FramePhi`` with its structure and sensors)."""

    def __init__(self, spec: Building, ag: np.ndarray) -> None:
        self.spec = spec
        nominal = {name: 30e9 for name in spec.names}
        undamped = spec.build(0.0, 0.0).assemble(nominal, sparse=True)
        f1 = float(lowest_modes(undamped.K, undamped.M, n_modes=1).freqs_hz[0])
        w1, w2 = 2 * np.pi * f1, 2 * np.pi * 10.0
        self.alpha, self.beta = 0.04 * w1 * w2 / (w1 + w2), 0.04 / (w1 + w2)
        self.structure = spec.build(self.alpha, self.beta)
        self.outputs = [self.structure.dof_index(node, dof) for node, dof in spec.sensors()]
        self.ag = ag
        self.sos = ss.butter(4, BAND_HZ, fs=1 / DT, output="sos")
        system = self.structure.assemble(nominal, sparse=True, direction="x")
        self.start = ReducedSimulator(system, DT, self.outputs, band_hz=BAND_HZ).modes
        self.target = None


def opensees_building(problem: BuildingPhi, x: np.ndarray, substeps: int = 1,
                      modes: int = 0) -> tuple[float, np.ndarray, np.ndarray]:
    """OpenSeesPy's model of the building at ``x``: (build + analysis seconds, the sensors'
    displacements relative to the base at the samples, the lowest ``modes`` frequencies)."""
    from femupdate.external.openseespy import import_opensees

    ops = import_opensees()
    spec, values = problem.spec, problem.values(x)
    n = spec.bays + 1
    t0 = time.perf_counter()
    ops.wipe()
    ops.model("basic", "-ndm", 3, "-ndf", 6)
    tags = opensees_grid(ops, spec)
    for node, m in floor_masses(spec).items():
        ops.mass(tags[node], m, m, 0.0, 0.0, 0.0, 0.0)
    for level in range(1, spec.storeys + 1):
        ops.rigidDiaphragm(3, tags[master(spec, level)], *[
            tags[node_name(i, j, level)] for i in range(n) for j in range(n)
            if node_name(i, j, level) != master(spec, level)])
    opensees_members(ops, spec, values, tags)
    ops.constraints("Transformation")
    ops.numberer("RCM")
    ops.system("ProfileSPD")  # the fastest of UmfPack, BandGeneral, BandSPD, ProfileSPD here
    freqs = np.zeros(0)
    if modes:
        w2 = np.asarray(ops.eigen("-fullGenLapack", modes))
        freqs = np.sqrt(w2) / (2 * np.pi)
    disp = opensees_transient(ops, problem, sensor_reads(tags, spec.sensors()), substeps)
    elapsed = time.perf_counter() - t0
    ops.wipe()
    return elapsed, disp, freqs


def same_model_check(problem: BuildingPhi, x: np.ndarray) -> dict:
    """Frequencies and time histories of the two codes (module docstring, item 2)."""
    system = problem.structure.assemble(problem.values(x), sparse=True, direction="x")
    count = 3 * problem.spec.storeys
    ours = ReducedSimulator(system, DT, problem.outputs, n_modes=count)
    out: dict = {}
    disp = ours.run(problem.ag).displacement
    for substeps in (20, 40):
        _, theirs, freqs = opensees_building(problem, x, substeps, modes=count)
        out[f"newmark_h/{substeps}_vs_exact"] = float(
            np.linalg.norm(disp - theirs) / np.linalg.norm(theirs))
    out["frequencies_rel"] = float(np.max(np.abs(freqs / ours.modes.freqs_hz - 1.0)))
    return out


def phi_rows(sizes: list[int], repeat: int) -> list[dict]:
    ag = ground_motion()
    rows = []
    for dofs in sizes:
        bays, storeys = SIZES[dofs]
        spec = Building(bays, storeys, min(storeys, 7), min(storeys, 3))
        problem = BuildingPhi(spec, ag)
        x, row = timed_phi(problem, repeat)
        row["storeys"] = storeys
        system = problem.structure.assemble(problem.values(x), sparse=True, direction="x")
        every = ReducedSimulator(system, DT, problem.outputs, n_modes=3 * storeys)
        reference = ss.sosfiltfilt(problem.sos, every.run(ag).acceleration, axis=0)
        row["truncation_phi"] = nmse(problem.target, reference)
        row["all_modes_kept"] = row["modes"] == 3 * storeys  # then nothing was truncated
        if row["dofs"] <= OPENSEES_MAX:
            row["opensees_s"] = opensees_building(problem, x)[0]
        if dofs == sizes[0]:
            row.update(same_model_check(problem, x))
        row["load"] = os.getloadavg()[0]
        rows.append(row)
        print(json.dumps(row), f"({load()})", flush=True)
    return rows


def multistart(dofs: int, runs: int, max_evals: int) -> dict:
    return frame_multistart(dofs, runs, max_evals, SIZES, Building, BuildingPhi)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small buildings, for CI")
    parser.add_argument("--skip-optimize", action="store_true", help="φ timings only")
    parser.add_argument("--skip-phi", action="store_true", help="multistart only")
    parser.add_argument("--runs", type=int, default=None, help="multistart-lm runs (10)")
    args = parser.parse_args()
    print(f"femupdate benchmarks/building3d_scale.py: 3-D buildings with rigid floors, "
          f"{ground_motion().size} samples, 3 sensors, band {BAND_HZ} Hz, modes to "
          f"{2 * BAND_HZ} Hz, floor nodes of {NODE_MASS / 1e3:.0f} t; {load()}", flush=True)
    report(args, phi_rows, [15, 105] if args.quick else list(SIZES), multistart,
           105 if args.quick else 999, min_dofs=100)


if __name__ == "__main__":
    main()

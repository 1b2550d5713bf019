"""The 3-D frame and multi-support checks against OpenSeesPy (tests and the benchmark script).

- :func:`example_frame`: a two-storey, one-by-one-bay steel frame (columns with a skew
  ``vecxz``, beams, a lumped mass off the centre, Rayleigh damping), optionally with rigid floor
  diaphragms (a master node per floor with the floor mass);
- :func:`two_span_beam`: a concrete beam on three supports along x, each support with its own
  vertical acceleration record;
- :func:`run_checks`: natural frequencies, uniform base motion in x and y (Newmark, same step in
  both codes) and multi-support time histories (``MultipleSupport``, imposed displacement,
  velocity and acceleration integrated from the acceleration records by the average
  acceleration relations, so that both codes integrate the same equations with the same
  scheme), each as the largest relative difference.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from femupdate.errors import ModelError
from femupdate.model.frame3d import Frame3D
from femupdate.model.structure import Structure
from femupdate.simulate import simulate
from femupdate.simulate.multisupport import integrate_record, multi_support_response

__all__ = ["SUPPORT_GROUPS", "as_structure", "example_frame", "portal_frame", "run_checks",
           "support_records", "two_span_beam"]

_STEEL = dict(E=2.1e11, nu=0.3, A=6e-3, Iy=4e-5, Iz=6e-5, J=2e-5, rho=7850.0, kappa_y=0.8,
              kappa_z=0.7)
_CONCRETE = dict(E=3e10, nu=0.2, A=0.5, Iy=0.02, Iz=0.04, J=0.03, rho=2500.0)
_SPAN_ELEMENTS = 8

#: Which support DOFs of :func:`two_span_beam` follow which record.
SUPPORT_GROUPS = (("P0.uz",), (f"P{_SPAN_ELEMENTS}.uz",), (f"P{2 * _SPAN_ELEMENTS}.uz",))


def example_frame(diaphragm: bool = False, kappa_z: float = 0.7) -> Frame3D:
    """Two storeys of 3 m, one bay of 5 m (x) by 4 m (y), fixed column bases.

    ``kappa_z = 0.8`` (the same shear coefficient on both axes) makes it a frame that
    ``Structure`` takes too (:func:`as_structure`)."""
    f = Frame3D()
    steel = {**_STEEL, "kappa_z": kappa_z}
    for i, x in enumerate((0.0, 5.0)):
        for j, y in enumerate((0.0, 4.0)):
            for k in range(3):
                f.add_node(f"N{i}{j}{k}", x, y, 3.0 * k)
            f.fix(f"N{i}{j}0")
            for k in range(2):
                f.add_beam(f"N{i}{j}{k}", f"N{i}{j}{k + 1}", vecxz=(1.0, 0.3, 0.0), **steel)
    for k in (1, 2):
        for j in range(2):
            f.add_beam(f"N0{j}{k}", f"N1{j}{k}", vecxz=(0.0, 0.0, 1.0), **steel)
        for i in range(2):
            f.add_beam(f"N{i}0{k}", f"N{i}1{k}", vecxz=(0.0, 0.0, 1.0), **steel)
        f.add_mass(f"N11{k}", 500.0, Jz=100.0)
        if diaphragm:
            f.add_node(f"M{k}", 2.5, 2.0, 3.0 * k)
            f.fix(f"M{k}", "uz", "rx", "ry")
            f.add_diaphragm(f"M{k}", [f"N{i}{j}{k}" for i in range(2) for j in range(2)])
            f.add_mass(f"M{k}", 2000.0, Jz=8000.0)
    f.set_rayleigh(0.3, 1e-4)
    return f


def two_span_beam() -> Frame3D:
    """Two 20 m spans along x; pinned-type supports (uy, uz, rx fixed) and a fixed end P0."""
    f = Frame3D()
    n = _SPAN_ELEMENTS
    for i, x in enumerate(np.linspace(0.0, 40.0, 2 * n + 1)):
        f.add_node(f"P{i}", float(x))
    for i in range(2 * n):
        f.add_beam(f"P{i}", f"P{i + 1}", vecxz=(0.0, 0.0, 1.0), **_CONCRETE)
    f.fix("P0")
    for i in (n, 2 * n):
        f.fix(f"P{i}", "uy", "uz", "rx")
    f.set_rayleigh(0.2, 2e-4)
    return f


def as_structure(frame: Frame3D) -> Structure:
    """The same frame (its diaphragms included) as a ``Structure(dofs_per_node=6)``."""
    s = Structure(dofs_per_node=6)
    for name, xyz in zip(frame.nodes, frame._xyz, strict=True):
        s.add_node(name, *xyz)
    for name, n1, n2, p in frame._beams:
        if p["kappa_y"] != p["kappa_z"] or p["Ip"] is not None:
            raise ModelError(f"beam {name!r}: Structure takes one kappa and Ip = J")
        shear = {"G": p["G"]} if p["G"] is not None else {"nu": p["nu"]}
        s.add_beam(frame.nodes[n1], frame.nodes[n2], E=p["E"], A=p["A"], Iy=p["Iy"],
                   Iz=p["Iz"], J=p["J"], vecxz=tuple(p["vecxz"]), rho=p["rho"],
                   kappa=p["kappa_y"], mass_per_length=p["mass_per_length"], name=name,
                   **shear)
    for k, (n, vals) in enumerate(frame._masses):
        if vals[3] == vals[4] == vals[5]:
            s.add_mass(frame.nodes[n], vals[0], vals[3], name=f"m{k}")
        elif vals[3] == vals[4] == 0.0:  # a floor's inertia about the vertical only
            s.add_mass(frame.nodes[n], vals[0], vals[5], name=f"m{k}",
                       dofs=("ux", "uy", "uz", "rz"))
        else:
            raise ModelError("Structure takes one rotary inertia J per mass, or Jz alone")
    for g in sorted(frame._fixed):
        s.fix(frame.nodes[g // 6], ("ux", "uy", "uz", "rx", "ry", "rz")[g % 6])
    masters: dict[int, list[str]] = {}
    for follower, master in frame._slaves.items():
        masters.setdefault(master, []).append(frame.nodes[follower])
    for master, followers in masters.items():
        s.add_diaphragm(frame.nodes[master], followers)
    alpha, beta = frame._rayleigh
    s.set_rayleigh(alpha, beta)
    return s


def portal_frame(e: float | str = 2.1e11) -> Frame3D:
    """Three columns and two girders (one shear modulus given, one from nu), a mass."""
    f = Frame3D()
    for i, (x, y) in enumerate([(0.0, 0.0), (4.0, 0.0), (4.0, 3.0)]):
        f.add_node(f"B{i}", x, y, 0.0)
        f.add_node(f"T{i}", x, y, 3.5)
        f.fix(f"B{i}")
        f.add_beam(f"B{i}", f"T{i}", vecxz=(1.0, 0.4, 0.0), E=e, nu=0.3, A=5e-3, Iy=3e-5,
                   Iz=7e-5, J=2e-5, rho=7850.0, kappa_y=0.7, kappa_z=0.7)
    for a, b in (("T0", "T1"), ("T1", "T2")):
        f.add_beam(a, b, vecxz=(0.0, 0.0, 1.0), E=e, G=8e10, A=4e-3, Iy=2e-5, Iz=5e-5,
                   J=1e-5, rho=7850.0, kappa_y=0.8, kappa_z=0.8)
    f.add_mass("T1", 900.0, Jx=50.0, Jy=50.0, Jz=50.0)
    f.set_rayleigh(0.2, 1e-4)
    return f


def support_records(n_samples: int, dt: float) -> np.ndarray:
    """Three smooth acceleration records (m/s²), starting at rest, the second delayed 0.2 s."""
    t = np.arange(n_samples) * dt
    ramp = np.minimum(t, 1.0)
    late = np.clip(t - 0.2, 0.0, 1.0)
    return np.column_stack([1.5 * np.sin(2 * np.pi * 1.3 * t) * ramp,
                            1.5 * np.sin(2 * np.pi * 1.3 * (t - 0.2)) * late,
                            0.8 * np.sin(2 * np.pi * 2.1 * t) * ramp])


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


def run_checks(quick: bool = False) -> dict[str, float]:
    """Largest relative differences femupdate vs OpenSeesPy, by check name."""
    from femupdate.paper.bench.opensees3d import OpenSees3DPeer

    n_samples = 100 if quick else 400
    dt = 0.005
    t = np.arange(n_samples) * dt
    ag = 2.0 * np.sin(2 * np.pi * 1.7 * t) * np.minimum(t, 1.0)
    out: dict[str, float] = {}
    for diaphragm in (False, True):
        tag = "diaphragm" if diaphragm else "frame"
        frame = example_frame(diaphragm)
        model = frame.assemble()
        s = model.system
        n_modes = 6 if quick else 12
        ours = np.sqrt(scipy.linalg.eigh(s.K, s.M, eigvals_only=True)[:n_modes]) / (2 * np.pi)
        peer = OpenSees3DPeer(frame, model)
        out[f"{tag} frequencies ({n_modes} modes)"] = _rel(ours, peer.frequencies(n_modes))
        for direction in ("x", "y"):
            y = simulate(model.uniform_system(direction), dt, ag=ag, method="newmark")
            out[f"{tag} uniform {direction} time history"] = _rel(
                y.displacement, peer.run_uniform(ag, dt, direction))
    portal = portal_frame()
    structure = as_structure(portal).assemble(direction="y")
    ours = np.sqrt(scipy.linalg.eigh(structure.K, structure.M, eigvals_only=True)[:6]) / (
        2 * np.pi)
    peer = OpenSees3DPeer(portal, portal.assemble())
    out["Structure(dofs_per_node=6) portal frequencies (6 modes)"] = _rel(
        ours, peer.frequencies(6))
    y = simulate(structure, dt, ag=ag, method="newmark")
    out["Structure(dofs_per_node=6) portal uniform y"] = _rel(
        y.displacement, peer.run_uniform(ag, dt, "y"))
    beam = two_span_beam()
    model = beam.assemble()
    dt = 0.01
    acc = support_records(100 if quick else 300, dt)
    vel, disp = integrate_record(acc, dt, "newmark")
    ours_ms = multi_support_response(model, SUPPORT_GROUPS, acc, dt, method="newmark",
                                     velocity=vel, displacement=disp)
    theirs = OpenSees3DPeer(beam, model).run_multi_support(SUPPORT_GROUPS, acc, vel, disp, dt)
    out["two-span multi-support total displacement"] = _rel(ours_ms.total, theirs)
    return out

"""OpenSeesPy as a peer for 3-D frames (:class:`~femupdate.model.frame3d.Frame3D`).

The frame is rebuilt in OpenSees term by term: ``ElasticTimoshenkoBeam`` (3-D) with ``-cMass``
and ``-mass ρA + μ_extra``, a ``geomTransf Linear`` per beam with its ``vecxz``, nodal masses,
``zeroLength`` springs to fixed ground nodes, ``fix`` for supports and ``rigidDiaphragm 3`` for
floors (``Transformation`` constraint handler). OpenSees's beam takes the torsional inertia from
``J`` (``ρ J``): the peer refuses beams with another ``Ip``.

Time histories use Newmark's average acceleration in both codes at the same step:

- :meth:`OpenSees3DPeer.run_uniform`: a uniform base acceleration applied as the nodal load
  ``-p a_g(t)`` (``UniformExcitation`` counts the beams' mass twice; see
  :mod:`femupdate.paper.bench.opensees`); displacements relative to the base;
- :meth:`OpenSees3DPeer.run_multi_support`: ``MultipleSupport`` with ``imposedMotion`` of
  ``Plain`` ground motions given displacement, velocity and acceleration series; total
  displacements.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from femupdate.errors import ModelError, SimulationError
from femupdate.external.openseespy import import_opensees
from femupdate.model.frame3d import DOF_NAMES_3D, Frame3D, Frame3DModel, _beam_numbers

__all__ = ["OpenSees3DPeer"]


class OpenSees3DPeer:
    """A :class:`Frame3D` built in OpenSees (one domain per process: building wipes it)."""

    def __init__(self, frame: Frame3D, model: Frame3DModel,
                 values: Mapping[str, float] | None = None) -> None:
        self.ops = import_opensees()
        self.frame = frame
        self.model = model
        self.values = {} if values is None else dict(values)
        self.build()

    def build(self) -> None:
        ops, f = self.ops, self.frame
        ops.wipe()
        ops.model("basic", "-ndm", 3, "-ndf", 6)
        for i, xyz in enumerate(f._xyz):
            ops.node(i + 1, *xyz)
        mass = np.zeros((len(f._xyz), 6))
        for n, vals in f._masses:
            mass[n] += [self._number(v) for v in vals]
        for i, row in enumerate(mass):
            if row.any():
                ops.mass(i + 1, *row.tolist())
        for e, (name, n1, n2, raw) in enumerate(f._beams):
            p: dict = _beam_numbers(raw, self.values, name)
            if p["Ip"] is not None and p["Ip"] != p["J"]:
                raise ModelError(f"OpenSees peer: beam {name!r} has Ip != J; OpenSees uses J")
            ops.geomTransf("Linear", e + 1, *np.asarray(p["vecxz"]).tolist())
            args = [p["E"], p["G"], p["A"], p["J"], p["Iy"], p["Iz"], p["kappa_y"] * p["A"],
                    p["kappa_z"] * p["A"], e + 1]
            mu = p["rho"] * p["A"] + p["mass_per_length"]
            if not p["rotary_inertia"]:
                raise ModelError(f"OpenSees peer: beam {name!r} without rotary inertia")
            ops.element("ElasticTimoshenkoBeam", e + 1, n1 + 1, n2 + 1, *args, "-mass", mu,
                        "-cMass")
        fixed: dict[int, list[int]] = {}
        for g in f._fixed:
            fixed.setdefault(g // 6, [0] * 6)[g % 6] = 1
        for n, flags in fixed.items():
            ops.fix(n + 1, *flags)
        n_nodes = len(f._xyz)
        ops.uniaxialMaterial("Elastic", 1, 1.0)
        for s, (g, k) in enumerate(f._springs):
            ground = n_nodes + s + 1
            ops.node(ground, *f._xyz[g // 6])
            ops.fix(ground, 1, 1, 1, 1, 1, 1)
            ops.uniaxialMaterial("Elastic", s + 2, self._number(k))
            ops.element("zeroLength", 10_000 + s, ground, g // 6 + 1, "-mat", s + 2,
                        "-dir", g % 6 + 1)
        masters: dict[int, list[int]] = {}
        for s, m in f._slaves.items():
            masters.setdefault(m, []).append(s)
        for m, slaves in masters.items():
            ops.rigidDiaphragm(3, m + 1, *[s + 1 for s in slaves])
        alpha, beta = f._rayleigh
        if alpha or beta:
            ops.rayleigh(alpha, 0.0, 0.0, beta)  # β on the initial (= current) stiffness
        self._dofs = [(f.nodes.index(lab.split(".")[0]) + 1, DOF_NAMES_3D.index(
            lab.split(".")[1]) + 1) for lab in self.model.system.dof_labels]

    def _number(self, v: float | str) -> float:
        return float(self.values[v]) if isinstance(v, str) else float(v)

    def _analysis(self) -> None:
        ops = self.ops
        ops.wipeAnalysis()
        ops.constraints("Transformation")
        ops.numberer("Plain")
        ops.system("FullGeneral")
        ops.algorithm("Linear", "-factorOnce")
        ops.integrator("Newmark", 0.5, 0.25)
        ops.analysis("Transient")

    def frequencies(self, n_modes: int) -> np.ndarray:
        """Lowest natural frequencies (Hz) from ``eigen -fullGenLapack``."""
        self.ops.wipeAnalysis()
        self.ops.constraints("Transformation")
        w2 = np.asarray(self.ops.eigen("-fullGenLapack", n_modes), dtype=float)
        return np.sqrt(w2) / (2 * np.pi)

    def _march(self, n_samples: int, h: float) -> np.ndarray:
        ops = self.ops
        out = np.zeros((n_samples, len(self._dofs)))
        for k in range(1, n_samples):
            if ops.analyze(1, h) != 0:
                raise SimulationError(f"OpenSees failed at sample {k}")
            out[k] = [ops.nodeDisp(t, d) for t, d in self._dofs]
        return out

    def run_uniform(self, ag: np.ndarray, dt: float, direction: str = "x") -> np.ndarray:
        """Relative displacements of the free DOFs under a uniform base acceleration (nodal load).
        """
        ops = self.ops
        self.build()
        p = self.model.uniform_system(direction).seismic_load
        ops.timeSeries("Path", 1, "-dt", float(dt), "-values", *np.append(ag, ag[-1]).tolist())
        ops.pattern("Plain", 1, 1, "-fact", -1.0)
        loads: dict[int, list[float]] = {}
        for (tag, d), val in zip(self._dofs, p, strict=True):
            loads.setdefault(tag, [0.0] * 6)[d - 1] += float(val)
        for tag, load in loads.items():
            ops.load(tag, *load)
        self._analysis()
        return self._march(len(ag), dt)

    def run_multi_support(self, groups: Sequence[Sequence[str]], acc: np.ndarray,
                          vel: np.ndarray, disp: np.ndarray, dt: float) -> np.ndarray:
        """Total displacements of the free DOFs with the support motions imposed."""
        ops = self.ops
        self.build()
        ops.pattern("MultipleSupport", 1)
        for g, dofs in enumerate(groups):
            tags = (3 * g + 1, 3 * g + 2, 3 * g + 3)
            for tag, series in zip(tags, (disp[:, g], vel[:, g], acc[:, g]), strict=True):
                ops.timeSeries("Path", tag, "-dt", float(dt), "-values",
                               *np.append(series, series[-1]).tolist())
            ops.groundMotion(g + 1, "Plain", "-disp", tags[0], "-vel", tags[1], "-accel",
                             tags[2])
            for lab in dofs:
                node, dof = lab.split(".")
                ops.imposedMotion(self.frame.nodes.index(node) + 1, DOF_NAMES_3D.index(dof) + 1,
                                  g + 1)
        self._analysis()
        return self._march(acc.shape[0], dt)

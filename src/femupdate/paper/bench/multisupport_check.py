"""Multi-support excitation of a case file's model against OpenSeesPy's ``MultipleSupport``.

- :func:`two_span_case`: a two-span continuous beam on three supports (``[model]``,
  2 DOFs per node), each support a ``[[model.support_groups]]`` of its own, consistent beam
  mass, lumped masses at mid-span and Rayleigh damping (so that the support motion reaches the
  free DOFs through stiffness, mass and damping);
- :func:`opensees_two_span`: the same beam built term by term in OpenSees (``elasticBeamColumn``
  with ``-cMass``, the axial DOFs fixed, nodal masses, ``rayleigh``) under a ``MultipleSupport``
  pattern: a ``Plain`` ``groundMotion`` per group given displacement, velocity and
  acceleration series, and ``imposedMotion`` at its support;
- :func:`run_check`: both under the same three records, Newmark's average acceleration in both
  codes at the same step, the support displacements and velocities integrated from the records
  by the average-acceleration relations (so that both codes integrate the same equations with
  the same scheme); the largest relative differences of the total displacements and absolute
  accelerations at the outputs.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from typing import Any

import numpy as np

from femupdate.case import Case, parse_case
from femupdate.errors import SimulationError
from femupdate.external.openseespy import import_opensees
from femupdate.paper.bench.frame3d_check import support_records
from femupdate.problem.case_model import CaseModel
from femupdate.simulate.multisupport import integrate_record

__all__ = ["TRUTH", "opensees_two_span", "run_check", "two_span_case"]

#: Parameter values of :func:`two_span_case` (a steel strip beam: modes at 4–94 Hz).
TRUTH = {"E": 2.1e11, "beta": 4e-4}
_NODES = (("A", 0.0), ("AB", 1.0), ("B", 2.0), ("BC", 3.0), ("C", 4.0))
_SECTION = {"A": 1e-4, "I": 1e-9, "rho": 7850.0}
_MASSES = (("AB", 1.0), ("BC", 1.5))
_ALPHA = 0.05
_GROUPS = (("west", "A"), ("pier", "B"), ("east", "C"))


def two_span_case(method: str = "newmark") -> Case:
    """The two-span beam as a case (parameters ``E`` and ``beta``), outputs ``AB.uy`` and
    ``BC.uy`` (absolute), simulated by ``method``."""
    data: dict[str, Any] = {
        "case": {"name": "two-span multi-support check"},
        "model": {
            "dofs_per_node": 2,
            "nodes": [{"name": n, "x": x} for n, x in _NODES],
            "beams": [{"nodes": [a[0], b[0]], "E": "E", "rotary_inertia": False, **_SECTION}
                      for a, b in itertools.pairwise(_NODES)],
            "masses": [{"node": n, "m": m} for n, m in _MASSES],
            "supports": [{"node": node, "dofs": ["uy"]} for _, node in _GROUPS],
            "support_groups": [{"name": g, "nodes": [node]} for g, node in _GROUPS],
            "rayleigh": {"alpha": _ALPHA, "beta": "beta"},
        },
        "parameters": [{"name": "E", "lower": 1e11, "upper": 4e11},
                       {"name": "beta", "lower": 1e-5, "upper": 1e-2}],
        "data": {
            "format": "csv", "rate": 100.0,
            "inputs": {g: {"file": "supports.csv", "column": g} for g, _ in _GROUPS},
            "outputs": [{"file": "deck.csv", "column": n, "node": n, "dof": "uy"}
                        for n, _ in _MASSES],
        },
        "simulation": {"method": method},
    }
    return parse_case(data)


def opensees_two_span(values: Mapping[str, float], acc: np.ndarray, vel: np.ndarray,
                      disp: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Total displacements and absolute accelerations (uy) at ``AB`` and ``BC`` in OpenSees.

    ``acc``, ``vel``, ``disp``: (n_samples, 3) motions of the supports A, B, C.
    """
    ops = import_opensees()
    ops.wipe()
    ops.model("basic", "-ndm", 2, "-ndf", 3)
    tags = {name: i + 1 for i, (name, _) in enumerate(_NODES)}
    supports = {node for _, node in _GROUPS}
    for name, x in _NODES:
        ops.node(tags[name], x, 0.0)
        ops.fix(tags[name], 1, int(name in supports), 0)  # the axial DOF is not modelled
    for name, m in _MASSES:
        ops.mass(tags[name], 0.0, m, 0.0)
    ops.geomTransf("Linear", 1)
    mu = _SECTION["rho"] * _SECTION["A"]
    for e, (a, b) in enumerate(itertools.pairwise(_NODES)):
        ops.element("elasticBeamColumn", e + 1, tags[a[0]], tags[b[0]], _SECTION["A"],
                    float(values["E"]), _SECTION["I"], 1, "-mass", mu, "-cMass")
    ops.rayleigh(_ALPHA, 0.0, 0.0, float(values["beta"]))  # β on the committed (= initial) K
    ops.pattern("MultipleSupport", 1)
    for g, (_, node) in enumerate(_GROUPS):
        series = (3 * g + 1, 3 * g + 2, 3 * g + 3)
        for tag, history in zip(series, (disp[:, g], vel[:, g], acc[:, g]), strict=True):
            ops.timeSeries("Path", tag, "-dt", float(dt), "-values",
                           *np.append(history, history[-1]).tolist())
        ops.groundMotion(g + 1, "Plain", "-disp", series[0], "-vel", series[1], "-accel",
                         series[2])
        ops.imposedMotion(tags[node], 2, g + 1)
    ops.constraints("Transformation")
    ops.numberer("Plain")
    ops.system("FullGeneral")
    ops.algorithm("Linear")
    ops.integrator("Newmark", 0.5, 0.25)
    ops.analysis("Transient")
    n = acc.shape[0]
    u = np.zeros((n, len(_MASSES)))
    a = np.zeros((n, len(_MASSES)))
    a[0] = [ops.nodeAccel(tags[name], 2) for name, _ in _MASSES]
    for k in range(1, n):
        if ops.analyze(1, float(dt)) != 0:
            raise SimulationError(f"OpenSees failed at sample {k}")
        u[k] = [ops.nodeDisp(tags[name], 2) for name, _ in _MASSES]
        a[k] = [ops.nodeAccel(tags[name], 2) for name, _ in _MASSES]
    ops.wipe()
    return u, a


def run_check(n_samples: int = 400, dt: float = 0.01) -> dict[str, float]:
    """Largest relative differences femupdate (the case's model) vs OpenSeesPy."""
    case = two_span_case("newmark")
    acc = support_records(n_samples, dt)
    vel, disp = integrate_record(acc, dt, "newmark")
    ours = CaseModel(case).simulate(TRUTH, acc, dt)
    u, a = opensees_two_span(TRUTH, acc, vel, disp, dt)
    return {
        "two-span case, total displacement": _rel(ours.displacement, u),
        "two-span case, absolute acceleration": _rel(ours.acceleration, a),
    }


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())

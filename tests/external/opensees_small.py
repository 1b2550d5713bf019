"""A small OpenSeesPy model for the adapter's tests: a two-span beam on springs.

Nodes 1–3 along x (1.5 m spans), DOFs (ux fixed, uy, rz); ElasticTimoshenkoBeam deck; springs
``k`` at the ends and 2e5 N/m in the middle, a damper ``c`` in the middle, a rotational damper
at node 1; 10 kg and 0.05 kg·m² per node. ``build`` puts the beams' consistent mass in the
elements (needs the nodal base load); ``build_massless_beams`` leaves it out (UniformExcitation
is then right).
"""

from __future__ import annotations

from collections.abc import Mapping

import openseespy.opensees as ops

SPAN = 1.5
AREA, INERTIA, DENSITY, POISSON, KAPPA = 4e-4, 2e-8, 7850.0, 0.3, 0.5
NODE_MASS = 10.0
NODE_J = 0.05  # kg·m²: the rotations keep inertia without beam mass
MID_SPRING = 2e5
END_DAMPER = 1.0


def build(params: Mapping[str, float], *, beam_mass: bool = True) -> None:
    ops.model("basic", "-ndm", 2, "-ndf", 3)
    for n in (1, 2, 3):
        ops.node(n, (n - 1) * SPAN, 0.0)
        ops.fix(n, 1, 0, 0)
        ops.node(10 + n, (n - 1) * SPAN, 0.0)
        ops.fix(10 + n, 1, 1, 1)
        ops.mass(n, NODE_MASS, NODE_MASS, NODE_J)
    ops.geomTransf("Linear", 1)
    mass = ["-mass", DENSITY * AREA, "-cMass"] if beam_mass else []
    E = params["E"]
    for e in (1, 2):
        ops.element("ElasticTimoshenkoBeam", e, e, e + 1, E, E / (2 * (1 + POISSON)), AREA,
                    INERTIA, KAPPA * AREA, 1, *mass)
    links = [(1, 2, params["k"], 0.0), (2, 2, MID_SPRING, params["c"]), (3, 2, params["k"], 0.0),
             (1, 3, 0.0, END_DAMPER)]
    for i, (node, dof, k, c) in enumerate(links):
        ops.uniaxialMaterial("Elastic", 100 + i, k, c)
        ops.element("zeroLength", 100 + i, 10 + node, node, "-mat", 100 + i, "-dir", dof)


def build_massless_beams(params: Mapping[str, float]) -> None:
    build(params, beam_mass=False)


def build_that_fails(params: Mapping[str, float]) -> None:
    raise ValueError(f"no section for E = {params['E']:g}")

"""A three-storey shear frame as an OpenSeesPy model: the surrogate-aided posterior's example.

Nodes 0 (the ground) to 3 on one line, one DOF each (the horizontal displacement); storey i a
``zeroLength`` element between nodes i − 1 and i with an elastic spring ``k{i}`` (N/m, the
updated parameters) in parallel with a viscous damper of 300 N·s/m; floor masses of
100, 100 and 80 kg on the nodes (UniformExcitation is then right: no element carries mass).
"""

from __future__ import annotations

from collections.abc import Mapping

import openseespy.opensees as ops

MASSES = (100.0, 100.0, 80.0)  # kg
DAMPER = 300.0  # N·s/m, every storey


def build(params: Mapping[str, float]) -> None:
    ops.model("basic", "-ndm", 1, "-ndf", 1)
    ops.node(0, 0.0)
    ops.fix(0, 1)
    for i, mass in enumerate(MASSES, start=1):
        ops.node(i, 0.0)
        ops.mass(i, mass)
        ops.uniaxialMaterial("Elastic", i, params[f"k{i}"], DAMPER)
        ops.element("zeroLength", i, i - 1, i, "-mat", i, "-dir", 1)

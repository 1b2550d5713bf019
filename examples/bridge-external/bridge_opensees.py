"""The paper's bridge as an OpenSeesPy model: what a user would write, built from ``params``.

Nodes 1–5 (A1, P1, P2, P3, A2) along x at 2.8 m, in a 2-D model with DOFs (ux, uy, rz); the
deck's axial DOF is fixed (the base moves along y, transversely, and the beams are straight).
The deck: ``ElasticTimoshenkoBeam`` with consistent mass (``-cMass``); springs and dampers are
``zeroLength`` elements to fixed ground nodes 11–15; 48 kg on each node.

UniformExcitation counts this beam's mass twice in its load (docs/external-models.md): run this
model with ``excitation = "nodal"`` (femupdate applies −M r a_g as nodal loads), or femupdate's
base-load check stops the run. Two variants a user might try instead: ``build_lumped``, the
beams' own lumped mass (``-mass`` without ``-cMass``: still counted twice), and
``build_nodal_mass``, the beams' mass put on the nodes with ``ops.mass`` (loaded right by
UniformExcitation, but without rotary inertia: the modes change, see README.md).
"""

from __future__ import annotations

from collections.abc import Mapping

import openseespy.opensees as ops

SPAN = 2.8
WIDTH, WALL = 0.08, 0.005
AREA = WIDTH**2 - (WIDTH - 2 * WALL) ** 2
INERTIA = (WIDTH**4 - (WIDTH - 2 * WALL) ** 4) / 12.0
DENSITY, POISSON, KAPPA = 7850.0, 0.3, 0.44
NODE_MASS = 48.0
GROUND = 10  # ground node of deck node n: n + GROUND


def build(params: Mapping[str, float], *, mass: str = "consistent") -> None:
    """Build the bridge in the (wiped) OpenSees domain.

    ``mass``: the beams' mass ``"consistent"`` (``-cMass``), ``"lumped"`` by the element, or
    on the ``"nodes"`` (half a span's on each end, translations only).
    """
    E = params["E"]
    ops.model("basic", "-ndm", 2, "-ndf", 3)
    for n in range(1, 6):
        ops.node(n, (n - 1) * SPAN, 0.0)
        ops.fix(n, 1, 0, 0)
        ops.node(n + GROUND, (n - 1) * SPAN, 0.0)
        ops.fix(n + GROUND, 1, 1, 1)
        spans = (n > 1) + (n < 5)
        m = NODE_MASS + (spans * DENSITY * AREA * SPAN / 2 if mass == "nodes" else 0.0)
        ops.mass(n, m, m, 0.0)
    ops.geomTransf("Linear", 1)
    beam_mass = {"consistent": ["-mass", DENSITY * AREA, "-cMass"],
                 "lumped": ["-mass", DENSITY * AREA], "nodes": []}[mass]
    for e in range(1, 5):
        ops.element("ElasticTimoshenkoBeam", e, e, e + 1, E, E / (2 * (1 + POISSON)), AREA,
                    INERTIA, KAPPA * AREA, 1, *beam_mass)
    links = [(1, 2, params["kp1"], 0.0), (2, 2, params["kp2"], 0.0), (3, 2, params["kp3"], 0.0),
             (4, 2, params["kp4"], 0.0), (5, 2, params["kp1"], 0.0),
             (1, 3, 0.0, params["c1"]), (5, 3, 0.0, params["c1"]), (2, 2, 0.0, params["c2"]),
             (3, 2, 0.0, params["c3"]), (4, 2, 0.0, params["c4"])]
    for i, (node, dof, k, c) in enumerate(links):
        tag = 100 + i
        ops.uniaxialMaterial("Elastic", tag, k, c)  # E = k, damping tangent eta = c
        ops.element("zeroLength", tag, node + GROUND, node, "-mat", tag, "-dir", dof)


def build_lumped(params: Mapping[str, float]) -> None:
    """The bridge with the beams' lumped mass (``-mass`` without ``-cMass``)."""
    build(params, mass="lumped")


def build_nodal_mass(params: Mapping[str, float]) -> None:
    """The bridge with the beams' mass on the nodes (``ops.mass``), none in the elements."""
    build(params, mass="nodes")

"""The numbering and scatter plan of a ``Structure``, made once per topology.

``Structure._build`` runs the steps here in order: the free DOFs and their labels
(:func:`number_dofs`), the beams' global DOFs, lengths, rotations and support coupling
(:func:`beam_plan`), the links' DOF pairs (:func:`link_dofs`, :func:`odd_link_dofs` for the
nonlinear ones), the lumped masses' diagonal targets (:func:`lumped_mass_plan`) and whether
the mass matrix depends on a parameter (:func:`mass_is_constant`). The result,
:class:`Topology`, is what assembly reads: it then only evaluates the element formulas at the
parameter values and scatters them by this plan (:mod:`femupdate.model.matrices`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from femupdate.errors import ModelError
from femupdate.model.diaphragm import Diaphragms
from femupdate.model.elements import frame_rotation
from femupdate.model.elements3d import frame3d_rotation
from femupdate.model.properties import MASS_PROPS, Prop, Record
from femupdate.model.sparse import SparsePattern

__all__ = ["BeamPlan", "DofNumbering", "Topology", "beam_plan", "link_dofs", "lumped_mass_plan",
           "mass_is_constant", "number_dofs", "odd_link_dofs", "records_by_kind", "scatter_plan"]


@dataclass(frozen=True)
class Topology:
    """What assembly needs of a structure, fixed until its description changes."""

    n: int
    labels: tuple[str, ...]
    free: np.ndarray  # free index per global DOF, -1 where fixed
    dof_names: np.ndarray  # DOF name per global DOF (str array)
    # beams
    beam_props: dict[str, Prop]
    beam_L: np.ndarray
    beam_shear: np.ndarray  # 0 rigid in shear, 1 G given, 2 nu given
    beam_rotary: np.ndarray  # 1.0 with rotary inertia, else 0.0
    beam_T: np.ndarray | None  # (n_b, d, d) global→local, None when identity
    beam_target: np.ndarray
    beam_keep: np.ndarray
    beam_coupling: tuple[np.ndarray, np.ndarray, np.ndarray]  # row, keep, global column
    # links
    spring_k: Prop
    spring_target: np.ndarray
    spring_keep: np.ndarray
    damper_c: Prop
    damper_target: np.ndarray
    damper_keep: np.ndarray
    friction_i: np.ndarray
    friction_j: np.ndarray
    friction_kr: Prop
    friction_fu: Prop
    # lumped masses: flat diagonal targets and the owning element of each
    mass_m: Prop
    mass_J: Prop
    mass_m_target: np.ndarray
    mass_m_owner: np.ndarray
    mass_J_target: np.ndarray
    mass_J_owner: np.ndarray
    rayleigh: tuple[Prop, Prop] | None
    mass_const: bool  # no parameter changes M: it is assembled and checked once
    cache: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    # the CSR structure of the sparse K and C (their targets never change)
    patterns: dict[str, SparsePattern] = field(default_factory=dict)
    # Bouc–Wen elements: end DOFs and their six properties (BOUC_WEN_PARAMETERS)
    bouc_wen_i: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    bouc_wen_j: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    bouc_wen_props: tuple[Prop, ...] = ()
    # rigid floor diaphragms (3-D frames): the elimination of the follower DOFs, or None
    diaphragms: Diaphragms | None = None


class DofNumbering(NamedTuple):
    """The free DOFs of a structure: ``free`` numbers them (-1 where fixed)."""

    fixed: np.ndarray  # bool per global DOF
    free: np.ndarray  # free index per global DOF, -1 where fixed
    n: int
    dof_names: tuple[str, ...]  # DOF name per global DOF
    labels: tuple[str, ...]  # "node.dof" per free DOF


class BeamPlan(NamedTuple):
    """The beams' geometry and where their element matrices go."""

    length: np.ndarray
    T: np.ndarray | None  # (n_b, d, d) global→local, None when identity
    target: np.ndarray
    keep: np.ndarray
    coupling: tuple[np.ndarray, np.ndarray, np.ndarray]  # row, keep, global column


def scatter_plan(dof_map: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Flat targets in an ``n × n`` matrix and the kept entries of an element stack.

    ``dof_map`` (n_e, d) holds free-DOF indices, -1 for fixed DOFs and ground, whose rows and
    columns are dropped.
    """
    rows = dof_map[:, :, None]
    cols = dof_map[:, None, :]
    keep = ((rows >= 0) & (cols >= 0)).ravel()
    target = (rows * n + cols).ravel()[keep]
    return target, np.flatnonzero(keep)


def number_dofs(n_nodes: int, dpn: int, fixed_dofs: set[int], node_names: Sequence[str],
                node_dof_names: Sequence[str]) -> DofNumbering:
    """Number the free DOFs in node order (``ModelError`` without nodes or free DOFs)."""
    if n_nodes == 0:
        raise ModelError("the structure has no nodes; add_node first")
    n_global = n_nodes * dpn
    fixed = np.zeros(n_global, dtype=bool)
    fixed[list(fixed_dofs)] = True
    free = np.full(n_global, -1, dtype=np.int64)
    free[~fixed] = np.arange(int((~fixed).sum()))
    n = int((~fixed).sum())
    if n == 0:
        raise ModelError("every DOF is fixed; the structure has no free DOF")
    dof_names = tuple(d for _ in range(n_nodes) for d in node_dof_names)
    labels = tuple(
        f"{node_names[g // dpn]}.{dof_names[g]}" for g in range(n_global) if not fixed[g]
    )
    return DofNumbering(fixed, free, n, dof_names, labels)


def records_by_kind(records: Sequence[Record]) -> dict[str, list[Record]]:
    """The records grouped by kind, each group in the order described."""
    by_kind: dict[str, list[Record]] = {}
    for rec in records:
        by_kind.setdefault(rec.kind, []).append(rec)
    return by_kind


def beam_plan(beams: Sequence[Record], points: Sequence[tuple[float, float, float]], dpn: int,
              numbering: DofNumbering) -> BeamPlan:
    """Lengths, global→local rotations, scatter targets and support coupling of the beams.

    The coupling lists the entries of the beam stack in a free row and a fixed column: the
    inertia a consistent beam mass carries from a moving support into the free DOFs.
    """
    free, fixed, n = numbering.free, numbering.fixed, numbering.n
    d = 2 * dpn
    beam_t: np.ndarray | None
    gdofs = np.array(
        [[nd * dpn + j for nd in rec.nodes for j in range(dpn)] for rec in beams],
        dtype=np.int64,
    ).reshape(len(beams), d)
    xy = np.array(points, dtype=float).reshape(-1, 3)
    delta = xy[[rec.nodes[1] for rec in beams]] - xy[[rec.nodes[0] for rec in beams]]
    delta = delta.reshape(len(beams), 3)
    length = np.sqrt((delta * delta).sum(axis=1))
    cos, sin = delta[:, 0] / length, delta[:, 1] / length
    if dpn == 6:
        beam_t = np.array([frame3d_rotation(points[rec.nodes[0]], points[rec.nodes[1]],
                                            rec.options["vecxz"])  # type: ignore[arg-type]
                           for rec in beams]).reshape(len(beams), 12, 12)
    elif dpn == 3:
        beam_t = frame_rotation(cos, sin)
    elif np.all(cos > 0):
        beam_t = None
    else:  # a beam from right to left: its local v is -uy
        beam_t = np.zeros((len(beams), 4, 4))
        beam_t[:, [0, 2], [0, 2]] = np.sign(cos)[:, None]
        beam_t[:, [1, 3], [1, 3]] = 1.0
    fmap = free[gdofs]
    target, keep = scatter_plan(fmap, n)
    rows = np.broadcast_to(fmap[:, :, None], (len(beams), d, d)).ravel()
    gcols = np.broadcast_to(gdofs[:, None, :], (len(beams), d, d)).ravel()
    coupling = (rows >= 0) & fixed[gcols]
    return BeamPlan(length, beam_t, target, keep,
                    (rows[coupling], np.flatnonzero(coupling), gcols[coupling]))


def link_dofs(recs: Sequence[Record], free: np.ndarray, dpn: int, node_names: Sequence[str],
              node_dof_names: Sequence[str]) -> np.ndarray:
    """(n_e, 2) free DOFs of the links' two ends, -1 for ground or a fixed DOF.

    A link with both ends fixed or on the ground raises ``ModelError``: it would do nothing.
    """
    out = np.full((len(recs), 2), -1, dtype=np.int64)
    for e, rec in enumerate(recs):
        for side in (0, 1):
            if rec.nodes[side] >= 0:
                out[e, side] = free[rec.nodes[side] * dpn + rec.dofs[side]]
        if out[e, 0] < 0 and out[e, 1] < 0:
            ends = [
                f"{node_names[nd]}.{node_dof_names[dd]}"
                for nd, dd in zip(rec.nodes, rec.dofs, strict=True)
                if nd >= 0
            ]
            raise ModelError(
                f"{rec.kind} {rec.name!r} connects only fixed DOFs or ground "
                f"({', '.join(ends)} fixed); it would have no effect. Remove it or "
                "free the DOF"
            )
    return out


def odd_link_dofs(ends: np.ndarray) -> np.ndarray:
    """``ends`` with the two ends swapped where the first is fixed (in place, and returned).

    For friction and Bouc–Wen elements, whose laws are odd: the sign of the deformation does
    not matter, and the integrators then find a free DOF first.
    """
    swap = ends[:, 0] < 0
    ends[swap] = ends[swap][:, ::-1]
    return ends


def lumped_mass_plan(masses: Sequence[Record], free: np.ndarray, dpn: int, n: int,
                     node_dof_names: Sequence[str]
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Flat diagonal targets and owning mass of ``m`` (translations) and ``J`` (rotations).

    A mass acts on the DOFs its ``dofs`` option names (all of the node's by default), free
    ones only.
    """
    trans = [j for j, name in enumerate(node_dof_names) if name.startswith("u")]
    rot = [j for j, name in enumerate(node_dof_names) if name.startswith("r")]

    def diag(js: list[int]) -> tuple[np.ndarray, np.ndarray]:
        idx = [(free[rec.nodes[0] * dpn + j], e) for e, rec in enumerate(masses) for j in js
               if j in rec.options.get("dofs", js)]
        idx = [(i, e) for i, e in idx if i >= 0]
        arr = np.array(idx, dtype=np.int64).reshape(-1, 2)
        return arr[:, 0] * (n + 1), arr[:, 1]

    m_target, m_owner = diag(trans)
    j_target, j_owner = diag(rot)
    return m_target, m_owner, j_target, j_owner


def mass_is_constant(beam_props: Mapping[str, Prop], beam_shear: np.ndarray, mass_m: Prop,
                     mass_J: Prop) -> bool:
    """Whether no parameter changes ``M``: then it is assembled and checked once.

    ``E`` enters the beam mass only through Φ, and only where ``G`` is given (with ``nu``,
    ``E/G`` is fixed).
    """
    mass_const = all(beam_props[w].is_const for w in MASS_PROPS) and (
        beam_props["E"].is_const or not np.any(beam_props["E"].pidx[beam_shear == 1] >= 0)
    )
    return mass_const and all(prop.is_const for prop in (mass_m, mass_J))

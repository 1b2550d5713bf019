"""3-D frames in ``[model]`` (``dofs_per_node = 6``): the checks of their fields; and the check
that a model (of any ``dofs_per_node``) is not a mechanism.

Nodes take ``z`` (vertical: floors lie in ``xy`` planes, the base motion is along ``x`` or
``y``); beams take ``Iy``, ``Iz``, ``J`` and ``vecxz`` instead of ``I`` and ``G`` or ``nu`` (the
torsional stiffness); supports, springs and dampers any of the six DOFs ``ux, uy, uz, rx, ry,
rz``; a mass's ``J`` acts on each of the three rotations. The structure is
``femupdate.model.Structure(dofs_per_node=6)`` (docs/frames-3d.md).
"""

from __future__ import annotations

import math
import typing
from collections.abc import Mapping
from typing import Annotated

from pydantic import Field

from femupdate.case.fields import format_value, number_field
from femupdate.case.issues import Issue

if typing.TYPE_CHECKING:
    from femupdate.case.model_sections import Beam, Model
    from femupdate.model.structure import Structure

__all__ = ["SECTION_3D", "Vector3", "beam_issues", "check_not_mechanism", "mechanism_dofs",
           "node_issues"]

#: A vector of three coordinates (``vecxz``).
Vector3 = Annotated[list[number_field(ge=-1e6, le=1e6)], Field(min_length=3, max_length=3)]

#: The beam fields of a 3-D frame (refused in a planar model).
SECTION_3D = ("Iy", "Iz", "J", "vecxz")
#: Beam fields that only a 3-D frame uses, though optional there.
OPTIONS_3D = ("torsional_inertia",)

#: Relative size of ``vecxz × axis`` below which ``vecxz`` is along the beam
#: (``femupdate.model.elements3d.frame3d_rotation``'s test).
_PARALLEL_RTOL = 1e-9


def node_issues(model: Model) -> list[Issue]:
    """``z`` given on a planar model (a 3-D frame needs ``dofs_per_node = 6``)."""
    if model.dofs_per_node == 6:
        return []
    return [(f"nodes[{i}].z", f"z = {format_value(node.z)} with dofs_per_node = "
             f"{model.dofs_per_node} (a planar model)", "z = 0 (or left out), or "
             "dofs_per_node = 6 for a 3-D frame") for i, node in enumerate(model.nodes)
            if node.z != 0.0]


def beam_issues(model: Model, coordinates: Mapping[str, tuple[float, float, float]]
                ) -> list[Issue]:
    """The section fields of every beam against ``dofs_per_node``: ``I`` for planar models;
    ``Iy``, ``Iz``, ``J``, ``vecxz`` (not along the beam) and ``G`` or ``nu`` for 3-D frames."""
    issues: list[Issue] = []
    for i, beam in enumerate(model.beams):
        path = f"beams[{i}]"
        if model.dofs_per_node != 6:
            given = [key for key in (*SECTION_3D, *OPTIONS_3D) if getattr(beam, key) is not None]
            if given:
                issues.append((f"{path}.{given[0]}", f"{', '.join(given)} given with "
                               f"dofs_per_node = {model.dofs_per_node} (a planar model)",
                               "I (the second moment of area in the plane), or "
                               "dofs_per_node = 6 for a 3-D frame"))
            if beam.I is None:
                issues.append((f"{path}.I", "missing", "the second moment of area, a number "
                               "in (0, 1e4] (m4) or a parameter name"))
            continue
        issues += _beam3d_issues(beam, path, coordinates)
    return issues


def _beam3d_issues(beam: Beam, path: str,
                   coordinates: Mapping[str, tuple[float, float, float]]) -> list[Issue]:
    issues: list[Issue] = []
    if beam.I is not None:
        issues.append((f"{path}.I", f"I = {format_value(beam.I)} given with dofs_per_node = 6",
                       "Iy and Iz (second moments about the local y and z axes) and J "
                       "(torsion constant) instead of I"))
    missing = [key for key in SECTION_3D if getattr(beam, key) is None]
    if missing:
        issues.append((f"{path}.{missing[0]}", f"{', '.join(missing)} missing (a 3-D beam "
                       "with dofs_per_node = 6)", "Iy, Iz, J: numbers in (0, 1e4] (m4) or "
                       "parameter names; vecxz: three numbers, a vector in the local xz plane "
                       "not along the beam"))
    if beam.G is None and beam.nu is None:
        issues.append((f"{path}.G", "neither G nor nu given (a 3-D beam needs its torsional "
                       "stiffness G J)", "G, a number in (0, 1e13] (Pa), or nu, in (-1, 0.5]"))
    ends = [coordinates.get(node) for node in beam.nodes]
    if beam.vecxz is not None and None not in ends and ends[0] != ends[1]:
        axis = [b - a for a, b in zip(ends[0], ends[1], strict=True)]  # type: ignore[arg-type]
        if _parallel(beam.vecxz, axis):
            issues.append((f"{path}.vecxz", f"vecxz = {format_value(beam.vecxz)} is parallel "
                           f"to the beam from {beam.nodes[0]!r} to {beam.nodes[1]!r}",
                           "a vector in the beam's local xz plane not along the beam, e.g. "
                           "[1, 0, 0] for a vertical column, [0, 0, 1] for a horizontal beam"))
    return issues


def _parallel(v: list[float], axis: list[float]) -> bool:
    """Whether ``v`` lies along ``axis`` (or is zero)."""
    length = math.hypot(*axis)
    x = [a / length for a in axis]
    cross = (v[1] * x[2] - v[2] * x[1], v[2] * x[0] - v[0] * x[2], v[0] * x[1] - v[1] * x[0])
    return not math.hypot(*cross) > _PARALLEL_RTOL * max(math.hypot(*v), 1e-300)


def mechanism_dofs(structure: Structure, values: Mapping[str, float],
                   direction: str) -> list[str]:
    """Free DOFs in the zero-energy modes of the structure's stiffness at ``values`` (empty
    when it is not a mechanism), from the null space of the diagonally scaled ``K``
    (:func:`femupdate.model.frame3d.null_space_dofs`). ``K`` counts the friction and Bouc–Wen
    elements by their initial stiffness (:func:`femupdate.model.modes.initial_stiffness`): a
    structure held only by them is not a mechanism."""
    from femupdate.model.frame3d import null_space_dofs
    from femupdate.model.modes import initial_stiffness

    # sparse: no positive-definite mass asked of a model whose floors carry all its mass
    system = structure.assemble(values, direction=direction, sparse=True)
    return null_space_dofs(initial_stiffness(system).toarray(), system.dof_labels)


#: Free DOFs up to which a model's stiffness is checked for a mechanism by a dense
#: eigendecomposition when its case is built (larger models: the sparse factorisation of the
#: reduced path reports a singular stiffness itself).
MECHANISM_CHECK_MAX_DOFS = 1000


def check_not_mechanism(structure: Structure, values: Mapping[str, float], direction: str,
                        label: str) -> None:
    """Raise a one-line ``ModelError`` when the model of a case (``label``: its file) is a
    mechanism at the parameter ``values`` (the nominal ones): a singular stiffness has
    zero-frequency modes, which no measured response can fit. Friction and Bouc–Wen elements
    count by their initial stiffness."""
    from femupdate.errors import ModelError

    if structure.n_dof > MECHANISM_CHECK_MAX_DOFS:
        return
    loose = mechanism_dofs(structure, values, direction)
    if loose:
        shown = ", ".join(loose[:12]) + (", ..." if len(loose) > 12 else "")
        what = "the 3-D frame" if structure.dofs_per_node == 6 else "the model"
        raise ModelError(f"{label}: model: {what} is a mechanism (singular stiffness at "
                         f"the parameters' nominal values); free DOFs in its zero-energy modes: "
                         f"{shown} (allowed: supports, springs, beams, or friction and Bouc–Wen "
                         "elements by their initial stiffness, that restrain every rigid-body "
                         "motion: add them at these DOFs)")

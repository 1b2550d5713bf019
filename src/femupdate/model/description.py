"""Checks of a ``Structure``'s description beyond one number's range: a beam's geometry and
section (2-D or 3-D), and which DOFs a lumped mass acts on.

``Structure.add_beam`` and ``Structure.add_mass`` call them as elements are described, so a bad
element is refused where it is added, with its name in the message.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from femupdate.errors import ModelError
from femupdate.model.elements3d import frame3d_rotation
from femupdate.model.properties import Value

__all__ = ["beam3d_options", "beam_options", "check_mass_dofs"]

Point = tuple[float, float, float]


def beam3d_options(label: str, dpn: int, xyz1: Point, xyz2: Point,
                   I: Value | None,  # noqa: E741
                   Iy: Value | None, Iz: Value | None, J: Value | None,
                   vecxz: Sequence[float] | None, shear: int) -> dict[str, object]:
    """The 3-D beam's extra properties and options (checks which of I / Iy, Iz, J, vecxz)."""
    given3d = {k: v for k, v in (("Iy", Iy), ("Iz", Iz), ("J", J)) if v is not None}
    if dpn != 6:
        if given3d or vecxz is not None:
            raise ModelError(f"{label}: Iy, Iz, J and vecxz are for dofs_per_node=6; give I")
        if I is None:
            raise ModelError(f"{label}: I (second moment of area) is missing")
        return {"options": {}}
    if I is not None:
        raise ModelError(f"{label}: with dofs_per_node=6 give Iy, Iz and J, not I")
    missing = [k for k in ("Iy", "Iz", "J") if k not in given3d] + (
        ["vecxz"] if vecxz is None else [])
    if missing:
        raise ModelError(f"{label}: {', '.join(missing)} missing; a 3-D beam needs Iy, Iz, J "
                         "and vecxz")
    if shear == 0:
        raise ModelError(f"{label}: give G or nu (a 3-D beam needs its torsional stiffness)")
    vec = np.asarray(vecxz, dtype=float)
    if vec.shape != (3,) or not np.all(np.isfinite(vec)):
        raise ModelError(f"{label}: vecxz = {vecxz!r}; give three finite numbers")
    try:
        frame3d_rotation(xyz1, xyz2, vec)
    except ModelError as exc:
        raise ModelError(f"{label}: {str(exc).removeprefix('3-D beam: ')}") from None
    return {"options": {"vecxz": vec}, **given3d}


def beam_options(label: str, dpn: int, ends: tuple[str, str], xyz1: Point, xyz2: Point, *,
                 I: Value | None, Iy: Value | None, Iz: Value | None,  # noqa: E741
                 J: Value | None, vecxz: Sequence[float] | None, G: Value | None,
                 nu: Value | None, rotary_inertia: bool
                 ) -> tuple[dict[str, object], dict[str, Value]]:
    """A beam's options (shear model, rotary inertia, ``vecxz``) and its 3-D section
    properties, after checking its length, its direction and which properties it was given.

    ``options["shear"]`` is 0 for a beam rigid in shear, 1 with ``G``, 2 with ``nu``.
    """
    (x1, y1, z1), (x2, y2, z2) = xyz1, xyz2
    length = math.hypot(x2 - x1, y2 - y1, z2 - z1)
    if not length > 0.0:
        raise ModelError(
            f"{label}: length = {length!r} between nodes {ends[0]!r} and {ends[1]!r}; "
            "allowed > 0 (the nodes coincide)"
        )
    if dpn == 2 and abs(y2 - y1) > 1e-9 * length:
        raise ModelError(
            f"{label}: with dofs_per_node=2 beams must lie along the x axis; nodes "
            f"{ends[0]!r} and {ends[1]!r} differ in y by {y2 - y1!r}. Use dofs_per_node=3"
        )
    if G is not None and nu is not None:
        raise ModelError(f"{label}: give G or nu, not both")
    shear = 0 if G is None and nu is None else (1 if G is not None else 2)
    options: dict[str, object] = {"shear": shear, "rotary": bool(rotary_inertia)}
    extra = beam3d_options(label, dpn, xyz1, xyz2, I, Iy, Iz, J, vecxz, shear)
    options.update(extra.pop("options"))  # type: ignore[arg-type]
    return options, extra  # type: ignore[return-value]


def check_mass_dofs(label: str, names: Sequence[str], props: Mapping[str, Value],
                    given: bool) -> None:
    """A mass whose chosen DOFs (``names``, ``given`` by the user) cannot carry its ``m`` or
    ``J`` raises: it would act on nothing."""
    for what, letter, kind in (("m", "u", "translation"), ("J", "r", "rotation")):
        if props[what] != 0.0 and given and not any(d.startswith(letter) for d in names):
            raise ModelError(f"{label}: dofs = {list(names)} names no {kind}, so {what} = "
                             f"{props[what]!r} would act on nothing; name a {kind} in "
                             f"dofs, or give {what} = 0")

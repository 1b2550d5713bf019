"""Case files of 3-D frames under uniform or multi-support ground motion.

A TOML file of its own (docs/frames-3d.md gives an example)::

    [values]                       # parameter values, if any property names a parameter
    E = 2.1e11

    [[frame3d.nodes]]              # name, x, y, z (m)
    [[frame3d.beams]]              # nodes, E, G or nu, A, Iy, Iz, J, vecxz, kappa_y, kappa_z,
                                   # rho, mass_per_length, Ip, name
    [[frame3d.masses]]             # node, m, Jx, Jy, Jz
    [[frame3d.springs]]            # node, dof, k (to the ground)
    [[frame3d.supports]]           # node, dofs (default all six)
    [[frame3d.diaphragms]]         # master, nodes
    [frame3d.rayleigh]             # alpha, beta

    [[ground_motion]]              # one per record
    file = "north.csv"             # one number per line (or a column of a CSV: column = k)
    dt = 0.01                      # sample interval (s) of this record
    scale = 9.81                   # to m/s²
    dofs = ["A.uz", "B.uz"]        # the support DOFs that follow it

In place of ``dofs``, ``direction = "x"`` moves every support along x with the record (a
component of a uniform base motion: two records along ``"x"`` and ``"y"`` are an earthquake's
two horizontal components), and ``angle = 30`` moves every support along that direction of
the horizontal plane (degrees from x towards y): ``a cos θ`` along x, ``a sin θ`` along y.

Every record must share length and ``dt`` (one-line ``DataError`` otherwise); a support DOF
takes at most one record; support DOFs without a record stay still.
"""

from __future__ import annotations

import math
import os
import tomllib
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import Field, ValidationError

from femupdate.case.fields import (
    Area,
    Coordinate,
    Density,
    MassPerLength,
    Modulus,
    NodalMass,
    NodeName,
    ParameterValue,
    Poisson,
    PositiveModulus,
    RayleighAlpha,
    RayleighBeta,
    RotaryInertia,
    SecondMoment,
    Section,
    ShearFactor,
    Stiffness,
    integer_field,
    number_field,
    text_field,
)
from femupdate.data.records import check_records
from femupdate.errors import ConfigError, DataError, ModelError
from femupdate.model.frame3d import Frame3D, Frame3DModel

__all__ = ["Frame3DCase", "load_frame3d_case"]

Dof3D = Literal["ux", "uy", "uz", "rx", "ry", "rz"]
Vector3 = Annotated[list[number_field(ge=-1e6, le=1e6)], Field(min_length=3, max_length=3)]


class Node3D(Section):
    name: NodeName
    x: Coordinate
    y: Coordinate = 0.0
    z: Coordinate = 0.0


class Beam3D(Section):
    nodes: Annotated[list[NodeName], Field(min_length=2, max_length=2)]
    E: Modulus
    G: PositiveModulus | None = None
    nu: Poisson | None = None
    A: Area
    Iy: SecondMoment
    Iz: SecondMoment
    J: SecondMoment
    vecxz: Vector3
    kappa_y: ShearFactor = 5.0 / 6.0
    kappa_z: ShearFactor = 5.0 / 6.0
    rho: Density = 0.0
    mass_per_length: MassPerLength = 0.0
    Ip: SecondMoment | None = None
    rotary_inertia: bool = True
    name: text_field(64, 1) | None = None


class Mass3D(Section):
    node: NodeName
    m: NodalMass = 0.0
    Jx: RotaryInertia = 0.0
    Jy: RotaryInertia = 0.0
    Jz: RotaryInertia = 0.0


class Spring3D(Section):
    node: NodeName
    dof: Dof3D
    k: Stiffness


class Support3D(Section):
    node: NodeName
    dofs: Annotated[list[Dof3D], Field(min_length=1, max_length=6)] | None = None


class Diaphragm(Section):
    master: NodeName
    nodes: Annotated[list[NodeName], Field(min_length=1, max_length=100_000)]


class Rayleigh3D(Section):
    alpha: RayleighAlpha = 0.0
    beta: RayleighBeta = 0.0


class Frame3DSection(Section):
    nodes: Annotated[list[Node3D], Field(min_length=2, max_length=100_000)]
    beams: Annotated[list[Beam3D], Field(min_length=1, max_length=100_000)]
    masses: list[Mass3D] = Field(default_factory=list)
    springs: list[Spring3D] = Field(default_factory=list)
    supports: Annotated[list[Support3D], Field(min_length=1, max_length=100_000)]
    diaphragms: list[Diaphragm] = Field(default_factory=list)
    rayleigh: Rayleigh3D | None = None


class GroundMotion(Section):
    file: text_field(4096, 1)
    dt: number_field("s", gt=0.0, le=10.0)
    column: integer_field(ge=0, le=10_000) = 0
    scale: number_field(gt=0.0, le=1e6) = 1.0
    dofs: Annotated[list[text_field(200, 3)], Field(min_length=1, max_length=100_000)] | None = (
        None)
    # uniform: every support along a direction, or along an angle in the horizontal plane
    direction: Literal["x", "y", "z"] | None = None
    angle: number_field("deg", ge=0.0, lt=360.0) | None = None

    def targets(self, support_labels: tuple[str, ...], where: str
                ) -> list[tuple[list[str], float]]:
        """(support DOFs, factor on the record) of each group this record drives: its
        ``dofs``; every support's DOF along ``direction``; or along x and y by cos θ, sin θ
        for an ``angle``."""
        given = [k for k in ("dofs", "direction", "angle") if getattr(self, k) is not None]
        if len(given) != 1:
            raise ConfigError(f"{where}: {' and '.join(given) or 'none'} of dofs, direction, "
                              "angle given (allowed: exactly one: the support DOFs that follow "
                              "the record, or a direction or an angle that every support "
                              "follows)")
        if self.dofs is not None:
            return [(list(self.dofs), 1.0)]
        if self.direction is not None:
            parts = [(self.direction, 1.0)]
        else:
            theta = math.radians(float(self.angle))
            parts = [("x", math.cos(theta)), ("y", math.sin(theta))]
        out = []
        for direction, factor in parts:
            dofs = [lab for lab in support_labels if lab.endswith(f".u{direction}")]
            if not dofs:
                key = "direction" if self.direction is not None else "angle"
                raise ConfigError(f"{where}.{key}: no support DOF along {direction} (allowed: "
                                  "a direction the supports are fixed along)")
            out.append((dofs, factor))
        return out


class Frame3DCase(Section):
    """A 3-D frame case: the frame, parameter values and the ground motions."""

    frame3d: Frame3DSection
    values: dict[str, ParameterValue] = Field(default_factory=dict)
    ground_motion: Annotated[list[GroundMotion], Field(min_length=1, max_length=10_000)]

    def build(self) -> Frame3D:
        """The :class:`Frame3D` described."""
        f = Frame3D()
        s = self.frame3d
        for n in s.nodes:
            f.add_node(n.name, n.x, n.y, n.z)
        for b in s.beams:
            props: dict[str, Any] = b.model_dump(exclude={"nodes", "vecxz", "G", "nu"})
            shear = {"G": b.G} if b.G is not None else {"nu": b.nu}
            f.add_beam(b.nodes[0], b.nodes[1], vecxz=b.vecxz, **shear, **props)
        for m in s.masses:
            f.add_mass(m.node, m.m, Jx=m.Jx, Jy=m.Jy, Jz=m.Jz)
        for k in s.springs:
            f.add_spring(k.node, k.dof, k.k)
        for sup in s.supports:
            f.fix(sup.node, *(sup.dofs or ()))
        for d in s.diaphragms:
            f.add_diaphragm(d.master, d.nodes)
        if s.rayleigh is not None:
            f.set_rayleigh(s.rayleigh.alpha, s.rayleigh.beta)
        return f


def _with_derived(case: Frame3DCase, path: Path) -> dict[str, float]:
    """``[values]`` with the value of every field that is an expression of them, keyed by its
    text (as ``Frame3D.assemble`` looks a string field up); a value read only by expressions
    is left out (the frame knows it under no name)."""
    from femupdate.case.checks import quantities
    from femupdate.case.expressions import is_name, parse_expression

    derived: dict[str, float] = {}
    plain: set[str] = set()
    for where, text, _ in quantities(case.frame3d, "frame3d"):
        if not isinstance(text, str) or is_name(text):
            plain.add(str(text))
            continue
        expression = parse_expression(text)
        missing = [n for n in expression.names if n not in case.values]
        if missing:
            raise ConfigError(f"{path}: {where}: {text!r} names {missing[0]!r}, which has no "
                              f"value (allowed: names given in [values]: "
                              f"{', '.join(case.values) or 'none'})")
        derived[text] = float(expression(case.values))
    only_in_expressions = {n for text in derived for n in parse_expression(text).names} - plain
    return {**{k: v for k, v in case.values.items() if k not in only_in_expressions},
            **derived}


def _read_record(path: Path, column: int, where: str) -> np.ndarray:
    try:
        data = np.loadtxt(path, delimiter="," if path.suffix == ".csv" else None, ndmin=2)
    except FileNotFoundError:
        raise DataError(f"{where}: file not found: {path}") from None
    except (OSError, ValueError) as exc:
        raise DataError(f"{where}: cannot read {path}: {str(exc).splitlines()[0]}") from None
    if column >= data.shape[1]:
        raise DataError(f"{where}: column = {column} but {path} has {data.shape[1]} column(s); "
                        f"allowed 0 to {data.shape[1] - 1}")
    return data[:, column]


def load_frame3d_case(path: str | os.PathLike[str]
                      ) -> tuple[Frame3DCase, Frame3D, Frame3DModel, list[list[str]],
                                 np.ndarray, float]:
    """Read a 3-D frame case file: the case, frame, assembled model, groups, records and dt.

    Returns
    -------
    case, frame, model, groups, acceleration (n_samples, n_records), dt

    Raises
    ------
    ConfigError
        Unreadable TOML or invalid fields (one line per problem: ``file: field: what``).
    ModelError
        A frame that cannot be assembled (e.g. a mechanism), prefixed with the file name.
    DataError
        Records that cannot be read, differ in length or rate, or hold NaN.
    """
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ConfigError(f"case file not found: {path}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML: {exc}") from None
    try:
        case = Frame3DCase.model_validate(data)
    except ValidationError as exc:
        lines = [f"{path}: {'.'.join(map(str, e['loc'])) or '(top level)'}: {e['msg']}"
                 for e in exc.errors(include_url=False)]
        raise ConfigError("\n".join(lines)) from None
    try:
        frame = case.build()
        model = frame.assemble(_with_derived(case, path))
    except ModelError as exc:
        raise ModelError(f"{path}: frame3d: {exc}") from None
    records: dict[str, tuple[np.ndarray, float]] = {}
    groups: list[list[str]] = []
    seen: dict[str, int] = {}
    for i, gm in enumerate(case.ground_motion):
        where = f"{path}: ground_motion[{i}]"
        key = "dofs" if gm.dofs is not None else "direction" if gm.direction else "angle"
        targets = gm.targets(model.support_labels, where)
        for dofs, _ in targets:
            for lab in dofs:
                if lab not in model.support_labels:
                    raise ConfigError(f"{where}.dofs: {lab!r} is not a support DOF (allowed: "
                                      f"{', '.join(model.support_labels)})")
                if lab in seen:
                    raise ConfigError(f"{where}.{key}: {lab!r} already follows ground_motion"
                                      f"[{seen[lab]}]; a support DOF takes one record")
                seen[lab] = i
        record = gm.scale * _read_record(path.parent / gm.file, gm.column, where)
        for j, (dofs, factor) in enumerate(targets):
            part = f" {'xy'[j]}" if gm.angle is not None else ""
            records[f"ground_motion[{i}]{part} ({gm.file})"] = (factor * record, gm.dt)
            groups.append(list(dofs))
    try:
        acc, dt = check_records(records)
    except DataError as exc:
        raise DataError(f"{path}: {exc}") from None
    return case, frame, model, groups, acc, dt

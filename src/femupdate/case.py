"""Case files: one model-updating job described in TOML, validated once, here.

A case file names the structural model, the parameters to update and their bounds, the measured
data, the signal processing, the error function, the integrator and the search. ``load_case``
reads it with the standard library's ``tomllib`` and validates it with the pydantic models below
(``extra="forbid"``, bounds on every number), then checks what one field cannot check alone
(references to nodes and parameters, bounds in order, ...). Every problem found is reported in
one ``ConfigError``, one line per problem::

    case.toml: model.beams[2].E: got -2e11: out of range (allowed: a number in [0, 1e13] (Pa)
    or a parameter name)

``docs/case-files.md`` documents every field. The numbers of the model may name a parameter
declared in ``[[parameters]]`` instead of giving a value (``k = "kp2"``); ``build_structure``
keeps those names, and ``Structure.assemble(values)`` substitutes them at every evaluation.
"""

from __future__ import annotations

import difflib
import hashlib
import json
import math
import os
import re
import tomllib
import types
import typing
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PlainValidator,
    PrivateAttr,
    ValidationError,
    WithJsonSchema,
    model_validator,
)
from pydantic_core import PydanticCustomError

from femupdate.errors import ConfigError

if typing.TYPE_CHECKING:
    from femupdate.model.structure import Structure

__all__ = [
    "ACCELERATION_UNITS",
    "DOF_NAMES",
    "TIME_UNITS",
    "Beam",
    "Case",
    "CaseInfo",
    "Channel",
    "Damper",
    "Data",
    "Friction",
    "Mass",
    "Model",
    "Node",
    "Objective",
    "OutputChannel",
    "Parameter",
    "Preprocess",
    "Rayleigh",
    "Search",
    "ShearBuilding",
    "Simulation",
    "Spring",
    "Support",
    "build_structure",
    "format_value",
    "load_case",
    "parse_case",
]

#: DOF names of a node, by ``model.dofs_per_node``.
DOF_NAMES: dict[int, tuple[str, ...]] = {2: ("uy", "rz"), 3: ("ux", "uy", "rz")}
#: Factor from each accepted acceleration unit to m/s² (standard gravity for "g").
ACCELERATION_UNITS: dict[str, float] = {"m/s2": 1.0, "g": 9.80665, "cm/s2": 0.01, "mm/s2": 0.001}
#: Factor from each accepted ``data.time_unit`` to seconds.
TIME_UNITS: dict[str, float] = {"s": 1.0, "ms": 1e-3, "us": 1e-6}

_PARAMETER_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_\-]*")
_ENV_VAR = re.compile(r"\$\{([^}]*)\}")
_MAX_NAME = 64
_RESERVED = frozenset({"inf", "nan", "infinity", "true", "false"})  # read as values elsewhere
_SIGMA_MAX = math.sqrt(1.0 / 12.0)  # standard deviation of the uniform law on [0, 1]

DofName = Literal["ux", "uy", "rz"]
AccelerationUnit = Literal["m/s2", "g", "cm/s2", "mm/s2"]


# ----------------------------------------------------------------------------- values


def format_value(value: Any) -> str:
    """Show a value from a case file the way a user would write it in TOML."""
    if value is None:
        return "(not set)"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        if value == 0.0 or 1e-4 <= abs(value) < 1e6:
            return np.format_float_positional(value, unique=True, trim="-")
        mantissa, exponent = np.format_float_scientific(value, unique=True, trim="-").split("e")
        return f"{mantissa}e{int(exponent)}"
    if isinstance(value, dict):
        return "{...}" if value else "{}"
    if isinstance(value, list) and len(value) > 6:
        return "[" + ", ".join(format_value(v) for v in value[:6]) + ", ...]"
    if isinstance(value, list):
        return "[" + ", ".join(format_value(v) for v in value) + "]"
    return repr(value)


def _fmt_bound(value: float) -> str:
    return str(value) if isinstance(value, int) else format_value(float(value))


@dataclass(frozen=True)
class Range:
    """The values a numeric field accepts; it is also the field's pydantic validator.

    ``parameter`` fields also accept the name of a parameter declared in ``[[parameters]]``.
    """

    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None
    integer: bool = False
    parameter: bool = False
    unit: str = ""

    def interval(self) -> str:
        """The range in words: ``"> 0"``, ``"in [1, 8]"``."""
        low = (f"({_fmt_bound(self.gt)}" if self.gt is not None else
               f"[{_fmt_bound(self.ge)}" if self.ge is not None else None)
        high = (f"{_fmt_bound(self.lt)})" if self.lt is not None else
                f"{_fmt_bound(self.le)}]" if self.le is not None else None)
        if low and high:
            return f"in {low}, {high}"
        if low:
            return f"> {low[1:]}" if low[0] == "(" else f">= {low[1:]}"
        if high:
            return f"< {high[:-1]}" if high[-1] == ")" else f"<= {high[:-1]}"
        return ""

    def describe(self) -> str:
        kind = "an integer" if self.integer else "a number"
        text = f"{kind} {self.interval()}".rstrip()
        if self.unit:
            text += f" ({self.unit})"
        if self.parameter:
            text += " or a parameter name"
        return text

    def contains(self, value: float) -> bool:
        return not (
            math.isnan(value)
            or (self.gt is not None and value <= self.gt)
            or (self.ge is not None and value < self.ge)
            or (self.lt is not None and value >= self.lt)
            or (self.le is not None and value > self.le)
        )

    def contains_closed(self, low: float, high: float) -> bool:
        """Whether ``[low, high]`` lies in the closure of the range (open ends made closed).

        A parameter's bounds are reached with probability zero, so a bound equal to an open end
        (a stiffness ``> 0`` searched in ``[0, 1e6]``) is accepted; ``Structure`` still checks
        every value it assembles.
        """
        lo = self.gt if self.gt is not None else self.ge
        hi = self.lt if self.lt is not None else self.le
        return (lo is None or low >= lo) and (hi is None or high <= hi)

    def __call__(self, value: Any) -> float | int | str:
        allowed = {"allowed": self.describe()}
        if isinstance(value, str) and self.parameter:
            if _is_parameter_name(value):
                return value
            if _is_number(value):
                raise PydanticCustomError(
                    "quoted_number", "got {got}: a number in quotes; remove the quotes",
                    {**allowed, "got": repr(value)})
            raise PydanticCustomError(
                "parameter_name",
                "got {got}: not a valid parameter name (letters, digits and _, not starting "
                "with a digit, at most 64 characters)",
                {**allowed, "got": repr(value)})
        if self.integer:
            if isinstance(value, bool) or not isinstance(value, int):
                raise PydanticCustomError(
                    "integer_type", "got {got}: not an integer", {**allowed,
                                                                  "got": format_value(value)})
            number: float | int = value
        else:
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise PydanticCustomError(
                    "number_type", "got {got}: not a number", {**allowed,
                                                               "got": format_value(value)})
            number = float(value)
            if not math.isfinite(number):
                raise PydanticCustomError(
                    "finite_number", "got {got}: not a finite number",
                    {**allowed, "got": format_value(number)})
        if not self.contains(number):
            raise PydanticCustomError(
                "out_of_range", "got {got}: out of range", {**allowed,
                                                             "got": format_value(number)})
        return number

    def json_schema(self) -> dict[str, Any]:
        schema: dict[str, Any] = {"type": "integer" if self.integer else "number"}
        for key, name in (("gt", "exclusiveMinimum"), ("ge", "minimum"),
                          ("lt", "exclusiveMaximum"), ("le", "maximum")):
            if getattr(self, key) is not None:
                schema[name] = getattr(self, key)
        if self.unit:
            schema["description"] = f"unit: {self.unit}"
        if self.parameter:
            return {"anyOf": [schema, {"type": "string", "pattern": _PARAMETER_NAME.pattern}]}
        return schema


def _is_parameter_name(text: str) -> bool:
    return (bool(_PARAMETER_NAME.fullmatch(text)) and len(text) <= _MAX_NAME
            and text.lower() not in _RESERVED)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _number(unit: str = "", **bounds: Any) -> Any:
    """Annotated float field checked by ``Range`` (finite, with bounds)."""
    rng = Range(unit=unit, **bounds)
    return Annotated[float, PlainValidator(rng), WithJsonSchema(rng.json_schema()), rng]


def _integer(**bounds: Any) -> Any:
    rng = Range(integer=True, **bounds)
    return Annotated[int, PlainValidator(rng), WithJsonSchema(rng.json_schema()), rng]


def _quantity(unit: str = "", **bounds: Any) -> Any:
    """A model property: a number in range, or the name of a declared parameter."""
    rng = Range(parameter=True, unit=unit, **bounds)
    return Annotated[float | str, PlainValidator(rng), WithJsonSchema(rng.json_schema()), rng]


def _name_check(kind: str, pattern: re.Pattern[str], rule: str,
                reserved: frozenset[str] = frozenset()) -> Any:
    def check(value: Any) -> str:
        if not isinstance(value, str):
            raise PydanticCustomError("string_type", "got {got}: not a string",
                                      {"allowed": f"a {kind} in quotes",
                                       "got": format_value(value)})
        if not pattern.fullmatch(value) or len(value) > _MAX_NAME or value.lower() in reserved:
            raise PydanticCustomError("name_pattern", "got {got}: not a valid {kind}",
                                      {"allowed": rule, "got": repr(value), "kind": kind})
        return value

    return Annotated[str, PlainValidator(check), WithJsonSchema(
        {"type": "string", "pattern": pattern.pattern, "maxLength": _MAX_NAME})]


def _column_check(value: Any) -> str | int:
    allowed = {"allowed": "a column name (string) or a 0-based column number"}
    if isinstance(value, bool) or not isinstance(value, str | int):
        raise PydanticCustomError("column_type", "got {got}: not a column",
                                  {**allowed, "got": format_value(value)})
    if isinstance(value, int) and not 0 <= value <= 100_000:
        raise PydanticCustomError("out_of_range", "got {got}: out of range",
                                  {"allowed": "a column number in [0, 100000]",
                                   "got": value})
    if isinstance(value, str) and not value.strip():
        raise PydanticCustomError("empty", "got {got}: empty", {**allowed, "got": repr(value)})
    return value


_DELAY_RANGE = Range(ge=-10.0, le=10.0, unit="s")


def _delay_check(value: Any) -> float | str:
    """A channel delay: a number of seconds in range, or ``"auto"``."""
    if value == "auto":
        return "auto"
    allowed = {"allowed": f"{_DELAY_RANGE.describe()}, or \"auto\" (estimated from the data)"}
    if isinstance(value, str):
        hint = "; a number in quotes: remove the quotes" if _is_number(value) else ""
        raise PydanticCustomError("delay_value", "got {got}: not a number or \"auto\"" + hint,
                                  {**allowed, "got": repr(value)})
    try:
        return _DELAY_RANGE(value)
    except PydanticCustomError as exc:
        raise PydanticCustomError(exc.type, exc.message_template, {**exc.context, **allowed}
                                  ) from None


def _json_value(value: Any, depth: int = 0) -> bool:
    if depth > 8:
        return False
    if value is None or isinstance(value, bool | int | str):
        return True
    if isinstance(value, float):
        return math.isfinite(value)
    if isinstance(value, list):
        return all(_json_value(v, depth + 1) for v in value)
    if isinstance(value, dict):
        return all(isinstance(k, str) and _json_value(v, depth + 1) for k, v in value.items())
    return False


def _options_check(value: Any) -> dict[str, Any]:
    allowed = {"allowed": "a table of option names and numbers, strings, booleans or arrays"}
    if not isinstance(value, dict):
        raise PydanticCustomError("dict_type", "got {got}: not a table",
                                  {**allowed, "got": format_value(value)})
    for key, item in value.items():
        if not _json_value(item):
            raise PydanticCustomError("option_value", "option {key!r} = {got} cannot be saved",
                                      {**allowed, "key": key, "got": format_value(item)})
    return dict(value)


def _text(max_length: int = 2000, min_length: int = 0) -> Any:
    return Annotated[str, Field(min_length=min_length, max_length=max_length)]


NodeName = _name_check("node name", _NAME,
                       "letters, digits, _ and -, not starting with -, at most 64 characters")
ElementName = _name_check("name", _NAME,
                          "letters, digits, _ and -, not starting with -, at most 64 characters")
ParameterName = _name_check("parameter name", _PARAMETER_NAME,
                            "letters, digits and _, not starting with a digit, "
                            "at most 64 characters, not inf or nan", _RESERVED)
Column = Annotated[str | int, PlainValidator(_column_check),
                   WithJsonSchema({"anyOf": [{"type": "string"}, {"type": "integer"}]})]
Options = Annotated[dict[str, Any], PlainValidator(_options_check),
                    WithJsonSchema({"type": "object"})]
Delay = Annotated[float | str, PlainValidator(_delay_check), WithJsonSchema(
    {"anyOf": [_DELAY_RANGE.json_schema(), {"const": "auto"}]})]

# Generous physical ranges: they catch slips of units and signs, not unusual structures.
Coordinate = _number("m", ge=-1e6, le=1e6)
Modulus = _quantity("Pa", ge=0.0, le=1e13)
PositiveModulus = _quantity("Pa", gt=0.0, le=1e13)
Poisson = _quantity(gt=-1.0, le=0.5)
Area = _quantity("m2", gt=0.0, le=1e4)
SecondMoment = _quantity("m4", gt=0.0, le=1e4)
Density = _quantity("kg/m3", ge=0.0, le=1e6)
ShearFactor = _quantity(gt=0.0, le=100.0)
MassPerLength = _quantity("kg/m", ge=0.0, le=1e9)
Stiffness = _quantity("N/m, or N·m/rad for a rotation", ge=0.0, le=1e15)
DampingCoefficient = _quantity("N·s/m, or N·m·s/rad for a rotation", ge=0.0, le=1e12)
SlipForce = _quantity("N, or N·m for a rotation", ge=0.0, le=1e12)
NodalMass = _quantity("kg", ge=0.0, le=1e9)
RotaryInertia = _quantity("kg·m2", ge=0.0, le=1e9)
RayleighAlpha = _quantity("1/s", ge=0.0, le=1e4)
RayleighBeta = _quantity("s", ge=0.0, le=1.0)
ParameterValue = _number(ge=-1e30, le=1e30)


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)


# ----------------------------------------------------------------------------- cross checks

#: A problem found by a cross-field check: field path (relative), what is wrong, allowed.
Issue = tuple[str, str, str]


def _raise_issues(issues: list[Issue]) -> None:
    """Report cross-field problems through pydantic, one error carrying them all.

    The loader expands them to one line each, prefixed by the section's location.
    """
    if issues:
        summary = "; ".join(f"{path}: {what}" if path else what for path, what, _ in issues)
        raise PydanticCustomError("case_consistency", "{summary}",
                                  {"summary": summary, "issues": issues})


def _join(*parts: str | int) -> str:
    path = ""
    for part in parts:
        if isinstance(part, int):
            path += f"[{part}]"
        elif part:
            path += f".{part}" if path else part
    return path


def _did_you_mean(name: str, candidates: Sequence[str]) -> str:
    """``"; did you mean 'x'?"`` for the closest candidate (same first letter preferred)."""
    close = difflib.get_close_matches(name, list(candidates), n=3, cutoff=0.5)
    same_start = [c for c in close if c[:1].lower() == name[:1].lower()]
    best = (same_start or close or [None])[0]
    return f"; did you mean {best!r}?" if best is not None else ""


def _duplicates(names: Sequence[tuple[str, str]], what: str, section: str = "") -> list[Issue]:
    """``names``: (path, name) pairs; one issue per repeated name, at its later uses.

    ``section`` prefixes the path of the first use in the message (paths are relative to it).
    """
    seen: dict[str, str] = {}
    issues = []
    for path, name in names:
        if name in seen:
            first = _join(section, seen[name])
            issues.append((path, f"duplicate {what} {name!r}, already used at {first}",
                           f"a {what} not used before"))
        else:
            seen[name] = path
    return issues


# ----------------------------------------------------------------------------- [case]


class CaseInfo(_Section):
    """``[case]``: what the job is."""

    name: _text(200, 1)
    description: _text(10_000) = ""


# ----------------------------------------------------------------------------- [model]


class Node(_Section):
    """``[[model.nodes]]``: a node in the plane of the model."""

    name: NodeName
    x: Coordinate
    y: Coordinate = 0.0


class Beam(_Section):
    """``[[model.beams]]``: a Timoshenko beam between two nodes (bending and shear)."""

    nodes: Annotated[list[NodeName], Field(min_length=2, max_length=2)]
    E: Modulus
    G: PositiveModulus | None = None
    nu: Poisson | None = None
    A: Area
    I: SecondMoment  # noqa: E741 (the usual symbol of the second moment of area)
    rho: Density = 0.0
    kappa: ShearFactor = 5.0 / 6.0
    mass_per_length: MassPerLength = 0.0
    rotary_inertia: bool = True
    name: ElementName | None = None

    @model_validator(mode="after")
    def _check(self) -> Beam:
        issues: list[Issue] = []
        if self.nodes[0] == self.nodes[1]:
            issues.append(("nodes", f"both ends are node {self.nodes[0]!r}",
                           "two different nodes"))
        if self.G is not None and self.nu is not None:
            issues.append(("nu", f"both G = {format_value(self.G)} and nu = "
                           f"{format_value(self.nu)} are given",
                           "G or nu, not both (neither: no shear deformation)"))
        _raise_issues(issues)
        return self


class _Link(_Section):
    """An element at one DOF, to the base (ground), or between two DOFs."""

    node: NodeName
    dof: DofName
    node2: NodeName | None = None
    dof2: DofName | None = None
    name: ElementName | None = None

    @model_validator(mode="after")
    def _check(self) -> _Link:
        if self.dof2 is not None and self.node2 is None:
            _raise_issues([("dof2", f"dof2 = {self.dof2!r} without node2",
                            "node2 with dof2 (between two DOFs), or neither (to the base)")])
        if self.node2 == self.node and self.second_dof == self.dof:
            _raise_issues([("node2", f"connects {self.node}.{self.dof} to itself",
                            "two different DOFs, or no node2 (to the base)")])
        return self

    @property
    def second_dof(self) -> str | None:
        """The DOF at ``node2`` (``dof2``, default the same as ``dof``), None to the base."""
        if self.node2 is None:
            return None
        return self.dof2 if self.dof2 is not None else self.dof


class Spring(_Link):
    """``[[model.springs]]``: a linear spring."""

    k: Stiffness


class Damper(_Link):
    """``[[model.dampers]]``: a linear viscous damper."""

    c: DampingCoefficient


class Friction(_Link):
    """``[[model.frictions]]``: an elasto-slip (Jenkins) damper: spring k_r, slider f_u."""

    k_r: Stiffness
    f_u: SlipForce


class Mass(_Section):
    """``[[model.masses]]``: a lumped mass on the node's translations and a rotary inertia."""

    node: NodeName
    m: NodalMass
    J: RotaryInertia = 0.0


class Support(_Section):
    """``[[model.supports]]``: DOFs fixed to the base (they move with the table)."""

    node: NodeName
    dofs: Annotated[list[DofName], Field(min_length=1, max_length=3)]

    @model_validator(mode="after")
    def _check(self) -> Support:
        _raise_issues([(f"dofs[{i}]", f"{dof!r} is listed twice", "each DOF once")
                       for i, dof in enumerate(self.dofs) if dof in self.dofs[:i]])
        return self


class Rayleigh(_Section):
    """``[model.rayleigh]``: damping ``C += alpha M + beta K``."""

    alpha: RayleighAlpha = 0.0
    beta: RayleighBeta = 0.0


class ShearBuilding(_Section):
    """``[model.shear_building]``: storeys on a shake table, storey 1 at the bottom."""

    masses: Annotated[list[NodalMass], Field(min_length=1, max_length=1000)]
    stiffnesses: Annotated[list[Stiffness], Field(min_length=1, max_length=1000)]
    dampers: Annotated[list[DampingCoefficient], Field(min_length=1, max_length=1000)] | None = None

    @model_validator(mode="after")
    def _check(self) -> ShearBuilding:
        n = len(self.masses)
        issues = [(key, f"has {len(values)} values but masses has {n}",
                   f"{n} values, one per storey")
                  for key, values in (("stiffnesses", self.stiffnesses),
                                      ("dampers", self.dampers or self.masses))
                  if len(values) != n]
        _raise_issues(issues)
        return self

    @property
    def floors(self) -> tuple[str, ...]:
        """Node names of the floors: ``"F1"`` (above storey 1) to ``"Fn"`` (the roof)."""
        return tuple(f"F{i + 1}" for i in range(len(self.masses)))


_ELEMENT_LISTS = ("nodes", "beams", "springs", "dampers", "frictions", "masses", "supports")


class Model(_Section):
    """``[model]``: the finite element model."""

    dofs_per_node: Literal[2, 3] = 2
    direction: Literal["x", "y"] | None = None
    rayleigh: Rayleigh | None = None
    nodes: list[Node] = Field(default_factory=list)
    beams: list[Beam] = Field(default_factory=list)
    springs: list[Spring] = Field(default_factory=list)
    dampers: list[Damper] = Field(default_factory=list)
    frictions: list[Friction] = Field(default_factory=list)
    masses: list[Mass] = Field(default_factory=list)
    supports: list[Support] = Field(default_factory=list)
    shear_building: ShearBuilding | None = None

    @model_validator(mode="after")
    def _check(self) -> Model:
        _raise_issues(_model_issues(self))
        return self

    @property
    def has_friction(self) -> bool:
        return bool(self.frictions)

    @property
    def excitation_direction(self) -> str:
        """Direction of the base motion: ``direction``, or "x" for a shear building and a
        plane frame, "y" (transverse) for a 2-DOF/node model."""
        if self.direction is not None:
            return self.direction
        return "y" if self.shear_building is None and self.dofs_per_node == 2 else "x"

    def dof_names(self) -> tuple[str, ...]:
        """DOF names of a node of this model (a shear building's floors: ``("ux",)``)."""
        return ("ux",) if self.shear_building is not None else DOF_NAMES[self.dofs_per_node]

    def node_names(self) -> tuple[str, ...]:
        if self.shear_building is not None:
            return self.shear_building.floors
        return tuple(node.name for node in self.nodes)

    def fixed_dofs(self) -> dict[tuple[str, str], str]:
        """``(node, dof) -> path of the support`` for every fixed DOF."""
        return {(s.node, dof): f"model.supports[{i}]"
                for i, s in reversed(list(enumerate(self.supports))) for dof in s.dofs}


def _model_issues(model: Model) -> list[Issue]:
    issues: list[Issue] = []
    used = [key for key in _ELEMENT_LISTS if getattr(model, key)]
    if model.shear_building is not None:
        if used:
            issues.append((
                "shear_building", "given together with model." + ", model.".join(used),
                "either [model.shear_building] or nodes and elements, not both"))
        if model.dofs_per_node != 2 or model.direction not in (None, "x"):
            issues.append(("shear_building", f"dofs_per_node = {model.dofs_per_node} and "
                           f"direction = {format_value(model.direction)} do not apply",
                           "leave dofs_per_node and direction out: each floor has one "
                           "translation 'ux' along the shaking"))
        return issues
    if not model.nodes:
        return [("nodes", "no nodes defined",
                 "[[model.nodes]] with elements, or [model.shear_building]")]
    if model.dofs_per_node == 2 and model.direction not in (None, "y"):
        issues.append(("direction", f"got {model.direction!r} with dofs_per_node = 2",
                       "'y' (the transverse direction of a 2-DOF/node model)"))
    issues += _duplicates([(f"nodes[{i}].name", n.name) for i, n in enumerate(model.nodes)],
                          "node name", "model")
    named = [(f"{key}[{i}].name", e.name) for key in _ELEMENT_LISTS[1:5]
             for i, e in enumerate(getattr(model, key)) if e.name is not None]
    issues += _duplicates(named, "element name", "model")

    coordinates = {n.name: (n.x, n.y) for n in model.nodes}
    defined = ", ".join(repr(n) for n in coordinates) or "none"
    dofs = DOF_NAMES[model.dofs_per_node]

    def node_issue(path: str, node: str | None) -> None:
        if node is not None and node not in coordinates:
            hint = _did_you_mean(node, list(coordinates))
            issues.append((path, f"unknown node {node!r}{hint}",
                           f"a node of [[model.nodes]]: {defined}"))

    def dof_issue(path: str, dof: str | None) -> None:
        if dof is not None and dof not in dofs:
            issues.append((path, f"got {dof!r}: not a DOF of a model with dofs_per_node = "
                           f"{model.dofs_per_node}", ", ".join(repr(d) for d in dofs)))

    for i, beam in enumerate(model.beams):
        for j, node in enumerate(beam.nodes):
            node_issue(f"beams[{i}].nodes[{j}]", node)
        ends = [coordinates.get(node) for node in beam.nodes]
        if None not in ends and beam.nodes[0] != beam.nodes[1] and ends[0] == ends[1]:
            issues.append((f"beams[{i}].nodes", f"nodes {beam.nodes[0]!r} and "
                           f"{beam.nodes[1]!r} are at the same point {ends[0]}",
                           "two nodes at different points (a beam of length > 0)"))
        if (model.dofs_per_node == 2 and None not in ends
                and abs(ends[1][1] - ends[0][1]) > 1e-9 * math.dist(ends[0], ends[1])):
            issues.append((f"beams[{i}].nodes", "with dofs_per_node = 2 beams lie along x; "
                           f"nodes {beam.nodes[0]!r} and {beam.nodes[1]!r} have different y",
                           "nodes with equal y, or dofs_per_node = 3 for a plane frame"))
    for key in ("springs", "dampers", "frictions"):
        for i, link in enumerate(getattr(model, key)):
            node_issue(f"{key}[{i}].node", link.node)
            node_issue(f"{key}[{i}].node2", link.node2)
            dof_issue(f"{key}[{i}].dof", link.dof)
            dof_issue(f"{key}[{i}].dof2", link.dof2)
    for i, mass in enumerate(model.masses):
        node_issue(f"masses[{i}].node", mass.node)
    fixed: dict[tuple[str, str], str] = {}
    for i, support in enumerate(model.supports):
        node_issue(f"supports[{i}].node", support.node)
        for j, dof in enumerate(support.dofs):
            dof_issue(f"supports[{i}].dofs[{j}]", dof)
            if (support.node, dof) in fixed:
                issues.append((f"supports[{i}].dofs[{j}]",
                               f"{support.node}.{dof} is already fixed by "
                               f"{fixed[support.node, dof]}", "each DOF fixed once"))
            fixed.setdefault((support.node, dof), f"model.supports[{i}]")
    for key in ("springs", "dampers", "frictions"):
        for i, link in enumerate(getattr(model, key)):
            ends = [(link.node, link.dof)]
            if link.node2 is not None:
                ends.append((link.node2, link.second_dof))
            if all(end in fixed for end in ends) and link.node2 is not None:
                issues.append((f"{key}[{i}]", "connects two fixed DOFs ("
                               + " and ".join(f"{n}.{d} by {fixed[n, d]}" for n, d in ends)
                               + "): it would have no effect",
                               "at least one free DOF; remove the element or free the DOF"))
            elif all(end in fixed for end in ends):
                issues.append((f"{key}[{i}]", f"acts on {link.node}.{link.dof}, fixed by "
                               f"{fixed[link.node, link.dof]}: it would have no effect",
                               "a free DOF; remove the element or free the DOF"))
    return issues


# ----------------------------------------------------------------------------- [[parameters]]


class Parameter(_Section):
    """``[[parameters]]``: an unknown of the model, searched between its bounds."""

    name: ParameterName
    lower: ParameterValue
    upper: ParameterValue
    scale: Literal["linear", "log"] = "linear"
    unit: _text(40) = ""
    nominal: ParameterValue | None = None

    @model_validator(mode="after")
    def _check(self) -> Parameter:
        issues: list[Issue] = []
        low, high = format_value(self.lower), format_value(self.upper)
        if self.lower >= self.upper:
            issues.append(("upper", f"parameter {self.name!r}: reversed bounds: lower = {low} "
                           f"is not below upper = {high}", "lower < upper"))
        if self.scale == "log" and self.lower <= 0.0:
            issues.append(("lower", f"parameter {self.name!r}: got {low} with scale = 'log'",
                           "lower > 0 for a log scale, or scale = 'linear'"))
        if (self.nominal is not None and self.lower < self.upper
                and not self.lower <= self.nominal <= self.upper):
            issues.append(("nominal", f"parameter {self.name!r}: got "
                           f"{format_value(self.nominal)}, outside the bounds",
                           f"a value in [{low}, {high}]"))
        _raise_issues(issues)
        return self

    @property
    def search_bounds(self) -> tuple[float, float]:
        """Bounds in the search space: log10 of the bounds for a log scale."""
        if self.scale == "log":
            return math.log10(self.lower), math.log10(self.upper)
        return self.lower, self.upper

    def to_physical(self, x: float) -> float:
        return 10.0 ** x if self.scale == "log" else float(x)

    def to_search(self, value: float) -> float:
        return math.log10(value) if self.scale == "log" else float(value)

    @property
    def nominal_value(self) -> float:
        """``nominal`` if given, else the middle of the search interval."""
        if self.nominal is not None:
            return self.nominal
        low, high = self.search_bounds
        return self.to_physical(0.5 * (low + high))


# ----------------------------------------------------------------------------- [data]


class Channel(_Section):
    """``[data.input]``: the base (table) acceleration channel."""

    file: _text(4096, 1)
    column: Column
    unit: AccelerationUnit | None = None


class OutputChannel(Channel):
    """``[[data.outputs]]``: a measured absolute acceleration at a DOF of the model."""

    node: NodeName
    dof: DofName
    weight: _number(gt=0.0, le=1e6) = 1.0
    name: ElementName | None = None
    delay: Delay = 0.0

    @property
    def label(self) -> str:
        return self.name if self.name is not None else f"{self.node}.{self.dof}"


class Data(_Section):
    """``[data]``: where the measured accelerations are and how to read them."""

    format: Literal["csv", "npz", "uff"]
    directory: _text(4096) | None = None
    time_column: Column | None = None
    time_unit: Literal["s", "ms", "us"] = "s"
    rate: _number("Hz", gt=0.0, le=1e7) | None = None
    skip_lines: _integer(ge=0, le=1_000_000) | None = None
    header: bool | None = None
    delimiter: _text(8, 1) | None = None
    comments: _text(8, 1) = "#"
    skip_rows: _integer(ge=0, le=1_000_000) = 0
    window: Annotated[list[_number("s", ge=0.0, le=1e7)],
                      Field(min_length=2, max_length=2)] | None = None
    unit: AccelerationUnit = "m/s2"
    input: Channel
    outputs: Annotated[list[OutputChannel], Field(min_length=1, max_length=10_000)]

    @model_validator(mode="after")
    def _check(self) -> Data:
        issues: list[Issue] = []
        if self.format != "csv":
            for key in ("time_column", "rate"):
                if getattr(self, key) is not None:
                    issues.append((key, f"given for format = {self.format!r}",
                                   "nothing: NPZ files hold their times in the array 't', "
                                   "UFF58 files carry their own time axis"))
            for key in ("skip_lines", "header", "delimiter"):
                if key in self.model_fields_set:
                    issues.append((key, f"given for format = {self.format!r}",
                                   "nothing: a CSV option"))
        elif (self.time_column is None) == (self.rate is None):
            what = "both given" if self.rate is not None else "neither given"
            issues.append(("rate", f"time_column and rate: {what}",
                           "either time_column (a column of times) or rate (Hz)"))
        if self.window is not None and self.window[0] >= self.window[1]:
            issues.append(("window", f"got {format_value(self.window)}: t_start is not "
                           "before t_end", "[t_start, t_end] with t_start < t_end (s)"))
        if self.directory is not None:
            issues += [("directory", problem, "${NAME} with NAME a variable name")
                       for problem in _env_syntax(self.directory)]
        channels = [("input", self.input)] + [(f"outputs[{i}]", c)
                                              for i, c in enumerate(self.outputs)]
        for path, channel in channels:
            issues += [(f"{path}.file", p, "${NAME} with NAME a variable name")
                       for p in _env_syntax(channel.file)]
            if self.format == "csv" and isinstance(channel.column, str) and self.header is False:
                issues.append((f"{path}.column", f"got {channel.column!r} but header = false",
                               "a 0-based column number, or header = true"))
            if self.format != "csv" and not isinstance(channel.column, str):
                issues.append((f"{path}.column", f"got {channel.column}: channels of "
                               f"{self.format.upper()} files have names",
                               "the name of the channel in the file"))
        issues += _duplicates([(f"outputs[{i}]", c.label) for i, c in enumerate(self.outputs)],
                              "output channel", "data")
        _raise_issues(issues)
        return self


def _env_syntax(text: str) -> list[str]:
    problems = [f"${{{name}}}: not a variable name" for name in _ENV_VAR.findall(text)
                if not _PARAMETER_NAME.fullmatch(name)]
    if "${" in _ENV_VAR.sub("", text):
        problems.append(f"got {text!r}: '${{' without a closing '}}'")
    return problems


def _expand(text: str, where: str, source: str) -> str:
    def value(match: re.Match[str]) -> str:
        name = match.group(1)
        if name not in os.environ:
            raise ConfigError(f"{source}: {where}: environment variable {name} is not set "
                              f"(allowed: set it, e.g. export {name}=/path/to/data, or write "
                              "the path)")
        return os.environ[name]

    return _ENV_VAR.sub(value, text)


# ----------------------------------------------------------------------------- the job


class Preprocess(_Section):
    """``[preprocess]``: signal processing of the measured data and integration substeps."""

    highpass_hz: _number("Hz", ge=0.0, le=1e6) = 0.0
    highpass_order: _integer(ge=1, le=8) = 4
    zero_phase: bool = False
    resample_hz: _number("Hz", gt=0.0, le=1e7) | None = None
    substeps: _integer(ge=1, le=1000) = 1
    delay_band_hz: Annotated[list[_number("Hz", gt=0.0, le=1e7)],
                             Field(min_length=2, max_length=2)] = Field(
        default_factory=lambda: [1.0, 10.0])
    filter_prediction: bool | None = None

    @model_validator(mode="after")
    def _check(self) -> Preprocess:
        low, high = self.delay_band_hz
        if low >= high:
            _raise_issues([("delay_band_hz", f"got {format_value(self.delay_band_hz)}: low is "
                            "not below high", "[low, high] with 0 < low < high, Hz")])
        return self


class Objective(_Section):
    """``[objective]``: what the error function compares (METHOD.md §1, §8)."""

    quantity: Literal["displacement", "acceleration"] = "displacement"
    experimental_parameters: bool = True
    integrate_prediction: bool = True


class Simulation(_Section):
    """``[simulation]``: the integrator (None: exact for linear models, nonlinear if friction)."""

    method: Literal["exact", "central_difference", "newmark", "nonlinear"] | None = None


class Search(_Section):
    """``[search]``: the optimiser, its stopping criteria and the repeated runs."""

    method: Literal["ab", "ib", "cmaes", "de", "ga", "multistart-lm", "scipy-lsq"] = "ab"
    runs: _integer(ge=1, le=10_000) = 1
    seed: _integer(ge=0, le=2**63 - 1) | None = None
    workers: _integer(ge=1, le=1024) = 1
    max_evals: _integer(ge=1, le=10**9) = 5000
    f_target: _number(ge=0.0, le=1e6) | None = None
    sigma_min: _number(gt=0.0, lt=_SIGMA_MAX) | None = None
    f_change_min: _number(ge=0.0, le=1e6) | None = None
    options: Options = Field(default_factory=dict)


# ----------------------------------------------------------------------------- Case


class Case(_Section):
    """A validated case file. Build it with ``load_case(path)`` or ``parse_case(mapping)``."""

    case: CaseInfo
    model: Model
    parameters: list[Parameter] = Field(default_factory=list)
    data: Data | None = None
    preprocess: Preprocess = Field(default_factory=Preprocess)
    objective: Objective = Field(default_factory=Objective)
    simulation: Simulation = Field(default_factory=Simulation)
    search: Search = Field(default_factory=Search)

    _source: Path | None = PrivateAttr(default=None)

    @model_validator(mode="after")
    def _check(self) -> Case:
        _raise_issues(_case_issues(self))
        return self

    # -- where it came from

    @property
    def source(self) -> Path | None:
        """The case file, or None for a case built from a mapping."""
        return self._source

    @property
    def label(self) -> str:
        """How messages name the case: its file, or ``<case 'name'>``."""
        return str(self._source) if self._source is not None else f"<case {self.case.name!r}>"

    # -- parameters and the search space

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def bounds(self) -> list[tuple[float, float]]:
        """(lower, upper) of each parameter in the search space (log10 for log scales)."""
        return [p.search_bounds for p in self.parameters]

    def to_physical(self, x: Sequence[float] | np.ndarray) -> dict[str, float]:
        """Parameter values from a point of the search space (undoing the log scales)."""
        values = np.asarray(x, dtype=float)
        if values.shape != (len(self.parameters),):
            raise ConfigError(f"{self.label}: to_physical: got an array of shape {values.shape} "
                              f"for {len(self.parameters)} parameters "
                              f"(allowed: one value per parameter: {list(self.parameter_names)})")
        pairs = zip(self.parameters, values, strict=True)
        return {p.name: p.to_physical(float(v)) for p, v in pairs}

    def to_search(self, values: Mapping[str, float]) -> np.ndarray:
        """The point of the search space of named parameter values (inverse of to_physical)."""
        missing = [n for n in self.parameter_names if n not in values]
        unknown = [n for n in values if n not in self.parameter_names]
        if missing or unknown:
            raise ConfigError(f"{self.label}: to_search: missing {missing}, unknown {unknown} "
                              f"(allowed: exactly the parameters {list(self.parameter_names)})")
        return np.array([p.to_search(values[p.name]) for p in self.parameters])

    def nominal(self) -> dict[str, float]:
        """Nominal parameter values (``nominal``, else the middle of the search interval)."""
        return {p.name: p.nominal_value for p in self.parameters}

    # -- resolved defaults

    @property
    def filters_prediction(self) -> bool:
        """Whether the high-pass is applied to the model's prediction rather than its input.

        ``preprocess.filter_prediction``, or by default: with frictions (a filter commutes with
        a linear model only). Never without a high-pass.
        """
        pre = self.preprocess
        if pre.highpass_hz <= 0.0:
            return False
        return self.model.has_friction if pre.filter_prediction is None else pre.filter_prediction

    @property
    def simulation_method(self) -> str:
        """``simulation.method``, or its default: ``"nonlinear"`` with frictions, else exact."""
        if self.simulation.method is not None:
            return self.simulation.method
        return "nonlinear" if self.model.has_friction else "exact"

    # -- data files

    def data_directory(self) -> Path:
        """``data.directory`` with ``${VAR}`` expanded, relative to the case file's folder."""
        base = self._source.parent if self._source is not None else Path.cwd()
        if self.data is None or self.data.directory is None:
            return base
        directory = Path(_expand(self.data.directory, "data.directory", self.label)).expanduser()
        return directory if directory.is_absolute() else base / directory

    def data_path(self, channel: Channel) -> Path:
        """Path of a channel's file (``${VAR}`` expanded; relative to ``data_directory()``)."""
        path = Path(_expand(channel.file, "data file", self.label)).expanduser()
        return Path(os.path.normpath(path if path.is_absolute() else self.data_directory() / path))

    # -- saving

    def to_dict(self) -> dict[str, Any]:
        """The whole case, defaults included, as JSON-ready data (saved with every result)."""
        return self.model_dump(mode="json")

    def fingerprint(self) -> str:
        """SHA-256 of the canonical JSON of ``to_dict()``: equal for equal cases."""
        text = json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"),
                          ensure_ascii=False, allow_nan=False)
        return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _quantities(obj: BaseModel, path: str) -> Iterator[tuple[str, float | str, Range]]:
    """Every model property checked by a ``Range``: (path, value, range), recursively."""
    for key, info in type(obj).model_fields.items():
        value = getattr(obj, key)
        if value is None:
            continue
        here = _join(path, key)
        if isinstance(value, BaseModel):
            yield from _quantities(value, here)
        elif isinstance(value, list):
            inner = _find_range(info.annotation, into_lists=True)
            for i, item in enumerate(value):
                if isinstance(item, BaseModel):
                    yield from _quantities(item, f"{here}[{i}]")
                elif inner is not None:
                    yield f"{here}[{i}]", item, inner
        else:
            rng = _field_range(info)
            if rng is not None:
                yield here, value, rng


def _find_range(tp: Any, into_lists: bool = False) -> Range | None:
    """The ``Range`` in a type annotation (through Annotated and Optional; list items if
    ``into_lists``)."""
    for meta in getattr(tp, "__metadata__", ()):
        if isinstance(meta, Range):
            return meta
    origin = typing.get_origin(tp)
    if origin is list and not into_lists:
        return None
    if origin in (Annotated, typing.Union, types.UnionType, list):
        for arg in typing.get_args(tp):
            found = _find_range(arg, into_lists)
            if found is not None:
                return found
    return None


def _field_range(info: Any) -> Range | None:
    """The ``Range`` of a scalar field (pydantic moves top-level metadata to ``metadata``)."""
    found = next((m for m in info.metadata if isinstance(m, Range)), None)
    return found if found is not None else _find_range(info.annotation)


def _case_issues(case: Case) -> list[Issue]:
    issues = _duplicates([(f"parameters[{i}].name", p.name)
                          for i, p in enumerate(case.parameters)], "parameter name")
    declared = {p.name: (i, p) for i, p in enumerate(case.parameters)}
    names = ", ".join(repr(n) for n in declared) or "none declared"
    used: set[str] = set()
    out_of_range: set[str] = set()
    for path, value, rng in _quantities(case.model, "model"):
        if not isinstance(value, str):
            continue
        used.add(value)
        if value not in declared:
            hint = _did_you_mean(value, list(declared))
            issues.append((path, f"parameter {value!r} is not declared in [[parameters]]{hint}",
                           f"a number, or a declared parameter: {names}"))
            continue
        i, p = declared[value]
        if not rng.contains_closed(p.lower, p.upper) and value not in out_of_range:
            out_of_range.add(value)  # once per parameter: its first use names the range
            side = "upper" if rng.contains_closed(p.lower, p.lower) else "lower"
            issues.append((f"parameters[{i}].{side}", f"parameter {value!r} has bounds "
                           f"[{format_value(p.lower)}, {format_value(p.upper)}] but is used "
                           f"at {path}", f"bounds {rng.interval()}"))
    for name, (i, _) in declared.items():
        if name not in used:
            issues.append((f"parameters[{i}].name", f"parameter {name!r} is declared but the "
                           "model never uses it", f'use it in [model] (e.g. k = "{name}") '
                           "or remove it"))
    if case.model.has_friction and case.simulation.method not in (None, "nonlinear"):
        issues.append(("simulation.method", f"got {case.simulation.method!r} but the model "
                       "has friction elements", "'nonlinear' (or leave it out)"))
    if case.data is not None:
        issues += _output_issues(case.model, case.data)
        rate = case.preprocess.resample_hz or case.data.rate
        if rate is not None and case.preprocess.highpass_hz >= rate / 2:
            cutoff = format_value(case.preprocess.highpass_hz)
            issues.append(("preprocess.highpass_hz", f"got {cutoff} for data at "
                           f"{format_value(rate)} Hz",
                           f"below the Nyquist frequency {format_value(rate / 2)} Hz"))
        band = case.preprocess.delay_band_hz
        auto = any(out.delay == "auto" for out in case.data.outputs)
        if auto and rate is not None and band[0] < band[1] and band[1] >= rate / 2:
            issues.append(("preprocess.delay_band_hz", f"got {format_value(band)} for data at "
                           f"{format_value(rate)} Hz (used by delay = \"auto\")",
                           f"0 < low < high < the Nyquist frequency {format_value(rate / 2)} "
                           "Hz, well below the first resonance"))
    return issues


def _output_issues(model: Model, data: Data) -> list[Issue]:
    issues: list[Issue] = []
    nodes = model.node_names()
    dofs = model.dof_names()
    fixed = model.fixed_dofs()
    for i, out in enumerate(data.outputs):
        path = f"data.outputs[{i}]"
        if out.node not in nodes:
            hint = _did_you_mean(out.node, list(nodes))
            shown = ", ".join(repr(n) for n in nodes[:20]) + (", ..." if len(nodes) > 20 else "")
            issues.append((f"{path}.node", f"unknown node {out.node!r}{hint}",
                           f"a node of the model: {shown}"))
        if out.dof not in dofs:
            issues.append((f"{path}.dof", f"got {out.dof!r}: not a DOF of this model",
                           ", ".join(repr(d) for d in dofs)))
        elif (out.node, out.dof) in fixed:
            issues.append((f"{path}.dof", f"{out.node}.{out.dof} is fixed by "
                           f"{fixed[out.node, out.dof]}: it moves with the table",
                           "a free DOF of the model"))
    return issues


# ----------------------------------------------------------------------------- loading


def load_case(path: str | os.PathLike[str]) -> Case:
    """Read and validate a case file.

    Parameters
    ----------
    path : str or PathLike
        The TOML case file.

    Returns
    -------
    Case
        The validated case; ``case.source`` is ``path``.

    Raises
    ------
    ConfigError
        The file cannot be read, is not valid TOML (the message gives line and column), or
        does not describe a valid case (the message lists every problem, one per line, as
        ``file: field.path: what is wrong (allowed: ...)``).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(f"case file not found: {path}") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: not a UTF-8 text file (byte {exc.start}); TOML files "
                          "are UTF-8") from None
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the case file: {exc.strerror}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(_toml_message(path, text, exc)) from None
    return parse_case(data, source=path)


def parse_case(data: Mapping[str, Any], source: str | os.PathLike[str] | None = None) -> Case:
    """Validate a case given as a mapping (the parsed TOML).

    Parameters
    ----------
    data : Mapping
        The case, as ``tomllib`` returns it.
    source : str or PathLike, optional
        The file it came from: messages name it, relative data paths start from its folder.

    Raises
    ------
    ConfigError
        Listing every problem found.
    """
    label = str(source) if source is not None else "case"
    try:
        case = Case.model_validate(dict(data))
    except ValidationError as exc:
        lines = _error_lines(label, exc)
        head = (f"{label}: {len(lines)} problem{'s' if len(lines) > 1 else ''} in the case "
                "file:\n  ")
        raise ConfigError(head + "\n  ".join(lines)) from None
    case._source = Path(source) if source is not None else None
    return case


def _toml_message(path: Path, text: str, exc: tomllib.TOMLDecodeError) -> str:
    match = re.search(r"^(.*) \(at line (\d+), column (\d+)\)$", str(exc))
    if match is None:  # "at end of document"
        return f"{path}: TOML syntax error: {exc}"
    what, line, column = match.group(1), int(match.group(2)), int(match.group(3))
    lines = text.splitlines()
    shown = lines[line - 1] if 0 < line <= len(lines) else ""
    return (f"{path}:{line}:{column}: TOML syntax error: {what} (line {line}, column {column})\n"
            f"    {shown}\n    {' ' * (column - 1)}^")


def _loc_path(loc: Sequence[str | int]) -> str:
    return _join(*loc) or "(top level)"


def _error_lines(label: str, exc: ValidationError) -> list[str]:
    lines = []
    for err in exc.errors(include_url=False):
        loc = tuple(err["loc"])
        ctx = err.get("ctx") or {}
        if err["type"] == "case_consistency":
            for rel, what, allowed in ctx["issues"]:
                path = _join(_join(*loc), rel) or "(top level)"
                lines.append(f"{label}: {path}: {what} (allowed: {allowed})")
            continue
        what, allowed = _describe(err, loc)
        tail = f" (allowed: {allowed})" if allowed else ""
        lines.append(f"{label}: {_loc_path(loc)}: {what}{tail}")
    return lines


_TYPE_WORDS = {
    "model_type": "a table",
    "model_attributes_type": "a table",
    "dict_type": "a table",
    "list_type": "an array",
    "string_type": "a string",
    "bool_type": "true or false",
    "int_type": "an integer",
    "float_type": "a number",
}


def _describe(err: Mapping[str, Any], loc: tuple[str | int, ...]) -> tuple[str, str]:
    kind = err["type"]
    ctx = err.get("ctx") or {}
    value = err.get("input")
    if "allowed" in ctx:  # our own validators
        return err["msg"], ctx["allowed"]
    if kind == "missing":
        return _missing(loc)
    if kind == "list_type" and isinstance(value, dict):
        name = _join(*loc)
        return (f"got a table where an array of tables is expected: write [[{name}]] "
                f"instead of [{name}]", f"[[{name}]] tables, or [ ... ]")
    if kind == "string_too_short":
        return f"got {format_value(value)}: empty", "a non-empty string"
    if kind == "string_too_long":
        return (f"got a text of {len(value)} characters",
                f"at most {ctx.get('max_length')} characters")
    if kind == "extra_forbidden":
        owner = _model_at(loc[:-1])
        fields = list(owner.model_fields) if owner is not None else []
        key = str(loc[-1])
        hint = _did_you_mean(key, fields)
        return f"unknown field {key!r}{hint}", ", ".join(fields)
    if kind == "literal_error":
        return f"got {format_value(value)}", ctx.get("expected", "").replace(" or ", ", ")
    if kind in ("too_short", "too_long"):
        low, high = _length_limits(loc)
        low = low if low is not None else ctx.get("min_length", 0)
        high = high if high is not None else ctx.get("max_length")
        allowed = (f"exactly {low} items" if low == high else
                   f"{low} to {high} items" if high is not None else f"at least {low} items")
        return f"got {ctx.get('actual_length', '?')} items", allowed
    if kind in _TYPE_WORDS:
        return f"got {format_value(value)}: not {_TYPE_WORDS[kind]}", _TYPE_WORDS[kind]
    if kind == "bool_parsing":
        return f"got {format_value(value)}", "true or false"
    return f"got {format_value(value)}: {err['msg']}", ""


def _missing(loc: tuple[str | int, ...]) -> tuple[str, str]:
    name = _join(*loc)
    field = _field_at(loc)
    if field is None:
        return "required field is missing", ""
    rng = _field_range(field)
    tp = _unwrap(field.annotation)
    if rng is not None:
        return "required field is missing", rng.describe()
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return f"required section [{name}] is missing", f"a [{name}] table"
    if typing.get_origin(tp) is list:
        item = _unwrap(typing.get_args(tp)[0])
        if isinstance(item, type) and issubclass(item, BaseModel):
            return f"required [[{name}]] is missing", f"at least one [[{name}]] table"
    if typing.get_origin(tp) is Literal:
        return "required field is missing", ", ".join(repr(a) for a in typing.get_args(tp))
    return "required field is missing", ""


def _length_limits(loc: Sequence[str | int]) -> tuple[int | None, int | None]:
    """(min_length, max_length) declared for the array field at ``loc``."""
    field = _field_at(loc)
    if field is None:
        return None, None
    found: dict[str, int] = {}

    def visit(metadata: Sequence[Any]) -> None:
        for meta in metadata:
            for key in ("min_length", "max_length"):
                if getattr(meta, key, None) is not None:
                    found.setdefault(key, getattr(meta, key))
            visit(getattr(meta, "metadata", ()))

    visit(field.metadata)
    tp = field.annotation
    for arg in (tp, *typing.get_args(tp)):  # Optional[Annotated[list, Field(...)]]
        visit(getattr(arg, "__metadata__", ()))
    return found.get("min_length"), found.get("max_length")


def _unwrap(tp: Any) -> Any:
    """Strip Annotated and Optional layers of a type annotation."""
    while True:
        origin = typing.get_origin(tp)
        if origin is Annotated:
            tp = typing.get_args(tp)[0]
        elif origin in (typing.Union, types.UnionType):
            args = [a for a in typing.get_args(tp) if a is not type(None)]
            if len(args) != 1:
                return tp
            tp = args[0]
        else:
            return tp


def _field_at(loc: Sequence[str | int]) -> Any:
    """The pydantic FieldInfo of the field at ``loc`` (None if not a model field)."""
    if not loc or not isinstance(loc[-1], str):
        return None
    owner = _model_at(loc[:-1])
    if owner is None:
        return None
    return owner.model_fields.get(loc[-1])


def _model_at(loc: Sequence[str | int]) -> type[BaseModel] | None:
    """The model class of the table at ``loc`` (walking fields and list items from Case)."""
    tp: Any = Case
    for key in loc:
        tp = _unwrap(tp)
        if isinstance(key, int):
            if typing.get_origin(tp) is not list:
                return None
            tp = typing.get_args(tp)[0]
        elif isinstance(tp, type) and issubclass(tp, BaseModel) and key in tp.model_fields:
            tp = tp.model_fields[key].annotation
        else:
            return None
    tp = _unwrap(tp)
    return tp if isinstance(tp, type) and issubclass(tp, BaseModel) else None


# ----------------------------------------------------------------------------- Structure


def build_structure(model: Model) -> Structure:
    """The ``femupdate.model.Structure`` described by ``[model]``.

    Numbers that name a parameter stay names: ``structure.assemble(values,
    direction=model.excitation_direction)`` substitutes them. Elements without a ``name`` are
    named by their place in the case file (``"model.springs[2]"``), so the model's own error
    messages point into the file.

    Parameters
    ----------
    model : Model
        ``case.model`` of a validated case.

    Returns
    -------
    Structure
        With its topology built (DOF map checked).
    """
    from femupdate.model.structure import Structure, shear_building

    if model.shear_building is not None:
        sb = model.shear_building
        structure = shear_building(sb.masses, sb.stiffnesses, sb.dampers)
    else:
        structure = Structure(dofs_per_node=model.dofs_per_node)
        for node in model.nodes:
            structure.add_node(node.name, x=node.x, y=node.y)
        for i, beam in enumerate(model.beams):
            structure.add_beam(
                beam.nodes[0], beam.nodes[1], E=beam.E, A=beam.A, I=beam.I, rho=beam.rho,
                G=beam.G, nu=beam.nu, kappa=beam.kappa, mass_per_length=beam.mass_per_length,
                rotary_inertia=beam.rotary_inertia, name=beam.name or f"model.beams[{i}]")
        for i, spring in enumerate(model.springs):
            structure.add_spring(spring.node, spring.dof, spring.k, node2=spring.node2,
                                 dof2=spring.dof2, name=spring.name or f"model.springs[{i}]")
        for i, damper in enumerate(model.dampers):
            structure.add_damper(damper.node, damper.dof, damper.c, node2=damper.node2,
                                 dof2=damper.dof2, name=damper.name or f"model.dampers[{i}]")
        for i, fr in enumerate(model.frictions):
            structure.add_friction(fr.node, fr.dof, fr.k_r, fr.f_u, node2=fr.node2,
                                   dof2=fr.dof2, name=fr.name or f"model.frictions[{i}]")
        for i, mass in enumerate(model.masses):
            structure.add_mass(mass.node, m=mass.m, J=mass.J, name=f"model.masses[{i}]")
        for support in model.supports:
            structure.fix(support.node, *support.dofs)
    if model.rayleigh is not None:
        structure.set_rayleigh(alpha=model.rayleigh.alpha, beta=model.rayleigh.beta)
    structure.influence_vector(model.excitation_direction)  # builds and checks the topology
    return structure

"""Field types of case files: numbers with ranges and units, names, columns, delays, options.

A ``Range`` is both a field's pydantic validator and the description its error messages quote
("a number in [0, 1e13] (Pa) or a parameter name"); the sections of ``schema`` are built from
these types only.
"""

from __future__ import annotations

import math
import os
import re
import types
import typing
from dataclasses import dataclass
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, PlainValidator, WithJsonSchema
from pydantic_core import PydanticCustomError

from femupdate.case.expressions import ALLOWED, ExpressionError, parse_expression
from femupdate.errors import ConfigError

#: DOF names of a node, by ``model.dofs_per_node``.
DOF_NAMES: dict[int, tuple[str, ...]] = {2: ("uy", "rz"), 3: ("ux", "uy", "rz"),
                                         6: ("ux", "uy", "uz", "rx", "ry", "rz")}

PARAMETER_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_\-]*")
ENV_VAR = re.compile(r"\$\{([^}]*)\}")
_MAX_NAME = 64
_RESERVED = frozenset({"inf", "nan", "infinity", "true", "false"})  # read as values elsewhere
SIGMA_MAX = math.sqrt(1.0 / 12.0)  # standard deviation of the uniform law on [0, 1]

DofName = Literal["ux", "uy", "uz", "rx", "ry", "rz"]
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

    ``parameter`` fields also accept the name of a parameter declared in ``[[parameters]]``,
    or an expression of parameters (:mod:`femupdate.case.expressions`).
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
            text += " or a parameter name or expression"
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
            if is_number(value):
                raise PydanticCustomError(
                    "quoted_number", "got {got}: a number in quotes; remove the quotes",
                    {**allowed, "got": repr(value)})
            try:  # an expression of parameters: its names are checked with [[parameters]]
                parse_expression(value)
            except ExpressionError as exc:
                raise PydanticCustomError(
                    "parameter_expression",
                    "got {got}: not a parameter name (letters, digits and _, not starting "
                    "with a digit) nor an expression of parameters: {why}",
                    {"allowed": f"{self.describe()}; an expression may contain {ALLOWED}",
                     "got": repr(value), "why": str(exc)}) from None
            return value
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
            return {"anyOf": [schema, {"type": "string", "description": "a parameter name, or an "
                                       "expression of parameters such as 0.5 * beta"}]}
        return schema


def _is_parameter_name(text: str) -> bool:
    return (bool(PARAMETER_NAME.fullmatch(text)) and len(text) <= _MAX_NAME
            and text.lower() not in _RESERVED)


def is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def number_field(unit: str = "", **bounds: Any) -> Any:
    """Annotated float field checked by ``Range`` (finite, with bounds)."""
    rng = Range(unit=unit, **bounds)
    return Annotated[float, PlainValidator(rng), WithJsonSchema(rng.json_schema()), rng]


def integer_field(**bounds: Any) -> Any:
    rng = Range(integer=True, **bounds)
    return Annotated[int, PlainValidator(rng), WithJsonSchema(rng.json_schema()), rng]


def quantity_field(unit: str = "", **bounds: Any) -> Any:
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
        hint = "; a number in quotes: remove the quotes" if is_number(value) else ""
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


def text_field(max_length: int = 2000, min_length: int = 0) -> Any:
    return Annotated[str, Field(min_length=min_length, max_length=max_length)]


NodeName = _name_check("node name", _NAME,
                       "letters, digits, _ and -, not starting with -, at most 64 characters")
ElementName = _name_check("name", _NAME,
                          "letters, digits, _ and -, not starting with -, at most 64 characters")
ParameterName = _name_check("parameter name", PARAMETER_NAME,
                            "letters, digits and _, not starting with a digit, "
                            "at most 64 characters, not inf or nan", _RESERVED)
Column = Annotated[str | int, PlainValidator(_column_check),
                   WithJsonSchema({"anyOf": [{"type": "string"}, {"type": "integer"}]})]
Options = Annotated[dict[str, Any], PlainValidator(_options_check),
                    WithJsonSchema({"type": "object"})]
Delay = Annotated[float | str, PlainValidator(_delay_check), WithJsonSchema(
    {"anyOf": [_DELAY_RANGE.json_schema(), {"const": "auto"}]})]

# Generous physical ranges: they catch slips of units and signs, not unusual structures.
Coordinate = number_field("m", ge=-1e6, le=1e6)
Modulus = quantity_field("Pa", ge=0.0, le=1e13)
PositiveModulus = quantity_field("Pa", gt=0.0, le=1e13)
Poisson = quantity_field(gt=-1.0, le=0.5)
Area = quantity_field("m2", gt=0.0, le=1e4)
SecondMoment = quantity_field("m4", gt=0.0, le=1e4)
Density = quantity_field("kg/m3", ge=0.0, le=1e6)
ShearFactor = quantity_field(gt=0.0, le=100.0)
MassPerLength = quantity_field("kg/m", ge=0.0, le=1e9)
Stiffness = quantity_field("N/m, or N·m/rad for a rotation", ge=0.0, le=1e15)
DampingCoefficient = quantity_field("N·s/m, or N·m·s/rad for a rotation", ge=0.0, le=1e12)
SlipForce = quantity_field("N, or N·m for a rotation", ge=0.0, le=1e12)
NodalMass = quantity_field("kg", ge=0.0, le=1e9)
# Bouc–Wen elements (femupdate.model.hysteresis); the pair (beta, gamma) is checked together.
InitialStiffness = quantity_field("N/m, or N·m/rad for a rotation", gt=0.0, le=1e15)
StiffnessRatio = quantity_field(ge=0.0, le=1.0)
BoucWenA = quantity_field(gt=0.0, le=1e6)
BoucWenShape = quantity_field("1/m^n, or 1/rad^n for a rotation", gt=0.0, le=1e30)
BoucWenGamma = quantity_field("1/m^n, or 1/rad^n for a rotation", ge=-1e30, le=1e30)
BoucWenExponent = quantity_field(gt=0.0, le=100.0)
# Baber–Wen degradation rates per unit of hysteretic energy (J = N·m)
BoucWenDegradation = quantity_field("1/J", ge=0.0, le=1e30)
RotaryInertia = quantity_field("kg·m2", ge=0.0, le=1e9)
RayleighAlpha = quantity_field("1/s", ge=0.0, le=1e4)
RayleighBeta = quantity_field("s", ge=0.0, le=1.0)
ParameterValue = number_field(ge=-1e30, le=1e30)


class Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)


def find_range(tp: Any, into_lists: bool = False) -> Range | None:
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
            found = find_range(arg, into_lists)
            if found is not None:
                return found
    return None


def field_range(info: Any) -> Range | None:
    """The ``Range`` of a scalar field (pydantic moves top-level metadata to ``metadata``)."""
    found = next((m for m in info.metadata if isinstance(m, Range)), None)
    return found if found is not None else find_range(info.annotation)


def env_syntax(text: str) -> list[str]:
    problems = [f"${{{name}}}: not a variable name" for name in ENV_VAR.findall(text)
                if not PARAMETER_NAME.fullmatch(name)]
    if "${" in ENV_VAR.sub("", text):
        problems.append(f"got {text!r}: '${{' without a closing '}}'")
    return problems


def expand_env(text: str, where: str, source: str) -> str:
    def value(match: re.Match[str]) -> str:
        name = match.group(1)
        if name not in os.environ:
            raise ConfigError(f"{source}: {where}: environment variable {name} is not set "
                              f"(allowed: set it, e.g. export {name}=/path/to/data, or write "
                              "the path)")
        return os.environ[name]

    return ENV_VAR.sub(value, text)

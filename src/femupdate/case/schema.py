"""The sections of a case file as pydantic models (``extra="forbid"``, bounds on every number).

``Case`` is the whole file; each section class documents its TOML table. What one field cannot
check alone is checked by ``checks`` from the sections' validators; ``load`` turns pydantic's
errors into messages naming file, field and allowed values.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import Field, PrivateAttr, model_validator

from femupdate.case.checks import case_issues, model_issues
from femupdate.case.fields import (
    DOF_NAMES,
    SIGMA_MAX,
    AccelerationUnit,
    Area,
    Column,
    Coordinate,
    DampingCoefficient,
    Delay,
    Density,
    DofName,
    ElementName,
    MassPerLength,
    Modulus,
    NodalMass,
    NodeName,
    Options,
    ParameterName,
    ParameterValue,
    Poisson,
    PositiveModulus,
    RayleighAlpha,
    RayleighBeta,
    RotaryInertia,
    SecondMoment,
    Section,
    ShearFactor,
    SlipForce,
    Stiffness,
    env_syntax,
    expand_env,
    format_value,
    integer_field,
    number_field,
    text_field,
)
from femupdate.case.issues import Issue, duplicates, raise_issues
from femupdate.errors import ConfigError

# ----------------------------------------------------------------------------- [case]


class CaseInfo(Section):
    """``[case]``: what the job is."""

    name: text_field(200, 1)
    description: text_field(10_000) = ""


# ----------------------------------------------------------------------------- [model]


class Node(Section):
    """``[[model.nodes]]``: a node in the plane of the model."""

    name: NodeName
    x: Coordinate
    y: Coordinate = 0.0


class Beam(Section):
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
        raise_issues(issues)
        return self


class _Link(Section):
    """An element at one DOF, to the base (ground), or between two DOFs."""

    node: NodeName
    dof: DofName
    node2: NodeName | None = None
    dof2: DofName | None = None
    name: ElementName | None = None

    @model_validator(mode="after")
    def _check(self) -> _Link:
        if self.dof2 is not None and self.node2 is None:
            raise_issues([("dof2", f"dof2 = {self.dof2!r} without node2",
                            "node2 with dof2 (between two DOFs), or neither (to the base)")])
        if self.node2 == self.node and self.second_dof == self.dof:
            raise_issues([("node2", f"connects {self.node}.{self.dof} to itself",
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


class Mass(Section):
    """``[[model.masses]]``: a lumped mass on the node's translations and a rotary inertia."""

    node: NodeName
    m: NodalMass
    J: RotaryInertia = 0.0


class Support(Section):
    """``[[model.supports]]``: DOFs fixed to the base (they move with the table)."""

    node: NodeName
    dofs: Annotated[list[DofName], Field(min_length=1, max_length=3)]

    @model_validator(mode="after")
    def _check(self) -> Support:
        raise_issues([(f"dofs[{i}]", f"{dof!r} is listed twice", "each DOF once")
                       for i, dof in enumerate(self.dofs) if dof in self.dofs[:i]])
        return self


class Rayleigh(Section):
    """``[model.rayleigh]``: damping ``C += alpha M + beta K``."""

    alpha: RayleighAlpha = 0.0
    beta: RayleighBeta = 0.0


class ShearBuilding(Section):
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
        raise_issues(issues)
        return self

    @property
    def floors(self) -> tuple[str, ...]:
        """Node names of the floors: ``"F1"`` (above storey 1) to ``"Fn"`` (the roof)."""
        return tuple(f"F{i + 1}" for i in range(len(self.masses)))



class Model(Section):
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
        raise_issues(model_issues(self))
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



# ----------------------------------------------------------------------------- [[parameters]]


class Parameter(Section):
    """``[[parameters]]``: an unknown of the model, searched between its bounds."""

    name: ParameterName
    lower: ParameterValue
    upper: ParameterValue
    scale: Literal["linear", "log"] = "linear"
    unit: text_field(40) = ""
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
        raise_issues(issues)
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


class Channel(Section):
    """``[data.input]``: the base (table) acceleration channel."""

    file: text_field(4096, 1)
    column: Column
    unit: AccelerationUnit | None = None


class OutputChannel(Channel):
    """``[[data.outputs]]``: a measured absolute acceleration at a DOF of the model."""

    node: NodeName
    dof: DofName
    weight: number_field(gt=0.0, le=1e6) = 1.0
    name: ElementName | None = None
    delay: Delay = 0.0

    @property
    def label(self) -> str:
        return self.name if self.name is not None else f"{self.node}.{self.dof}"


class Data(Section):
    """``[data]``: where the measured accelerations are and how to read them."""

    format: Literal["csv", "npz", "uff"]
    directory: text_field(4096) | None = None
    time_column: Column | None = None
    time_unit: Literal["s", "ms", "us"] = "s"
    rate: number_field("Hz", gt=0.0, le=1e7) | None = None
    skip_lines: integer_field(ge=0, le=1_000_000) | None = None
    header: bool | None = None
    delimiter: text_field(8, 1) | None = None
    comments: text_field(8, 1) = "#"
    skip_rows: integer_field(ge=0, le=1_000_000) = 0
    window: Annotated[list[number_field("s", ge=0.0, le=1e7)],
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
                       for problem in env_syntax(self.directory)]
        channels = [("input", self.input)] + [(f"outputs[{i}]", c)
                                              for i, c in enumerate(self.outputs)]
        for path, channel in channels:
            issues += [(f"{path}.file", p, "${NAME} with NAME a variable name")
                       for p in env_syntax(channel.file)]
            if self.format == "csv" and isinstance(channel.column, str) and self.header is False:
                issues.append((f"{path}.column", f"got {channel.column!r} but header = false",
                               "a 0-based column number, or header = true"))
            if self.format != "csv" and not isinstance(channel.column, str):
                issues.append((f"{path}.column", f"got {channel.column}: channels of "
                               f"{self.format.upper()} files have names",
                               "the name of the channel in the file"))
        issues += duplicates([(f"outputs[{i}]", c.label) for i, c in enumerate(self.outputs)],
                              "output channel", "data")
        raise_issues(issues)
        return self



# ----------------------------------------------------------------------------- the job


class Preprocess(Section):
    """``[preprocess]``: signal processing of the measured data and integration substeps."""

    highpass_hz: number_field("Hz", ge=0.0, le=1e6) = 0.0
    highpass_order: integer_field(ge=1, le=8) = 4
    zero_phase: bool = False
    resample_hz: number_field("Hz", gt=0.0, le=1e7) | None = None
    substeps: integer_field(ge=1, le=1000) = 1
    delay_band_hz: Annotated[list[number_field("Hz", gt=0.0, le=1e7)],
                             Field(min_length=2, max_length=2)] = Field(
        default_factory=lambda: [1.0, 10.0])
    filter_prediction: bool | None = None

    @model_validator(mode="after")
    def _check(self) -> Preprocess:
        low, high = self.delay_band_hz
        if low >= high:
            raise_issues([("delay_band_hz", f"got {format_value(self.delay_band_hz)}: low is "
                            "not below high", "[low, high] with 0 < low < high, Hz")])
        return self


class ObjectiveOptions(Section):
    """``[objective]``: what the error function compares (the paper's §2.1 and §5.2;
    docs/method.md)."""

    quantity: Literal["displacement", "acceleration"] = "displacement"
    experimental_parameters: bool = True
    integrate_prediction: bool = True


class Simulation(Section):
    """``[simulation]``: the integrator (None: exact for linear models, nonlinear if friction)."""

    method: Literal["exact", "central_difference", "newmark", "nonlinear"] | None = None


class Search(Section):
    """``[search]``: the optimiser, its stopping criteria and the repeated runs."""

    method: Literal["ab", "ib", "cmaes", "de", "ga"] = "ab"
    runs: integer_field(ge=1, le=10_000) = 1
    seed: integer_field(ge=0, le=2**63 - 1) | None = None
    workers: integer_field(ge=1, le=1024) = 1
    max_evals: integer_field(ge=1, le=10**9) = 5000
    f_target: number_field(ge=0.0, le=1e6) | None = None
    sigma_min: number_field(gt=0.0, lt=SIGMA_MAX) | None = None
    f_change_min: number_field(ge=0.0, le=1e6) | None = None
    options: Options = Field(default_factory=dict)


# ----------------------------------------------------------------------------- Case


class Case(Section):
    """A validated case file. Build it with ``load_case(path)`` or ``parse_case(mapping)``."""

    case: CaseInfo
    model: Model
    parameters: list[Parameter] = Field(default_factory=list)
    data: Data | None = None
    preprocess: Preprocess = Field(default_factory=Preprocess)
    objective: ObjectiveOptions = Field(default_factory=ObjectiveOptions)
    simulation: Simulation = Field(default_factory=Simulation)
    search: Search = Field(default_factory=Search)

    _source: Path | None = PrivateAttr(default=None)

    @model_validator(mode="after")
    def _check(self) -> Case:
        raise_issues(case_issues(self))
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
        directory = Path(expand_env(self.data.directory, "data.directory", self.label)).expanduser()
        return directory if directory.is_absolute() else base / directory

    def data_path(self, channel: Channel) -> Path:
        """Path of a channel's file (``${VAR}`` expanded; relative to ``data_directory()``)."""
        path = Path(expand_env(channel.file, "data file", self.label)).expanduser()
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

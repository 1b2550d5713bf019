"""The sections of a case file as pydantic models (``extra="forbid"``, bounds on every number).

The ``[model]`` sections are in :mod:`femupdate.case.model_sections`.

``Case`` is the whole file; each section class documents its TOML table. What one field cannot
check alone is checked by ``checks`` from the sections' validators; ``load`` turns pydantic's
errors into messages naming file, field and allowed values.

Why this file is long (about 600 lines): ``Case`` validates across its sections, so the sections
it holds directly stay beside it, each a pydantic model with its fields' bounds; the
``[model]`` and ``[posterior]`` sections and the cross-field checks already live apart.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import Field, PrivateAttr, model_validator

from femupdate.case.checks import case_issues
from femupdate.case.fields import (
    SIGMA_MAX,
    AccelerationUnit,
    Column,
    Delay,
    DofName,
    ElementName,
    NodeName,
    Options,
    ParameterName,
    ParameterValue,
    Section,
    env_syntax,
    expand_env,
    format_value,
    integer_field,
    number_field,
    text_field,
)
from femupdate.case.issues import Issue, did_you_mean, duplicates, raise_issues
from femupdate.case.model_sections import (
    Model,
)
from femupdate.case.posterior_section import PosteriorSection, posterior_issues
from femupdate.case.simulation_path import reduced_by_default, simulation_issues
from femupdate.data.defects import KINDS, REPAIRABLE
from femupdate.data.network import FORMATS as NETWORK_FORMATS
from femupdate.errors import ConfigError
from femupdate.optimize.registry import METHODS

# ----------------------------------------------------------------------------- [case]


class CaseInfo(Section):
    """``[case]``: what the job is."""

    name: text_field(200, 1)
    description: text_field(10_000) = ""


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


class ConstraintRule(Section):
    """``[[constraints]]``: a condition between parameters, ``rule = "gamma <= beta"``
    (:mod:`femupdate.case.expressions`); a searched point where it fails is a failed
    evaluation, and the checks of the box leave such points out (:mod:`femupdate.case.derived`).
    """

    rule: text_field(400, 1)


# ----------------------------------------------------------------------------- [data]


class Channel(Section):
    """``[data.input]``: the base (table) acceleration channel; ``[data.inputs.<group>]``:
    a support group's (``[[model.support_groups]]``)."""

    file: text_field(4096, 1)
    column: Column
    unit: AccelerationUnit | None = None


class InputChannel(Channel):
    """``[data.input]``: the base (table) acceleration channel, along the model's direction;
    with ``angle``, along that direction of the horizontal plane (degrees from x towards y):
    the record moves the base by ``a cos θ`` along x and ``a sin θ`` along y."""

    angle: number_field("deg", ge=0.0, lt=360.0) | None = None


class ComponentChannel(Channel):
    """``[[data.components]]``: one component of a uniform base motion, its own record along
    ``direction`` (every support moves with every component)."""

    direction: Literal["x", "y", "z"]


class OutputChannel(Channel):
    """``[[data.outputs]]``: a measured absolute acceleration at a DOF of the model."""

    node: NodeName | None = None
    dof: DofName | None = None
    weight: number_field(gt=0.0, le=1e6) = 1.0
    name: ElementName | None = None
    delay: Delay = 0.0
    # multi-support cases: the record is relative to this support group's ground motion
    relative_to: ElementName | None = None

    @property
    def label(self) -> str:
        if self.name is not None:
            return self.name
        return f"{self.node}.{self.dof}" if self.node is not None else str(self.column)


#: A time window [t_start, t_end] of a record, s.
Window = Annotated[list[number_field("s", ge=0.0, le=1e7)], Field(min_length=2, max_length=2)]


def _window_issues(window: list[float] | None, key: str) -> list[Issue]:
    if window is not None and window[0] >= window[1]:
        return [(key, f"got {format_value(window)}: t_start is not before t_end",
                 "[t_start, t_end] with t_start < t_end (s)")]
    return []


DefectKind = Literal["clock-offset", "clock-drift", "misaligned", "duplicate", "spike",
                     "saturation", "unit", "time-unit", "rate", "short"]
RepairableKind = Literal["clock-offset", "spike"]


def _defect_list_issues(accept: list[str], repair: list[str]) -> list[Issue]:
    """``accept`` and ``repair_defects``: each kind once, and never in both (a defect is
    either left as it is, said, or repaired; both were taken without a word)."""
    issues: list[Issue] = []
    for key, kinds in (("accept", accept), ("repair_defects", repair)):
        twice = sorted({k for k in kinds if kinds.count(k) > 1})
        if twice:
            issues.append((key, f"names {', '.join(twice)} more than once", "each kind once"))
    both = sorted(set(accept) & set(repair))
    if both:
        issues.append(("repair_defects", f"names {', '.join(both)}, which accept also names: "
                       "a defect is either accepted as it is or repaired",
                       "each kind in one of accept and repair_defects"))
    return issues


class Data(Section):
    """``[data]``: where the measured accelerations are and how to read them."""

    format: Literal["csv", "npz", "uff", "csmip", "cosmos", "at2"]
    directory: text_field(4096) | None = None
    time_column: Column | None = None
    time_unit: Literal["s", "ms", "us"] = "s"
    rate: number_field("Hz", gt=0.0, le=1e7) | None = None
    skip_lines: integer_field(ge=0, le=1_000_000) | None = None
    header: bool | None = None
    delimiter: text_field(8, 1) | None = None
    comments: text_field(8, 1) = "#"
    skip_rows: integer_field(ge=0, le=1_000_000) = 0
    window: Window | None = None
    repair: bool = False
    # the defect checks (femupdate.data.defects): kinds a case accepts, kinds it repairs
    accept: Annotated[list[DefectKind], Field(max_length=len(KINDS))] = Field(
        default_factory=list)
    repair_defects: Annotated[list[RepairableKind], Field(max_length=len(REPAIRABLE))] = Field(
        default_factory=list)
    unit: AccelerationUnit = "m/s2"
    input: InputChannel | None = None
    # multi-support excitation: one channel per [[model.support_groups]], by group name
    inputs: dict[ElementName, Channel] | None = None
    # uniform base motion with several components: one channel per direction
    components: Annotated[list[ComponentChannel], Field(min_length=1, max_length=3)] | None = None
    outputs: Annotated[list[OutputChannel], Field(min_length=1, max_length=10_000)]

    def input_channels(self) -> list[tuple[str, str, Channel]]:
        """(name once read, field, channel) of the input channels: ``"input"`` (the table),
        ``"input.<group>"`` for each support group's, or ``"input.<direction>"`` for each
        component of the base motion."""
        if self.inputs is not None:
            return [(f"input.{group}", f"inputs.{group}", channel)
                    for group, channel in self.inputs.items()]
        if self.components is not None:
            return [(f"input.{c.direction}", f"components[{i}]", c)
                    for i, c in enumerate(self.components)]
        return [("input", "input", self.input)] if self.input is not None else []

    @property
    def base_directions(self) -> tuple[str, ...]:
        """The directions of a base motion with several components, in the order of its
        columns: those of ``[[data.components]]``, ("x", "y") for an input with an ``angle``;
        () for one record along the model's direction (or support groups)."""
        if self.components is not None:
            return tuple(c.direction for c in self.components)
        if self.input is not None and self.input.angle is not None:
            return ("x", "y")
        return ()

    @property
    def angle(self) -> float | None:
        """The input's ``angle`` (degrees), if it has one."""
        return self.input.angle if self.input is not None else None

    def _given(self, key: str) -> bool:
        """Whether ``key`` was given a value other than its default (a saved case, which
        holds every default, reads back as the case it was)."""
        return (key in self.model_fields_set
                and getattr(self, key) != type(self).model_fields[key].get_default(
                    call_default_factory=True))

    @model_validator(mode="after")
    def _check(self) -> Data:
        issues: list[Issue] = []
        network = self.format in NETWORK_FORMATS
        if self.format != "csv":
            for key in ("time_column", "rate"):
                if getattr(self, key) is not None:
                    issues.append((key, f"given for format = {self.format!r}",
                                   "nothing: NPZ files hold their times in the array 't', "
                                   "UFF58 files carry their own time axis, network records "
                                   "their interval in the header"))
            for key in ("skip_lines", "header", "delimiter", "repair"):
                if self._given(key):
                    issues.append((key, f"given for format = {self.format!r}",
                                   "nothing: a CSV option"))
        elif (self.time_column is None) == (self.rate is None):
            what = "both given" if self.rate is not None else "neither given"
            issues.append(("rate", f"time_column and rate: {what}",
                           "either time_column (a column of times) or rate (Hz)"))
        elif self.rate is not None and self._given("time_unit"):
            issues.append(("time_unit", "given with rate and no time_column: the times come "
                           "from the rate, this unit would change nothing",
                           "time_unit with time_column only"))
        if network and self._given("unit"):
            issues.append(("unit", f"given for format = {self.format!r}",
                           "nothing: network records say their units in the header, and "
                           "femupdate converts them to m/s2"))
        issues += _window_issues(self.window, "window")
        given = [key for key in ("input", "inputs", "components")
                 if getattr(self, key) is not None]
        if len(given) > 1:
            issues.append((given[1], f"both data.{given[0]} and data.{given[1]} are given",
                           "one of data.input (one table record), data.inputs (one record per "
                           "[[model.support_groups]]) and [[data.components]] (one record "
                           "per direction of a uniform base motion)"))
        elif not given:
            issues.append(("input", "missing", "[data.input] (the table record), "
                           "[data.inputs.<group>] for each [[model.support_groups]], or "
                           "[[data.components]] (one record per direction)"))
        if self.components is not None:
            seen: dict[str, int] = {}
            for i, c in enumerate(self.components):
                if c.direction in seen:
                    issues.append((f"components[{i}].direction", f"got {c.direction!r}, "
                                   f"already the direction of components[{seen[c.direction]}]",
                                   "each direction once: 'x', 'y', 'z'"))
                seen.setdefault(c.direction, i)
        if self.directory is not None:
            issues += [("directory", problem, "${NAME} with NAME a variable name")
                       for problem in env_syntax(self.directory)]
        channels = [(path, c) for _, path, c in self.input_channels()] + [
            (f"outputs[{i}]", c) for i, c in enumerate(self.outputs)]
        for path, channel in channels:
            issues += [(f"{path}.file", p, "${NAME} with NAME a variable name")
                       for p in env_syntax(channel.file)]
            if self.format == "csv" and isinstance(channel.column, str) and self.header is False:
                issues.append((f"{path}.column", f"got {channel.column!r} but header = false",
                               "a 0-based column number, or header = true"))
            if network and channel.unit is not None:
                issues.append((f"{path}.unit", f"given for format = {self.format!r}",
                               "nothing: the units come from the record's header"))
            if self.format in ("npz", "uff") and not isinstance(channel.column, str):
                issues.append((f"{path}.column", f"got {channel.column}: channels of "
                               f"{self.format.upper()} files have names",
                               "the name of the channel in the file"))
        issues += duplicates([(f"outputs[{i}]", c.label) for i, c in enumerate(self.outputs)],
                              "output channel", "data")
        issues += _defect_list_issues(self.accept, self.repair_defects)
        raise_issues(issues)
        return self



class Trial(Section):
    """``[[trials]]``: one test of the specimen: a record, or a part of one, fitted or
    validated.

    The model and the parameters are shared by all trials; each trial names its records
    (``input``, ``outputs``, ``directory``, ``window``; what it leaves out comes from
    ``[data]``, which also says how to read them). ``role = "fit"`` trials make up φ (the mean
    of their NMSE weighted by ``weight``); ``"validate"`` trials are predicted by the fitted
    model and scored, never fitted. ``score_window`` scores part of the simulated record
    only: the model is simulated over the whole ``window`` (from rest at its start) and the
    error is taken over ``score_window`` (record time, s), so one record splits into a fitting
    and a validation part without restarting the model mid-record. ``file`` replaces the file
    of every channel of the trial (input and outputs, its own or ``[data]``'s): another event
    of one station, archived under the same channel numbers, is one line.
    """

    name: ElementName
    role: Literal["fit", "validate"] = "fit"
    weight: number_field(gt=0.0, le=1e6) = 1.0
    directory: text_field(4096) | None = None
    file: text_field(4096) | None = None
    input: InputChannel | None = None
    inputs: dict[ElementName, Channel] | None = None
    components: Annotated[list[ComponentChannel], Field(min_length=1, max_length=3)] | None = None
    outputs: Annotated[list[OutputChannel], Field(min_length=1, max_length=10_000)] | None = None
    window: Window | None = None
    score_window: Window | None = None

    @model_validator(mode="after")
    def _check(self) -> Trial:
        issues = _window_issues(self.window, "window")
        issues += _window_issues(self.score_window, "score_window")
        if (self.window is not None and self.score_window is not None
                and not self.window[0] <= self.score_window[0] < self.score_window[1]
                <= self.window[1]):
            issues.append(("score_window", f"got {format_value(self.score_window)} outside "
                           f"window {format_value(self.window)}",
                           "a part of the trial's window"))
        raise_issues(issues)
        return self


@dataclass(frozen=True)
class TrialSpec:
    """A trial resolved against ``[data]``: its full ``Data`` (records, reading options,
    window) and its role, weight and scored window."""

    name: str
    role: str
    weight: float
    data: Data
    score_window: tuple[float, float] | None
    path: str  # where in the case file it is defined: "trials[2]" or "data"


# ----------------------------------------------------------------------------- the job


class Preprocess(Section):
    """``[preprocess]``: signal processing of the measured data and integration substeps."""

    highpass_hz: number_field("Hz", ge=0.0, le=1e6) = 0.0
    highpass_order: integer_field(ge=1, le=8) = 4
    lowpass_hz: number_field("Hz", gt=0.0, le=1e6) | None = None
    lowpass_order: integer_field(ge=1, le=8) = 4
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
        if self.lowpass_hz is not None and self.lowpass_hz <= self.highpass_hz:
            raise_issues([("lowpass_hz", f"got {format_value(self.lowpass_hz)}, not above "
                           f"highpass_hz = {format_value(self.highpass_hz)}",
                           "a low-pass above the high-pass, Hz")])
        return self


class ObjectiveOptions(Section):
    """``[objective]``: what the error function compares (the paper's §2.1 and §5.2;
    docs/method.md)."""

    quantity: Literal["displacement", "acceleration"] = "displacement"
    experimental_parameters: bool = True
    integrate_prediction: bool = True


class Simulation(Section):
    """``[simulation]``: the integrator (None: exact for linear models, nonlinear if friction;
    ``"implicit"``: Newmark with Newton iterations, for stiff nonlinear elements)."""

    method: Literal["exact", "central_difference", "newmark", "nonlinear", "implicit",
                    "reduced"] | None = None
    # the reduced path's (femupdate.problem.reduced_path): modes kept up to cutoff_factor × the
    # fitted band, or the lowest n_modes
    cutoff_factor: number_field(ge=1.0, le=1e3) | None = None
    n_modes: integer_field(ge=1, le=10**7) | None = None
    # the implicit scheme's HHT α (given, or chosen for a nonlinear model): 0 is Newmark's
    # average acceleration; below 0 it damps the unresolved high modes of stiff links
    hht_alpha: number_field(ge=-1.0 / 3.0, le=0.0) | None = None


#: ``[search] agree`` when not given (femupdate.runs.verdict.AGREE).
AGREE_DEFAULT = 2


class Search(Section):
    """``[search]``: the optimiser, its stopping criteria and the repeated runs."""

    method: str = "multistart-lm"
    runs: integer_field(ge=1, le=10_000) = 1
    seed: integer_field(ge=0, le=2**63 - 1) | None = None
    workers: integer_field(ge=1, le=1024) = 1
    max_evals: integer_field(ge=1, le=10**9) = 5000
    f_target: number_field(ge=0.0, le=1e6) | None = None
    sigma_min: number_field(gt=0.0, lt=SIGMA_MAX) | None = None
    f_change_min: number_field(ge=0.0, le=1e6) | None = None
    # runs that must end at the same best φ before the others are not needed (with residuals
    # and no f_target only: femupdate.runs.verdict.runs_needed); 0 or None: every run
    agree: integer_field(ge=0, le=10_000) | None = AGREE_DEFAULT
    options: Options = Field(default_factory=dict)

    @model_validator(mode="after")
    def _check_method(self) -> Search:
        # By name in the optimizers' registry: the product's four, and any plug-in registered
        # (benchmarks/plugins); the sampler is not a search.
        allowed = [name for name in METHODS if name != "tmcmc"]
        if self.method not in allowed:
            raise_issues([("method", f"got {self.method!r}{did_you_mean(self.method, allowed)}",
                           ", ".join(repr(name) for name in allowed))])
        return self


# ----------------------------------------------------------------------------- Case


class Case(Section):
    """A validated case file. Build it with ``load_case(path)`` or ``parse_case(mapping)``."""

    case: CaseInfo
    model: Model
    parameters: list[Parameter] = Field(default_factory=list)
    constraints: list[ConstraintRule] = Field(default_factory=list)
    data: Data | None = None
    trials: list[Trial] = Field(default_factory=list)
    preprocess: Preprocess = Field(default_factory=Preprocess)
    objective: ObjectiveOptions = Field(default_factory=ObjectiveOptions)
    simulation: Simulation = Field(default_factory=Simulation)
    search: Search = Field(default_factory=Search)
    posterior: PosteriorSection | None = None

    _source: Path | None = PrivateAttr(default=None)

    @model_validator(mode="after")
    def _check(self) -> Case:
        raise_issues(case_issues(self) + posterior_issues(self) + simulation_issues(self))
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
        """Whether the filters are applied to the model's prediction rather than its input.

        ``preprocess.filter_prediction``, or by default: with frictions (a filter commutes with
        a linear model only). Never without a filter.
        """
        pre = self.preprocess
        if pre.highpass_hz <= 0.0 and pre.lowpass_hz is None:
            return False
        if pre.filter_prediction is not None:
            return pre.filter_prediction
        return self.model.has_nonlinear  # an external model's linearity is unknown: not filtered

    @property
    def simulation_method(self) -> str:
        """``simulation.method``, or its default: ``"nonlinear"`` with friction or Bouc–Wen
        elements, ``"reduced"`` for a linear model of ``REDUCED_MIN_DOF`` DOFs or more
        (:mod:`femupdate.problem.reduced_path`), else exact.

        ``"nonlinear"`` by default names the nonlinear family: the model's integrator within
        it (central differences or the implicit scheme) is chosen where the model is built,
        at the nominal point and the records' sample interval
        (:func:`femupdate.problem.case_model.choose_integrator`)."""
        if self.simulation.method is not None:
            return self.simulation.method
        if self.model.support_groups:  # multi-support: the dense linear path
            return "exact"
        if reduced_by_default(self.model):  # a large linear model: its lowest modes
            return "reduced"
        return "nonlinear" if self.model.has_nonlinear else "exact"

    # -- trials and data files

    def trial_specs(self) -> list[TrialSpec]:
        """The trials, resolved: each ``[[trials]]`` over ``[data]``'s defaults, or ``[data]``
        alone as one fitted trial named after the case. Empty without ``[data]``."""
        if self.data is None:
            return []
        if not self.trials:
            return [TrialSpec(self.case.name, "fit", 1.0, self.data, None, "data")]
        return [TrialSpec(t.name, t.role, t.weight, trial_data(self.data, t),
                          None if t.score_window is None else tuple(t.score_window),
                          f"trials[{i}]")
                for i, t in enumerate(self.trials)]

    def data_directory(self, data: Data | None = None) -> Path:
        """The ``directory`` of ``data`` (default ``[data]``) with ``${VAR}`` expanded, relative
        to the case file's folder."""
        base = self._source.parent if self._source is not None else Path.cwd()
        data = data or self.data
        if data is None or data.directory is None:
            return base
        directory = Path(expand_env(data.directory, "data.directory", self.label)).expanduser()
        return directory if directory.is_absolute() else base / directory

    def data_path(self, channel: Channel, data: Data | None = None) -> Path:
        """Path of a channel's file (``${VAR}`` expanded; relative to ``data_directory(data)``)."""
        path = Path(expand_env(channel.file, "data file", self.label)).expanduser()
        where = self.data_directory(data)
        return Path(os.path.normpath(path if path.is_absolute() else where / path))

    # -- saving

    def to_dict(self) -> dict[str, Any]:
        """The whole case, defaults included, as JSON-ready data (saved with every result).

        Without ``[posterior]`` nothing is saved for it, nor for a low-pass not given: the
        fingerprints of cases written before they existed stay the same."""
        data = self.model_dump(mode="json")
        if not data.get("constraints"):  # nor constraints when there are none
            data.pop("constraints", None)
        if data.get("posterior") is None:
            data.pop("posterior", None)
        else:
            for key in ("surrogate", "ess"):  # nor [posterior] fields left unset
                if data["posterior"].get(key) is None:
                    data["posterior"].pop(key, None)
        for key in ("cutoff_factor", "n_modes"):  # nor the reduced path's when not given
            if data["simulation"].get(key) is None:
                data["simulation"].pop(key, None)
        if data["preprocess"].get("lowpass_hz") is None:  # nor a low-pass not given
            data["preprocess"].pop("lowpass_hz", None)
            data["preprocess"].pop("lowpass_order", None)
        for trial in data.get("trials") or []:  # nor a trial's file not given
            if trial.get("file") is None:
                trial.pop("file", None)
        _drop_unused_support_fields(data)  # nor multi-support's fields, unused
        if data["search"].get("agree") == AGREE_DEFAULT:  # nor the agreement stop's default
            data["search"].pop("agree", None)
        return data

    def fingerprint(self) -> str:
        """SHA-256 of the canonical JSON of ``to_dict()``: equal for equal cases. Without
        ``[search] agree``: it chooses which runs are needed, never what a run computes, so a
        set resumes with another ``agree`` (0: the runs not needed before are run now)."""
        data = self.to_dict()
        data["search"].pop("agree", None)
        text = json.dumps(data, sort_keys=True, separators=(",", ":"),
                          ensure_ascii=False, allow_nan=False)
        return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _drop_unused_support_fields(data: dict[str, Any]) -> None:
    """Leave out of a saved case the multi-support fields it does not use (empty or None),
    so that a uniform-excitation case saves as it did before they existed."""
    if not data["model"].get("support_groups"):
        data["model"].pop("support_groups", None)
    sections = [(data["data"], ("input", "inputs", "components"))] if data.get("data") else []
    sections += [(trial, ("inputs", "components")) for trial in data.get("trials") or []]
    for section, keys in sections:
        for key in keys:  # a trial's input was saved as None before: it stays
            if key in section and section[key] is None:
                section.pop(key)
        if isinstance(section.get("input"), dict) and section["input"].get("angle") is None:
            section["input"].pop("angle", None)
        for out in section.get("outputs") or []:
            if out.get("relative_to") is None:
                out.pop("relative_to", None)


def trial_data(data: Data, trial: Trial) -> Data:
    """``[data]`` with what ``trial`` gives instead (records, directory, window; ``file`` for
    the file of every channel)."""
    update = {key: getattr(trial, key) for key in ("directory", "input", "inputs", "components",
                                                   "outputs", "window")
              if getattr(trial, key) is not None}
    if trial.input is not None or trial.components is not None:
        # a trial's base motion replaces [data]'s, one record or several components
        update.setdefault("input", None)
        update.setdefault("components", None)
    if trial.file is not None:
        moved = {"file": trial.file}
        single = update.get("input", data.input)
        if single is not None:
            update["input"] = single.model_copy(update=moved)
        groups = update.get("inputs", data.inputs)
        if groups:
            update["inputs"] = {name: c.model_copy(update=moved) for name, c in groups.items()}
        parts = update.get("components", data.components)
        if parts:
            update["components"] = [c.model_copy(update=moved) for c in parts]
        update["outputs"] = [o.model_copy(update=moved)
                             for o in update.get("outputs", data.outputs)]
    return data.model_copy(update=update)

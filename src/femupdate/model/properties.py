"""Element properties of a ``Structure``: a number or a parameter's name, its allowed range,
and its values over all elements of a kind for a parameter vector.

The description (``Structure.add_*``) checks numbers against their range at once and keeps
parameter names; at assembly a :class:`Prop` gathers one property of every element of a kind
and evaluates it for the parameter vector in one vectorised step, checking the parameter values
against the same range.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from femupdate.errors import ModelError
from femupdate.model.elements import _range_text, check_value

__all__ = ["BEAM_SPECS", "BOUC_WEN_SPECS", "MASS_PROPS", "NONNEG", "POSITIVE", "Prop", "Record",
           "Spec", "Value", "check_property", "parameter_names", "parameter_vector",
           "property_over"]

Value = float | str
"""A numeric property: a number, or the name of a parameter given at assembly."""

_INF = math.inf


@dataclass(frozen=True)
class Spec:
    """Allowed range of a property: ``[low, high]``, or ``(low, high]`` when ``low_open``."""

    low: float = 0.0
    high: float = _INF
    low_open: bool = False


NONNEG = Spec()
POSITIVE = Spec(low_open=True)

BEAM_SPECS = {
    "E": NONNEG,
    "A": POSITIVE,
    "I": POSITIVE,
    "rho": NONNEG,
    "G": POSITIVE,
    "nu": Spec(-1.0, 0.5, low_open=True),
    "kappa": POSITIVE,
    "mass_per_length": NONNEG,
    # 3-D beams (dofs_per_node=6), femupdate.model.elements3d
    "Iy": POSITIVE,
    "Iz": POSITIVE,
    "J": POSITIVE,
}

# Bouc–Wen properties one by one; the admissible (β, γ) pairs are checked at assembly.
BOUC_WEN_SPECS = {
    "k": POSITIVE,
    "alpha": Spec(0.0, 1.0),
    "A": POSITIVE,
    "beta": POSITIVE,
    "gamma": Spec(-_INF),
    "n": POSITIVE,
    "delta_a": NONNEG,
    "delta_nu": NONNEG,
    "delta_eta": NONNEG,
}

# Beam properties the mass matrix depends on (besides E, through Φ, when G is given).
MASS_PROPS = ("A", "I", "rho", "G", "nu", "kappa", "mass_per_length", "Iy", "Iz", "J")


@dataclass(frozen=True)
class Record:
    """One element as described by the user: its kind, name, where it acts and its properties."""

    kind: str  # "beam", "spring", "damper", "friction", "bouc_wen", "mass", "rayleigh"
    name: str
    props: dict[str, Value]
    nodes: tuple[int, ...] = ()
    dofs: tuple[int, ...] = ()  # local DOF index per node (links only)
    options: dict[str, object] = field(default_factory=dict)


@dataclass(frozen=True)
class Prop:
    """One property over all elements of a kind: constants, and where parameters go."""

    what: str
    kind: str
    names: tuple[str, ...]
    const: np.ndarray
    pidx: np.ndarray  # parameter index per element, -1 for a constant
    spec: Spec
    params: tuple[str, ...]
    where: np.ndarray  # elements whose value is a parameter

    @property
    def is_const(self) -> bool:
        return self.where.size == 0

    def evaluate(self, p: np.ndarray) -> np.ndarray:
        """Values for parameter vector ``p``; parameter values outside the range raise."""
        where = self.where
        if where.size == 0:
            return self.const
        vp = p[self.pidx[where]]
        s = self.spec
        ok = (vp > s.low if s.low_open else vp >= s.low) & (vp <= s.high)
        if not ok.all():
            e = int(where[np.argmin(ok)])
            v = float(p[self.pidx[e]])
            raise ModelError(
                f"{self.kind} {self.names[e]!r}: {self.what} = {v!r} (parameter "
                f"{self.params[self.pidx[e]]!r}) is out of range; allowed "
                f"{_range_text(s.low, s.high, s.low_open)}"
            )
        v = self.const.copy()
        v[where] = vp
        return v


def check_property(v: Value, element: str, what: str, spec: Spec) -> Value:
    """A number checked against ``spec`` now, or a (non-empty) parameter name kept."""
    if isinstance(v, str):
        if not v:
            raise ModelError(f"{element}: {what} is an empty parameter name")
        return v
    return check_value(element, what, v, spec.low, spec.high, low_open=spec.low_open)


def parameter_names(records: Sequence[Record]) -> tuple[str, ...]:
    """The parameter names the records use, in first-use order."""
    seen: dict[str, None] = {}
    for rec in records:
        for v in rec.props.values():
            if isinstance(v, str):
                seen.setdefault(v, None)
    return tuple(seen)


def property_over(recs: Sequence[Record], kind: str, what: str, spec: Spec,
                  params: tuple[str, ...], default: float = 0.0) -> Prop:
    """Property ``what`` of every record in ``recs`` (``default`` where one does not give it)."""
    const = np.zeros(len(recs))
    pidx = np.full(len(recs), -1, dtype=np.int64)
    for e, rec in enumerate(recs):
        v = rec.props.get(what, default)
        if isinstance(v, str):
            pidx[e] = params.index(v)
        else:
            const[e] = v
    names = tuple(r.name for r in recs)
    return Prop(what, kind, names, const, pidx, spec, params, np.flatnonzero(pidx >= 0))


def parameter_vector(names: tuple[str, ...], values: Mapping[str, float] | ArrayLike | None
                     ) -> np.ndarray:
    """The parameter vector in the order of ``names`` from a mapping or a sequence.

    Unknown or missing names, a wrong count, non-numbers and non-finite values raise
    ``ModelError``.
    """
    if values is None:
        values = {}
    if isinstance(values, Mapping):
        unknown = [key for key in values if key not in names]
        if unknown:
            raise ModelError(
                f"unknown parameter(s) {', '.join(map(repr, unknown))}; this structure "
                f"uses {names}"
            )
        missing = [key for key in names if key not in values]
        if missing:
            raise ModelError(
                f"missing value(s) for parameter(s) {', '.join(map(repr, missing))}"
            )
        raw: Sequence[object] = [values[key] for key in names]
    else:
        raw = list(np.atleast_1d(np.asarray(values)))
        if len(raw) != len(names):
            raise ModelError(
                f"got {len(raw)} parameter values; this structure has {len(names)}: {names}"
            )
    try:
        p = np.array([float(v) for v in raw], dtype=float)  # type: ignore[arg-type]
    except (TypeError, ValueError) as exc:
        raise ModelError(f"parameter values must be numbers: {exc}") from exc
    bad = np.flatnonzero(~np.isfinite(p))
    if bad.size:
        raise ModelError(
            f"parameter {names[bad[0]]!r} = {float(p[bad[0]])!r}; it must be finite"
        )
    return p

"""Checks of derived fields and constraints against the parameters' box, at load time.

A field that is an expression of parameters, and the Bouc–Wen pair ``−β < γ ≤ β``, must hold
over the searched box; ``[[constraints]]`` take points out of it. Both are checked at a finite
set of *check points* (:func:`check_points`): every corner of the box of the parameters
involved (the others at their nominal values), and the nominal point, keeping only the points
where every constraint holds. A corner that a constraint excludes is never a reason to refuse
a case. Between the check points each searched point is checked again when it is evaluated
(``femupdate.problem.update``): a point outside the constraints, or whose derived values leave
their range, is a failed evaluation.

Problems shared by many elements (the same ``beta`` and ``gamma`` in 204 Bouc–Wen links) are
reported once, with the count of the others.
"""

from __future__ import annotations

import itertools
import typing
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from femupdate.case.expressions import (
    Constraint,
    ExpressionError,
    is_name,
    parse_constraint,
    parse_expression,
)
from femupdate.case.fields import Range, format_value
from femupdate.case.issues import Issue, did_you_mean

if typing.TYPE_CHECKING:
    from femupdate.case.schema import Case, Parameter

__all__ = ["MAX_CORNER_PARAMETERS", "bouc_wen_pairs", "check_points", "constraint_issues",
           "derived_issues"]

#: Up to this many parameters involved, every corner of their box is a check point (4,096);
#: beyond, the points with one parameter at a bound and the others nominal.
MAX_CORNER_PARAMETERS = 12

Env = dict[str, Any]


def constraints_of(case: Case) -> list[Constraint]:
    """The case's parsed ``[[constraints]]`` (those that parse and name declared parameters)."""
    declared = set(case.parameter_names)
    out = []
    for item in case.constraints:
        try:
            constraint = parse_constraint(item.rule)
        except ExpressionError:
            continue
        if set(constraint.names) <= declared:
            out.append(constraint)
    return out


def _involved(names: Iterable[str], constraints: Sequence[Constraint]) -> list[str]:
    """``names`` with the parameters of every constraint that shares one with them
    (repeatedly): the parameters whose corners decide the check."""
    found = dict.fromkeys(names)
    grown = True
    while grown:
        grown = False
        for constraint in constraints:
            if any(n in found for n in constraint.names):
                for n in constraint.names:
                    if n not in found:
                        found[n] = None
                        grown = True
    return list(found)


def check_points(parameters: Sequence[Parameter], names: Iterable[str],
                 constraints: Sequence[Constraint]) -> Env:
    """The check points of a condition on the parameters ``names``, as {name: array}.

    The corners of the box of the parameters involved (``names`` and those tied to them by a
    constraint), up to :data:`MAX_CORNER_PARAMETERS` of them, else each one at either bound with
    the others nominal; then the nominal point; every other parameter nominal. Points where a
    constraint fails are left out.
    """
    by_name = {p.name: p for p in parameters}
    involved = [n for n in _involved(names, constraints) if n in by_name]
    nominal = {p.name: p.nominal_value for p in parameters}
    if len(involved) <= MAX_CORNER_PARAMETERS:
        rows = [dict(zip(involved, corner, strict=True)) for corner in itertools.product(
            *[(by_name[n].lower, by_name[n].upper) for n in involved])]
    else:
        rows = [{n: getattr(by_name[n], side)} for n in involved for side in ("lower", "upper")]
    rows.append({})
    env = {n: np.array([row.get(n, nominal[n]) for row in rows], dtype=float)
           for n in by_name}
    keep = np.ones(len(rows), dtype=bool)
    for constraint in constraints:
        keep &= np.asarray(constraint.holds(env), dtype=bool)
    return {n: v[keep] for n, v in env.items()}


def _value(spec: object, env: Env) -> Any:
    """A field's values at the check points: a number, a parameter or an expression."""
    if isinstance(spec, str):
        return env[spec] if is_name(spec) else parse_expression(spec)(env)
    return float(spec)  # type: ignore[arg-type]


def _first(env: Env, bad: np.ndarray, names: Sequence[str]) -> str:
    """The parameters' values at the first bad check point, in words."""
    i = int(np.flatnonzero(bad)[0])
    return ", ".join(f"{n} = {format_value(float(env[n][i]))}" for n in names)


def _others(count: int, what: str) -> str:
    return "" if count == 0 else f"; the same for {count} more {what}"


def derived_issues(case: Case, fields: Sequence[tuple[str, str, Range]]) -> list[Issue]:
    """Expression fields ``(path, text, range)`` (names all declared) whose value leaves the
    field's range at a check point, one issue per expression and range."""
    constraints = constraints_of(case)
    groups: dict[tuple[str, str], list[tuple[str, Range]]] = {}
    for path, text, rng in fields:
        groups.setdefault((text, rng.describe()), []).append((path, rng))
    issues: list[Issue] = []
    for (text, _), members in groups.items():
        path, rng = members[0]
        expression = parse_expression(text)
        env = check_points(case.parameters, expression.names, constraints)
        shape = next(iter(env.values())).shape if env else ()
        values = np.broadcast_to(np.asarray(expression(env), dtype=float), shape)
        low = rng.gt if rng.gt is not None else rng.ge
        high = rng.lt if rng.lt is not None else rng.le
        bad = ~np.isfinite(values)
        if low is not None:
            bad |= values < low
        if high is not None:
            bad |= values > high
        if np.any(bad):
            at = _first(env, bad, expression.names) if expression.names else "every point"
            value = format_value(float(values[np.flatnonzero(bad)[0]]))
            issues.append((path, f"{text!r} = {value} at {at}: out of range within the "
                           f"parameters' bounds{_others(len(members) - 1, 'fields')}",
                           f"{rng.interval()} over the bounds (or [[constraints]] that "
                           "exclude those points)"))
    return issues


def bouc_wen_pairs(case: Case) -> list[tuple[str, object, object]]:
    """(path of gamma, beta, gamma) of every Bouc–Wen element of ``[model]``, as written."""
    model = case.model
    pairs: list[tuple[str, object, object]] = [
        (f"model.bouc_wen[{i}].gamma", bw.beta, bw.gamma) for i, bw in enumerate(model.bouc_wen)]
    storeys = model.shear_building.bouc_wen if model.shear_building is not None else None
    if storeys is not None:
        n = len(model.shear_building.masses)
        for i in range(n):
            beta, gamma = (v[i] if isinstance(v, list) else v for v in (storeys.beta,
                                                                        storeys.gamma))
            pairs.append((f"model.shear_building.bouc_wen.gamma (storey {i + 1})", beta,
                          gamma))
    return pairs


def _names(spec: object) -> tuple[str, ...]:
    if not isinstance(spec, str):
        return ()
    if is_name(spec):
        return (spec,)
    try:
        return parse_expression(spec).names
    except ExpressionError:
        return ("",)  # said by the field's own check


def bouc_wen_bound_issues(case: Case) -> list[Issue]:
    """Bouc–Wen elements whose (beta, gamma) can leave −β < γ ≤ β at a check point: the
    search would reach points without hysteresis. One issue per (beta, gamma) as written."""
    declared = set(case.parameter_names)
    constraints = constraints_of(case)
    groups: dict[tuple[str, str], list[tuple[str, object, object]]] = {}
    for path, beta, gamma in bouc_wen_pairs(case):
        names = _names(beta) + _names(gamma)
        if not names or not set(names) <= declared:
            continue  # two numbers: checked with the section; an unknown name: said elsewhere
        groups.setdefault((repr(beta), repr(gamma)), []).append((path, beta, gamma))
    issues: list[Issue] = []
    for members in groups.values():
        path, beta, gamma = members[0]
        names = list(dict.fromkeys(_names(beta) + _names(gamma)))
        env = check_points(case.parameters, names, constraints)
        b, g = (np.asarray(_value(v, env), dtype=float) for v in (beta, gamma))
        b, g = np.broadcast_arrays(b, g)
        bad = ~((-b < g) & (g <= b))
        if np.any(bad):
            issues.append((path, f"beta = {format_value(beta)} and gamma = "
                           f"{format_value(gamma)} can leave -beta < gamma <= beta within "
                           f"the parameters' bounds (no hysteresis there), e.g. at "
                           f"{_first(env, bad, names)}"
                           f"{_others(len(members) - 1, 'Bouc–Wen elements alike')}",
                           "bounds with -(lowest beta) < gamma <= lowest beta everywhere, "
                           "gamma as an expression of beta (e.g. \"0.5 * beta\"), or "
                           "[[constraints]] that exclude those points (e.g. rule = "
                           "\"gamma <= beta\")"))
    return issues


def constraint_issues(case: Case) -> list[Issue]:
    """``[[constraints]]``: each parses, names declared parameters only, and holds at the
    nominal point (where the runs and the model's checks start)."""
    declared = case.parameter_names
    listed = ", ".join(repr(n) for n in declared) or "none declared"
    nominal = case.nominal()
    issues: list[Issue] = []
    for i, item in enumerate(case.constraints):
        path = f"constraints[{i}].rule"
        try:
            constraint = parse_constraint(item.rule)
        except ExpressionError as exc:
            issues.append((path, f"got {item.rule!r}: {exc}",
                           "a comparison (<, <=, >, >=) of expressions of parameters, e.g. "
                           "\"gamma <= beta\""))
            continue
        unknown = [n for n in constraint.names if n not in declared]
        if unknown:
            hint = did_you_mean(unknown[0], list(declared))
            issues.append((path, f"{item.rule!r} names {unknown[0]!r}, not declared in "
                           f"[[parameters]]{hint}", f"declared parameters: {listed}"))
        elif not constraint.names:
            issues.append((path, f"{item.rule!r} names no parameter",
                           "a condition between parameters"))
        elif not bool(constraint.holds(nominal)):
            issues.append((path, f"{constraint.explain(nominal)} at the nominal point",
                           "nominal values (parameters' nominal, else the middle of the "
                           "bounds) where every constraint holds"))
    return issues

"""Cross-field checks of a case: what one field cannot check alone.

References to nodes, DOFs and parameters, duplicates, supports, bounds against the ranges of
the properties that use them, outputs on fixed DOFs, filter and delay bands against the
sampling rate. The sections of ``schema`` call these from their ``model_validator``.
:func:`check_parameter_values` checks the parameter values a user passes beside a case (JSON on
the command line, a truth file).
"""

from __future__ import annotations

import math
import numbers
import typing
from collections.abc import Iterator, Mapping

from pydantic import BaseModel, ValidationError

from femupdate.case.derived import bouc_wen_bound_issues, constraint_issues, derived_issues
from femupdate.case.expressions import ExpressionError, is_name, parse_expression
from femupdate.case.fields import DOF_NAMES, Range, field_range, find_range, format_value
from femupdate.case.issues import Issue, did_you_mean, duplicates, join_path
from femupdate.case.model3d import beam_issues, node_issues
from femupdate.errors import ConfigError

if typing.TYPE_CHECKING:
    from femupdate.case.model_sections import Model
    from femupdate.case.schema import Case, Data

#: The element lists of ``[model]``, in the order of the case file.
ELEMENT_LISTS = ("nodes", "beams", "springs", "dampers", "frictions", "bouc_wen", "masses",
                 "supports", "diaphragms")


def diaphragm_issues(model: Model, coordinates: dict[str, tuple[float, float, float]]
                     ) -> list[Issue]:
    """``[[model.diaphragms]]``: 3-D frames only; known nodes at the master's height, each
    node in one diaphragm, a master not among its own nodes."""
    if model.diaphragms and model.dofs_per_node != 6:
        return [("diaphragms", f"rigid floor diaphragms with dofs_per_node = "
                 f"{model.dofs_per_node}", "dofs_per_node = 6 (a 3-D frame), or no diaphragms")]
    issues: list[Issue] = []
    seen: dict[str, str] = {}
    for i, floor in enumerate(model.diaphragms):
        for path, node in ((f"diaphragms[{i}].master", floor.master),
                           *((f"diaphragms[{i}].nodes[{j}]", n)
                             for j, n in enumerate(floor.nodes))):
            if node not in coordinates:
                hint = did_you_mean(node, list(coordinates))
                issues.append((path, f"unknown node {node!r}{hint}", "a node of [[model.nodes]]"))
                continue
            if node in seen:
                issues.append((path, f"node {node!r} is already in {seen[node]}",
                               "each node in one diaphragm"))
                continue
            seen[node] = f"model.diaphragms[{i}]"
            z_master = coordinates.get(floor.master, (0.0, 0.0, None))[2]
            z = coordinates[node][2]
            if z_master is not None and abs(z - z_master) > 1e-9 * max(1.0, abs(z_master)):
                issues.append((path, f"node {node!r} is at z = {format_value(z)}, the master "
                               f"{floor.master!r} at z = {format_value(z_master)}",
                               "nodes of the master's floor (the same z)"))
    return issues


def model_issues(model: Model) -> list[Issue]:
    issues: list[Issue] = []
    external = [key for key in ("python", "opensees") if getattr(model, key) is not None]
    if model.support_groups and (external or model.shear_building is not None):
        issues.append(("support_groups", "given with "
                       + ("an external model" if external else "[model.shear_building]"),
                       "support groups on femupdate's own nodes and elements: "
                       "[[model.nodes]], [[model.supports]]"))
        return issues
    if external:
        given = [key for key in (*ELEMENT_LISTS, "shear_building", "rayleigh")
                 if getattr(model, key)]
        if len(external) > 1:
            issues.append(("python", "both [model.python] and [model.opensees] are given",
                           "one external model"))
        if given:
            issues.append((external[0], "an external model given together with model."
                           + ", model.".join(given), "either an external model or femupdate's "
                           "elements, not both"))
        return issues
    used = [key for key in ELEMENT_LISTS if getattr(model, key)]
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
    issues += duplicates([(f"nodes[{i}].name", n.name) for i, n in enumerate(model.nodes)],
                          "node name", "model")
    named = [(f"{key}[{i}].name", e.name) for key in ELEMENT_LISTS[1:6]
             for i, e in enumerate(getattr(model, key)) if e.name is not None]
    issues += duplicates(named, "element name", "model")

    coordinates = {n.name: (n.x, n.y, n.z) for n in model.nodes}
    defined = ", ".join(repr(n) for n in coordinates) or "none"
    dofs = DOF_NAMES[model.dofs_per_node]

    def node_issue(path: str, node: str | None) -> None:
        if node is not None and node not in coordinates:
            hint = did_you_mean(node, list(coordinates))
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
    issues += node_issues(model) + beam_issues(model, coordinates)
    for key in ("springs", "dampers", "frictions", "bouc_wen"):
        for i, link in enumerate(getattr(model, key)):
            node_issue(f"{key}[{i}].node", link.node)
            node_issue(f"{key}[{i}].node2", link.node2)
            dof_issue(f"{key}[{i}].dof", link.dof)
            dof_issue(f"{key}[{i}].dof2", link.dof2)
    for i, mass in enumerate(model.masses):
        node_issue(f"masses[{i}].node", mass.node)
        for j, dof in enumerate(mass.dofs or ()):
            dof_issue(f"masses[{i}].dofs[{j}]", dof)
    issues += diaphragm_issues(model, coordinates)
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
    for key in ("springs", "dampers", "frictions", "bouc_wen"):
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
    return issues + support_group_issues(model, fixed, defined)


def support_group_issues(model: Model, fixed: dict[tuple[str, str], str], defined: str
                         ) -> list[Issue]:
    """``[[model.support_groups]]``: each a non-empty list of known nodes whose DOF along the
    group's direction is fixed, each such DOF in one group, on a linear model."""
    groups = model.support_groups
    if not groups:
        return []
    issues: list[Issue] = duplicates([(f"support_groups[{i}].name", g.name)
                                      for i, g in enumerate(groups)], "support group name",
                                     "model")
    if model.has_nonlinear:
        issues.append(("support_groups", "given with friction or Bouc–Wen elements",
                       "a linear model: multi-support excitation splits the motion into a "
                       "pseudo-static and a dynamic part, which holds for linear models only"))
    dofs = DOF_NAMES[model.dofs_per_node]
    nodes = {n.name for n in model.nodes}
    moved: dict[tuple[str, str], str] = {}
    for i, group in enumerate(groups):
        path = f"support_groups[{i}]"
        dof = model.group_dof(group)
        if dof not in dofs:
            translations = [d[1] for d in dofs if d.startswith("u")]
            issues.append((f"{path}.direction", f"got {dof[1]!r}: the model has no {dof} "
                           f"(dofs_per_node = {model.dofs_per_node})",
                           ", ".join(repr(d) for d in translations)))
            continue
        if not group.nodes:
            issues.append((f"{path}.nodes", f"support group {group.name!r} is empty",
                           "one node or more, each fixed in [[model.supports]]"))
        for j, node in enumerate(group.nodes):
            where = f"{path}.nodes[{j}]"
            if node not in nodes:
                hint = did_you_mean(node, sorted(nodes))
                issues.append((where, f"support node {node!r} is not in the model{hint}",
                               f"a node of [[model.nodes]]: {defined}"))
            elif (node, dof) not in fixed:
                issues.append((where, f"{node}.{dof} is not fixed: a support group moves "
                               "supports", f"a node with {dof!r} in its [[model.supports]] "
                               "dofs"))
            elif (node, dof) in moved:
                issues.append((where, f"node {node!r} ({dof}) is already in {moved[node, dof]}",
                               "each support DOF in one group (a second direction of a node: "
                               "a group of its own with that direction)"))
            else:
                moved[node, dof] = f"model.{path} ({group.name!r})"
    return issues


def quantities(obj: BaseModel, path: str) -> Iterator[tuple[str, float | str, Range]]:
    """Every model property checked by a ``Range``: (path, value, range), recursively."""
    for key, info in type(obj).model_fields.items():
        value = getattr(obj, key)
        if value is None:
            continue
        here = join_path(path, key)
        if isinstance(value, BaseModel):
            yield from quantities(value, here)
        elif isinstance(value, list):
            inner = find_range(info.annotation, into_lists=True)
            for i, item in enumerate(value):
                if isinstance(item, BaseModel):
                    yield from quantities(item, f"{here}[{i}]")
                elif inner is not None:
                    yield f"{here}[{i}]", item, inner
        else:
            rng = field_range(info)
            if rng is not None:
                yield here, value, rng


def case_issues(case: Case) -> list[Issue]:
    issues = duplicates([(f"parameters[{i}].name", p.name)
                          for i, p in enumerate(case.parameters)], "parameter name")
    declared = {p.name: (i, p) for i, p in enumerate(case.parameters)}
    names_listed = ", ".join(repr(n) for n in declared) or "none declared"
    used: set[str] = set()
    out_of_range: set[str] = set()
    expressions: list[tuple[str, str, Range]] = []
    for path, value, rng in quantities(case.model, "model"):
        if not isinstance(value, str):
            continue
        if not is_name(value):  # an expression: its names declared, its values in range
            try:
                names = parse_expression(value).names
            except ExpressionError:
                continue  # said by the field's own check
            used.update(names)
            unknown = [n for n in names if n not in declared]
            for name in unknown:
                hint = did_you_mean(name, list(declared))
                issues.append((path, f"{value!r} names {name!r}, not declared in "
                               f"[[parameters]]{hint}", f"declared parameters: {names_listed}"))
            if not unknown:
                expressions.append((path, value, rng))
            continue
        used.add(value)
        if value not in declared:
            hint = did_you_mean(value, list(declared))
            issues.append((path, f"parameter {value!r} is not declared in [[parameters]]{hint}",
                           f"a number, or a declared parameter: {names_listed}"))
            continue
        i, p = declared[value]
        if not rng.contains_closed(p.lower, p.upper) and value not in out_of_range:
            out_of_range.add(value)  # once per parameter: its first use names the range
            side = "upper" if rng.contains_closed(p.lower, p.lower) else "lower"
            issues.append((f"parameters[{i}].{side}", f"parameter {value!r} has bounds "
                           f"[{format_value(p.lower)}, {format_value(p.upper)}] but is used "
                           f"at {path}", f"bounds {rng.interval()}"))
    issues += constraint_issues(case) + derived_issues(case, expressions)
    for name, (i, _) in declared.items():
        if name not in used and case.model.external is None:  # an external model's own use
            issues.append((f"parameters[{i}].name", f"parameter {name!r} is declared but the "
                           "model never uses it", f'use it in [model] (e.g. k = "{name}") '
                           "or remove it"))
    if case.model.external is not None and case.simulation.method is not None:
        kind = "python" if getattr(case.model, "python", None) is not None else "opensees"
        issues.append(("simulation.method", f"got {case.simulation.method!r} but the model is "
                       f"external ([model.{kind}]): it computes its own response, femupdate "
                       "integrates nothing", "no simulation.method with an external model"))
    elif case.model.has_nonlinear and case.simulation.method not in (None, "nonlinear",
                                                                      "implicit", "reduced"):
        issues.append(("simulation.method", f"got {case.simulation.method!r} but the model "
                       "has friction or Bouc–Wen elements",
                       "'nonlinear' (or leave it out), 'implicit' for stiff elements, or "
                       "'reduced' for a large model"))
    if case.model.support_groups and case.simulation.method in ("nonlinear", "implicit",
                                                                 "reduced"):
        issues.append(("simulation.method", f"got {case.simulation.method!r} with "
                       "[[model.support_groups]]", "'exact' (or leave it out), "
                       "'central_difference' or 'newmark': multi-support excitation runs on "
                       "the dense linear integrators"))
    issues += bouc_wen_bound_issues(case)
    if case.trials and case.data is None:
        issues.append(("trials", "[[trials]] given without [data]",
                       "a [data] section: how to read the records, and the channels a trial "
                       "does not give"))
    if case.trials:
        issues += duplicates([(f"trials[{i}].name", t.name) for i, t in enumerate(case.trials)],
                             "trial name")
        if not any(t.role == "fit" for t in case.trials):
            issues.append(("trials", "no trial has role = \"fit\": nothing to fit",
                           "at least one trial with role = \"fit\""))
    for spec in case.trial_specs():
        issues += _data_issues(case, spec.data, spec.path)
    return issues


def _data_issues(case: Case, data: Data, path: str) -> list[Issue]:
    """The checks of one trial's records against the model and the processing."""
    issues: list[Issue] = []
    if path != "data":  # [data] checked its own channels; a trial's merged ones are new
        try:  # validated again as their section ([data]'s class: no import of the schema)
            type(data).model_validate(data.model_dump())
        except ValidationError as exc:
            for err in exc.errors(include_url=False):
                ctx = err.get("ctx") or {}
                for rel, what, allowed in ctx.get("issues", [("", err["msg"], "")]):
                    where = join_path(path, *[p for p in err["loc"] if p != "data"], rel)
                    issues.append((where, what, allowed))
    issues += output_issues(case.model, data, path) + input_issues(case.model, data, path)
    if path != "data" and case.data is not None and (
            data.base_directions != case.data.base_directions):
        issues.append((f"{path}.components", f"the base motion's directions "
                       f"{list(data.base_directions) or 'one record'} differ from [data]'s "
                       f"{list(case.data.base_directions) or 'one record'}",
                       "every trial with the components of [data], in the same order"))
    rate = case.preprocess.resample_hz or data.rate
    for name in ("highpass_hz", "lowpass_hz"):
        cutoff = getattr(case.preprocess, name)
        if rate is not None and cutoff is not None and cutoff >= rate / 2:
            issues.append((f"preprocess.{name}", f"got {format_value(cutoff)} for data at "
                           f"{format_value(rate)} Hz",
                           f"below the Nyquist frequency {format_value(rate / 2)} Hz"))
    band = case.preprocess.delay_band_hz
    auto = any(out.delay == "auto" for out in data.outputs)
    if auto and rate is not None and band[0] < band[1] and band[1] >= rate / 2:
        issues.append(("preprocess.delay_band_hz", f"got {format_value(band)} for data at "
                       f"{format_value(rate)} Hz (used by delay = \"auto\")",
                       f"0 < low < high < the Nyquist frequency {format_value(rate / 2)} "
                       "Hz, well below the first resonance"))
    return issues


def output_issues(model: Model, data: Data, where: str = "data") -> list[Issue]:
    """Outputs on nodes and free DOFs of the model (``where``: "data" or "trials[i]"); an
    external model's outputs are its columns in order: as many as it gives."""
    if model.external is not None:
        return _external_output_issues(model, data, where)
    issues: list[Issue] = []
    nodes = model.node_names()
    dofs = model.dof_names()
    fixed = model.fixed_dofs()
    follows = {node: floor.master for floor in model.diaphragms for node in floor.nodes}
    for i, out in enumerate(data.outputs):
        path = f"{where}.outputs[{i}]"
        missing = [key for key in ("node", "dof") if getattr(out, key) is None]
        if missing:
            issues.append((f"{path}.{missing[0]}", f"{' and '.join(missing)} not given",
                           "the node and DOF of the model this channel measures"))
            continue
        if out.node not in nodes:
            hint = did_you_mean(out.node, list(nodes))
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
        elif out.node in follows and out.dof in ("ux", "uy", "rz"):
            issues.append((f"{path}.node", f"{out.node}.{out.dof} follows the rigid diaphragm "
                           f"of {follows[out.node]!r} (its ux, uy, rz are the master's)",
                           f"the master: node = {follows[out.node]!r} (or {out.node}.uz, or a "
                           "node outside the diaphragms)"))
        elif out.dof.startswith("r"):
            unit = out.unit or data.unit
            translations = ", ".join(repr(d) for d in dofs if d.startswith("u"))
            issues.append((f"{path}.dof", f"got {out.dof!r}, a rotation: its acceleration is in "
                           f"rad/s², but the records are linear accelerations (unit = "
                           f"{unit!r}, in m/s² once read)",
                           f"a translation DOF: {translations}; femupdate reads no angular "
                           "accelerations"))
    return issues


def input_issues(model: Model, data: Data, where: str = "data") -> list[Issue]:
    """The input channels against the support groups: one table record without groups, one
    record per group with them; ``relative_to`` naming a group."""
    groups = [g.name for g in model.support_groups]
    issues: list[Issue] = component_issues(model, data, where)
    if not groups:
        if data.inputs is not None:
            issues.append((f"{where}.inputs", "given without [[model.support_groups]]",
                           "[data.input] (the table record), or support groups in [model]"))
        issues += [(f"{where}.outputs[{i}].relative_to", f"got {out.relative_to!r} without "
                    "[[model.support_groups]]", "leave it out: the outputs of a case with one "
                    "table record are absolute accelerations")
                   for i, out in enumerate(data.outputs) if out.relative_to is not None]
        return issues
    listed = ", ".join(repr(g) for g in groups)
    if data.input is not None:
        issues.append((f"{where}.input", "one table record given, but the model has "
                       "[[model.support_groups]]", f"[data.inputs.<group>] for each group: "
                       f"{listed}"))
    given = data.inputs or {}
    for group in groups:
        if group not in given and data.input is None:
            issues.append((f"{where}.inputs", f"support group {group!r} has no input channel",
                           f"[{where}.inputs.{group}] with its file and column"))
    for name in given:
        if name not in groups:
            issues.append((f"{where}.inputs.{name}", f"{name!r} is not a support group"
                           f"{did_you_mean(name, groups)}", f"a group of "
                           f"[[model.support_groups]]: {listed}"))
    for i, out in enumerate(data.outputs):
        if out.delay == "auto":
            issues.append((f"{where}.outputs[{i}].delay", "\"auto\" with "
                           "[[model.support_groups]]: the supports' records differ, none is the "
                           "base to estimate a delay against", "the delay as a number of "
                           "seconds (0: none)"))
        if out.relative_to is not None and out.relative_to not in groups:
            issues.append((f"{where}.outputs[{i}].relative_to", f"{out.relative_to!r} is not a "
                           f"support group{did_you_mean(out.relative_to, groups)}",
                           f"a group of [[model.support_groups]]: {listed}, or leave it out "
                           "(an absolute record)"))
    return issues


def component_issues(model: Model, data: Data, where: str = "data") -> list[Issue]:
    """A base motion with several components (``[[data.components]]``, or an input with an
    ``angle``): femupdate's own model, uniform excitation, a translation DOF of the model's
    nodes along each direction."""
    directions = data.base_directions
    if not directions:
        return []
    key = (f"{where}.components" if data.components is not None else f"{where}.input.angle")
    if model.external is not None:
        return [(key, "given with an external model ([model.python] or [model.opensees]), "
                 "which takes one base record", "one [data.input] without angle")]
    if model.support_groups:
        return [(key, "given with [[model.support_groups]]", "support groups (one record per "
                 "group) or a uniform base motion with components, not both")]
    issues: list[Issue] = []
    if model.direction is not None:
        issues.append(("model.direction", f"got {model.direction!r}, but {key} gives the "
                       "directions of the base motion", "leave it out"))
    allowed = [d for d in model.dof_names() if d in ("ux", "uy", "uz")]
    for i, direction in enumerate(directions):
        if f"u{direction}" not in allowed:
            field = (f"{where}.components[{i}].direction" if data.components is not None
                     else key)
            issues.append((field, f"moves the base along {direction}, but the model's nodes "
                           f"have no u{direction} DOF", "directions among "
                           + ", ".join(repr(d[1:]) for d in allowed)))
    for i, out in enumerate(data.outputs):
        if out.delay == "auto" and data.components is not None:
            issues.append((f"{where}.outputs[{i}].delay", "\"auto\" with [[data.components]]: "
                           "the components differ, none is the base to estimate a delay "
                           "against", "the delay as a number of seconds (0: none)"))
    return issues


def _external_output_issues(model: Model, data: Data, where: str) -> list[Issue]:
    count = (len(model.opensees.outputs) if model.opensees is not None
             else len(model.python.influence) if model.python and model.python.influence
             else None)
    if count is not None and count != len(data.outputs):
        key = "model.opensees.outputs" if model.opensees is not None else "model.python.influence"
        return [(f"{where}.outputs", f"{len(data.outputs)} channels but {key} gives {count}",
                 f"one channel per output of the model, in the order of {key}")]
    return []


def check_parameter_values(values: object, names: tuple[str, ...],
                           what: str = "parameter values") -> dict[str, float]:
    """``values`` as {name: float} for exactly the parameters ``names``; ConfigError otherwise.

    For values a user passes (JSON on the command line, a truth file): says which names are
    missing or unknown and which values are not finite numbers.
    """
    if not isinstance(values, Mapping):
        raise ConfigError(f"{what}: expected an object of parameter values {{name: number}}, "
                          f"got {type(values).__name__} (allowed: the parameters "
                          f"{list(names)})")
    missing = [n for n in names if n not in values]
    unknown = [str(n) for n in values if n not in names]
    if missing or unknown:
        wrong = "; ".join(f"{word} {listed}" for word, listed in (("missing", missing),
                                                                 ("unknown", unknown)) if listed)
        raise ConfigError(f"{what}: {wrong} (allowed: exactly the parameters {list(names)})")
    out = {}
    for name in names:
        value = values[name]
        if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(
                float(value)):
            raise ConfigError(f"{what}: {name} = {value!r} is not a finite number (allowed: a "
                              "finite number)")
        out[name] = float(value)
    return out

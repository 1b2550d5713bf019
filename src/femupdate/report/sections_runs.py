"""The report's first sections: the case, the runs, their convergence and the spread of the
parameters. Each is a function of the :class:`~femupdate.report.facts.Context` returning HTML."""

from __future__ import annotations

import datetime
import json

import numpy as np

from femupdate.case import Case
from femupdate.pipeline.results import Results, RunRecord, Summary
from femupdate.problem.reduced_path import describe_simulation
from femupdate.report.facts import Context, case_positions, relative_error
from femupdate.report.markup import (
    Page,
    esc,
    format_number,
    format_value,
    note,
    num,
    pairs,
    table,
    td,
    warn,
)
from femupdate.runs.stats import BOUND_TOL, bound_flags

# ----------------------------------------------------------------------------- the case


#: The singular of the counted words of :func:`_model_text` ("1 storeys; 1 free DOFs").
_SINGULAR = {"storeys": "storey", "free DOFs": "free DOF", "nodes": "node", "beams": "beam",
             "springs": "spring", "dampers": "damper", "frictions": "friction",
             "masses": "mass", "supports": "support"}


def _counted(n: int, plural: str) -> str:
    """``n`` and the word, singular for one."""
    return f"{n} {_SINGULAR.get(plural, plural) if n == 1 else plural}"


def _model_text(ctx: Context) -> str:
    model = ctx.res.case.model
    if model.shear_building is not None:
        parts = [f"shear building of {_counted(len(model.shear_building.masses), 'storeys')}"]
        parts += [f"{what} in every storey" for what, section in (
            ("friction elements", model.shear_building.frictions),
            ("Bouc–Wen elements", model.shear_building.bouc_wen)) if section is not None]
    else:
        parts = [_counted(len(model.nodes), "nodes")]
        parts += [_counted(len(getattr(model, key)), key)
                  for key in ("beams", "springs", "dampers", "frictions", "bouc_wen", "masses",
                              "supports")
                  if getattr(model, key)]
    dofs = (_counted(ctx.model.structure.n_dof, "free DOFs") if ctx.model is not None
            else str(ctx.model_note))
    return ", ".join(parts) + f"; {dofs}"


def _data_items(ctx: Context) -> list[tuple[str, str]]:
    case = ctx.res.case
    data = case.data
    assert data is not None
    items = [("format", esc(data.format)), ("directory", esc(case.data_directory()))]
    for name, _, channel in data.input_channels():  # the table's, or each support group's
        what = "input (table)" if name == "input" else f"input ({name.removeprefix('input.')})"
        items.append((what, esc(f"{channel.file} [{channel.column}] "
                                f"({channel.unit or data.unit})")))
    if data.window is not None:
        items.append(("window", esc(f"{format_number(data.window[0])} – "
                                    f"{format_number(data.window[1])} s")))
    manifest = ctx.truth.manifest
    if manifest:
        what = [str(manifest[k]) for k in ("motion",) if k in manifest]
        if "snr" in manifest:
            what.append(f"noise {format_number(100.0 * float(manifest['snr']))} % rms")
        if "seed" in manifest:
            what.append(f"seed {manifest['seed']}")
        items.append(("virtual experiment", esc("; ".join(what))))
    return items


def _excitation_text(case: Case) -> str:
    """The base motion's directions: the model's one, an input's angle, or the components."""
    data = case.data
    if data is not None and data.angle is not None:
        return f"base motion at {format_value(data.angle)}° from x (its x and y components)"
    if data is not None and data.components is not None:
        return ("uniform base motion with components along "
                + " and ".join(c.direction for c in data.components) + ", a record each")
    return f"base motion in {case.model.excitation_direction}"


def _simulation_text(res: Results) -> str:
    """The path that simulated the model, as the run said it (its integrator, the one chosen
    at the nominal point when the case gives none), else the case's."""
    if res.summary.simulation:
        return describe_simulation(res.summary.simulation).removeprefix("simulation: ")
    return res.case.simulation_method


def section_case(ctx: Context) -> str:
    """The model, the parameters (with the truth), the data, the processing and the search."""
    res = ctx.res
    case = res.case
    model = case.model
    out = [f"<p>{esc(case.case.description)}</p>" if case.case.description else ""]
    items = [("model", esc(_model_text(ctx))),
             ("excitation", esc(_excitation_text(case))),
             ("simulation", esc(_simulation_text(res)))]
    if model.rayleigh is not None:
        links = ("" if not model.has_nonlinear else
                 " (K with the Bouc–Wen elements' initial stiffness)"
                 if model.has_bouc_wen and model.rayleigh.bouc_wen else
                 " (K without the friction and Bouc–Wen elements)")
        items.append(("Rayleigh damping C += α M + β K",
                      esc(f"α = {format_value(model.rayleigh.alpha, '1/s')}, "
                          f"β = {format_value(model.rayleigh.beta, 's')}{links}")))
    out.append(pairs(items))
    out.append("<h3>Parameters</h3>")
    truth = ctx.truth.values
    header = ["parameter", "unit", "lower", "upper", "scale", "nominal"]
    rows = []
    for p in case.parameters:
        cells = [td(esc(p.name)), td(esc(p.unit)), td(num(p.lower), "num"),
                 td(num(p.upper), "num"), td(esc(p.scale)), td(num(p.nominal), "num")]
        if truth is not None:
            cells.append(td(num(truth[p.name]), "num truth"))
        rows.append(cells)
    out.append(table(header + (["truth"] if truth is not None else []), rows,
                     table_id="parameters"))
    out.append(note(f"Truth: {ctx.truth.source}.") if truth is not None
               else note(f"No truth to compare with ({ctx.truth.source})."))
    if case.data is not None:
        out.append("<h3>Data</h3>")
        out.append(pairs(_data_items(ctx)))
        data = case.data
        rows = [[td(esc(c.label)), td(esc(c.file)), td(esc(c.column)),
                 td(esc(f"{c.node}.{c.dof}")), td(esc(c.unit or data.unit)),
                 td(num(c.weight), "num"),
                 td(esc(c.delay if c.delay == "auto" else format_value(c.delay, "s")))]
                for c in data.outputs]
        out.append(table(["channel", "file", "column", "DOF", "unit", "weight", "delay"], rows,
                         table_id="channels"))
    pre, obj = case.preprocess, case.objective
    out.append("<h3>Processing and error function</h3>")
    hp = (f"Butterworth high-pass {format_number(pre.highpass_hz)} Hz, order "
          f"{pre.highpass_order}, {'zero-phase' if pre.zero_phase else 'causal'}"
          if pre.highpass_hz > 0 else "none")
    lp = (f"Butterworth low-pass {format_number(pre.lowpass_hz)} Hz, order "
          f"{pre.lowpass_order}" if pre.lowpass_hz is not None else "none")
    out.append(pairs([
        ("high-pass", esc(hp)),
        ("low-pass", esc(lp)),
        ("resampling", esc(f"{format_number(pre.resample_hz)} Hz" if pre.resample_hz
                           else "none")),
        ("delay estimation band", esc(f"{format_number(pre.delay_band_hz[0])}–"
                                      f"{format_number(pre.delay_band_hz[1])} Hz")),
        ("integration substeps", esc(pre.substeps)),
        ("compared quantity", esc(obj.quantity)),
        ("experimental parameters", esc("integration constants by least squares"
                                        if obj.experimental_parameters
                                        and obj.quantity == "displacement" else "none")),
    ]))
    out.append("<h3>Search</h3>")
    out.append(pairs(_search_items(ctx)))
    out.append(_software(ctx))
    return "\n".join(out)


def _runs_ran(summary: Summary) -> str:
    """The runs made; "k of n, the others not needed" when the first ones agreed."""
    planned = summary.verdict.planned if summary.verdict is not None else None
    if planned is None:
        return str(len(summary.runs))
    return (f"{len(summary.runs)} of {planned} (the others were not needed: "
            f"[search] agree = {summary.settings.get('agree', '?')})")


def _search_items(ctx: Context) -> list[tuple[str, str]]:
    res = ctx.res
    search, summary = res.case.search, res.summary
    settings = summary.settings or (res.meta or {}).get("settings", {})
    seed = settings.get("seed", search.seed)
    items = [
        ("method", esc(summary.method)),
        ("runs", esc(_runs_ran(summary))),
        ("root seed", esc(seed if seed is not None else "fresh entropy")),
        ("max evaluations", num(settings.get("max_evals", search.max_evals))),
        ("f_target (φ_s)", num(settings.get("f_target", search.f_target))),
    ]
    if search.sigma_min is not None:
        items.append(("σ_s", num(search.sigma_min)))
    if search.f_change_min is not None:
        items.append(("Δφ_s", num(search.f_change_min)))
    options = settings.get("options", search.options)
    if options:
        items.append(("options", esc(json.dumps(options, sort_keys=True))))
    items += [("success", esc(summary.success_rule)),
              ("wall time", esc(f"{format_number(summary.wall_s, 3)} s")),
              ("case fingerprint", f"<code>{esc(summary.fingerprint[:16])}…</code>")]
    return items


def _software(ctx: Context) -> str:
    res = ctx.res
    if res.meta is None:
        return note(f"Software versions unknown: {res.store_note}.")
    items = [(k, esc(v)) for k, v in res.meta.get("versions", {}).items()]
    created = res.meta.get("created")
    if isinstance(created, (int, float)):
        stamp = datetime.datetime.fromtimestamp(created, datetime.UTC)
        items.append(("store created", esc(stamp.strftime("%Y-%m-%d %H:%M:%S UTC"))))
    return "<h3>Software</h3>" + pairs(items)


# ----------------------------------------------------------------------------- the runs


def run_positions(ctx: Context) -> tuple[np.ndarray, np.ndarray]:
    """Each run's parameters between their bounds (runs × n) and their bound flags."""
    res = ctx.res
    values = np.array([[run.params[n] for n in res.names] for run in res.summary.runs],
                      dtype=float).reshape(-1, len(res.names))
    pos = case_positions(res.case, values)
    return pos, bound_flags(pos)


#: The methods that sample Beta distributions (the paper's IB and AB): the only ones whose
#: runs have a trace of a, b and σ to draw.
BETA_METHODS = frozenset({"ib", "ab"})

#: Parameter columns per table of the runs' parameters: with the run column, a table of this
#: many numbers fits an 800 px wide window (checked in headless Chromium).
PARAMETERS_PER_TABLE = 6


def stop_text(run: RunRecord) -> str:
    """Why a run stopped, in full: its criteria (``max_evals = 300``) and its restarts."""
    after = (f" (after {run.restarts} restart{'s' if run.restarts > 1 else ''})"
             if run.restarts else "")
    if not run.stop:
        return run.message + after
    return ", ".join(_criterion(key, value) for key, value in run.stop.items()) + after


def _criterion(key: str, value: object) -> str:
    if isinstance(value, bool) or value is None:
        return key
    if isinstance(value, (int, float)):
        return f"{key} = {format_number(value)}"
    return f"{key}: {value}"


def stop_codes(runs: list[RunRecord]) -> tuple[list[str], list[str]]:
    """A short code of why each run stopped, and the legend that gives them in full.

    The code of a run is the names of the criteria that fired (``f_target``, ``max_evals``),
    or ``note 1``, ``note 2`` … for a run that stopped with a message only; the legend gives
    each criterion's values over the runs (one value, or the range) and each note's message,
    with the number of runs, so that a table of many runs keeps one line per run.
    """
    codes: list[str] = []
    values: dict[str, list[object]] = {}
    notes: dict[str, int] = {}
    for run in runs:
        if run.stop:
            codes.append(", ".join(run.stop))
            for key, value in run.stop.items():
                values.setdefault(key, []).append(value)
        else:
            k = notes.setdefault(run.message, len(notes) + 1)
            codes.append(f"note {k}")
    legend = [_criterion_range(key, found) for key, found in values.items()]
    for message, k in notes.items():
        count = sum(1 for run in runs if not run.stop and run.message == message)
        legend.append(f"note {k}: {message} ({_count(count)})")
    return codes, legend


def _criterion_range(key: str, found: list[object]) -> str:
    numbers = [float(v) for v in found
               if isinstance(v, (int, float)) and not isinstance(v, bool)]
    if len(numbers) == len(found) and numbers:
        low, high = min(numbers), max(numbers)
        shown = (format_number(found[0]) if low == high
                 else f"{format_number(low)} … {format_number(high)}")
        return f"{key} = {shown} ({_count(len(found))})"
    texts = sorted({_criterion(key, v) for v in found})
    return f"{'; '.join(texts)} ({_count(len(found))})"


def _count(runs: int) -> str:
    return f"{runs} run{'s' if runs != 1 else ''}"


def section_runs(ctx: Context) -> str:
    """Every run (the paper's Tables 3–6 and 9) in one line each: NMSE, evaluations, why it
    stopped (a code, the legend below), success and values at a bound; then the parameters of
    every run, PARAMETERS_PER_TABLE to a table, and the statistics."""
    res = ctx.res
    summary = res.summary
    names = res.names
    _, flags = run_positions(ctx)
    restarted = any(run.restarts for run in summary.runs)
    codes, legend = stop_codes(summary.runs)
    header = ["run", "NMSE %", "evaluations", "stop", *(["restarts"] if restarted else []),
              "success", "improper minimum"]
    rows = []
    for run, row_flags, code in zip(summary.runs, flags, codes, strict=True):
        best = run.index == res.best_index
        at_bound = [f"{name} ({'lower' if flag < 0 else 'upper'})"
                    for name, flag in zip(names, row_flags, strict=True) if flag]
        cells = [td(esc(f"{run.index} (best)" if best else run.index)),
                 td(num(100.0 * run.phi), "num"), td(num(run.nfev), "num"),
                 td(esc(code), "code", title=stop_text(run)),
                 *([td(num(run.restarts), "num")] if restarted else []),
                 td("yes" if run.success else "no", "ok" if run.success else "fail"),
                 td(esc(", ".join(at_bound)), "bound" if at_bound else "")]
        rows.append(cells)
    out = [table(header, rows, table_id="runs",
                 caption="Every run: NMSE = 100 φ, evaluations, why it stopped, a parameter "
                         "at a bound (an improper minimum)"),
           f'<p class="note" id="stop-legend">stop: {esc("; ".join(legend))}.</p>']
    out += _parameter_tables(ctx, flags)
    n_runs = len(summary.runs)
    ok = summary.successes
    items = [("successful runs", esc(f"{ok}/{n_runs} ({format_number(100.0 * ok / n_runs, 3)}"
                                     " %)" if n_runs else "0")),
             ("evaluations (successful runs)", esc(
                 f"min {format_number(summary.evals_min)}, mean "
                 f"{format_number(summary.evals_mean)}, median "
                 f"{format_number(summary.evals_median)}, max "
                 f"{format_number(summary.evals_max)}")),
             ("best run", esc(f"{res.best_index}: NMSE "
                              f"{format_number(summary.best.nmse_percent)} %"))]
    if summary.verdict is not None:  # docs/verdicts.md
        items.insert(0, ("verdict", esc(summary.verdict.words)))
    if ctx.truth.noise_floor is not None:
        items.append(("noise floor (truth against the data)",
                      esc(f"NMSE {format_number(100.0 * ctx.truth.noise_floor)} %")))
    out.append(pairs(items))
    n_flagged = int(np.any(flags != 0, axis=1).sum()) if flags.size else 0
    if n_flagged:
        out.append(note(f"{n_flagged} run(s) ended with a parameter within "
                        f"{format_number(BOUND_TOL)} of its search range from a bound: an "
                        "improper minimum, unless the bound is the physical answer."))
    return "\n".join(out)


def _parameter_tables(ctx: Context, flags: np.ndarray) -> list[str]:
    """The parameters of every run, PARAMETERS_PER_TABLE to a table (ids ``run-parameters``,
    then ``run-parameters-2`` …), cells at a bound marked."""
    res = ctx.res
    names = res.names
    units = {p.name: p.unit for p in res.case.parameters}
    groups = [list(range(j, min(j + PARAMETERS_PER_TABLE, len(names))))
              for j in range(0, len(names), PARAMETERS_PER_TABLE)]
    out = []
    for g, group in enumerate(groups):
        rows = []
        for run, row_flags in zip(res.summary.runs, flags, strict=True):
            cells = [td(esc(run.index))]
            for j in group:
                flag = row_flags[j]
                side = "lower" if flag < 0 else "upper"
                cells.append(td(num(run.params[names[j]]), "num bound" if flag else "num",
                                f"at the {side} bound" if flag else ""))
            rows.append(cells)
        header = ["run", *(f"{names[j]} [{units[names[j]]}]" if units[names[j]] else names[j]
                           for j in group)]
        span = (f" ({names[group[0]]} … {names[group[-1]]}, {g + 1} of {len(groups)})"
                if len(groups) > 1 else "")
        out.append(table(header, rows, table_id="run-parameters" + (f"-{g + 1}" if g else ""),
                         caption=f"The parameters of every run{span}; cells at a bound are "
                                 "marked"))
    return out


# ----------------------------------------------------------------------------- convergence


def physical_history(case: Case, x: np.ndarray) -> np.ndarray:
    """History points from the search space to physical values, column by column."""
    x = np.asarray(x, dtype=float)
    log = np.array([p.scale == "log" for p in case.parameters])
    return np.where(log, 10.0 ** np.where(log, x, 0.0), x)


def section_convergence(ctx: Context, page: Page) -> str:
    """φ of every run, the Beta trace and the parameters of the best run (Figs. 2–4)."""
    from femupdate.report.figures import MAX_PARAMETER_PANELS, plot_beta, plot_parameters, plot_phi

    res = ctx.res
    if not res.histories:
        why = res.store_note or "the results store holds no evaluations"
        return "\n".join([page.absent("φ against evaluations", why),
                          page.absent("a, b and σ against step", why),
                          page.absent("parameters against evaluations", why)])
    indices = sorted(res.histories)
    labels = [f"run {i}" + (" (best)" if i == res.best_index else "") for i in indices]
    highlight = indices.index(res.best_index) if res.best_index in indices else None
    fig = plot_phi([res.histories[i]["fun"] for i in indices], labels=labels,
                   highlight=highlight, title=f"{res.case.case.name}: φ_m, every run")
    out = [page.figure(fig, "phi", "φ_m (best so far) against evaluations, every run (log); "
                                   "black: the best run")]
    best = res.histories.get(res.best_index)
    if best is None:
        out.append(page.absent("a, b and σ and the parameters of the best run",
                               "the store holds no history of the best run"))
        return "\n".join(out)
    if all(k in best for k in ("a", "b")) and np.size(best["a"]):
        fig = plot_beta(best, res.names, title=f"run {res.best_index} (the best)")
        out.append(page.figure(fig, "beta", f"run {res.best_index}: Beta parameters a, b of "
                                            "every parameter and σ against step (log)"))
    elif res.summary.method in BETA_METHODS:  # other methods never have one: nothing to say
        out.append(page.absent("a, b and σ against step",
                               "the store holds no Beta trace of the best run"))
    if np.size(best["x"]):
        params = res.case.parameters
        fig = plot_parameters(physical_history(res.case, best["x"]), best["fun"], res.names,
                              units=[p.unit for p in params], truth=ctx.truth.at(res.names),
                              bounds=[(p.lower, p.upper) for p in params],
                              log=[p.scale == "log" for p in params],
                              title=f"run {res.best_index} (the best)")
        together = len(res.names) > MAX_PARAMETER_PANELS
        out.append(page.figure(fig, "parameters", f"run {res.best_index}: the parameters of the "
                               "best-so-far solution against evaluations"
                               + (f" (all {len(res.names)} in one panel, as positions between "
                                  "their bounds: a panel each would be unreadable)"
                                  if together else "")))
    return "\n".join(out)


# ----------------------------------------------------------------------------- the spread


def _improper_list(ctx: Context, flags: np.ndarray) -> str:
    names = ctx.res.names
    flagged = [(run.index, [f"{n} = {format_number(run.params[n])} at its "
                            f"{'lower' if f < 0 else 'upper'} bound"
                            for n, f in zip(names, row, strict=True) if f])
               for run, row in zip(ctx.res.summary.runs, flags, strict=True)]
    flagged = [(i, items) for i, items in flagged if items]
    if not flagged:
        return "<p>No run ended at a bound.</p>"
    lis = "".join(f"<li>run {i}: {esc('; '.join(items))}</li>" for i, items in flagged)
    return (warn(f"Improper minima (a parameter within {format_number(BOUND_TOL)} of its range "
                 "from a bound):") + f'<ul id="improper">{lis}</ul>')


def section_spread(ctx: Context, page: Page) -> str:
    """The parameters over the successful runs (box plots, table), with the truth."""
    from femupdate.report.plots import plot_spread

    res = ctx.res
    summary, names = res.summary, res.names
    positions, flags = run_positions(ctx)
    success = np.array([run.success for run in summary.runs], dtype=bool)
    truth = ctx.truth.values
    out = []
    # Drawn also when no run succeeded: where runs that disagree ended is the evidence.
    truth_pos = (case_positions(res.case, np.array(ctx.truth.at(names)))
                 if truth is not None else None)
    fig = plot_spread(positions, names, success=success, truth=truth_pos)
    out.append(page.figure(fig, "spread", "parameters of every run between their bounds "
                                          "(box: quartiles of the successful runs; dots: "
                                          "successful runs; crosses: unsuccessful runs; "
                                          "log parameters on a log scale)"
                                          + ("; diamonds: truth" if truth else "")
                                          + ("" if success.any() else
                                             "; no run was successful")))
    spread = summary.spread.params
    best = summary.best.params
    header = ["parameter", "unit", "best", "mean", "std", "CV %", "min", "max", "at a bound"]
    if truth is not None:
        header[3:3] = ["truth", "best − truth [%]"]
    rows = []
    for j, p in enumerate(res.case.parameters):
        s = spread.get(p.name, {})
        mean, std = s.get("mean"), s.get("std")
        cv = 100.0 * std / abs(mean) if mean not in (None, 0.0) and std is not None else None
        n_low, n_high = int(np.sum(flags[:, j] < 0)), int(np.sum(flags[:, j] > 0))
        where = ", ".join(t for t in (f"{n_low} at lower" if n_low else "",
                                      f"{n_high} at upper" if n_high else "") if t)
        cells = [td(esc(p.name)), td(esc(p.unit)), td(num(best[p.name]), "num"),
                 td(num(mean), "num"), td(num(std), "num"), td(num(cv, 3), "num"),
                 td(num(s.get("min")), "num"), td(num(s.get("max")), "num"),
                 td(esc(where), "bound" if where else "")]
        if truth is not None:
            cells[3:3] = [td(num(truth[p.name]), "num truth"),
                          td(num(relative_error(best[p.name], truth[p.name]), 3), "num")]
        rows.append(cells)
    out.append(table(header, rows, table_id="spread",
                     caption=f"Spread over the {int(success.sum())} successful runs "
                             "(\"at a bound\" counts every run)"))
    out.append(_improper_list(ctx, flags))
    return "\n".join(out)

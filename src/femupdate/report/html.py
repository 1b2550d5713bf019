"""``femupdate report DIR``: one self-contained HTML page of a results directory.

Reads the results directory (:func:`femupdate.results.load_results`: ``summary.json``, the
best model's fit ``fit.npz`` and, optionally, the results store with the runs' histories) and
writes
``DIR/report.html`` with its figures in ``DIR/report/*.png`` (referenced relatively, so the
directory can be moved or zipped as a whole). Plain HTML and inline CSS, no JavaScript.

Sections: the case; the table of runs (the paper's Tables 3–6 and 9); convergence (φ of every
run, the Beta trace, the parameters); the spread of the parameters over the successful runs,
with values at a bound flagged as improper minima; measured against predicted time histories
and Fourier spectra (Figs. 13, 18, 19); natural frequencies (Tables 7, 11); identifiability.
What cannot be drawn (no results store, no fit) is said where it would be.

Why this file is long (about 700 lines): one page of seven sections, each a function of the
results; the figures are drawn by :mod:`femupdate.report.figures` and ``plots``.
"""

from __future__ import annotations

import datetime
import html
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from femupdate.case import Case, build_structure
from femupdate.errors import FemupdateError
from femupdate.results import REPORT_FILE, Fit, load_results
from femupdate.runs.stats import BOUND_TOL, bound_flags

__all__ = [
    "BOUND_TOL",
    "FIGURE_DIR",
    "bound_flags",
    "bound_positions",
    "format_number",
    "spectrum_limit",
    "write_report",
]

FIGURE_DIR = "report"
#: Every figure the report may draw (report/<name>.png): stale ones are removed first.
_FIGURES = ("phi", "beta", "parameters", "spread", "fit", "spectra", "correlation")


# ----------------------------------------------------------------------------- pure functions


def format_number(value: Any, digits: int = 4) -> str:
    """A number as a table shows it: ``digits`` significant digits, thousands separated.

    Integers are shown in full (``12,345``); floats with ``digits`` significant digits, in
    scientific notation with a plain exponent (``2.1e11``, ``3.5e-5``) outside [1e-3, 1e5);
    None and NaN as an en dash.
    """
    if value is None:
        return "–"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, (int, np.integer)):
        return f"{int(value):,}"
    x = float(value)
    if math.isnan(x):
        return "–"
    if math.isinf(x):
        return "∞" if x > 0 else "−∞"
    if x == 0.0:
        return "0"
    if 1e-3 <= abs(x) < 1e5:
        # Positional, never "1e+04": rounded to ``digits`` significant digits.
        return np.format_float_positional(x, precision=digits, unique=False,
                                          fractional=False, trim="-")
    mantissa, exponent = f"{x:.{digits - 1}e}".split("e")
    mantissa = mantissa.rstrip("0").rstrip(".") if "." in mantissa else mantissa
    return f"{mantissa}e{int(exponent)}"


def bound_positions(values: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                    log: np.ndarray) -> np.ndarray:
    """Where values sit between their bounds: 0 at the lower, 1 at the upper.

    Measured in the search space, as the optimizers see it: log10 for log-scale parameters
    (a non-positive value of a log parameter is at −∞, below its lower bound).

    Parameters
    ----------
    values : ndarray, shape (..., n)
        Physical parameter values.
    lower, upper : ndarray, shape (n,)
        Physical bounds.
    log : ndarray of bool, shape (n,)
        Log-scale parameters.
    """
    values = np.asarray(values, dtype=float)
    log = np.asarray(log, dtype=bool)
    with np.errstate(divide="ignore", invalid="ignore"):
        v = np.where(log, np.log10(np.where(values > 0, values, np.nan)), values)
        v = np.where(log & ~(values > 0), -np.inf, v)
        lo = np.where(log, np.log10(np.where(log, lower, 1.0)), lower)
        hi = np.where(log, np.log10(np.where(log, upper, 1.0)), upper)
    return (v - lo) / (hi - lo)


def spectrum_limit(f: np.ndarray, amplitude: np.ndarray, *, fraction: float = 0.995,
                   margin: float = 1.5) -> float:
    """Upper frequency of a spectrum plot: ``margin`` × where the energy reaches ``fraction``.

    The energy is Σ|Y|² over the frequencies (all channels together); the limit is capped at
    the last frequency (Nyquist).
    """
    f = np.asarray(f, dtype=float)
    power = np.sum(np.asarray(amplitude, dtype=float).reshape(f.size, -1) ** 2, axis=1)
    total = power.sum()
    if not np.isfinite(total) or total <= 0.0:
        return float(f[-1])
    k = int(np.searchsorted(np.cumsum(power) / total, fraction))
    return float(min(f[-1], margin * f[min(k, f.size - 1)]))


# ----------------------------------------------------------------------------- the view


@dataclass
class Results:
    """What the page reads: the results directory with the summary as plain data (the bridge
    benchmark's truth and noise floor at its top level, where the sections look for them)."""

    directory: Path
    summary: dict[str, Any]
    case: Case
    meta: dict[str, Any] | None
    histories: dict[int, dict[str, np.ndarray]]
    fit: Fit | str
    store_note: str | None

    @property
    def names(self) -> tuple[str, ...]:
        return self.case.parameter_names

    @property
    def best_index(self) -> int:
        return int(self.summary["best"]["run"])


def _view(results_dir: str | Path) -> Results:
    typed = load_results(results_dir)
    summary = typed.summary.model_dump()
    bench = summary.pop("benchmark", None)
    if bench:
        summary.update({k: bench[k] for k in ("truth", "noise_floor", "truth_frequencies_hz")})
    return Results(typed.directory, summary, typed.case, typed.meta, typed.histories, typed.fit,
                   typed.store_note)


# ----------------------------------------------------------------------------- HTML helpers


def _esc(text: Any) -> str:
    return html.escape(str(text), quote=True)


def _num(value: Any, digits: int = 4) -> str:
    return _esc(format_number(value, digits))


def _td(content: str, cls: str = "", title: str = "") -> str:
    attrs = (f' class="{cls}"' if cls else "") + (f' title="{_esc(title)}"' if title else "")
    return f"<td{attrs}>{content}</td>"


def _table(header: Sequence[str], rows: Sequence[Sequence[str]], *, table_id: str = "",
           caption: str = "") -> str:
    """A table: ``header`` is plain text (escaped here), ``rows`` hold finished ``<td>`` cells."""
    ident = f' id="{table_id}"' if table_id else ""
    head = "".join(f"<th>{_esc(h)}</th>" for h in header)
    body = "\n".join(f"<tr>{''.join(r)}</tr>" for r in rows)
    cap = f"<caption>{_esc(caption)}</caption>" if caption else ""
    return f"<table{ident}>{cap}<thead><tr>{head}</tr></thead>\n<tbody>\n{body}\n</tbody></table>"


def _pairs(items: Sequence[tuple[str, str]]) -> str:
    """A two-column definition table; values are finished HTML."""
    rows = "".join(f"<tr><th>{_esc(k)}</th><td>{v}</td></tr>" for k, v in items)
    return f'<table class="pairs">{rows}</table>'


def _note(text: str) -> str:
    return f'<p class="note">{_esc(text)}</p>'


class _Page:
    """Collects figures (drawn into ``figure_dir``) and the notes of what could not be drawn."""

    def __init__(self, directory: Path) -> None:
        self.directory = directory
        self.figure_dir = directory / FIGURE_DIR
        self.missing: list[str] = []

    def path(self, name: str) -> Path:
        return self.figure_dir / name

    def figure(self, path: Path, caption: str) -> str:
        rel = path.relative_to(self.directory).as_posix()
        return (f'<figure><img src="{_esc(rel)}" alt="{_esc(caption)}">'
                f"<figcaption>{_esc(caption)}</figcaption></figure>")

    def absent(self, what: str, why: str) -> str:
        self.missing.append(f"{what}: {why}")
        return _note(f"{what} not drawn: {why}.")


# ----------------------------------------------------------------------------- sections


def _section_case(res: Results) -> str:
    case, summary = res.case, res.summary
    model = case.model
    out = [f"<p>{_esc(case.case.description)}</p>" if case.case.description else ""]
    try:
        structure = build_structure(model)
        dofs = f"{structure.n_dof} free DOFs"
        nodes = len(structure.nodes)
    except FemupdateError as exc:
        dofs, nodes = f"cannot be assembled: {exc}", len(model.nodes)
    if model.shear_building is not None:
        kind = f"shear building of {len(model.shear_building.masses)} storeys"
        parts = [kind]
    else:
        parts = [f"{nodes} nodes"]
        for key in ("beams", "springs", "dampers", "frictions", "masses", "supports"):
            count = len(getattr(model, key))
            if count:
                parts.append(f"{count} {key}")
    items = [
        ("model", _esc(", ".join(parts) + f"; {dofs}")),
        ("excitation", _esc(f"base motion in {model.excitation_direction}")),
        ("simulation", _esc(case.simulation_method)),
    ]
    if model.rayleigh is not None:
        alpha, beta = model.rayleigh.alpha, model.rayleigh.beta
        items.append(("Rayleigh damping", _esc(f"α = {format_number(alpha)} 1/s, "
                                                f"β = {format_number(beta)} s")))
    out.append(_pairs(items))
    out.append("<h3>Parameters</h3>")
    rows = [[_td(_esc(p.name)), _td(_esc(p.unit)), _td(_num(p.lower), "num"),
             _td(_num(p.upper), "num"), _td(_esc(p.scale)), _td(_num(p.nominal), "num")]
            for p in case.parameters]
    out.append(_table(["parameter", "unit", "lower", "upper", "scale", "nominal"], rows,
                      table_id="parameters"))
    if case.data is not None:
        data = case.data
        out.append("<h3>Data</h3>")
        items = [("format", _esc(data.format)), ("directory", _esc(case.data_directory())),
                 ("input (table)", _esc(f"{data.input.file} [{data.input.column}] "
                                        f"({data.input.unit or data.unit})"))]
        if data.window is not None:
            items.append(("window", _esc(f"{format_number(data.window[0])} – "
                                         f"{format_number(data.window[1])} s")))
        out.append(_pairs(items))
        rows = [[_td(_esc(c.label)), _td(_esc(c.file)), _td(_esc(c.column)),
                 _td(_esc(f"{c.node}.{c.dof}")), _td(_esc(c.unit or data.unit)),
                 _td(_num(c.weight), "num")] for c in data.outputs]
        out.append(_table(["channel", "file", "column", "DOF", "unit", "weight"], rows,
                          table_id="channels"))
    pre, obj = case.preprocess, case.objective
    out.append("<h3>Processing and error function</h3>")
    hp = (f"Butterworth high-pass {format_number(pre.highpass_hz)} Hz, order "
          f"{pre.highpass_order}, {'zero-phase' if pre.zero_phase else 'causal'}"
          if pre.highpass_hz > 0 else "none")
    out.append(_pairs([
        ("high-pass", _esc(hp)),
        ("resampling", _esc(f"{format_number(pre.resample_hz)} Hz" if pre.resample_hz
                            else "none")),
        ("integration substeps", _esc(pre.substeps)),
        ("compared quantity", _esc(obj.quantity)),
        ("experimental parameters", _esc("integration constants by least squares"
                                         if obj.experimental_parameters
                                         and obj.quantity == "displacement" else "none")),
    ]))
    out.append("<h3>Search</h3>")
    search = case.search
    settings = (res.meta or {}).get("settings", {})
    items = [
        ("method", _esc(summary.get("method", search.method))),
        ("runs", _esc(len(summary["runs"]))),
        ("seed", _esc(settings.get("entropy", search.seed if search.seed is not None
                                   else "fresh entropy"))),
        ("max evaluations", _num(settings.get("max_evals", search.max_evals))),
        ("f_target (φ_s)", _num(settings.get("f_target", search.f_target))),
    ]
    if search.sigma_min is not None:
        items.append(("σ_s", _num(search.sigma_min)))
    if search.f_change_min is not None:
        items.append(("Δφ_s", _num(search.f_change_min)))
    options = settings.get("options", search.options)
    if options:
        items.append(("options", _esc(json.dumps(options, sort_keys=True))))
    if "success_rule" in summary:
        items.append(("success", _esc(summary["success_rule"])))
    if "wall_s" in summary:
        items.append(("wall time", _esc(f"{format_number(summary['wall_s'], 3)} s")))
    if "fingerprint" in summary:
        items.append(("case fingerprint", f"<code>{_esc(summary['fingerprint'][:16])}…</code>"))
    out.append(_pairs(items))
    if res.meta is not None:
        versions = res.meta.get("versions", {})
        items = [(k, _esc(v)) for k, v in versions.items()]
        created = res.meta.get("created")
        if isinstance(created, (int, float)):
            stamp = datetime.datetime.fromtimestamp(created, datetime.UTC)
            items.append(("store created", _esc(stamp.strftime("%Y-%m-%d %H:%M:%S UTC"))))
        out.append("<h3>Software</h3>" + _pairs(items))
    else:
        out.append(_note(f"Software versions unknown: {res.store_note}."))
    return "\n".join(out)


def _run_positions(res: Results) -> tuple[np.ndarray, np.ndarray]:
    """Each run's parameters between their bounds (runs × n) and their bound flags."""
    params = res.case.parameters
    values = np.array([[float(run["params"][p.name]) for p in params]
                       for run in res.summary["runs"]], dtype=float).reshape(-1, len(params))
    pos = bound_positions(values, np.array([p.lower for p in params]),
                          np.array([p.upper for p in params]),
                          np.array([p.scale == "log" for p in params]))
    return pos, bound_flags(pos)


def _stop_text(run: Mapping[str, Any]) -> str:
    restarts = int(run.get("restarts", 0))
    after = f" (after {restarts} restart{'s' if restarts > 1 else ''})" if restarts else ""
    return _criteria_text(run) + after


def _criteria_text(run: Mapping[str, Any]) -> str:
    stop = run.get("stop") or {}
    if not stop:
        return str(run.get("message", ""))
    parts = []
    for key, value in stop.items():
        if isinstance(value, bool) or value is None:
            parts.append(key)
        elif isinstance(value, (int, float)):
            parts.append(f"{key} = {format_number(value)}")
        else:
            parts.append(f"{key}: {value}")
    return ", ".join(parts)


def _section_runs(res: Results) -> str:
    summary, case = res.summary, res.case
    names = res.names
    units = {p.name: p.unit for p in case.parameters}
    _, flags = _run_positions(res)
    header = ["run", "NMSE %", "evaluations", "stop", "success",
              *[f"{n} [{units[n]}]" if units[n] else n for n in names], "improper minimum"]
    rows = []
    for run, row_flags in zip(summary["runs"], flags, strict=True):
        index = int(run["index"])
        best = index == res.best_index
        cells = [_td(_esc(f"{index} (best)" if best else index)),
                 _td(_num(100.0 * float(run["phi"])), "num"),
                 _td(_num(int(run["nfev"])), "num"),
                 _td(_esc(_stop_text(run)), title=str(run.get("message", ""))),
                 _td("yes" if run.get("success") else "no",
                     "ok" if run.get("success") else "fail")]
        at_bound = []
        for name, flag in zip(names, row_flags, strict=True):
            value = run["params"][name]
            if flag:
                side = "lower" if flag < 0 else "upper"
                at_bound.append(f"{name} ({side})")
                cells.append(_td(_num(value), "num bound", f"at the {side} bound"))
            else:
                cells.append(_td(_num(value), "num"))
        cells.append(_td(_esc("improper minimum: " + ", ".join(at_bound)) if at_bound else "",
                         "bound" if at_bound else ""))
        rows.append(cells)
    out = [_table(header, rows, table_id="runs",
                  caption="Every run: NMSE = 100 φ, evaluations, why it stopped, parameters "
                          "(cells at a bound are marked)")]
    n_runs = len(summary["runs"])
    ok = summary.get("successes", sum(bool(r.get("success")) for r in summary["runs"]))
    items = [("successful runs", _esc(f"{ok}/{n_runs} ({format_number(100.0 * ok / n_runs, 3)}"
                                      " %)" if n_runs else "0")),
             ("evaluations (successful runs)", _esc(
                 f"min {format_number(summary.get('evals_min'))}, mean "
                 f"{format_number(summary.get('evals_mean'))}, median "
                 f"{format_number(summary.get('evals_median'))}, max "
                 f"{format_number(summary.get('evals_max'))}")),
             ("best run", _esc(f"{res.best_index}: NMSE "
                               f"{format_number(100.0 * float(summary['best']['phi']))} %"))]
    if summary.get("noise_floor") is not None:
        items.append(("noise floor (truth against the data)",
                      _esc(f"NMSE {format_number(100.0 * summary['noise_floor'])} %")))
    out.append(_pairs(items))
    n_flagged = int(np.any(flags != 0, axis=1).sum()) if flags.size else 0
    if n_flagged:
        out.append(_note(f"{n_flagged} run(s) ended with a parameter within "
                         f"{format_number(BOUND_TOL)} of its search range from a bound: an "
                         "improper minimum, unless the bound is the physical "
                         "answer."))
    return "\n".join(out)


def _physical_history(case: Case, x: np.ndarray) -> np.ndarray:
    """History points from the search space to physical values, column by column."""
    x = np.asarray(x, dtype=float)
    out = np.empty_like(x)
    for j, p in enumerate(case.parameters):
        out[:, j] = 10.0 ** x[:, j] if p.scale == "log" else x[:, j]
    return out


def _section_convergence(res: Results, page: _Page) -> str:
    from femupdate.report.figures import plot_parameters
    from femupdate.report.plots import plot_beta_trace, plot_phi_runs

    if not res.histories:
        why = res.store_note or "the results store holds no evaluations"
        return "\n".join([page.absent("φ against evaluations", why),
                          page.absent("a, b and σ against step", why),
                          page.absent("parameters against evaluations", why)])
    out = []
    indices = sorted(res.histories)
    labels = [f"run {i}" + (" (best)" if i == res.best_index else "") for i in indices]
    highlight = indices.index(res.best_index) if res.best_index in indices else None
    path = plot_phi_runs([res.histories[i]["fun"] for i in indices], labels, page.path("phi.png"),
                         highlight=highlight, title=f"{res.case.case.name}: φ_m, every run")
    out.append(page.figure(path, "φ_m (best so far) against evaluations, every run (log)"))
    best = res.histories.get(res.best_index)
    if best is None:
        out.append(page.absent("a, b and σ and the parameters of the best run",
                               "the store holds no history of the best run"))
        return "\n".join(out)
    if all(k in best for k in ("a", "b", "sigma")) and np.size(best["a"]):
        path = plot_beta_trace(best, res.names, page.path("beta.png"))
        out.append(page.figure(path, f"run {res.best_index}: Beta parameters a, b of every "
                                     "parameter and σ against step (log)"))
    else:
        method = res.summary.get("method", res.case.search.method)
        out.append(page.absent("a, b and σ against step",
                               f"the store holds no Beta trace: method {method!r} is not "
                               "IB or AB"))
    if np.size(best["x"]):
        hist = {"x": _physical_history(res.case, best["x"]), "fun": best["fun"]}
        truth = res.summary.get("truth")
        path = plot_parameters(hist, res.names, page.path("parameters.png"),
                               truth=[truth[n] for n in res.names] if truth else None)
        out.append(page.figure(path, f"run {res.best_index}: the parameters of the best-so-far "
                                     "solution against evaluations"
                                     + (" (dashed: truth)" if truth else "")))
    return "\n".join(out)


def _section_spread(res: Results, page: _Page) -> str:
    from femupdate.report.plots import plot_spread

    summary, names = res.summary, res.names
    positions, flags = _run_positions(res)
    success = np.array([bool(r.get("success")) for r in summary["runs"]], dtype=bool)
    out = []
    truth = summary.get("truth")
    truth_pos = None
    if truth:
        params = res.case.parameters
        truth_pos = bound_positions(np.array([truth[n] for n in names]),
                                    np.array([p.lower for p in params]),
                                    np.array([p.upper for p in params]),
                                    np.array([p.scale == "log" for p in params]))
    if success.any():
        path = plot_spread(positions, names, page.path("spread.png"), success=success,
                           truth=truth_pos)
        out.append(page.figure(path, "parameters of the successful runs between their bounds "
                                     "(box: quartiles; dots: runs; crosses: unsuccessful runs; "
                                     "log parameters on a log scale)"))
    else:
        out.append(page.absent("box plots of the parameters", "no run was successful"))
    spread = summary.get("spread", {}).get("params", {})
    best = summary["best"]["params"]
    header = ["parameter", "unit", "best", "mean", "std", "CV %", "min", "max", "at a bound"]
    if truth:
        header.insert(3, "truth")
    rows = []
    for j, p in enumerate(res.case.parameters):
        s = spread.get(p.name, {})
        mean, std = s.get("mean"), s.get("std")
        cv = 100.0 * std / abs(mean) if mean not in (None, 0.0) and std is not None else None
        n_low = int(np.sum(flags[:, j] < 0))
        n_high = int(np.sum(flags[:, j] > 0))
        where = ", ".join(t for t in (f"{n_low} at lower" if n_low else "",
                                      f"{n_high} at upper" if n_high else "") if t)
        cells = [_td(_esc(p.name)), _td(_esc(p.unit)), _td(_num(best[p.name]), "num"),
                 _td(_num(mean), "num"), _td(_num(std), "num"), _td(_num(cv, 3), "num"),
                 _td(_num(s.get("min")), "num"), _td(_num(s.get("max")), "num"),
                 _td(_esc(where), "bound" if where else "")]
        if truth:
            cells.insert(3, _td(_num(truth.get(p.name)), "num"))
        rows.append(cells)
    out.append(_table(header, rows, table_id="spread",
                      caption=f"Spread over the {int(success.sum())} successful runs "
                              "(\"at a bound\" counts every run)"))
    flagged = [(int(run["index"]), [f"{n} = {format_number(run['params'][n])} at its "
                                    f"{'lower' if f < 0 else 'upper'} bound"
                                    for n, f in zip(names, row, strict=True) if f])
               for run, row in zip(summary["runs"], flags, strict=True)]
    flagged = [(i, items) for i, items in flagged if items]
    if flagged:
        lis = "".join(f"<li>run {i}: {_esc('; '.join(items))}</li>" for i, items in flagged)
        out.append(f'<p class="warn">Improper minima (a parameter within '
                   f"{_esc(format_number(BOUND_TOL))} of its range from a bound):</p>"
                   f'<ul id="improper">{lis}</ul>')
    else:
        out.append("<p>No run ended at a bound.</p>")
    return "\n".join(out)


def _section_fit(res: Results, page: _Page, fit: Fit | str) -> str:
    from femupdate.data.signal import fourier_amplitude
    from femupdate.report.figures import plot_fit
    from femupdate.report.plots import plot_spectra

    out = []
    per_channel = res.summary["best"].get("nmse_per_channel") or {}
    if per_channel:
        rows = [[_td(_esc(ch)), _td(_num(100.0 * float(v)), "num")]
                for ch, v in per_channel.items()]
        out.append(_table(["channel", "NMSE %"], rows, table_id="channels-nmse",
                          caption=f"Best run ({res.best_index}), per channel"))
    if isinstance(fit, str):
        out.append(page.absent("measured against predicted time histories and spectra", fit))
        return "\n".join(out)
    labels = [f"{c} [{fit.unit}]" for c in fit.channels]
    path = plot_fit(fit.t, fit.measured, fit.predicted, page.path("fit.png"), labels=labels)
    out.append(page.figure(path, "measured (with the fitted integration constants, as φ "
                                 "compares them) and predicted time histories, best model"
                           if fit.unit == "m" else
                           "measured and predicted time histories, best model"))
    dt = float(fit.t[1] - fit.t[0])
    f, measured = fourier_amplitude(fit.measured_acc, fs=1.0 / dt)
    _, predicted = fourier_amplitude(fit.predicted_acc, fs=1.0 / dt)
    path = plot_spectra(f, measured, predicted, page.path("spectra.png"),
                        labels=[f"{c} [m/s]" for c in fit.channels],
                        f_max=spectrum_limit(f, measured),
                        marks=res.summary["best"].get("frequencies_hz") or (),
                        ylabel="Fourier amplitude of the acceleration relative to the table")
    out.append(page.figure(path, "Fourier amplitude spectra of the accelerations relative to "
                                 "the table, measured and predicted (dotted: natural "
                                 "frequencies of the best model)"))
    return "\n".join(out)


def _section_frequencies(res: Results) -> str:
    summary = res.summary
    best = summary["best"].get("frequencies_hz") or []
    spread = summary.get("spread", {}).get("frequencies_hz", {})
    ref, ref_name = None, ""
    for key, name in (("measured_frequencies_hz", "measured"), ("truth_frequencies_hz", "truth")):
        if summary.get(key):
            ref, ref_name = summary[key], name
            break
    if not best:
        return _note("The summary holds no natural frequencies.")
    header = ["mode", "best model [Hz]", "mean ± std, successful runs [Hz]"]
    if ref is not None:
        header += [f"{ref_name} [Hz]", f"best − {ref_name} [%]"]
    rows = []
    for i, fb in enumerate(best):
        s = spread.get(f"f{i + 1}", {})
        ms = (f"{format_number(s['mean'])} ± {format_number(s['std'], 2)}"
              if "mean" in s else "–")
        cells = [_td(_esc(i + 1)), _td(_num(fb), "num"), _td(_esc(ms), "num")]
        if ref is not None:
            fr = ref[i] if i < len(ref) else None
            diff = 100.0 * (fb / fr - 1.0) if fr else None
            cells += [_td(_num(fr), "num"), _td(_num(diff, 3), "num")]
        rows.append(cells)
    out = [_table(header, rows, table_id="frequencies",
                  caption="Natural frequencies (K, M; friction elements stuck)")]
    if ref is None:
        out.append(_note("No measured or true frequencies in the summary to compare with."))
    return "\n".join(out)


def _section_identifiability(res: Results, page: _Page) -> str:
    from femupdate.report.plots import plot_correlation

    ident = res.summary.get("identifiability")
    if ident is None:
        return page.absent("identifiability", "the summary holds no sensitivities")
    if "error" in ident:
        return page.absent("identifiability", f"the sensitivities failed: {ident['error']}")
    names = list(ident["names"])
    phi_best = float(res.summary["best"]["phi"])
    undetermined = set(ident.get("undetermined", []))
    change = ident.get("phi_change_1pct", {})
    rows = []
    for name, value in zip(names, ident.get("values", [None] * len(names)), strict=True):
        d = change.get(name)
        rel = d / phi_best if d is not None and phi_best > 0 else None
        rows.append([_td(_esc(name)), _td(_num(value), "num"), _td(_num(d), "num"),
                     _td(_num(rel, 3), "num"),
                     _td("no" if name in undetermined else "yes",
                         "fail" if name in undetermined else "ok")])
    out = [_table(["parameter", "value", "Δφ for a 1 % change", "Δφ / φ", "determined"], rows,
                  table_id="identifiability",
                  caption="Sensitivity of φ at the best solution (to second order, from the "
                          "Jacobian of the residuals)")]
    sv = np.asarray(ident.get("singular_values", []), dtype=float)
    if sv.size:
        ratios = sv / sv[0] if sv[0] > 0 else sv
        text = ", ".join(f"{format_number(s)} ({format_number(r, 2)})"
                         for s, r in zip(sv, ratios, strict=True))
        cond = sv[0] / sv[-1] if sv[-1] > 0 else math.inf
        out.append(_pairs([("singular values (÷ largest)", _esc(text)),
                           ("condition number", _num(cond, 3))]))
    corr = np.asarray(ident.get("correlations", []), dtype=float)
    if corr.shape == (len(names), len(names)):
        path = plot_correlation(corr, names, page.path("correlation.png"))
        out.append(page.figure(path, "correlation matrix of the parameter estimates"))
    if undetermined:
        out.append(f'<p class="warn" id="undetermined">The data cannot determine: '
                   f"{_esc(', '.join(n for n in names if n in undetermined))}.</p>")
    else:
        out.append('<p id="undetermined">Every parameter is determined by the data.</p>')
    return "\n".join(out)


# ----------------------------------------------------------------------------- the page

_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 2em auto;
       max-width: 72em; padding: 0 1em; color: #222; line-height: 1.4; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; } h2 { border-bottom: 1px solid #ccc;
     margin-top: 2em; } h3 { font-size: 1.05em; margin-bottom: 0.3em; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.88em; }
th, td { border: 1px solid #ddd; padding: 0.25em 0.6em; vertical-align: top; }
thead th { background: #f2f2f2; } table.pairs th { text-align: left; background: #fafafa;
     font-weight: normal; color: #555; }
caption { caption-side: top; text-align: left; color: #555; padding-bottom: 0.3em; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
td.bound { background: #fde2c8; } td.ok { color: #176117; } td.fail { color: #a31515; }
.note { color: #666; font-style: italic; } .warn { color: #8a4b00; }
figure { margin: 1em 0; } figure img { max-width: 100%; border: 1px solid #eee; }
figcaption { color: #555; font-size: 0.9em; } .missing { background: #fff8e5;
     border: 1px solid #f0d48a; padding: 0.5em 1em; } code { font-size: 0.95em; }
.scroll { overflow-x: auto; }
"""


def write_report(results_dir: str | Path) -> Path:
    """Write ``report.html`` and its figures (``report/*.png``) into a results directory.

    Parameters
    ----------
    results_dir : path
        The ``--out`` directory of ``femupdate run``: ``summary.json`` and, if present,
        ``results.sqlite``.

    Returns
    -------
    Path
        ``results_dir/report.html``.

    Raises
    ------
    FemupdateError
        No results directory, or no readable ``summary.json`` in it.
    """
    res = _view(results_dir)
    page = _Page(res.directory)
    page.figure_dir.mkdir(parents=True, exist_ok=True)
    for stem in _FIGURES:  # a figure not drawn this time must not linger from an earlier one
        (page.figure_dir / f"{stem}.png").unlink(missing_ok=True)
    fit = res.fit
    name = res.case.case.name
    sections = [
        ("case", "1. The case", _section_case(res)),
        ("runs", "2. Runs", f'<div class="scroll">{_section_runs(res)}</div>'),
        ("convergence", "3. Convergence", _section_convergence(res, page)),
        ("spread", "4. Spread of the parameters", _section_spread(res, page)),
        ("fit", "5. Measured against predicted", _section_fit(res, page, fit)),
        ("frequencies", "6. Natural frequencies", _section_frequencies(res)),
        ("identifiability", "7. Identifiability",
         _section_identifiability(res, page)),
    ]
    toc = " · ".join(f'<a href="#{key}">{_esc(title)}</a>' for key, title, _ in sections)
    missing = ""
    if page.missing:
        lis = "".join(f"<li>{_esc(m)}</li>" for m in page.missing)
        missing = f'<div class="missing" id="missing"><p>Not drawn:</p><ul>{lis}</ul></div>'
    best = res.summary["best"]
    lead = (f"{len(res.summary['runs'])} runs of {res.summary.get('method', '?')}; best run "
            f"{res.best_index}, NMSE {format_number(100.0 * float(best['phi']))} %.")
    body = "\n".join(f'<section id="{key}"><h2>{_esc(title)}</h2>\n{content}\n</section>'
                     for key, title, content in sections)
    text = (
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
        f"<title>femupdate report: {_esc(name)}</title>\n<style>{_CSS}</style>\n</head>\n"
        f"<body>\n<h1>femupdate report: {_esc(name)}</h1>\n<p>{_esc(lead)}</p>\n"
        f"<nav>{toc}</nav>\n{missing}\n{body}\n</body>\n</html>\n"
    )
    out = res.directory / REPORT_FILE
    out.write_text(text, encoding="utf-8")
    return out


"""What the commands print: their tables (80 columns, numbers whole) and summaries."""

from __future__ import annotations

import shlex
from typing import TYPE_CHECKING, Any

import numpy as np
from rich import box
from rich.console import Console
from rich.table import Table
from rich.text import Text

from femupdate.cli.options import _fmt, console, say

if TYPE_CHECKING:
    from femupdate.pipeline.results import Summary, TrialRecord


def _dynamic_table(rows: list[dict[str, Any]]) -> Table:
    table = Table(title="Two-mode identification (paper Table 2): evaluations of successful runs",
                  # 80 columns hold it whole
                  box=box.SIMPLE_HEAD, pad_edge=False, collapse_padding=True)
    for col in ("method", "runs", "success", "min", "mean", "median", "max",
                "ERT*", "wall s"):
        table.add_column(col, justify="left" if col == "method" else "right", no_wrap=True)
    table.caption = "* ERT: evaluations of all runs, failed ones included, per successful run"
    for r in rows:
        table.add_row(
            r["method"], str(r["runs"]), f"{100 * r['success_ratio']:.0f} %",
            _fmt(r["evals_min"]), _fmt(r["evals_mean"]), _fmt(r["evals_median"]),
            _fmt(r["evals_max"]), _fmt(r["evals_per_success"]), f"{r['wall_s']:.1f}",
        )
    return table


def _methods_table(rows: list[Summary]) -> Table:
    """The methods of one bridge benchmark side by side, on the same data and target."""
    target = rows[0].benchmark.f_target if rows[0].benchmark is not None else None
    table = Table(title="methods side by side" + (f" (success: φ ≤ {target:.3g})"
                                                  if target is not None else ""),
                  box=box.SIMPLE_HEAD, pad_edge=False, collapse_padding=True)
    noisy = rows[0].benchmark is not None and rows[0].benchmark.snr > 0
    columns = ["method", "success", "mean", "median", "per success*", "wall s"]
    if noisy:
        columns.insert(2, "≤1.5× floor")
    for col in columns:
        table.add_column(col, justify="left" if col == "method" else "right", no_wrap=True)
    table.caption = "evaluations of successful runs; * all runs' evaluations, failed ones " \
                    "included, per successful run" + ("; floor: φ of the truth on the noisy " \
                                                      "data" if noisy else "")
    for r in rows:
        cells = [r.method, f"{r.successes}/{len(r.runs)}", _fmt(r.evals_mean),
                 _fmt(r.evals_median), _fmt(r.evals_per_success), f"{r.wall_s:.1f}"]
        if noisy:
            cells.insert(2, f"{r.benchmark.within_1_5_noise_floor}/{len(r.runs)}")
        table.add_row(*cells)
    return table


def _print_bridge(summary: Summary) -> None:
    from femupdate.problem.identifiability import strong_correlations

    print_update_summary(summary)
    bench = summary.benchmark
    if bench is None:
        return
    freqs = Table(title="natural frequencies [Hz] (paper Tables 7 and 11)")
    for col in ("mode", "truth", "best", "mean ± std (successful)", "best error"):
        freqs.add_column(col, justify="right", overflow="fold")
    spread = summary.spread.frequencies_hz
    for i, (ft, fb) in enumerate(zip(bench.truth_frequencies_hz[:4],
                                     summary.best.frequencies_hz[:4], strict=True)):
        s = spread.get(f"f{i + 1}")
        freqs.add_row(str(i + 1), f"{ft:.3f}", f"{fb:.3f}",
                      f"{s['mean']:.3f} ± {s['std']:.3f}" if s else "–",
                      f"{100 * (fb / ft - 1):+.2f} %")
    console.print(freqs)
    ident = summary.identifiability or {}
    errs = Table(title="best run against the truth; Δφ for a 1 % change of each parameter")
    for col in ("parameter", "truth", "best", "error", "Δφ (1 %)"):
        errs.add_column(col, justify="right", overflow="fold")
    best = summary.best.params
    change = ident.get("phi_change_1pct", {})
    for name, value in bench.truth.items():
        rel = f"{100 * (best[name] / value - 1):+.3f} %" if value else f"{best[name]:.3g}"
        errs.add_row(name, f"{value:.4g}", f"{best[name]:.4g}", rel,
                     f"{change[name]:.2e}" if name in change else "–")
    console.print(errs)
    floor = bench.noise_floor
    within = bench.within_1_5_noise_floor
    console.print(f"noise floor (NMSE of the truth model against the data): {100 * floor:.4g} %"
                  + (f"; runs within 1.5× of it: {within}/{len(summary.runs)}"
                     if within is not None else ""))
    if within:
        near = np.array([np.abs(e[:2]) for r, e in zip(summary.runs, bench.frequency_errors,
                                                       strict=True) if r.phi <= 1.5 * floor])
        worst = 100 * near.max(axis=0)
        console.print(f"their largest f1, f2 errors against the truth's: {worst[0]:.3f} %, "
                      f"{worst[1]:.3f} %")
    if ident.get("undetermined"):
        console.print(f"parameters the data hardly determine: {', '.join(ident['undetermined'])}")
    sv = ident.get("singular_values")
    if sv:
        pairs = strong_correlations(ident["names"], np.asarray(ident["correlations"]))
        console.print(f"sensitivity matrix at the best run: condition number {sv[0] / sv[-1]:.3g}"
                      + ("; strongly correlated (|ρ| > 0.9): " + ", ".join(
                          f"{a}–{b} {rho:+.3f}" for a, b, rho in pairs) if pairs else ""))


def _params_table(title: str, rows: list[tuple[str, str, str]]) -> Table:
    table = Table(title=Text(title))
    for col in ("parameter", "value", "spread (successful runs)"):
        table.add_column(col, justify="right", overflow="fold")
    for row in rows:
        table.add_row(*row)
    return table


#: Width a parameter column takes in a table beside its cell text: padding and border.
_COLUMN_EDGES = 3


def _column_groups(names: list[str], values: list[list[str]], width: int,
                   first: int) -> list[list[int]]:
    """Indices of ``names`` in groups whose columns fit ``width`` beside a first column of
    width ``first`` (every group at least one column)."""
    groups: list[list[int]] = [[]]
    used = first + 1
    for j, name in enumerate(names):
        need = max([len(name), *(len(row[j]) for row in values)]) + _COLUMN_EDGES
        if groups[-1] and used + need > width:
            groups.append([])
            used = first + 1
        groups[-1].append(j)
        used += need
    return groups


def _success_words(summary: Summary) -> tuple[str, str, str]:
    """What success meant: the success column's header, its caption and the rule."""
    from femupdate.pipeline.run import NEAR_BEST

    target = summary.settings.get("f_target")
    if target is not None:
        rule = f"φ ≤ f_target = {target:g}"
        return "φ ≤ target", f"✓: the run reached {rule} ([search] f_target)", rule
    if summary.verdict is not None:  # docs/verdicts.md
        rule = "at the best minimum, found again, NMSE < 100 %"
        return ("found again", "✓: the run ended at the best minimum and that minimum was "
                               "found again by independent searches (no f_target given)", rule)
    rule = f"φ within {NEAR_BEST:g} × the best run's φ"
    return ("≈ best", f"✓: {rule}; no f_target was given, so success is relative to the best "
                      "run, not to an absolute target", rule)


def print_update_summary(summary: Summary, out: Console | None = None) -> None:
    """The table of runs (as the paper's Tables 5, 6, 9), their parameters and the best one.

    Readable at 80 columns: the runs' parameters go in tables of as many columns as fit the
    console, after the table of runs.
    """
    out = out or console
    names = list(summary.best.params)
    restarted = any(r.restarts for r in summary.runs)
    header, meaning, rule = _success_words(summary)
    # Text, not str: the console given may interpret markup, which would eat "[search]".
    planned = summary.verdict.planned if summary.verdict is not None else None
    ran = (f"{len(summary.runs)} runs" if planned is None else
           f"{len(summary.runs)} of {planned} runs needed")
    runs = Table(title=Text(f"{summary.name}: {summary.method}, {ran}"),
                 caption=Text(meaning))
    for col in ("run", "NMSE %", "evals", "stop", header, *(["restarts"] if restarted else []),
                "at a bound"):
        runs.add_column(col, justify="left" if col in ("stop", "at a bound") else "right",
                        overflow="fold")
    for r in summary.runs:
        bound = ", ".join(f"{n} {side}" for n, side in r.at_bounds.items()) or "–"
        runs.add_row(str(r.index), f"{100 * r.phi:.4g}", f"{r.nfev:,}", ", ".join(r.stop),
                     "✓" if r.success else "✗", *([str(r.restarts)] if restarted else []),
                     bound)
    out.print(runs)
    values = [[f"{r.params[n]:.4g}" for n in names] for r in summary.runs]
    groups = _column_groups(names, values, out.width, len("run") + _COLUMN_EDGES)
    for k, group in enumerate(groups):
        part = f" ({k + 1}/{len(groups)})" if len(groups) > 1 else ""
        table = Table(title=Text(f"parameters of each run{part}"))
        table.add_column("run", justify="right", overflow="fold")
        for j in group:
            table.add_column(names[j], justify="right", overflow="fold")
        for r, row in zip(summary.runs, values, strict=True):
            table.add_row(str(r.index), *(row[j] for j in group))
        out.print(table)
    spread = summary.spread.params
    out.print(_params_table(
        f"best run {summary.best.run}: NMSE {summary.best.nmse_percent:.4g} %",
        [(n, f"{v:.6g}", f"{spread[n]['mean']:.4g} ± {spread[n]['std']:.2g}" if n in spread
          else "–") for n, v in summary.best.params.items()],
    ))
    freqs = ", ".join(f"{f:.3f}" for f in summary.best.frequencies_hz)
    say(f"natural frequencies of the best model [Hz]: {freqs}", out=out)
    from femupdate.pipeline.posterior.console import print_laplace

    print_laplace(summary.laplace, summary.best.params, out)
    print_trials(summary.trials, "the best model on each trial", out=out)
    say(f"successful runs ({rule}): {summary.successes}/{len(summary.runs)}; "
        f"evaluations (successful): mean {_fmt(summary.evals_mean)}, "
        f"median {_fmt(summary.evals_median)}; per success, failed runs "
        f"included: {_fmt(summary.evals_per_success)}; "
        f"wall {summary.wall_s:.1f} s", out=out)
    if summary.verdict is not None:
        say(f"verdict: {summary.verdict.words}", "green" if summary.verdict.converged
            and summary.verdict.fits else "yellow", out=out)
        if (words := disagreement_words(summary)) is not None:
            say(words, out=out)
    if restarted:
        counts = [r.restarts for r in summary.runs]
        say(f"restarts (searches that converged or stalled): {sum(counts)} in all, in "
            f"{sum(c > 0 for c in counts)} of {len(counts)} runs", out=out)
    blocking = [d for d in summary.defects if d.status == "open" and d.severity == "error"]
    if blocking:
        say(f"not a success: {len(blocking)} defect(s) in the records neither repaired nor "
            "accepted (listed above and in summary.json 'defects'; see [data] repair_defects "
            "and accept)", "red", out=out)
    failed = [r for r in summary.runs if not r.success]
    improper = [r for r in failed if r.at_bounds]
    if improper:
        say(f"unsuccessful runs: {len(failed)}, of which {len(improper)} end with a "
            "parameter at a bound (improper minima): " + "; ".join(
                f"run {r.index}: " + ", ".join(f"{n} {side}" for n, side in r.at_bounds.items())
                for r in improper), out=out)
    elif failed:
        say(f"unsuccessful runs: {len(failed)}, none with a parameter at a bound: stopped "
            "before reaching the target (budget or stopping criteria) or in another minimum",
            out=out)


def disagreement_words(summary: Summary) -> str | None:
    """What the success count and the verdict each mean, where they disagree: runs that
    reached the target (successes) at different minima (not converged). The noise-free bridge
    printed 'successful runs 25/25' beside 'not converged: … 21 different minima'."""
    target = summary.settings.get("f_target")
    verdict = summary.verdict
    if target is None or verdict is None or verdict.converged or not summary.successes:
        return None
    return (f"success and verdict differ: {summary.successes} of {len(summary.runs)} runs "
            f"reached φ ≤ f_target = {target:g} (a success), but the verdict asks whether the "
            f"runs ended at the same point, and they ended in {verdict.minima} different "
            "minima: below the target the data do not single out one set of parameters (see "
            "the intervals above)")


def _resume_hint(words: list[str]) -> None:
    """Say how to continue after Ctrl-C (the store keeps every finished chunk)."""
    say("interrupted; the runs so far are kept: resume with", "yellow")
    say(shlex.join(words), "yellow", whole=True)


def print_trials(trials: list[TrialRecord], title: str, *, out: Console | None = None) -> None:
    """Each trial's NMSE, each channel's, and the channel delays removed."""
    if not trials:
        return
    table = Table(title=Text(title))
    for col in ("trial", "role", "NMSE %", "channels: NMSE %", "delays removed"):
        table.add_column(col, justify="right", overflow="fold")
    for t in trials:
        channels = ", ".join(f"{c} {100 * v:.4g}" for c, v in t.nmse_per_channel.items())
        delays = ", ".join(f"{c} {1e3 * d:.2f} ms" for c, d in t.delays_s.items()) or "–"
        table.add_row(Text(t.name), t.role, f"{100 * t.phi:.4g}", Text(channels), Text(delays))
    (out or console).print(table)
    for t in trials:
        for note in t.notes:
            say(f"{t.name}: {note}", out=out)


def print_coverage(bands: list[Any], title: str = "5–95 % predictive bands") -> None:
    """The share of each trial's measured record inside its predictive band."""
    table = Table(title=Text(f"{title}: share of the measured record inside"))
    for col in ("trial", "role", "channels: covered"):
        table.add_column(col, justify="right", overflow="fold")
    for b in bands:
        table.add_row(Text(b.trial), b.role, Text(", ".join(
            f"{c} {100 * v:.1f} %" for c, v in zip(b.channels, b.coverage, strict=True))))
    console.print(table)


#: Mode shapes printed by `femupdate modes` (all of them with --json).
SHAPES_SHOWN = 6


def pair_modes(undamped: np.ndarray, damped: np.ndarray) -> np.ndarray:
    """For each undamped frequency, the index of the damped mode of nearest |λ|/2π (relative
    distance), each used once; -1 where none is left. Overdamped poles make the damped list
    longer than the undamped one (a frame with dashpots and hysteretic links paired them by
    position: ζ 0 % or 100 % with a damped frequency 0 against the wrong modes)."""
    match = np.full(undamped.size, -1)
    free = list(range(damped.size))
    for i in np.argsort(undamped, kind="stable"):
        if not free:
            break
        scale = np.maximum(np.maximum(abs(undamped[i]), np.abs(damped[free])), 1e-300)
        k = int(np.argmin(np.abs(damped[free] - undamped[i]) / scale))
        match[i] = free.pop(k)
    return match


def _unsigned_zero(text: str) -> str:
    """A formatted number without the sign of a rounded zero ("-0.000": ζ of -1e-17)."""
    return text[1:] if text.startswith("-") and float(text) == 0.0 else text


def _shapes_table(labels: list[str], shapes: np.ndarray, freqs: np.ndarray) -> Table:
    """The first mode shapes, each scaled to a largest component of 1."""
    k = min(SHAPES_SHOWN, shapes.shape[1])
    table = Table(title=f"mode shapes of modes 1–{k} (undamped), each scaled to a largest "
                        "component of ±1")
    table.add_column("DOF", justify="left", overflow="fold")
    for i in range(k):
        table.add_column(f"mode {i + 1}", justify="right", overflow="fold")
    scaled = shapes[:, :k] / np.where(np.abs(shapes[:, :k]).max(axis=0) > 0,
                                      np.abs(shapes[:, :k]).max(axis=0), 1.0)
    for label, row in zip(labels, scaled, strict=True):
        table.add_row(label, *(f"{v:+.3f}" for v in row))
    return table


def _records_table(title: str, rows: list[dict[str, Any]]) -> Table:
    """The channels of a network record: numbers never cut, the location wraps."""
    table = Table(title=Text(title), box=box.SIMPLE_HEAD, pad_edge=False,
                  collapse_padding=True)
    table.add_column("ch", justify="right", no_wrap=True)
    table.add_column("location", justify="left", overflow="fold", ratio=1)
    table.add_column("dir", justify="left", no_wrap=True)
    for col in ("Hz", "samples", "s", "peak m/s²", "file unit"):
        table.add_column(col, justify="right", no_wrap=True)
    for r in rows:
        table.add_row(str(r["channel"]), r["location"], r["direction"], f"{r['rate_hz']:g}",
                      str(r["samples"]), f"{r['duration_s']:.2f}", f"{r['peak_m_s2']:.4f}",
                      r["file_unit"])
    return table


"""The ``femupdate`` command line (also ``python -m femupdate``).

Messages and help are printed as written (no rich markup: bracketed names such as ``[search]``
stay), femupdate's errors as one line with exit code 2, Ctrl-C as one line (with the command that
resumes a run) and exit code 130; tables fit 80 columns.

Why this file is long (about 650 lines): typer declares each command's options, with their help,
in the command's signature, so ten commands take half of the file; the other half prints their
results (the run tables, the bridge's, the modes'), which only the command line needs.
"""

from __future__ import annotations

import json
import math
import shlex
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import numpy as np
import typer
from rich import box
from rich.console import Console
from rich.table import Table
from rich.text import Text

from femupdate.errors import ConfigError, FemupdateError

if TYPE_CHECKING:
    from femupdate.case import Case
    from femupdate.results import Summary, TrialRecord

# Help and messages are printed as written: rich markup would eat bracketed names such as
# [search] or [[parameters]] (rich_markup_mode=None; console output with markup=False).
app = typer.Typer(
    help="Finite element model updating in structural dynamics, in the time domain.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
    rich_markup_mode=None,
)
bench_app = typer.Typer(help="Benchmarks of the paper and of speed.", no_args_is_help=True,
                        rich_markup_mode=None)
app.add_typer(bench_app, name="bench")
console = Console(markup=False)

def _inputs() -> Any:
    """femupdate.inputs, imported when an option is checked: it loads the case schema, which
    ``femupdate --help`` does not need."""
    import femupdate.inputs

    return femupdate.inputs


def _path_check(check_name: str, flag: str) -> Any:
    """A typer callback running ``femupdate.inputs.<check_name>(flag, value)`` on a path given,
    before any work."""
    def check(value: Path | None) -> Path | None:
        if value is not None:
            getattr(_inputs(), check_name)(flag, value)
        return value
    return check


def _output_file(flag: str) -> Any:
    """A typer callback checking an output file before any work."""
    return _path_check("check_output_file", flag)


def _output_dir(flag: str) -> Any:
    """A typer callback checking an output folder before any work."""
    return _path_check("check_output_dir", flag)


def _input_dir(flag: str) -> Any:
    """A typer callback checking that a folder to read from exists."""
    def check(value: Path | None) -> Path | None:
        if value is not None and not value.is_dir():
            what = "is a file, not a folder" if value.exists() else "does not exist"
            raise ConfigError(f"{flag}: {value} {what} (allowed: the folder that holds the "
                              "data files)")
        return value
    return check


def _search_limit(field: str, flag: str) -> Any:
    """A typer callback holding an override to the case file's range of [search] field."""
    def check(value: int | None) -> int | None:
        from femupdate.case.overrides import check_search_override

        check_search_override(field, value, flag)
        return value
    return check


def _seed_check(flag: str) -> Any:
    """A typer callback holding a seed of a command without a case's [search] (synth, the
    benchmarks) to the range of every seed."""
    def check(value: int | None) -> int | None:
        from femupdate.case.fields import field_range
        from femupdate.case.schema import Search

        rng = field_range(Search.model_fields["seed"])
        if value is not None and not rng.contains(value):
            raise ConfigError(f"{flag}: got {value!r} (allowed: {rng.describe()})")
        return value
    return check


JsonOption = Annotated[
    Path | None, typer.Option("--json", help="Write machine-readable results to this file.",
                              callback=_output_file("--json"))
]
WorkersOption = Annotated[
    int, typer.Option("--workers", min=1, callback=_search_limit("workers", "--workers"),
                      help="Parallel worker processes for the benchmark's "
                      "runs (its cases have no [search] workers of their own).")
]


def say(message: str, style: str | None = None, *, out: Console | None = None,
        whole: bool = False) -> None:
    """Print ``message`` as written (no markup), wrapped at spaces to the console's width;
    ``whole``: unwrapped (a command to copy)."""
    (out or console).print(Text(message, style=style or ""), soft_wrap=whole)


def _write_json(path: Path | None, data: Any) -> None:
    if path is None:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=2, allow_nan=True) + "\n")
    say(f"wrote {path}")


def _fmt(value: float | None, spec: str = ",.0f") -> str:
    return "–" if value is None else format(value, spec)


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


def _bench_dynamic(method: str, runs: int, seed: int, workers: int, plots: Path | None
                   ) -> list[dict[str, Any]]:
    from femupdate.bench.dynamic import ALL_METHODS, run_benchmark
    from femupdate.optimize.minimize import METHODS

    methods = ([m for m in ALL_METHODS if m in METHODS] if method == "all"
               else _inputs().method_list("--method", method, METHODS))
    rows = []
    for m in methods:
        with console.status(f"{runs} runs of {m} on {workers} worker(s)…"):
            rows.append(run_benchmark(m, runs=runs, seed=seed, workers=workers))
    console.print(_dynamic_table(rows))
    if plots is not None:
        from femupdate.bench.dynamic import run_with_history
        from femupdate.report.dynamic import dynamic_figures

        for m in methods:
            outcome = run_with_history(m, seed=seed)
            for path in dynamic_figures(outcome, plots, m):
                say(f"figure: {path}")
    return rows


@bench_app.command("dynamic")
def bench_dynamic(
    method: Annotated[
        str, typer.Option(help="A method, a comma-separated list (side by side, e.g. ab,cmaes) "
                               "or all.")
    ] = "ab",
    runs: Annotated[int, typer.Option(min=1, help="Independent runs.",
                                      callback=_search_limit("runs", "--runs"))] = 100,
    seed: Annotated[int, typer.Option(help="Root seed; run i uses child i.",
                                      callback=_seed_check("--seed"))] = 0,
    json_path: JsonOption = None,
    plots: Annotated[
        Path | None, typer.Option(help="Directory for the paper's Figs. 2–5 (PNG) of run 0.",
                                  callback=_output_dir("--plots"))
    ] = None,
    workers: WorkersOption = 2,
) -> None:
    """Benchmark 1 of the paper: identify a two-mode free vibration (Tables 1–2, Figs. 2–5)."""
    rows = _bench_dynamic(method, runs, seed, workers, plots)
    _write_json(json_path, rows if len(rows) > 1 else rows[0])


def _options_of(method: str, options: dict[str, Any] | None) -> dict[str, Any] | None:
    """A method's options from ``--options``: the object itself, or its entry when the object
    is keyed by method names (several methods, each its own options)."""
    from femupdate.optimize.minimize import METHODS

    if options and all(name in METHODS for name in options):
        return options.get(method)
    return options


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
    from femupdate.identifiability import strong_correlations

    print_update_summary(summary)
    bench = summary.benchmark
    if bench is None:
        return
    freqs = Table(title="natural frequencies [Hz] (paper Tables 7 and 11)")
    for col in ("mode", "truth", "best", "mean ± std (successful)", "best error"):
        freqs.add_column(col, justify="right")
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
        errs.add_column(col, justify="right")
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


@bench_app.command("bridge")
def bench_bridge(
    model: Annotated[str, typer.Option(help="viscous (9 parameters) or friction (13).")
                     ] = "viscous",
    band: Annotated[str, typer.Option(help="narrow or broad bounds (the paper's).")] = "narrow",
    method: Annotated[str, typer.Option(
        help="ab, cmaes, … or a comma-separated list run on the same data (e.g. ab,cmaes)."
    )] = "ab",
    runs: Annotated[int, typer.Option(min=1, help="Independent runs.",
                                      callback=_search_limit("runs", "--runs"))] = 25,
    seed: Annotated[int, typer.Option(help="Seed of the virtual experiment and of the runs.",
                                      callback=_seed_check("--seed"))] = 0,
    snr: Annotated[float, typer.Option(min=0.0, help="Noise: rms noise / rms signal.")] = 0.02,
    max_evals: Annotated[int | None, typer.Option(min=1, help="Budget per run (default: the "
                                                  "case's: 20,000 viscous, 5,000 friction).",
                                                  callback=_search_limit("max_evals",
                                                                         "--max-evals"))
                         ] = None,
    work_dir: Annotated[Path | None, typer.Option(
        "--work-dir", "--out", help="Keep the records and results here (default: "
        "$XDG_CACHE_HOME/femupdate/bench-bridge, else ~/.cache/femupdate/bench-bridge).",
        callback=_output_dir("--work-dir"))
    ] = None,
    options: Annotated[str | None, typer.Option(
        help='Options of the method(s) as JSON, e.g. \'{"tolfun": 0, "tolfunhist": 0}\', or '
             'per method: \'{"cmaes": {"restarts": 20, "stall_window": 1000}}\'.')
    ] = None,
    json_path: JsonOption = None,
    workers: WorkersOption = 2,
    resume: Annotated[bool, typer.Option(
        "--resume", help="Continue an interrupted benchmark in --work-dir (same settings)."
    )] = False,
) -> None:
    """Benchmark 2 of the paper: update the 1:50 bridge from a virtual experiment."""
    from femupdate.bench.bridge import default_work_dir, run_bridge_benchmark
    from femupdate.optimize.minimize import METHODS

    # all checked before the first runs
    methods = _inputs().method_list("--method", method, METHODS)
    method_options = _json_object("--options", options)
    work = work_dir or default_work_dir()
    rows = []
    for m in methods:
        try:
            with console.status(f"{runs} runs of {m} on the {model} bridge…"):
                summary = run_bridge_benchmark(model, band, m, runs=runs, seed=seed,
                                               snr=snr, workers=workers, max_evals=max_evals,
                                               options=_options_of(m, method_options),
                                               work_dir=work, resume=resume)
        except KeyboardInterrupt:
            words = ["femupdate", "bench", "bridge", "--model", model, "--band", band,
                     "--method", method, "--runs", str(runs), "--seed", str(seed), "--snr",
                     f"{snr:g}", "--work-dir", str(work)]
            if max_evals is not None:
                words += ["--max-evals", str(max_evals)]
            if options is not None:
                words += ["--options", options]
            _resume_hint([*words, "--resume"])
            raise SystemExit(130) from None
        _print_bridge(summary)
        rows.append(summary)
    if len(rows) > 1:
        console.print(_methods_table(rows))
    say(f"records and results in {work.resolve()}")
    dumped = [r.model_dump() for r in rows]
    _write_json(json_path, dumped[0] if len(dumped) == 1 else dumped)


@bench_app.command("simulate")
def bench_simulate(
    repeat: Annotated[int, typer.Option(min=1, help="Timed repetitions per integrator.")] = 20,
    opensees: Annotated[bool, typer.Option(help="Time the same models in OpenSeesPy too "
                                                "(when installed).")] = True,
    json_path: JsonOption = None,
) -> None:
    """Time every integrator on the paper-size bridge (and 10× longer), beside OpenSeesPy."""
    from femupdate.bench.simulate import print_simulate_rows, run_simulate_benchmark

    with console.status("timing the integrators…"):
        rows = run_simulate_benchmark(repeat, opensees=None if opensees else False)
    print_simulate_rows(rows, console)
    _write_json(json_path, rows)


@app.command()
def report(
    results: Annotated[Path, typer.Argument(help="A results directory (femupdate run --out).")],
) -> None:
    """Write RESULTS/report.html: one self-contained HTML file (figures embedded, no external
    files, opens offline) of a results directory."""
    from femupdate.report.html import write_report

    with console.status("writing the report…"):
        path = write_report(results)
    say(f"report: {path}")


@app.command()
def demo(
    runs: Annotated[int, typer.Option(min=1, help="Independent AB runs.",
                                      callback=_search_limit("runs", "--runs"))] = 20,
    out: Annotated[Path, typer.Option(help="Where the figures go.",
                                      callback=_output_dir("--out"))] = Path("femupdate-demo"),
    workers: WorkersOption = 2,
) -> None:
    """Run the paper's dynamic benchmark quickly with AB and draw its figures."""
    console.print(
        "femupdate demo: the adaptive Beta-sampling search (AB) identifies the 8 parameters of "
        f"a two-mode free vibration (Zapico-Valle et al. 2010, §4), {runs} independent runs."
    )
    _bench_dynamic("ab", runs, 0, workers, out)
    say(f"figures in {out.resolve()}")


CaseArgument = Annotated[Path, typer.Argument(help="The case file (TOML).", exists=False)]


def _load(path: Path):
    from femupdate.case import load_case

    return load_case(path)


def _params_table(title: str, rows: list[tuple[str, str, str]]) -> Table:
    table = Table(title=Text(title))
    for col in ("parameter", "value", "spread (successful runs)"):
        table.add_column(col, justify="right")
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
    from femupdate.workflow import NEAR_BEST

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
    runs = Table(title=Text(f"{summary.name}: {summary.method}, {len(summary.runs)} runs"),
                 caption=Text(meaning))
    for col in ("run", "NMSE %", "evals", "stop", header, *(["restarts"] if restarted else []),
                "at a bound"):
        runs.add_column(col, justify="left" if col in ("stop", "at a bound") else "right")
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
        table.add_column("run", justify="right")
        for j in group:
            table.add_column(names[j], justify="right")
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
    from femupdate.sampling.console import print_laplace

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
        table.add_column(col, justify="right")
    for t in trials:
        channels = ", ".join(f"{c} {100 * v:.4g}" for c, v in t.nmse_per_channel.items())
        delays = ", ".join(f"{c} {1e3 * d:.2f} ms" for c, d in t.delays_s.items()) or "–"
        table.add_row(Text(t.name), t.role, f"{100 * t.phi:.4g}", Text(channels), Text(delays))
    (out or console).print(table)
    for t in trials:
        for note in t.notes:
            say(f"{t.name}: {note}", out=out)


@app.command()
def run(
    case_file: CaseArgument,
    out: Annotated[Path, typer.Option("--out", help="Results directory.",
                                      callback=_output_dir("--out"))] = Path("results"),
    runs: Annotated[int | None, typer.Option(min=1, help="Override [search] runs.",
                                             callback=_search_limit("runs", "--runs"))] = None,
    seed: Annotated[int | None, typer.Option(help="Override [search] seed.",
                                             callback=_search_limit("seed", "--seed"))] = None,
    max_evals: Annotated[int | None, typer.Option(min=1, help="Override [search] max_evals.",
                                                  callback=_search_limit("max_evals",
                                                                         "--max-evals"))
                         ] = None,
    method: Annotated[str | None, typer.Option(
        help="Override [search] method: multistart-lm (the default of case files), ab, ib, "
             "cmaes (or a registered plug-in); the case's options for its own method are then "
             "not used.")] = None,
    data: Annotated[Path | None, typer.Option(help="Read the records from this directory "
                                                   "instead of [data] directory.",
                                              callback=_input_dir("--data"))] = None,
    resume: Annotated[bool, typer.Option(
        "--resume", help="Continue the runs stored in --out, unfinished or interrupted "
        "(from their last checkpoint); refused, naming what changed, if the case, its data "
        "files or the settings changed.")] = False,
    restart: Annotated[bool, typer.Option(
        "--restart", help="Discard the runs stored in --out (results.sqlite, summary.json, "
        "fit.npz) and start over there, e.g. after a run that aborted or a change of the "
        "case.")] = False,
    scheduler: Annotated[str | None, typer.Option(help="Dask scheduler address, e.g. "
                                                       "tcp://host:8786 (extra 'dask').")
                         ] = None,
    quiet: Annotated[bool, typer.Option(help="No progress bar.")] = False,
    log_json: Annotated[Path | None, typer.Option(help="Append JSON lines (one per chunk and "
                                                       "run event) to this file.",
                                                  callback=_output_file("--log-json"))] = None,
    workers: Annotated[int | None, typer.Option(
        "--workers", min=1, help="Parallel worker processes (default: the case's [search] "
        "workers).", callback=_search_limit("workers", "--workers"))] = None,
    json_path: JsonOption = None,
) -> None:
    """Update the model of a case from its measured data: repeated runs and their summary
    (`femupdate report OUT` draws the plots).

    Every evaluation and the optimizers' checkpoints go to OUT/results.sqlite as they happen,
    so an interrupted or killed run continues with --resume; --restart starts over.
    """
    from femupdate.case.reduced_path import describe_simulation
    from femupdate.optimize.minimize import METHODS
    from femupdate.runs import Execution
    from femupdate.workflow import run_case, with_data_directory, with_method

    if resume and restart:
        raise ConfigError("--resume and --restart exclude each other: --resume continues the "
                          "runs stored in --out, --restart discards them and starts over")
    from femupdate.runs.store import FILENAME

    if resume and not (out / FILENAME).is_file():
        # a wrong --out is the likely cause: a long search must not start there unasked
        raise ConfigError(f"--resume: nothing is stored in {out} to continue (allowed: "
                          "--resume into the --out of an interrupted `femupdate run`; without "
                          "--resume the runs start)")
    case = _load(case_file)
    if data is not None:
        case = with_data_directory(case, data)
    if method is not None:
        if method not in METHODS:
            raise ConfigError(f"--method: got {method!r} (allowed: {', '.join(METHODS)})")
        own = case.search.method
        case, dropped = with_method(case, method)
        if dropped:
            say(f"--method {method}: not using {', '.join(dropped)} (set for {own})")
    execution = Execution(scheduler=scheduler, quiet=quiet, log_json=log_json, label=case.label)
    try:
        result = run_case(case, out, runs=runs, seed=seed, max_evals=max_evals,
                          workers=workers, resume=resume, restart=restart,
                          execution=execution, keep_history=True)
    except KeyboardInterrupt:
        words = ["femupdate", "run", str(case_file), "--out", str(out)]
        for flag, value in (("--runs", runs), ("--seed", seed), ("--max-evals", max_evals),
                            ("--method", method), ("--data", data)):
            if value is not None:
                words += [flag, str(value)]
        _resume_hint([*words, "--resume"])
        raise SystemExit(130) from None
    print_update_summary(result.summary)
    if result.summary.simulation is not None:  # which path ran (reduced: modes, truncation)
        say(describe_simulation(result.summary.simulation))
    say(f"results in {out.resolve()}")
    _write_json(json_path, result.summary.model_dump())


#: The integrators of `femupdate frame3d` (linear methods of femupdate.simulate).
FRAME3D_METHODS = ("exact", "newmark", "central_difference")

#: Exit code of a command that finished without the result it is for (a sampled posterior
#: whose runs did not reach β = 1); 2 is femupdate's errors, 130 Ctrl-C.
NOT_THE_RESULT = 1


def _posterior_limit(field: str, flag: str) -> Any:
    """A typer callback holding an override to the range of [posterior] field."""
    def check(value: int | None) -> int | None:
        from femupdate.case.fields import field_range
        from femupdate.case.posterior_section import PosteriorSection

        rng = field_range(PosteriorSection.model_fields[field])
        if value is not None and not rng.contains(value):
            raise ConfigError(f"{flag}: got {value!r} (allowed: {rng.describe()}, as "
                              f"[posterior] {field} in a case file)")
        return value
    return check


@app.command()
def posterior(
    case_file: CaseArgument,
    out: Annotated[Path, typer.Option("--out", help="Results directory.",
                                      callback=_output_dir("--out"))] = Path("results"),
    seed: Annotated[int | None, typer.Option(help="Override [posterior] seed.",
                                             callback=_posterior_limit("seed", "--seed"))
                    ] = None,
    samples: Annotated[int | None, typer.Option(
        min=20, help="Override [posterior] samples (TMCMC's population, per run).",
        callback=_posterior_limit("samples", "--samples"))] = None,
    runs: Annotated[int | None, typer.Option(
        min=1, max=64, help="Override [posterior] runs (independent sampler runs, pooled; "
        "their agreement checks the effective samples).")] = None,
    max_runs: Annotated[int | None, typer.Option(
        "--max-runs", min=1, max=256, help="Override [posterior] max_runs (while a parameter "
        "is unsettled, runs are added, --runs at a time, up to this many).")] = None,
    recentre: Annotated[int | None, typer.Option(
        "--recentre", min=0, max=8, help="Override [posterior] recentre (how many times at "
        "most to sample again from a better fit the sampler finds; 0: only say so).")] = None,
    error_model: Annotated[str | None, typer.Option(
        "--error-model", help="Override [posterior] error_model (the sampled posterior's "
        "likelihood; allowed: the kinds a case may name, default neff).")] = None,
    ess: Annotated[int | None, typer.Option(
        "--ess", min=10, max=10_000_000, help="Override [posterior] ess (the effective samples "
        "every parameter needs; runs are added until it has them, up to --max-runs).")
    ] = None,
    search_from: Annotated[Path | None, typer.Option(
        "--from", help="Take the search of this results directory (`femupdate run --out`, "
        "same case) instead of searching in --out; a finished search is not run again.")
    ] = None,
    data: Annotated[Path | None, typer.Option(help="Read the records from this directory "
                                                   "instead of [data] directory.",
                                              callback=_input_dir("--data"))] = None,
    resume: Annotated[bool, typer.Option(
        "--resume", help="Continue the sampler (and the search) stored in --out from its "
        "last checkpoint: the samples are those of an uninterrupted run.")] = False,
    restart: Annotated[bool, typer.Option(
        "--restart", help="Discard the search and the sampler stored in --out and start "
        "over.")] = False,
    scheduler: Annotated[str | None, typer.Option(help="Dask scheduler address, e.g. "
                                                       "tcp://host:8786 (extra 'dask').")
                         ] = None,
    quiet: Annotated[bool, typer.Option(help="No progress bar.")] = False,
    log_json: Annotated[Path | None, typer.Option(help="Append JSON lines (one per chunk and "
                                                       "run event) to this file.",
                                                  callback=_output_file("--log-json"))] = None,
    workers: Annotated[int | None, typer.Option(
        "--workers", min=1, help="Parallel worker processes (default: the case's [search] "
        "workers).", callback=_search_limit("workers", "--workers"))] = None,
    surrogate: Annotated[bool | None, typer.Option(
        "--surrogate/--no-surrogate", help="TMCMC on a Gaussian-process surrogate trained at "
        "300 model runs at most (default: [posterior] surrogate, else on for an external "
        "model); results in OUT/surrogate.json and OUT/surrogate.npz.")] = None,
    json_path: JsonOption = None,
) -> None:
    """The posterior of the parameters by TMCMC, beside the best fit: intervals,
    correlations, frequency posteriors, predictive bands, log-evidence.

    The case's search runs first (a finished one in OUT is reused); then the sampler, with
    its settings from [posterior]: independent runs (default 4), pooled, and their verdict
    (do they agree on each parameter?), checkpointed in OUT/posterior (--resume continues
    them to the same samples). The results go into OUT/summary.json (posterior) and
    OUT/posterior.npz; `femupdate report OUT` draws them. With --surrogate (the default for an
    external model) TMCMC samples a Gaussian-process surrogate of the model trained at 300
    model runs at most instead, checked against true runs at its samples.
    """
    from femupdate.runs import Execution
    from femupdate.sampling.console import print_posterior
    from femupdate.sampling.run import run_posterior
    from femupdate.workflow import with_data_directory

    if resume and restart:
        raise ConfigError("--resume and --restart exclude each other: --resume continues the "
                          "sampler stored in --out, --restart discards it and starts over")
    case = _load(case_file)
    if data is not None:
        case = with_data_directory(case, data)
    execution = Execution(scheduler=scheduler, quiet=quiet, log_json=log_json, label=case.label)
    from femupdate.sampling.run import run_surrogate_posterior

    aided = run_surrogate_posterior(case, out, surrogate=surrogate, seed=seed, workers=workers,
                                    execution=execution)
    if aided is not None:
        say(aided.message)
        for name, mean, sd in zip(aided.names, aided.means(), aided.sds(), strict=True):
            say(f"{name}: mean {mean:.6g}, sd {sd:.3g}")
        say(f"results in {out.resolve()} (surrogate.json, surrogate.npz)")
        _write_json(json_path, json.loads((out / "surrogate.json").read_text()))
        return
    try:
        result = run_posterior(case, out, seed=seed, samples=samples, runs=runs,
                               max_runs=max_runs, recentre=recentre, workers=workers,
                               resume=resume, restart=restart, execution=execution,
                               error_model=error_model, search_from=search_from, ess=ess)
    except KeyboardInterrupt:
        words = ["femupdate", "posterior", str(case_file), "--out", str(out)]
        for flag, value in (("--seed", seed), ("--samples", samples), ("--runs", runs),
                            ("--max-runs", max_runs), ("--recentre", recentre),
                            ("--error-model", error_model), ("--ess", ess),
                            ("--from", search_from),
                            ("--data", data)):
            if value is not None:
                words += [flag, str(value)]
        _resume_hint([*words, "--resume"])
        raise SystemExit(130) from None
    print_posterior(result.record, console)
    if result.bands:
        print_coverage(result.bands)
    say(f"results in {out.resolve()} (femupdate report {out})")
    _write_json(json_path, result.summary.model_dump())
    if not result.record.reached:  # finished, but not a posterior: scripts must tell
        raise SystemExit(NOT_THE_RESULT)


def print_coverage(bands: list[Any], title: str = "5–95 % predictive bands") -> None:
    """The share of each trial's measured record inside its predictive band."""
    table = Table(title=Text(f"{title}: share of the measured record inside"))
    for col in ("trial", "role", "channels: covered"):
        table.add_column(col, justify="right")
    for b in bands:
        table.add_row(Text(b.trial), b.role, Text(", ".join(
            f"{c} {100 * v:.1f} %" for c, v in zip(b.channels, b.coverage, strict=True))))
    console.print(table)


def _json_object(flag: str, text: str | None) -> dict[str, Any] | None:
    """A JSON object given inline or as a file (None when not given); ConfigError otherwise."""
    if text is None:
        return None
    raw = _inputs().json_source(text)
    try:
        data = json.loads(raw)
    except json.JSONDecodeError as exc:
        raise ConfigError(f"{flag}: {text!r} is neither a JSON file nor a JSON object "
                          f"({exc}) (allowed: a JSON object {{name: value}}, or a file holding "
                          "one)") from None
    if not isinstance(data, dict):
        got = "null" if data is None else type(data).__name__
        raise ConfigError(f"{flag}: expected a JSON object {{name: value}}, got {got} (allowed: "
                          "a JSON object, or a file holding one)")
    return data


def _read_params(flag: str, text: str, case: Case) -> dict[str, float]:
    """Values of every parameter of ``case`` from a JSON object, a JSON file, or a
    summary.json (its best run); ConfigError naming the flag, the parameter and what is
    allowed otherwise."""
    from femupdate.case.build import check_parameter_values

    data = _json_object(flag, text)
    assert data is not None
    if isinstance(data.get("best"), dict) and "params" in data["best"]:
        data = data["best"]["params"]
    return check_parameter_values(data, case.parameter_names, what=flag)


def _outside_bounds(case: Case, values: dict[str, float]) -> list[str]:
    """The values outside the case's bounds, in words (field, value, bounds)."""
    out = []
    for i, p in enumerate(case.parameters):
        value = values[p.name]
        if not p.lower <= value <= p.upper:
            side = "lower" if value < p.lower else "upper"
            out.append(f"{p.name} = {value:g} is outside its bounds [{p.lower:g}, "
                       f"{p.upper:g}] (parameters[{i}].{side})")
    return out


def _warn_outside_bounds(flag: str, case: Case, values: dict[str, float]) -> None:
    """Say which given values lie outside the case's bounds (no update of it would give
    them)."""
    for problem in _outside_bounds(case, values):
        say(f"warning: {flag}: {problem} in {case.label}", "yellow")


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
    table.add_column("DOF", justify="left")
    for i in range(k):
        table.add_column(f"mode {i + 1}", justify="right")
    scaled = shapes[:, :k] / np.where(np.abs(shapes[:, :k]).max(axis=0) > 0,
                                      np.abs(shapes[:, :k]).max(axis=0), 1.0)
    for label, row in zip(labels, scaled, strict=True):
        table.add_row(label, *(f"{v:+.3f}" for v in row))
    return table


@app.command()
def modes(
    case_file: CaseArgument,
    params: Annotated[str | None, typer.Option(
        help="Parameter values: a JSON object, a JSON file, or a summary.json (its best run). "
             "Default: the case's nominal values.")] = None,
    json_path: JsonOption = None,
) -> None:
    """Natural frequencies, damping ratios and mode shapes of a case's model."""
    from femupdate.case import CaseModel
    from femupdate.model.modes import damped_modes, natural_frequencies

    case = _load(case_file)
    values = case.nominal() if params is None else _read_params("--params", params, case)
    _warn_outside_bounds("--params", case, values)
    model = CaseModel(case)
    if model.reduced is not None:  # a large model: its lowest modes, sparse (no dense n × n)
        from femupdate.case.reduced_path import lowest_case_modes

        (freqs, shapes), damped, dof_labels = lowest_case_modes(model.reduced, values)
        title = (f"{case.label}: the lowest {freqs.size} natural frequencies of "
                 f"{len(dof_labels)} DOFs (sparse eigensolver; damped: C projected on them)")
    else:
        system = model.system(values)
        freqs, shapes = natural_frequencies(system)
        damped = damped_modes(system)
        dof_labels = system.dof_labels
        title = (f"{case.label}: natural frequencies"
                 + (" (friction elements stuck)" if system.n_friction else "")
                 + (" (Bouc–Wen initial tangent)" if system.n_bouc_wen else ""))
    table = Table(title=title)
    for col in ("mode", "f [Hz]", "damped f [Hz]", "ζ [%]"):
        table.add_column(col, justify="right")
    above = False
    match = pair_modes(np.asarray(freqs), np.asarray(damped.freqs_hz))
    for i, f in enumerate(freqs):
        j = match[i]
        fd = damped.damped_freqs_hz[j] if j >= 0 else float("nan")
        zeta = damped.damping_ratios[j] if j >= 0 else float("nan")
        above |= bool(fd > f * (1 + 1e-9))
        table.add_row(str(i + 1), f"{f:.4f}", _unsigned_zero(f"{fd:.4f}"),
                      _unsigned_zero(f"{100 * zeta:.3f}"))
    extra = sorted(set(range(len(damped.freqs_hz))) - set(match.tolist()))
    for j in extra:  # real poles of DOFs that dashpots hold more than springs
        table.add_row("–", "–", _unsigned_zero(f"{damped.damped_freqs_hz[j]:.4f}"),
                      _unsigned_zero(f"{100 * damped.damping_ratios[j]:.3f}"))
    console.print(table)
    if extra:
        say(f"–: {len(extra)} overdamped pole(s) of the damped model (ζ = 100 %, no "
            "oscillation: a real pole whose 'f' is its decay rate |λ|/2π) beside the modes of "
            "K and M; each undamped mode is shown with the damped mode of nearest |λ|/2π.")
    if above:
        say("f: undamped, from K and M; damped f and ζ: the complex modes of the damped model. "
            "Its damping is not proportional (C is not a combination of M and K that the "
            "undamped modes diagonalise), so the damped modes are not the undamped ones with "
            "damping added: a damped frequency can exceed its undamped one.")
    labels = list(dof_labels)
    console.print(_shapes_table(labels, np.asarray(shapes), np.asarray(freqs)))
    if shapes.shape[1] > SHAPES_SHOWN:
        say(f"{shapes.shape[1] - SHAPES_SHOWN} more mode shapes with --json")
    _write_json(json_path, {
        "params": values, "frequencies_hz": freqs.tolist(),
        "damped_frequencies_hz": np.asarray(damped.damped_freqs_hz).tolist(),
        "damping_ratios": np.asarray(damped.damping_ratios).tolist(),
        "dof_labels": labels, "mode_shapes": shapes.tolist(),
    })


#: Sensor errors `femupdate synth` adds to noisy records unless told otherwise (as the bridge
#: benchmark): offsets up to this (m/s²), drifts up to this (m/s² per s).
SYNTH_OFFSET = 0.05
SYNTH_DRIFT = 0.01


@app.command()
def validate(
    case_file: CaseArgument,
    params: Annotated[str, typer.Option(
        help="Parameter values: a summary.json of `femupdate run` (its best run), a JSON file "
             "or a JSON object.")],
    out: Annotated[Path | None, typer.Option(
        "--out", help="Write validation.json and a fit plot per trial here.",
        callback=_output_dir("--out"))] = None,
    data: Annotated[Path | None, typer.Option(help="Read the records from this directory "
                                                   "instead of [data] directory.",
                                              callback=_input_dir("--data"))] = None,
    json_path: JsonOption = None,
    posterior_dir: Annotated[Path | None, typer.Option(
        "--posterior", help="Also the 5–95 % predictive bands of the posterior in this "
        "directory (the --out of `femupdate posterior`) on every trial, and the share of "
        "each measured record inside them.")] = None,
) -> None:
    """Evaluate fixed parameters on every trial of a case: NMSE per trial and channel.

    Each trial is simulated over its whole window and scored over its score_window, fitted
    trials and validation trials alike; nothing is searched.
    """
    from femupdate.workflow import validate_case, with_data_directory

    case = _load(case_file)
    if data is not None:
        case = with_data_directory(case, data)
    values = _read_params("--params", params, case)
    _warn_outside_bounds("--params", case, values)
    result = validate_case(case, values, unseen=data is not None)
    if result.frequencies_hz:
        say("natural frequencies of the model [Hz]: "
            + ", ".join(f"{f:.3f}" for f in result.frequencies_hz))
    print_trials(result.trials, f"{case.label}: the given parameters on each trial")
    bands = None
    if posterior_dir is not None:
        from femupdate.sampling.validate import validate_posterior

        bands = validate_posterior(case, posterior_dir)
        print_coverage(bands, f"{case.label}: 5–95 % predictive bands of the posterior")
    report = result.to_dict()
    if bands is not None:
        report["coverage"] = {b.trial: dict(zip(b.channels, b.coverage.tolist(), strict=True))
                              for b in bands}
    if out is not None:
        from femupdate.report.figures import plot_fit, save_png

        out.mkdir(parents=True, exist_ok=True)
        (out / "validation.json").write_text(json.dumps(report, indent=2) + "\n")
        records = {t.name: t for t in result.trials}
        for fit in result.fits:
            nmse = [100.0 * records[fit.trial].nmse_per_channel[c] for c in fit.channels]
            save_png(plot_fit(fit.t, fit.measured, fit.predicted, channels=fit.channels,
                              unit=fit.unit, nmse_percent=nmse,
                              title=f"{fit.trial} ({fit.role})"), out / f"fit-{fit.trial}.png")
        if bands is not None:
            from femupdate.report.posterior_plots import plot_bands

            for b in bands:
                save_png(plot_bands(b.t, b.measured, np.stack([b.q05, b.q50, b.q95]),
                                    b.channels, b.unit, b.coverage, f"{b.trial} ({b.role})"),
                         out / f"bands-{b.trial}.png")
        console.print(f"validation in {out.resolve()}")
    _write_json(json_path, report)


@app.command()
def synth(
    case_file: CaseArgument,
    truth: Annotated[str, typer.Option(help="Truth parameter values: a JSON object or file.")],
    out: Annotated[Path, typer.Option("--out", help="Directory for the records.",
                                      callback=_output_dir("--out"))],
    seed: Annotated[int, typer.Option(help="Seed of the motion and of the noise.",
                                      callback=_seed_check("--seed"))] = 0,
    snr: Annotated[float, typer.Option(min=0.0, help="rms noise / rms signal per channel; 0: "
                                       "noise-free records.")] = 0.02,
    duration: Annotated[float, typer.Option(min=0.01, help="Record length, s (model scale).")
                        ] = 4.6,
    rate: Annotated[float | None, typer.Option(help="Sampling rate, Hz, in (0, 1e7] (default: "
                                                    "the case's [data] rate, else 1035).")
                    ] = None,
    pga: Annotated[float, typer.Option(help="Peak ground acceleration of the EC8 spectrum, g."
                                       )] = 0.25,
    motion: Annotated[Path | None, typer.Option(
        help="A recorded ground motion (El Centro formats, e.g. "
             "../shared/data/elcentro1940/...) instead of the EC8 artificial one.")] = None,
    length_scale: Annotated[float, typer.Option(
        help="Model length scale λ; time scales by √λ. The default, 1/50, is the paper's 1:50 "
             "model (a motion 7.1× faster than full scale); 1 for a full-scale structure.")
                            ] = 1 / 50,
    offset: Annotated[float | None, typer.Option(
        min=0.0, help=f"Accelerometer offsets up to this, m/s² (default: {SYNTH_OFFSET:g} with "
        "noise, 0 with --snr 0).")] = None,
    drift: Annotated[float | None, typer.Option(
        min=0.0, help=f"Accelerometer drifts up to this, m/s² per s (default: {SYNTH_DRIFT:g} "
        "with noise, 0 with --snr 0).")] = None,
) -> None:
    """A virtual experiment: simulate a truth model and write what the sensors would record.

    With --snr 0 and no --offset or --drift the records are exact (no sensor errors): the
    truth then fits them to rounding. The sensor errors added are printed.
    """
    from femupdate import virtual

    case = _load(case_file)
    values = _read_params("--truth", truth, case)
    for problem in _outside_bounds(case, values):
        say(f"warning: --truth: {problem} in {case.label}: an update of this case cannot reach "
            "the truth", "yellow")
    if rate is None:
        rate = case.data.rate if case.data is not None and case.data.rate else 1035.0
    elif not (math.isfinite(rate) and 0.0 < rate <= 1e7):
        raise ConfigError(f"--rate: got {rate:g} (allowed: a sampling rate in (0, 1e7] Hz)")
    offset = (SYNTH_OFFSET if snr > 0 else 0.0) if offset is None else offset
    drift = (SYNTH_DRIFT if snr > 0 else 0.0) if drift is None else drift
    base = (None if motion is None
            else virtual.recorded_motion(motion, rate=rate, length_scale=length_scale))
    manifest = virtual.virtual_experiment(case, values, out, seed=seed, motion=base, snr=snr,
                                          offset=offset, drift=drift, duration=duration,
                                          rate=rate, pga_g=pga, length_scale=length_scale)
    say(f"{manifest['motion']}; {manifest['samples']} samples at {manifest['rate_hz']:g} Hz")
    errors = [f"noise {100 * snr:g} % rms of each channel"] if snr > 0 else []
    if offset > 0:
        errors.append(f"offsets up to {offset:g} m/s²")
    if drift > 0:
        errors.append(f"drifts up to {drift:g} m/s² per s")
    say("sensor errors added: " + (", ".join(errors) if errors else
                                   "none (noise-free records: the truth fits them to rounding)"))
    say(f"wrote {', '.join(manifest['files'])}, truth.json, manifest.json in {out}")


@app.command()
def frame3d(
    case_file: Annotated[Path, typer.Argument(help="A 3-D frame case file (docs/frames-3d.md).")],
    out: Annotated[Path | None, typer.Option("--out", help="Write the responses (CSV) here.",
                                             callback=_output_dir("--out"))] = None,
    method: Annotated[str, typer.Option(help="Integrator: exact, newmark or "
                                             "central_difference.")] = "exact",
) -> None:
    """Simulate a 3-D frame under its ground motions (one record per support group)."""
    from femupdate.case.frame3d_case import run_frame3d_case

    if method not in FRAME3D_METHODS:  # before the case is read and assembled
        raise ConfigError(f"--method: got {method!r} (allowed: {', '.join(FRAME3D_METHODS)})")

    for line in run_frame3d_case(case_file, out, method=method):
        say(line)


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


@app.command()
def inspect(
    records: Annotated[Path, typer.Argument(
        help="A network record: a zip archive of an event (CSMIP or COSMOS V2 files), a "
             "folder of them, one such file, or a PEER .AT2 file.")],
    json_path: JsonOption = None,
) -> None:
    """List the channels of a strong-motion record: location, direction, rate, length, peak.

    The peaks are in m/s² (converted from the file's unit, listed); each file's header has
    been checked against its samples. A case reads a channel by its number or by
    "location / direction" as listed here ([data] format = "csmip", "cosmos" or "at2").
    """
    from femupdate.data.network import channel_label, read_network_records

    channels = read_network_records(records)
    rows = [{
        "channel": ch.number, "location": ch.location, "direction": ch.direction,
        "selector": channel_label(ch), "rate_hz": ch.rate, "dt_s": ch.dt,
        "samples": ch.n_samples, "duration_s": (ch.n_samples - 1) * ch.dt,
        "peak_m_s2": float(np.max(np.abs(ch.acceleration))), "file_unit": ch.file_unit,
        "header_peak": ch.peak, "recorder": ch.recorder, "station": ch.station,
        "source": ch.source,
    } for ch in channels]
    stations = sorted({ch.station for ch in channels if ch.station})
    title = f"{records.name}: {len(rows)} channel{'s' if len(rows) > 1 else ''}" + (
        f", {', '.join(stations)}" if stations else "")  # station, or an AT2's event
    console.print(_records_table(title, rows))
    recorders: dict[str, list[Any]] = {}
    for ch in channels:
        recorders.setdefault(ch.recorder, []).append(ch)
    if len(recorders) > 1 and len({ch.dt for ch in channels}) > 1:
        listing = "; ".join(
            f"{name or '?'}: channels {', '.join(str(c.number) for c in chans)} at "
            f"{', '.join(f'{1 / dt:g}' for dt in sorted({c.dt for c in chans}))} Hz"
            for name, chans in recorders.items())
        say(f"recorders (serial numbers): {listing}. Channels of different rates are "
            "resampled to one ([preprocess] resample_hz) when a case reads them together; "
            "each file's time starts at its recorder's first sample.")
    _write_json(json_path, rows)


def _show_warning(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                  file: Any = None, line: str | None = None) -> None:
    """Every warning as one line on the console, without Python's source echo."""
    from femupdate.console import warning_text

    say(warning_text(message, category), "yellow")


def main() -> None:
    """Console entry point: femupdate errors become a one-line message and exit code 2; Ctrl-C
    a line and exit code 130."""
    warnings.showwarning = _show_warning
    try:
        app()
    except FemupdateError as exc:
        console.print(Text("error: ", style="red") + Text(str(exc)))
        raise SystemExit(2) from None
    except KeyboardInterrupt:
        say("interrupted", "yellow")
        raise SystemExit(130) from None
    except OSError as exc:  # a file system's refusal (full, read-only, removed): one line too
        console.print(Text("error: ", style="red") + Text(_inputs().os_error_line(exc)),
                      soft_wrap=True)
        raise SystemExit(2) from None

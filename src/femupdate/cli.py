"""The ``femupdate`` command line (also ``python -m femupdate``)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from femupdate.errors import FemupdateError

if TYPE_CHECKING:
    from femupdate.results import Summary

app = typer.Typer(
    help="Finite element model updating in structural dynamics, in the time domain.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)
bench_app = typer.Typer(help="Benchmarks of the paper and of speed.", no_args_is_help=True)
app.add_typer(bench_app, name="bench")
console = Console()

JsonOption = Annotated[
    Path | None, typer.Option("--json", help="Write machine-readable results to this file.")
]
WorkersOption = Annotated[
    int, typer.Option("--workers", min=1, help="Parallel worker processes for the runs.")
]


def _write_json(path: Path | None, data: Any) -> None:
    if path is None:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=2, allow_nan=True) + "\n")
    console.print(f"wrote {path}")


def _fmt(value: float | None, spec: str = ",.0f") -> str:
    return "–" if value is None else format(value, spec)


def _dynamic_table(rows: list[dict[str, Any]]) -> Table:
    table = Table(title="Two-mode identification (paper Table 2): evaluations of successful runs")
    for col in ("method", "runs", "success", "min", "mean", "median", "max",
                "ERT*", "wall (s)"):
        table.add_column(col, justify="right")
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

    methods = list(ALL_METHODS) if method == "all" else [method]
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
                console.print(f"figure: {path}")
    return rows


@bench_app.command("dynamic")
def bench_dynamic(
    method: Annotated[
        str, typer.Option(help="ib, ab, cmaes, de, ga, or all (side by side).")
    ] = "ab",
    runs: Annotated[int, typer.Option(min=1, help="Independent runs.")] = 100,
    seed: Annotated[int, typer.Option(help="Root seed; run i uses child i.")] = 0,
    json_path: JsonOption = None,
    plots: Annotated[
        Path | None, typer.Option(help="Directory for the paper's Figs. 2–5 (PNG) of run 0.")
    ] = None,
    workers: WorkersOption = 2,
) -> None:
    """Benchmark 1 of the paper: identify a two-mode free vibration (Tables 1–2, Figs. 2–5)."""
    rows = _bench_dynamic(method, runs, seed, workers, plots)
    _write_json(json_path, rows if method == "all" else rows[0])


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
    runs: Annotated[int, typer.Option(min=1, help="Independent runs.")] = 25,
    seed: Annotated[int, typer.Option(help="Seed of the virtual experiment and of the runs.")
                    ] = 0,
    snr: Annotated[float, typer.Option(min=0.0, help="Noise: rms noise / rms signal.")] = 0.02,
    max_evals: Annotated[int | None, typer.Option(min=1, help="Budget per run (default: the "
                                                  "case's: 20,000 viscous, 5,000 friction).")
                         ] = None,
    work_dir: Annotated[Path | None, typer.Option(help="Keep the data and results here.")
                        ] = None,
    options: Annotated[str | None, typer.Option(
        help='Options of the method(s) as JSON, e.g. \'{"tolfun": 0, "tolfunhist": 0}\'.')
    ] = None,
    json_path: JsonOption = None,
    workers: WorkersOption = 2,
    resume: Annotated[bool, typer.Option(
        "--resume", help="Continue an interrupted benchmark in --work-dir (same settings)."
    )] = False,
) -> None:
    """Benchmark 2 of the paper: update the 1:50 bridge from a virtual experiment."""
    from femupdate.bench.bridge import run_bridge_benchmark

    method_options = _json_object("--options", options)
    work = work_dir or Path("femupdate-bench-bridge")
    rows = []
    for m in method.split(","):
        with console.status(f"{runs} runs of {m} on the {model} bridge…"):
            summary = run_bridge_benchmark(model, band, m.strip(), runs=runs, seed=seed,
                                           snr=snr, workers=workers, max_evals=max_evals,
                                           options=method_options, work_dir=work,
                                           resume=resume)
        _print_bridge(summary)
        rows.append(summary)
    if len(rows) > 1 and all(r.evals_mean for r in rows):
        base = rows[0]
        for r in rows[1:]:
            console.print(
                f"to φ ≤ {base.benchmark.f_target:.3g}, {r.method} / {base.method}: "
                f"evaluations per success, failed runs included "
                f"{r.evals_per_success / base.evals_per_success:.2f}; mean evaluations "
                f"of successful runs {r.evals_mean / base.evals_mean:.2f} (medians "
                f"{r.evals_median / base.evals_median:.2f}); success "
                f"{r.successes}/{len(r.runs)} against {base.successes}/{len(base.runs)}")
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
    console.print(f"report: {path}")


@app.command()
def demo(
    runs: Annotated[int, typer.Option(min=1, help="Independent AB runs.")] = 20,
    out: Annotated[Path, typer.Option(help="Where the figures go.")] = Path("femupdate-demo"),
    workers: WorkersOption = 2,
) -> None:
    """Run the paper's dynamic benchmark quickly with AB and draw its figures."""
    console.print(
        "femupdate demo: the adaptive Beta-sampling search (AB) identifies the 8 parameters of "
        f"a two-mode free vibration (Zapico-Valle et al. 2010, §4), {runs} independent runs."
    )
    _bench_dynamic("ab", runs, 0, workers, out)
    console.print(f"figures in {out.resolve()}")


CaseArgument = Annotated[Path, typer.Argument(help="The case file (TOML).", exists=False)]


def _load(path: Path):
    from femupdate.case import load_case

    return load_case(path)


def _params_table(title: str, rows: list[tuple[str, str, str]]) -> Table:
    table = Table(title=title)
    for col in ("parameter", "value", "spread (successful runs)"):
        table.add_column(col, justify="right")
    for row in rows:
        table.add_row(*row)
    return table


def print_update_summary(summary: Summary) -> None:
    """The table of runs (as the paper's Tables 5, 6, 9) and the best parameters."""
    runs = Table(title=f"{summary.name}: {summary.method} runs ({summary.success_rule})")
    names = list(summary.best.params)
    restarted = any(r.restarts for r in summary.runs)
    for col in ("run", "NMSE %", "evals", "stop", "ok", *(["restarts"] if restarted else []),
                *names):
        runs.add_column(col, justify="right")
    for r in summary.runs:
        runs.add_row(str(r.index), f"{100 * r.phi:.4g}", str(r.nfev), ",".join(r.stop),
                     "✓" if r.success else "✗", *([str(r.restarts)] if restarted else []),
                     *(f"{r.params[n]:.4g}" for n in names))
    console.print(runs)
    spread = summary.spread.params
    console.print(_params_table(
        f"best run {summary.best.run}: NMSE {summary.best.nmse_percent:.4g} %",
        [(n, f"{v:.6g}", f"{spread[n]['mean']:.4g} ± {spread[n]['std']:.2g}" if n in spread
          else "–") for n, v in summary.best.params.items()],
    ))
    freqs = ", ".join(f"{f:.3f}" for f in summary.best.frequencies_hz)
    console.print(f"natural frequencies of the best model [Hz]: {freqs}")
    console.print(f"successful runs: {summary.successes}/{len(summary.runs)}; "
                  f"evaluations (successful): mean {_fmt(summary.evals_mean)}, "
                  f"median {_fmt(summary.evals_median)}; per success, failed runs "
                  f"included: {_fmt(summary.evals_per_success)}; "
                  f"wall {summary.wall_s:.1f} s")
    if restarted:
        counts = [r.restarts for r in summary.runs]
        console.print(f"restarts (searches that converged or stalled): {sum(counts)} in all, in "
                      f"{sum(c > 0 for c in counts)} of {len(counts)} runs")
    failed = [r for r in summary.runs if not r.success]
    improper = [r for r in failed if r.at_bounds]
    if failed:
        console.print(f"unsuccessful runs: {len(failed)}, of which {len(improper)} end with a "
                      "parameter at a bound (improper minima): " + "; ".join(
                          f"run {r.index}: " + ", ".join(f"{n} {side}" for n, side
                                                           in r.at_bounds.items())
                          for r in improper))


@app.command()
def run(
    case_file: CaseArgument,
    out: Annotated[Path, typer.Option("--out", help="Results directory.")] = Path("results"),
    runs: Annotated[int | None, typer.Option(min=1, help="Override [search] runs.")] = None,
    seed: Annotated[int | None, typer.Option(help="Override [search] seed.")] = None,
    max_evals: Annotated[int | None, typer.Option(min=1, help="Override [search] max_evals.")
                         ] = None,
    data: Annotated[Path | None, typer.Option(help="Read the records from this directory "
                                                   "instead of [data] directory.")] = None,
    resume: Annotated[bool, typer.Option(help="Continue the unfinished runs stored in --out "
                                              "(ib, ab, cmaes from their last checkpoint; "
                                              "de, ga restart).")] = False,
    scheduler: Annotated[str | None, typer.Option(help="Dask scheduler address, e.g. "
                                                       "tcp://host:8786 (extra 'dask').")
                         ] = None,
    quiet: Annotated[bool, typer.Option(help="No progress bar.")] = False,
    log_json: Annotated[Path | None, typer.Option(help="Append JSON lines (one per chunk and "
                                                       "run event) to this file.")] = None,
    workers: Annotated[int | None, typer.Option(
        "--workers", min=1, help="Parallel worker processes (default: the case's [search] "
        "workers).")] = None,
    json_path: JsonOption = None,
) -> None:
    """Update the model of a case from its measured data: repeated runs, summary, plots.

    Every evaluation and the optimizers' checkpoints go to OUT/results.sqlite as they happen,
    so an interrupted or killed run continues with --resume.
    """
    from femupdate.report.figures import write_run_plots
    from femupdate.runs import Execution
    from femupdate.workflow import run_case, with_data_directory

    case = _load(case_file)
    if data is not None:
        case = with_data_directory(case, data)
    execution = Execution(scheduler=scheduler, quiet=quiet, log_json=log_json, label=case.label)
    result = run_case(case, out, runs=runs, seed=seed, max_evals=max_evals, workers=workers,
                      resume=resume, execution=execution, keep_history=True)
    write_run_plots(result, out)
    print_update_summary(result.summary)
    console.print(f"results in {out.resolve()}")
    _write_json(json_path, result.summary.model_dump())


def _json_object(flag: str, text: str | None) -> dict[str, Any] | None:
    """A JSON object given inline or as a file (None when not given); ConfigError otherwise."""
    if text is None:
        return None
    from femupdate.errors import ConfigError

    source = Path(text)
    raw = source.read_text() if source.is_file() else text
    try:
        data = json.loads(raw)
    except json.JSONDecodeError as exc:
        raise ConfigError(f"{flag}: {text!r} is neither a JSON file nor a JSON object "
                          f"({exc})") from None
    if not isinstance(data, dict):
        raise ConfigError(f"{flag}: expected a JSON object {{name: value}}, got "
                          f"{type(data).__name__}")
    return data


def _read_params(text: str | None) -> dict[str, float] | None:
    """Parameter values from a JSON object, a JSON file, or a summary.json (its best run)."""
    data = _json_object("--params", text)
    if data is None:
        return None
    if "best" in data:
        data = data["best"]["params"]
    return {str(k): float(v) for k, v in data.items()}


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
    values = _read_params(params) or case.nominal()
    system = CaseModel(case).system(values)
    freqs, shapes = natural_frequencies(system)
    damped = damped_modes(system)
    table = Table(title=f"{case.label}: natural frequencies"
                        + (" (friction elements stuck)" if not system.is_linear else ""))
    for col in ("mode", "f [Hz]", "damped f [Hz]", "ζ [%]"):
        table.add_column(col, justify="right")
    for i, f in enumerate(freqs):
        fd = damped.damped_freqs_hz[i] if i < len(damped.freqs_hz) else float("nan")
        zeta = damped.damping_ratios[i] if i < len(damped.freqs_hz) else float("nan")
        table.add_row(str(i + 1), f"{f:.4f}", f"{fd:.4f}", f"{100 * zeta:.3f}")
    console.print(table)
    _write_json(json_path, {
        "params": values, "frequencies_hz": freqs.tolist(),
        "damped_frequencies_hz": np.asarray(damped.damped_freqs_hz).tolist(),
        "damping_ratios": np.asarray(damped.damping_ratios).tolist(),
        "dof_labels": list(system.dof_labels), "mode_shapes": shapes.tolist(),
    })


@app.command()
def synth(
    case_file: CaseArgument,
    truth: Annotated[str, typer.Option(help="Truth parameter values: a JSON object or file.")],
    out: Annotated[Path, typer.Option("--out", help="Directory for the records.")],
    seed: Annotated[int, typer.Option(help="Seed of the motion and of the noise.")] = 0,
    snr: Annotated[float, typer.Option(min=0.0, help="rms noise / rms signal per channel.")
                   ] = 0.02,
    duration: Annotated[float, typer.Option(min=0.01, help="Record length, s (model scale).")
                        ] = 4.6,
    rate: Annotated[float | None, typer.Option(help="Sampling rate, Hz (default: the case's, "
                                                    "else 1035).")] = None,
    pga: Annotated[float, typer.Option(help="Peak ground acceleration of the EC8 spectrum, g."
                                       )] = 0.25,
    motion: Annotated[Path | None, typer.Option(
        help="A recorded ground motion (El Centro formats, e.g. "
             "../shared/data/elcentro1940/...) instead of the EC8 artificial one.")] = None,
    length_scale: Annotated[float, typer.Option(help="Model length scale λ; time scales by √λ.")
                            ] = 1 / 50,
    offset: Annotated[float, typer.Option(help="Accelerometer offsets up to this, m/s².")
                      ] = 0.05,
    drift: Annotated[float, typer.Option(help="Accelerometer drifts up to this, m/s² per s.")
                     ] = 0.01,
) -> None:
    """A virtual experiment: simulate a truth model and write what the sensors would record."""
    from femupdate import virtual

    case = _load(case_file)
    values = _read_params(truth)
    assert values is not None  # truth is required
    rate = rate or (case.data.rate if case.data is not None and case.data.rate else 1035.0)
    base = (None if motion is None
            else virtual.recorded_motion(motion, rate=rate, length_scale=length_scale))
    manifest = virtual.virtual_experiment(case, values, out, seed=seed, motion=base, snr=snr,
                                          offset=offset, drift=drift, duration=duration,
                                          rate=rate, pga_g=pga, length_scale=length_scale)
    console.print(f"{manifest['motion']}; {manifest['samples']} samples at "
                  f"{manifest['rate_hz']:g} Hz; noise {100 * snr:g} %")
    console.print(f"wrote {', '.join(manifest['files'])}, truth.json, manifest.json in {out}")


def main() -> None:
    """Console entry point: femupdate errors become a one-line message and exit code 2."""
    try:
        app()
    except FemupdateError as exc:
        console.print(f"[red]error:[/red] {exc}")
        raise SystemExit(2) from None

"""``femupdate bench``: the paper's benchmarks and the integrators' speed."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from femupdate.cli.options import (
    JsonOption,
    WorkersOption,
    _inputs,
    _json_object,
    _output_dir,
    _search_limit,
    _seed_check,
    _write_json,
    console,
    say,
)
from femupdate.cli.tables import _dynamic_table, _methods_table, _print_bridge, _resume_hint

bench_app = typer.Typer(help="Benchmarks of the paper and of speed.", no_args_is_help=True,
                        rich_markup_mode=None)


def _bench_dynamic(method: str, runs: int, seed: int, workers: int, plots: Path | None
                   ) -> list[dict[str, Any]]:
    from femupdate.optimize.minimize import METHODS
    from femupdate.paper.bench.dynamic import ALL_METHODS, run_benchmark

    methods = ([m for m in ALL_METHODS if m in METHODS] if method == "all"
               else _inputs().method_list("--method", method, METHODS))
    rows = []
    for m in methods:
        with console.status(f"{runs} runs of {m} on {workers} worker(s)…"):
            rows.append(run_benchmark(m, runs=runs, seed=seed, workers=workers))
    console.print(_dynamic_table(rows))
    if plots is not None:
        from femupdate.paper.bench.dynamic import run_with_history
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
    from femupdate.optimize.minimize import METHODS
    from femupdate.paper.bench.bridge import default_work_dir, run_bridge_benchmark

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
    from femupdate.paper.bench.simulate import print_simulate_rows, run_simulate_benchmark

    with console.status("timing the integrators…"):
        rows = run_simulate_benchmark(repeat, opensees=None if opensees else False)
    print_simulate_rows(rows, console)
    _write_json(json_path, rows)


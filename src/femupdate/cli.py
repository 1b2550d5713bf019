"""The ``femupdate`` command line (also ``python -m femupdate``)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.table import Table

from femupdate.errors import FemupdateError

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
    for col in ("method", "runs", "success", "min", "mean", "median", "max", "wall [s]"):
        table.add_column(col, justify="right")
    for r in rows:
        table.add_row(
            r["method"], str(r["runs"]), f"{100 * r['success_ratio']:.0f} %",
            _fmt(r["evals_min"]), _fmt(r["evals_mean"]), _fmt(r["evals_median"]),
            _fmt(r["evals_max"]), f"{r['wall_s']:.1f}",
        )
    return table


def _bench_dynamic(method: str, runs: int, seed: int, workers: int, plots: Path | None
                   ) -> list[dict[str, Any]]:
    from femupdate.benchmarks.dynamic import ALL_METHODS, run_benchmark

    methods = list(ALL_METHODS) if method == "all" else [method]
    rows = []
    for m in methods:
        with console.status(f"{runs} runs of {m} on {workers} worker(s)…"):
            rows.append(run_benchmark(m, runs=runs, seed=seed, workers=workers))
    console.print(_dynamic_table(rows))
    if plots is not None:
        from femupdate.report.dynamic import dynamic_figures

        for m in methods:
            for path in dynamic_figures(plots, m, seed=seed, options=ALL_METHODS.get(m)):
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


def main() -> None:
    """Console entry point: femupdate errors become a one-line message and exit code 2."""
    try:
        app()
    except FemupdateError as exc:
        console.print(f"[red]error:[/red] {exc}")
        raise SystemExit(2) from None

"""The simulation benchmark's table: every engine, scheme and φ batch size in one run, and
80 columns wide (what it measures is printed, never asserted: times live in benchmarks)."""
from __future__ import annotations

import io
import re

from rich.console import Console

from femupdate.paper.bench.simulate import PHI_BATCHES, print_simulate_rows, run_simulate_benchmark


def test_benchmark_rows_and_table_fit_80_columns():
    rows = run_simulate_benchmark(repeat=1, opensees=False)
    methods = {(r["model"], r["method"]) for r in rows}
    for k in PHI_BATCHES:
        assert ("bridge-viscous", f"phi exact k={k}") in methods
        assert ("bridge-friction", f"phi nonlinear k={k}") in methods
    assert {"exact", "newmark", "central_difference", "nonlinear"} <= {m for _, m in methods}
    assert all(r["median_s"] > 0 and r["ratio_vs_opensees"] is None for r in rows)

    out = io.StringIO()
    print_simulate_rows(rows, Console(file=out, width=80))
    lines = out.getvalue().splitlines()
    assert max(len(line) for line in lines) <= 80
    assert sum(bool(re.search(r"φ k=\d", line)) for line in lines) == 2 * len(PHI_BATCHES)
    assert not any("…" in line for line in lines)  # no cell cut short

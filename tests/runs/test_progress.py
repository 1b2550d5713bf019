"""Progress: the bar's figures and the JSON-lines log."""

from __future__ import annotations

import io
import json
import math
from pathlib import Path

from rich.console import Console

from femupdate.runs.progress import RunProgress


def test_bar_shows_runs_best_phi_and_evaluations() -> None:
    out = io.StringIO()
    console = Console(file=out, width=160, force_terminal=False, color_system=None)
    with RunProgress(3, label="ab", console=console) as progress:
        progress.start(runs_done=1, evals=500, best_phi=0.5)
        progress.chunk(1, 300, 2e-3, 300)
        progress.chunk(2, 100, math.inf, 100)  # a run whose evaluations all failed so far
        progress.run_done(1, 300, 2e-3, "f_target reached")
    text = out.getvalue()
    assert "2/3" in text and "best φ 2.000e-03" in text and "900 evals" in text
    assert progress.session_evals == 400 and progress.evals == 900


def test_quiet_writes_nothing_but_the_log(tmp_path: Path) -> None:
    out = io.StringIO()
    log = tmp_path / "sub" / "log.jsonl"
    with RunProgress(2, quiet=True, log_json=log, console=Console(file=out)) as progress:
        progress.start(method="ab")
        progress.chunk(0, 10, math.inf, 10)
        progress.chunk(0, 20, 0.25, 10)
        progress.run_done(0, 20, 0.25, "budget")
    assert out.getvalue() == ""
    lines = [json.loads(line) for line in log.read_text().splitlines()]
    assert [x["event"] for x in lines] == ["start", "chunk", "chunk", "run", "end"]
    assert lines[0]["method"] == "ab" and lines[0]["runs"] == 2
    assert lines[1]["best_phi"] is None  # not finite: null, the file stays strict JSON
    assert lines[2] == {**lines[2], "run": 0, "nfev": 20, "best_phi": 0.25}
    assert lines[3]["status"] == "budget"
    assert lines[4]["nfev"] == 20 and lines[4]["session_evals"] == 20
    assert all(x["elapsed"] >= 0 and x["time"] > 1e9 for x in lines)
    # A resumed set appends to the same log.
    with RunProgress(2, quiet=True, log_json=log) as progress:
        progress.start(runs_done=1, evals=20)
    assert len(log.read_text().splitlines()) == 7


def test_a_sampler_s_stages_are_logged_once_each(tmp_path: Path) -> None:
    import numpy as np

    log = tmp_path / "log.jsonl"
    rows = {"stage": np.array([0.0, 1.0, 1.0, 2.0]), "beta": np.array([0.0, 0.3, 0.3, 1.0]),
            "acceptance": np.array([np.nan, 0.2, 0.4, 0.3]),
            "weights_ess": np.array([100.0, 50.0, 50.0, 60.0])}
    with RunProgress(1, quiet=True, log_json=log) as progress:
        progress.start()
        progress.stages(0, {k: v[:2] for k, v in rows.items()})
        progress.stages(0, {k: v[2:] for k, v in rows.items()})  # the next chunk
        progress.stages(0, {"x": np.zeros(3)})  # a search's trace: nothing
    events = [json.loads(line) for line in log.read_text().splitlines()]
    stages = [(e["stage"], e["beta"], e["acceptance"]) for e in events if e["event"] == "stage"]
    assert stages == [(0, 0.0, None), (1, 0.3, None), (2, 1.0, 0.4)]


def test_a_samplers_lines_say_its_own_state_within_80_columns() -> None:
    """TMCMC's stage lines fit 79 columns at their widest (two-digit runs and stages, an ESS
    in thousands), and its bar shows the lowest β of its runs, not a φ."""
    import numpy as np

    from femupdate.runs.progress import stage_line

    widest = stage_line(11, 12, 0.71523, 12_345.0, 0.31)
    assert len(widest) <= 79 and "β = 0.7152" in widest and "previous acceptance 0.31" in widest
    assert "acceptance" not in stage_line(0, 1, 0.4388, 500.0, math.nan)
    out = io.StringIO()
    console = Console(file=out, width=80, force_terminal=False, color_system=None)
    with RunProgress(2, label="case.toml", console=console, max_evals=1_000_000) as progress:
        progress.start()
        progress.chunk(0, 1000, 0.5, 1000)
        progress.stages(0, {"stage": np.array([0.0, 1.0]), "beta": np.array([0.0, 0.4388]),
                            "acceptance": np.array([math.nan, math.nan]),
                            "weights_ess": np.array([1000.0, 500.0])})
    text = out.getvalue()
    assert "run 0: stage 1, β = 0.4388, weights' ESS 500" in text
    assert "lowest β 0.4388" in text and "best φ" not in text
    assert all(len(line) <= 79 for line in text.splitlines() if line.startswith("run "))

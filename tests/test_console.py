"""The console at 80 columns: every line of run, modes, validate and bench within the width,
warnings on one line without Python's source echo, no files left that were not asked for."""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
from rich.console import Console
from typer.testing import CliRunner

from femupdate.case import load_case
from femupdate.cli.commands import app
from femupdate.console import one_line_warnings, warning_text
from femupdate.errors import FemupdateWarning
from femupdate.trials.virtual import virtual_experiment

ROOT = Path(__file__).resolve().parents[1]
WIDTH = 80
TRUTH = {"k1": 4000.0, "k2": 2500.0, "c1": 1.2, "c2": 0.6}

CASE = """\
[case]
name = "a two-storey shear building with a long name, as users give their specimens"
[model.shear_building]
masses = [1.0, 0.8]
stiffnesses = ["k1", "k2"]
dampers = ["c1", "c2"]
[[parameters]]
name = "k1"
lower = 1000.0
upper = 10000.0
unit = "N/m"
[[parameters]]
name = "k2"
lower = 1000.0
upper = 10000.0
unit = "N/m"
[[parameters]]
name = "c1"
lower = 0.0
upper = 5.0
[[parameters]]
name = "c2"
lower = 0.0
upper = 5.0
[data]
format = "csv"
directory = "data"
time_column = "t"
input = { file = "table.csv", column = "table" }
outputs = [{ file = "floors.csv", column = "a1", node = "F1", dof = "ux" },
           { file = "floors.csv", column = "a2", node = "F2", dof = "ux" }]
[search]
method = "multistart-lm"
runs = 3
seed = 5
max_evals = 200
"""


@pytest.fixture(scope="module")
def case_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The case with noise-free records of TRUTH, 2 s at 200 Hz."""
    folder = tmp_path_factory.mktemp("console")
    path = folder / "case.toml"
    path.write_text(CASE)
    virtual_experiment(load_case(path), TRUTH, folder / "data", seed=3, rate=200.0,
                       duration=2.0, snr=0.0, offset=0.0, drift=0.0)
    return path


def _lines_fit(output: str) -> None:
    lines = output.splitlines()
    assert lines, "nothing printed"
    too_long = [line for line in lines if len(line) > WIDTH]
    assert not too_long, "\n".join(too_long)


def _invoke(*args: str) -> str:
    result = CliRunner().invoke(app, list(args), env={"COLUMNS": str(WIDTH)})
    assert result.exit_code == 0, result.output
    return result.output


def test_runs_not_needed_are_said_within_80_columns(case_file: Path, tmp_path: Path) -> None:
    # a budget for multistart-lm's patience: runs 0 and 1 end at the same φ, run 2 is not needed
    case = case_file.parent / "agree.toml"
    case.write_text(CASE.replace("max_evals = 200", "max_evals = 5000"))
    result = CliRunner().invoke(app, ["run", str(case), "--out", str(tmp_path / "out")],
                                env={"COLUMNS": str(WIDTH)})
    assert result.exit_code == 0, result.output
    _lines_fit(result.output)
    said = " ".join(result.output.split())
    assert "2 of 3 runs were needed: they ended at the same best φ; the others are not run" \
        in said  # the progress line
    assert "multistart-lm, 2 of 3 runs needed" in said  # the table of runs
    assert "verdict: converged: 2 of 3 runs were needed: they ended at the same best" in said


def test_run_modes_validate_fit_80_columns(case_file: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    text = _invoke("run", str(case_file), "--out", str(out), "--quiet")
    _lines_fit(text)
    said = " ".join(text.split())
    assert "successful runs (" in said and "verdict: " in said
    assert "evaluations (successful): mean " in said and "results in " in said
    # a finished results directory holds no journal or lock files
    assert not {p.name for p in out.iterdir()} & {"results.sqlite-wal", "results.sqlite-shm",
                                                  "results.sqlite.lock"}
    # nor figures: `femupdate report` draws them (drawing took 5 s of a 1,000-DOF run)
    assert not list(out.glob("*.png"))
    _lines_fit(_invoke("modes", str(case_file)))
    text = _invoke("validate", str(case_file), "--params", str(out / "summary.json"))
    _lines_fit(text)
    assert "natural frequencies of the model [Hz]:" in text


def test_the_modes_footnote_wraps(tmp_path: Path) -> None:
    # Storey dampers: non-proportional damping, the footnote about damped frequencies.
    case = tmp_path / "case.toml"
    case.write_text(CASE.split("[data]")[0])
    text = _invoke("modes", str(case), "--params", json.dumps(TRUTH | {"c1": 5.0, "c2": 0.0}))
    _lines_fit(text)
    said = " ".join(text.split())
    assert "f: undamped, from K and M; damped f and ζ: the complex modes" in said
    assert len([line for line in text.splitlines() if line.strip()]) > 10


def test_bench_bridge_fits_80_columns_and_writes_nothing_here(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    cache = tmp_path / "cache"
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache))
    here = tmp_path / "here"
    here.mkdir()
    monkeypatch.chdir(here)
    text = _invoke("bench", "bridge", "--runs", "1", "--max-evals", "20", "--workers", "1")
    _lines_fit(text)
    assert list(here.iterdir()) == []  # nothing in the working folder
    work = cache / "femupdate" / "bench-bridge"
    assert (work / "out-viscous-narrow-ab" / "summary.json").is_file()
    assert str(work) in "".join(text.split())  # said where
    out = tmp_path / "chosen"
    _invoke("bench", "bridge", "--runs", "1", "--max-evals", "20", "--workers", "1", "--out",
            str(out))
    assert (out / "out-viscous-narrow-ab" / "summary.json").is_file()


def test_bench_dynamic_fits_80_columns(tmp_path: Path) -> None:
    _lines_fit(_invoke("bench", "dynamic", "--method", "ab", "--runs", "2", "--seed", "1",
                       "--workers", "1"))


def test_warnings_on_one_line_wrapped_without_source_echo() -> None:
    out = io.StringIO()
    console = Console(file=out, width=WIDTH, color_system=None)
    before = warnings.showwarning
    with one_line_warnings(console), warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.warn("records cut to their overlap: " + "x " * 60, FemupdateWarning,
                      stacklevel=1)
        warnings.warn("divide by zero", RuntimeWarning, stacklevel=1)
    assert warnings.showwarning is before
    text = out.getvalue()
    _lines_fit(text)
    assert text.startswith("warning: records cut to their overlap: x x")
    assert "warning (RuntimeWarning): divide by zero\n" in text
    assert "warnings.warn" not in text and __file__ not in text  # no source line, no path
    assert warning_text("m", FemupdateWarning) == "warning: m"


def test_the_command_line_prints_a_warning_on_one_line(case_file: Path, tmp_path: Path) -> None:
    # Records of unequal length: femupdate warns that it uses their overlap.
    folder = tmp_path / "short"
    folder.mkdir()
    (folder / "data").mkdir()
    for name in ("table.csv", "floors.csv"):
        lines = (case_file.parent / "data" / name).read_text().splitlines()
        keep = lines if name == "table.csv" else lines[:-20]
        (folder / "data" / name).write_text("\n".join(keep) + "\n")
    (folder / "case.toml").write_text(CASE)
    env = dict(os.environ, COLUMNS=str(WIDTH), PYTHONPATH=str(ROOT / "src"))
    proc = subprocess.run([sys.executable, "-m", "femupdate", "validate",
                           str(folder / "case.toml"), "--params", json.dumps(TRUTH)],
                          capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr
    text = proc.stdout + proc.stderr
    _lines_fit(text)
    said = " ".join(text.split())
    assert "warning: " in said and "only their overlap is used" in said
    assert "FemupdateWarning" not in text and ".py:" not in text  # no Python source echo


def test_trial_tables_fold_long_names_whole_at_80_columns() -> None:
    from types import SimpleNamespace

    from femupdate.cli.tables import print_trials

    name = "very-long-trial-name-of-a-shake-table-run-number-1"
    channel = "roof_acceleration_north_of_the_specimen"
    trial = SimpleNamespace(name=name, role="validate", phi=0.123456,
                            nmse_per_channel={channel: 0.1, "floor1": 0.3},
                            delays_s={channel: 0.0233}, notes=[])
    out = io.StringIO()
    print_trials([trial], "title", out=Console(file=out, width=WIDTH))
    text = out.getvalue()
    _lines_fit(text)
    assert "…" not in text
    cells = [line.split("│") for line in text.splitlines() if line.startswith("│")]
    column = ["".join(row[i].strip() for row in cells) for i in range(1, 6)]
    assert column[0] == name  # the trial's name, folded over lines, whole
    assert channel in column[3] and channel in column[4]

"""What a new user hits (issue 15): resumes and restarts, bad command-line input, messages that
keep their words, input accepted silently, and output that reads at 80 columns.

A small two-storey shear building with noise-free CSV records (as in test_workflow) is the case;
the bridge example stands in where a model with rotations or non-proportional damping is needed.
"""

from __future__ import annotations

import io
import json
import math
import shutil
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from rich.console import Console
from typer.testing import CliRunner

from femupdate import cli
from femupdate.case import load_case
from femupdate.cli.commands import app
from femupdate.errors import ConfigError, DataError, FemupdateError, FemupdateWarning
from femupdate.pipeline.run import run_case
from femupdate.runs.store import StoreError
from femupdate.trials.virtual import virtual_experiment
from two_storey_case import DATA, MODEL, TRUTH, parameters

ROOT = Path(__file__).resolve().parents[1]
BRIDGE = ROOT / "examples" / "bridge" / "viscous-narrow.toml"
RATE = 200.0

CASE = MODEL + "\n" + parameters() + "\n" + DATA + """
[search]
method = "ab"
runs = 2
seed = 5
max_evals = 60
"""

runner = CliRunner()


def _said(output: str) -> str:
    """What a command printed, its lines (wrapped at 80 columns) joined by single spaces."""
    return " ".join(output.split())


@pytest.fixture(scope="module")
def records(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Noise-free records of the truth, 2 s at 200 Hz."""
    folder = tmp_path_factory.mktemp("records")
    (folder / "case.toml").write_text(CASE)
    virtual_experiment(load_case(folder / "case.toml"), TRUTH, folder / "data", seed=3,
                       rate=RATE, duration=2.0, snr=0.0, offset=0.0, drift=0.0)
    return folder / "data"


def _case(folder: Path, records: Path, text: str = CASE, name: str = "case.toml") -> Path:
    """The case file in ``folder`` with a copy of the records beside it."""
    folder.mkdir(parents=True, exist_ok=True)
    if not (folder / "data").exists():
        shutil.copytree(records, folder / "data")
    path = folder / name
    path.write_text(text)
    return path


def _scale_column(path: Path, column: int, factor: float) -> None:
    lines = path.read_text().splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("t,"))
    rows = [line.split(",") for line in lines[first + 1:]]
    for row in rows:
        row[column] = repr(factor * float(row[column]))
    path.write_text("\n".join(lines[:first + 1] + [",".join(r) for r in rows]) + "\n")


def _main(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
          *args: str) -> tuple[int, str]:
    """``femupdate ARGS`` through the console entry point: (exit code, what it printed, its
    lines, wrapped to the console's 80 columns, joined by single spaces)."""
    monkeypatch.setattr(sys, "argv", ["femupdate", *args])
    code = 0
    try:
        cli.main()
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 0
    captured = capsys.readouterr()
    text = captured.out + captured.err
    assert max(map(len, text.splitlines()), default=0) <= 80, text
    return code, _said(text)


# ============================================================================ 2. resume, restart


def test_resume_on_changed_data_is_refused_naming_the_file(tmp_path: Path,
                                                          records: Path) -> None:
    path = _case(tmp_path, records)
    first = run_case(load_case(path), tmp_path / "out", sensitivities=False)
    _scale_column(tmp_path / "data" / "floors.csv", 2, 1.5)  # a2, scaled
    with pytest.raises(StoreError) as info:
        run_case(load_case(path), tmp_path / "out", resume=True, sensitivities=False)
    message = str(info.value)
    assert "cannot resume: the data changed" in message and "floors.csv changed" in message
    assert "table.csv" not in message  # unchanged, not named
    assert "--restart" in message and "resume=True" not in message
    # the same file back: the resume is accepted and keeps the finished runs
    shutil.rmtree(tmp_path / "data")
    shutil.copytree(records, tmp_path / "data")
    again = run_case(load_case(path), tmp_path / "out", resume=True, sensitivities=False)
    assert [r.phi for r in again.summary.runs] == [r.phi for r in first.summary.runs]


def test_resume_on_a_changed_case_names_the_fields(tmp_path: Path, records: Path) -> None:
    path = _case(tmp_path, records)
    run_case(load_case(path), tmp_path / "out", sensitivities=False)
    changed = CASE.replace("upper = 5.0\n[[parameters]]", "upper = 6.0\n[[parameters]]", 1)
    changed = changed.replace('name = "two-storey"', 'name = "two storeys"')
    path.write_text(changed)
    with pytest.raises(StoreError) as info:
        run_case(load_case(path), tmp_path / "out", resume=True, sensitivities=False)
    message = str(info.value)
    assert "the case changed since its runs started" in message
    assert "case.name: 'two-storey' → 'two storeys'" in message
    assert "parameters[2].upper: 5.0 → 6.0" in message
    assert "fingerprint" not in message


def test_an_aborted_run_starts_over_with_restart(tmp_path: Path, records: Path,
                                                 monkeypatch: pytest.MonkeyPatch,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    # Central differences with one step per sample are unstable for every stiffness in the
    # bounds: no evaluation succeeds and the run aborts.
    unstable = (CASE.replace("upper = 10000.0", "upper = 1e7").replace("lower = 1000.0",
                                                                        "lower = 1e6")
                + '\n[simulation]\nmethod = "central_difference"\n')
    path = _case(tmp_path, records, unstable)
    out = str(tmp_path / "out")
    code, text = _main(monkeypatch, capsys, "run", str(path), "--out", out, "--quiet")
    assert code == 2
    assert "no evaluation of any run succeeded" in text and "not stable" in text
    assert "--restart" in text
    # a rerun is refused in command-line words
    code, text = _main(monkeypatch, capsys, "run", str(path), "--out", out, "--quiet")
    assert code == 2 and "already holds a results store" in text
    assert "--resume" in text and "--restart" in text and "resume=True" not in text
    # the fixed case cannot resume the aborted store (it is another case), and says why
    fixed = path.read_text().replace('method = "central_difference"',
                                     'method = "central_difference"\n\n[preprocess]\n'
                                     "substeps = 12")
    path.write_text(fixed)
    code, text = _main(monkeypatch, capsys, "run", str(path), "--out", out, "--quiet",
                       "--resume")
    assert code == 2 and "preprocess.substeps: 1 → 12" in text and "--restart" in text
    # --restart starts over in the same folder
    code, text = _main(monkeypatch, capsys, "run", str(path), "--out", out, "--quiet",
                       "--restart")
    assert code == 0, text
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert all(math.isfinite(r["phi"]) for r in summary["runs"])
    assert summary["case"]["preprocess"]["substeps"] == 12
    # and the two flags together are refused
    code, text = _main(monkeypatch, capsys, "run", str(path), "--out", out, "--resume",
                       "--restart")
    assert code == 2 and "exclude each other" in text


def test_ctrl_c_says_how_to_resume_and_the_resume_finishes(
        tmp_path: Path, records: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from femupdate.problem.update import UpdateProblem

    path = _case(tmp_path, records)
    whole = run_case(load_case(path), tmp_path / "whole", sensitivities=False).summary
    calls = {"n": 0}
    original = UpdateProblem.__call__

    def interrupted(self: UpdateProblem, x: np.ndarray) -> float:
        calls["n"] += 1
        if calls["n"] == 90:  # in run 1, after run 0 (60 evaluations) is stored
            raise KeyboardInterrupt
        return original(self, x)

    monkeypatch.setattr(UpdateProblem, "__call__", interrupted)
    out = tmp_path / "out"
    result = runner.invoke(app, ["run", str(path), "--out", str(out), "--quiet"])
    assert result.exit_code == 130
    assert ("interrupted; the runs so far are kept: resume with\n"
            f"femupdate run {path} --out {out} --resume\n") in result.output  # whole: to copy
    from femupdate.runs.store import ResultsStore

    with ResultsStore.open(out, read_only=True) as store:
        assert [r.status for r in store.runs()] == ["done", "running"]
        before = store.meta()["wall_s"]  # the interrupted session's time, up to its last chunk
    assert before > 0.0
    monkeypatch.setattr(UpdateProblem, "__call__", original)
    result = runner.invoke(app, ["run", str(path), "--out", str(out), "--quiet", "--resume"])
    assert result.exit_code == 0, result.output
    resumed = json.loads((out / "summary.json").read_text())
    assert [(r["phi"], r["nfev"]) for r in resumed["runs"]] == [
        (r.phi, r.nfev) for r in whole.runs]
    assert resumed["wall_s"] > before  # both sessions counted


def test_wall_time_counts_every_session(tmp_path: Path, records: Path) -> None:
    path = _case(tmp_path, records)
    first = run_case(load_case(path), tmp_path / "out", sensitivities=False).summary
    again = run_case(load_case(path), tmp_path / "out", resume=True,
                     sensitivities=False).summary
    # a resume of finished runs adds (almost) nothing, it does not start the clock again
    assert again.wall_s >= first.wall_s > 0.0
    assert again.wall_s == pytest.approx(first.wall_s, rel=0.05)


# ============================================================================ 4. bad CLI input


@pytest.mark.parametrize("text", ['{"k1": "abc"}', "null", "{}",
                                  '{"k1": "abc", "k2": 1, "c1": 1, "c2": 1}',
                                  '{"k1": null, "k2": 1, "c1": 1, "c2": 1}'])
@pytest.mark.parametrize("command", ["modes", "synth"])
def test_parameter_values_on_the_command_line_are_checked(tmp_path: Path, records: Path,
                                                          command: str, text: str) -> None:
    path = _case(tmp_path, records)
    flag = "--params" if command == "modes" else "--truth"
    extra = [] if command == "modes" else ["--out", str(tmp_path / "synth")]
    result = runner.invoke(app, [command, str(path), flag, text, *extra])
    assert isinstance(result.exception, ConfigError), result.output
    message = str(result.exception)
    assert message.startswith(f"{flag}: ") and "allowed" in message
    assert "Traceback" not in result.output
    assert not (tmp_path / "synth").exists()


def test_synth_refuses_a_rate_of_zero(tmp_path: Path, records: Path) -> None:
    path = _case(tmp_path, records)
    for rate in ("0", "-5", "nan"):
        result = runner.invoke(app, ["synth", str(path), "--truth", json.dumps(TRUTH), "--out",
                                     str(tmp_path / "s"), "--rate", rate])
        assert isinstance(result.exception, ConfigError), result.output
        assert "--rate" in str(result.exception) and "(0, 1e7] Hz" in str(result.exception)
    assert not (tmp_path / "s").exists()


def test_synth_warns_of_a_truth_outside_the_bounds(tmp_path: Path, records: Path) -> None:
    path = _case(tmp_path, records)
    truth = {**TRUTH, "k1": 20000.0}
    result = runner.invoke(app, ["synth", str(path), "--truth", json.dumps(truth), "--out",
                                 str(tmp_path / "s"), "--duration", "0.5", "--rate", "200"])
    assert result.exit_code == 0, result.output
    assert ("warning: --truth: k1 = 20000 is outside its bounds [1000, 10000] "
            "(parameters[0].upper)") in _said(result.output)
    assert "k2" not in _said(result.output).split("warning:")[1].split(" in ")[0]
    assert json.loads((tmp_path / "s" / "truth.json").read_text()) == truth


@pytest.mark.parametrize(("snr", "extra", "said"), [
    ("0", [], "sensor errors added: none"),
    ("0", ["--offset", "0.1"], "sensor errors added: offsets up to 0.1 m/s²"),
    ("0.02", [], "sensor errors added: noise 2 % rms of each channel, offsets up to 0.05 m/s², "
                 "drifts up to 0.01 m/s² per s"),
])
def test_synth_adds_and_says_exactly_its_sensor_errors(tmp_path: Path, records: Path, snr: str,
                                                       extra: list[str], said: str) -> None:
    path = _case(tmp_path, records)
    result = runner.invoke(app, ["synth", str(path), "--truth", json.dumps(TRUTH), "--out",
                                 str(tmp_path / "s"), "--duration", "0.5", "--rate", "200",
                                 "--snr", snr, *extra])
    assert result.exit_code == 0, result.output
    assert said in _said(result.output)
    manifest = json.loads((tmp_path / "s" / "manifest.json").read_text())
    offsets, drifts = np.abs(manifest["offsets_m_s2"]), np.abs(manifest["drifts_m_s3"])
    assert (offsets.max() > 0) == ("offsets" in said) and (drifts.max() > 0) == ("drifts" in said)
    assert offsets.max() <= (0.1 if "0.1" in said else 0.05)


def test_workers_help_says_where_the_default_comes_from() -> None:
    run_help = runner.invoke(app, ["run", "--help"], terminal_width=200).output
    assert "default: the case's [search] workers" in run_help
    for words in (["bench", "bridge"], ["bench", "dynamic"], ["demo"]):
        text = runner.invoke(app, [*words, "--help"], terminal_width=200).output
        assert "no [search] workers of their own" in text, words


# ============================================================================ 5. messages


def test_help_keeps_bracketed_names() -> None:
    text = runner.invoke(app, ["run", "--help"], terminal_width=200).output
    assert "Override [search] runs." in text and "instead of [data] directory." in text
    assert "Override  runs" not in text


@pytest.mark.parametrize(("edit", "expected"), [
    (('dampers = ["c1", "c2"]', 'dampers = ["c1", "c3"]'),
     "parameter 'c3' is not declared in [[parameters]]; did you mean 'c2'?"),
    (("[data]", '[[parameters]]\nname = "k9"\nlower = 1.0\nupper = 2.0\n\n[data]'),
     'use it in [model] (e.g. k = "k9") or remove it'),
    (('[case]\nname = "two-storey"\n', ""),
     "required section [case] is missing (allowed: a [case] table)"),
])
def test_errors_keep_bracketed_names(tmp_path: Path, records: Path, edit: tuple[str, str],
                                     expected: str, monkeypatch: pytest.MonkeyPatch,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    path = _case(tmp_path, records, CASE.replace(*edit))
    code, text = _main(monkeypatch, capsys, "modes", str(path))
    assert code == 2
    assert expected in text


def test_time_stamp_errors_show_plain_numbers(tmp_path: Path, records: Path) -> None:
    path = _case(tmp_path, records)
    table = tmp_path / "data" / "table.csv"
    lines = table.read_text().splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("t,"))
    fields = lines[first + 3].split(",")
    fields[0] = lines[first + 2].split(",")[0]  # a repeated time stamp
    lines[first + 3] = ",".join(fields)
    table.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError) as info:
        run_case(load_case(path), None, runs=1, max_evals=5)
    message = str(info.value)
    assert "np.float64" not in message
    assert "line 5 (t = 0.005 s): repeated time stamp" in message
    assert str(table) in message


def test_a_gap_in_time_offers_a_fix_a_case_file_user_can_make(tmp_path: Path,
                                                              records: Path) -> None:
    path = _case(tmp_path, records)
    table = tmp_path / "data" / "table.csv"
    lines = table.read_text().splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("t,"))
    del lines[first + 50]  # one sample lost: a gap of two steps
    table.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError) as info:
        run_case(load_case(path), None, runs=1, max_evals=5)
    message = str(info.value)
    assert str(table) in message and "dropped samples (1 missing" in message
    assert "[data] repair = true" in message  # a fix a case file can say
    assert "time_rtol" not in message and "np.float64" not in message


def test_missing_samples_offer_a_fix_a_case_file_user_can_make(tmp_path: Path,
                                                               records: Path) -> None:
    path = _case(tmp_path, records)
    floors = tmp_path / "data" / "floors.csv"
    lines = floors.read_text().splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("t,"))
    fields = lines[first + 20].split(",")
    fields[1] = ""
    lines[first + 20] = ",".join(fields)
    floors.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError) as info:
        run_case(load_case(path), None, runs=1, max_evals=5)
    message = str(info.value)
    assert str(floors) in message and "'a1'" in message and f"line {first + 21}" in message
    assert "[data] repair = true" in message  # a fix a case file can say
    assert "on_nan" not in message and "fill_gaps" not in message


@pytest.mark.parametrize("field", ["highpass_hz", "lowpass_hz"])
def test_a_filter_above_nyquist_names_file_field_and_range(tmp_path: Path, records: Path,
                                                           field: str) -> None:
    # The rate comes from the files' time column: known once they are read.
    path = _case(tmp_path, records, CASE + f"\n[preprocess]\n{field} = 150.0\n")
    with pytest.raises(ConfigError) as info:
        run_case(load_case(path), None, runs=1, max_evals=5)
    message = str(info.value)
    assert str(path) in message and f"preprocess.{field}" in message
    assert "150 Hz" in message and "200 Hz" in message and "table.csv" in message
    assert "below the Nyquist frequency 100 Hz" in message


def test_an_unknown_search_option_names_file_and_field(tmp_path: Path, records: Path) -> None:
    path = _case(tmp_path, records, CASE + "options = { sigma_0 = 0.1 }\n")
    with pytest.raises(ConfigError) as info:
        run_case(load_case(path), tmp_path / "out", runs=1, max_evals=5)
    message = str(info.value)
    assert message.startswith(f"{path}: search.options: ")
    assert "'sigma_0'" in message and "sigma0" in message  # what is allowed
    assert not (tmp_path / "out").exists()  # refused before anything is written


# ============================================================================ 6. silent acceptance


def test_records_of_different_lengths_are_cut_with_a_warning(tmp_path: Path,
                                                             records: Path) -> None:
    path = _case(tmp_path, records)
    floors = tmp_path / "data" / "floors.csv"
    lines = floors.read_text().splitlines()
    floors.write_text("\n".join(lines[:-100]) + "\n")  # 100 samples shorter
    from femupdate.trials.experiment import load_experiment

    with pytest.warns(FemupdateWarning) as caught:
        exp = load_experiment(load_case(path))
    message = str(caught[0].message)
    assert "table.csv: 401 samples" in message and "floors.csv: 301 samples" in message
    assert "only their overlap is used: 301 samples, 1.5 s" in message
    assert exp.t.size == 301
    with warnings.catch_warnings():  # records of one length: no warning
        warnings.simplefilter("error", FemupdateWarning)
        shutil.rmtree(tmp_path / "data")
        shutil.copytree(records, tmp_path / "data")
        load_experiment(load_case(path))


def test_a_table_that_does_not_move_is_refused(tmp_path: Path, records: Path) -> None:
    path = _case(tmp_path, records)
    _scale_column(tmp_path / "data" / "table.csv", 1, 0.0)
    with pytest.raises(DataError) as info:
        run_case(load_case(path), None, runs=1, max_evals=5)
    message = str(info.value)
    assert "table.csv" in message and "data.input" in message
    assert "0 in every sample" in message and "the table did not move" in message


def test_an_output_on_a_rotation_is_refused(tmp_path: Path) -> None:
    text = BRIDGE.read_text().replace('column = "P2", node = "P2", dof = "uy"',
                                      'column = "P2", node = "P2", dof = "rz"')
    path = tmp_path / "rotation.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_case(path)
    message = str(info.value)
    assert "data.outputs[1].dof: got 'rz', a rotation" in message
    assert "rad/s²" in message and "unit = 'm/s2'" in message and "'uy'" in message


def test_all_evaluations_failing_is_an_error_not_a_best_model(tmp_path: Path,
                                                              records: Path) -> None:
    from femupdate.problem.update import UpdateProblem

    path = _case(tmp_path, records)
    case = load_case(path)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(UpdateProblem, "__call__", lambda self, x: float("nan"))
        with pytest.raises(FemupdateError, match=r"no evaluation of any run succeeded"):
            run_case(case, None, runs=2, max_evals=20)


# ============================================================================ 7. output


def _summary(n_runs: int = 25):
    """A summary of the friction bridge's 13 parameters with the widest cells a run has."""
    from femupdate.pipeline.results import Best, RunRecord, Spread, Summary

    names = ["E", "kp1", "kp2", "kp3", "kp4", "kr1", "kr2", "kr3", "kr4", "fu1", "fu2", "fu3",
             "fu4"]
    rng = np.random.default_rng(0)
    runs = []
    for i in range(n_runs):
        values = {n: float(v) for n, v in zip(names, -rng.uniform(1, 9, 13) * 10.0 ** rng
                                              .integers(-5, 12, 13), strict=True)}
        bounds = {"kp1": "upper", "fu3": "lower", "kr4": "upper"} if i % 3 == 0 else {}
        runs.append(RunRecord(index=i, seed={}, success=i % 3 != 0, status=0, message="",
                              stop={"f_target": 1e-6} if i % 3 else {"sigma_min": 1e-12,
                                                                    "stall": True},
                              phi=rng.uniform(1e-7, 0.5), nfev=int(rng.integers(1, 100_000)),
                              nit=1, restarts=i % 4, wall_s=1.0, x=list(values.values()),
                              params=values, at_bounds=bounds))
    return Summary(case={"case": {"name": "bridge-friction-narrow"}}, case_file=None,
                   settings={"f_target": 1e-6}, delays_s={}, fingerprint="", method="ab",
                   successes=sum(r.success for r in runs), success_ratio=0.6, evals_min=1,
                   evals_mean=2.0, evals_median=2.0, evals_max=3, evals_per_success=4.0,
                   success_rule="reached f_target = 1e-06", wall_s=1.0, runs=runs,
                   best=Best(run=1, phi=1e-7, nmse_percent=1e-5, params=runs[1].params,
                             frequencies_hz=[11.7, 13.6], nmse_per_channel={}),
                   spread=Spread())


@pytest.mark.parametrize("width", [80, 120])
def test_the_run_table_reads_at_80_columns(width: int) -> None:
    summary = _summary()
    out = io.StringIO()
    cli.print_update_summary(summary, Console(file=out, width=width, color_system=None))
    text = out.getvalue()
    assert "…" not in text
    tables = [line for line in text.splitlines() if line[:1] in "┏┃┡│└"]
    assert len(tables) > 2 * len(summary.runs)
    assert max(len(line) for line in tables) <= width
    assert max(len(line) for line in text.splitlines()) <= width  # the sentences wrapped too
    for r in summary.runs:  # every value of every run is shown whole
        for value in r.params.values():
            assert f"{value:.4g}" in text
    assert "✓: the run reached φ ≤ f_target = 1e-06 ([search] f_target)" in text
    assert "φ ≤ target" in text  # the column says what ✓ means
    improper = _said(text).split("unsuccessful runs:")[1]
    assert improper.endswith("fu3 lower, kr4 upper")


def test_failures_without_improper_minima_end_in_words() -> None:
    summary = _summary(6)
    for r in summary.runs:
        r.at_bounds = {}
    summary.settings = {}  # no f_target: success relative to the best run
    out = io.StringIO()
    cli.print_update_summary(summary, Console(file=out, width=80, color_system=None))
    text = out.getvalue()
    line = _said(text).split("unsuccessful runs:")[1]
    assert not line.endswith(":") and "none with a parameter at a bound" in line
    assert "≈ best" in text
    assert "relative to the best run, not to an absolute target" in _said(text)


def test_the_progress_bar_moves_with_evaluations_and_shows_time_left() -> None:
    from femupdate.runs.progress import RunProgress

    out = io.StringIO()
    console = Console(file=out, width=80, force_terminal=True, color_system=None)
    with RunProgress(4, label="case.toml", console=console, max_evals=1000) as progress:
        progress.start(runs_done=1, evals=1100, budget_done=1000 + 100)
        task = progress._bar.tasks[0]
        assert (task.total, task.completed) == (4000, 1100)
        progress.chunk(1, 300, 0.5, 200)
        assert progress._bar.tasks[0].completed == 1300  # a chunk moves the bar
        progress.run_done(1, 300, 0.5, "f_target")  # its unused budget is done at once
        assert progress._bar.tasks[0].completed == 2000
    text = out.getvalue()
    assert "left" in text and "2/4 runs" in text and "…" not in text


def test_ctrl_c_of_any_command_is_one_line(monkeypatch: pytest.MonkeyPatch,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    def interrupt(*args: object, **kwargs: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(cli.commands, "app", interrupt)  # where main reads it
    code, text = _main(monkeypatch, capsys, "demo")
    assert code == 130 and text.strip() == "interrupted"


def test_modes_prints_the_mode_shapes_and_explains_a_damped_frequency_above(
        tmp_path: Path) -> None:
    result = runner.invoke(app, ["modes", str(BRIDGE)], terminal_width=100)
    assert result.exit_code == 0, result.output
    text = result.output
    assert "mode shapes of modes 1–6" in text
    for label in ("A1.uy", "P1.uy", "P2.rz", "A2.rz"):
        assert label in text
    assert "+1.000" in text  # each shape scaled to a largest component of 1
    assert "not proportional" in text  # the bridge's mode 1: damped 11.6745 > 11.6714 Hz
    # Without damping, the damped frequencies are the undamped ones: nothing to explain.
    undamped = tmp_path / "undamped.toml"
    undamped.write_text('[case]\nname = "sdof"\n[model.shear_building]\nmasses = [1.0, 1.0]\n'
                        "stiffnesses = [1e4, 1e4]\n")
    text = runner.invoke(app, ["modes", str(undamped)], terminal_width=100).output
    assert "mode shapes" in text and "F2.ux" in text and "not proportional" not in text


def test_the_docs_give_the_default_stop_on_sigma_that_the_code_has() -> None:
    from femupdate.optimize.beta import SIGMA_MIN_DEFAULT

    row = next(line for line in (ROOT / "docs" / "case-files.md").read_text().splitlines()
               if line.startswith("| `sigma_min` |"))
    default = row.split("|")[3].strip()
    assert default.startswith(f"`{SIGMA_MIN_DEFAULT:g}` (ab, ib")


# ============================================================================ 9. the method's docs


def test_docs_cite_the_paper_and_docs_method_not_private_notes() -> None:
    banned = ("METHOD" + ".md", "shared/" + "paper", "pitfalls" + ".md")
    found = []
    for folder in ("src", "docs", "examples", "tests", "benchmarks"):
        for path in (ROOT / folder).rglob("*"):
            if path.suffix in (".py", ".md", ".toml", ".txt") and path.is_file():
                text = path.read_text(encoding="utf-8", errors="replace")
                found += [f"{path.relative_to(ROOT)}: {b}" for b in banned if b in text]
    text = (ROOT / "README.md").read_text()
    found += [f"README.md: {b}" for b in banned if b in text]
    assert not found, found
    method = " ".join((ROOT / "docs" / "method.md").read_text().replace("*", "")
                      .replace("\n> ", "\n").split())
    assert ("Zapico-Valle, R. Alonso-Camblor, M. P. González-Martínez, M. García-Diéguez, \"A new "
            "method for finite element model updating in structural dynamics\", Mechanical "
            "Systems and Signal Processing 24 (2010) 2137–2159") in method
    for topic in ("Eq. 1", "improper minim", "α = 2^(1/n)", "CMA-ES", "mode", "variance"):
        assert topic in method, topic


# ============================================================================ 6. minimize


def test_bounds_whose_span_overflows_are_refused() -> None:
    from femupdate.optimize import minimize

    with pytest.raises(ConfigError) as info:
        minimize(lambda x: float(x[0] ** 2), [(-1e308, 1e308)], "ab", seed=0, max_evals=10)
    message = str(info.value)
    assert "bounds[0]" in message and "overflows" in message and "1.798e+308" in message
    # the widest interval that does not overflow is searched, and x stays finite
    res = minimize(lambda x: float(abs(x[0])), [(-8e307, 8e307)], "ab", seed=0, max_evals=50)
    assert np.all(np.isfinite(res.x))


def test_a_search_in_which_every_evaluation_fails_says_so() -> None:
    from femupdate.optimize import minimize

    with pytest.warns(RuntimeWarning, match="no evaluation succeeded"):
        res = minimize(lambda x: math.inf, [(0.0, 1.0)] * 3, "ab", seed=0, max_evals=2000,
                       sigma_min=1e-3)
    assert res.fun == math.inf and not res.success
    assert "sigma_min" in res.stop  # it converged on nothing: the message must say so
    assert "no evaluation succeeded" in res.message
    # one finite value is enough: no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        res = minimize(lambda x: float(x[0]) if x[0] < 0.9 else math.nan, [(0.0, 1.0)], "ab",
                       seed=0, max_evals=50)
    assert math.isfinite(res.fun) and "no evaluation succeeded" not in res.message


def test_run_method_overrides_the_case_and_drops_its_options(
        tmp_path: Path, records: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    with_options = CASE.replace('method = "ab"', 'method = "ab"\nsigma_min = 1e-3\n'
                                'options = { restarts = 1 }')
    path = _case(tmp_path, records, with_options)
    code, text = _main(monkeypatch, capsys, "run", str(path), "--out", str(tmp_path / "out"),
                       "--quiet", "--method", "multistart-lm", "--max-evals", "300")
    assert code == 0, text
    assert "not using search.options, search.sigma_min (set for ab)" in text
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["method"] == "multistart-lm"
    assert summary["runs"][0]["phi"] < 1e-6  # noise-free two-storey: found within 300
    code, text = _main(monkeypatch, capsys, "run", str(path), "--method", "nelder-mead")
    assert code == 2 and "--method: got 'nelder-mead'" in text and "multistart-lm" in text


def test_case_files_default_to_multistart_lm(tmp_path: Path, records: Path) -> None:
    path = _case(tmp_path, records, CASE.replace('method = "ab"\n', ""))
    assert load_case(path).search.method == "multistart-lm"
    beta_only = _case(tmp_path, records, CASE.replace('method = "ab"\n', "sigma_min = 1e-4\n"),
                      name="sigma.toml")
    with pytest.raises(ConfigError, match=r"search\.sigma_min: a stopping criterion of the Beta"):
        run_case(load_case(beta_only), runs=1, max_evals=10)

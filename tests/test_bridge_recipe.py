"""The bridge example as a new user runs it: the commands of the case file's header, verbatim.

The header of ``examples/bridge/viscous-narrow.toml`` says how to make its records
(``femupdate synth …``) and how to update it (``femupdate run …``). The commands are read from
the file, so that the test follows the documentation, and run from a copy of the example laid
out as the repository (their paths are relative to its root), with only overrides the README
and the header document: a shorter record (``--duration``), fewer runs and a smaller budget
(``--runs``, ``--max-evals``). Every run must reach the case's own ``[search] f_target``.
"""

from __future__ import annotations

import json
import shlex
import shutil
import subprocess
import tomllib
from pathlib import Path

import pytest
from typer.testing import CliRunner

from femupdate.cli.commands import app
from femupdate.errors import DataError

ROOT = Path(__file__).resolve().parents[1]
CASE = "examples/bridge/viscous-narrow.toml"
#: The overrides: 1 s of record instead of 4.6 s; the case's first eight runs with a budget
#: that bounds the time a regression can take (multistart-lm reaches 1e-6 in 200–800
#: evaluations here).
SHORTER = ["--duration", "1.0"]
FEWER = ["--runs", "8", "--max-evals", "3000", "--quiet"]

runner = CliRunner()


def header_commands(path: Path) -> list[str]:
    """The ``femupdate`` commands in the header comments of a case file (backslash-continued)."""
    commands: list[str] = []
    open_command = False
    for line in path.read_text(encoding="utf-8").splitlines():
        if not line.startswith("#"):
            break
        text = line.lstrip("#").strip()
        if open_command:
            commands[-1] += " " + text.removesuffix("\\").strip()
        elif text.startswith("femupdate "):
            commands.append(text.removesuffix("\\").strip())
        else:
            continue
        open_command = text.endswith("\\")
    return commands


@pytest.fixture()
def layout(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A copy of the example's files at their repository paths; the working directory."""
    for name in ("viscous-narrow.toml", "truth-viscous.json"):
        target = tmp_path / "examples" / "bridge" / name
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(ROOT / "examples" / "bridge" / name, target)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _invoke(command: str, extra: list[str]) -> str:
    words = shlex.split(command)
    assert words[0] == "femupdate"
    result = runner.invoke(app, [*words[1:], *extra])
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise result.exception
    assert result.exit_code == 0, result.output
    return result.output


def test_the_header_gives_both_commands() -> None:
    synth, run = header_commands(ROOT / CASE)
    assert synth.startswith(f"femupdate synth {CASE} ") and "--snr 0" in synth
    assert run.startswith(f"femupdate run {CASE} ")


def test_running_before_the_data_exist_says_how_to_make_them(layout: Path) -> None:
    synth, run = header_commands(layout / CASE)
    with pytest.raises(DataError) as info:
        _invoke(run, FEWER)
    message = str(info.value)
    assert "data file not found" in message and "accelerations.csv" in message
    assert "data.input.file" in message and "data.outputs[0].file" in message
    assert synth in message  # the command to run, as the header gives it


@pytest.mark.slow
def test_the_documented_recipe_reaches_the_case_target_in_every_run(layout: Path) -> None:
    synth, run = header_commands(layout / CASE)
    said = _invoke(synth, SHORTER)
    assert "sensor errors added: none" in said  # --snr 0: no noise, offsets or drift
    manifest = json.loads((layout / "examples/bridge/data-viscous/manifest.json").read_text())
    assert manifest["snr"] == 0
    assert not any(manifest["offsets_m_s2"]) and not any(manifest["drifts_m_s3"])
    _invoke(run, FEWER)
    out = Path(shlex.split(run)[shlex.split(run).index("--out") + 1])
    summary = json.loads((out / "summary.json").read_text())
    target = tomllib.loads((layout / CASE).read_text())["search"]["f_target"]
    assert summary["settings"]["f_target"] == target == 1e-6
    assert len(summary["runs"]) == 8 and summary["method"] == "multistart-lm"
    for r in summary["runs"]:
        assert r["success"] and r["phi"] <= target, r
        assert "f_target" in r["stop"]


def test_git_ignores_the_generated_records() -> None:
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    for path in ("examples/bridge/data-viscous/accelerations.csv",
                 "examples/bridge/data-friction/manifest.json"):
        done = subprocess.run(["git", "check-ignore", "-q", path], cwd=ROOT, timeout=30)
        assert done.returncode == 0, f"{path} is not ignored by .gitignore"

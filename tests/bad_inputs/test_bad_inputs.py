"""The corpus of bad inputs and misuses (issue 21): one case per file in ``cases/``.

Each case (a small TOML file, see docs/errors.md) gives what a user did (a command line, or a
few lines of Python), the files it writes beside a small valid case, and the fragment of the
message femupdate must give. For each, this runner asserts:

- no traceback: a command ends with exit code 2 (femupdate's errors, and the command line's
  usage errors) and the message, never an uncaught exception; a Python call raises a
  :class:`~femupdate.errors.FemupdateError` (or, where the case says so, warns or returns a
  result that says what went wrong);
- the expected message fragment;
- completion within the case's time limit (a hang fails the test instead of the suite).

Commands run in this process through the console entry point (``femupdate.cli.main``), which
keeps the corpus fast; three are run again as ``python -m femupdate`` in a process of their
own, to check that the terminal shows the same one line.
"""

from __future__ import annotations

import contextlib
import math
import os
import shutil
import signal
import sys
import time
import tomllib
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from femupdate import cli
from femupdate.case import load_case
from femupdate.errors import FemupdateError
from femupdate.trials.virtual import virtual_experiment
from two_storey_case import DATA, MODEL, TRUTH, parameters

HERE = Path(__file__).resolve().parent
CASES = sorted((HERE / "cases").glob("*.toml"))
ROOT = HERE.parents[1]
#: Seconds a case may take unless it says otherwise (``limit_s``): far above numba's first
#: compilation of a kernel in a fresh clone under load (30–60 s limits failed there), so a
#: limit catches a hang, not a cold cache. Cases that must fail fast (refused before any
#: work, a time-out option) keep limits of 30–60 s: they compile nothing.
LIMIT_S = 600.0
#: The keys a case file may have.
KEYS = {"about", "kind", "args", "code", "expect", "outcome", "result", "limit_s",
        "case_prefix", "case_replace", "case_append", "case_text", "files", "file_replace",
        "file_lines", "file_remove", "file_folder", "exit", "slow"}

BASE = MODEL + "\n" + parameters() + "\n" + DATA + """
[search]
method = "ab"
runs = 1
seed = 5
max_evals = 30
"""


@pytest.fixture(scope="module")
def records(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Noise-free records of the base case's truth: 1 s at 200 Hz."""
    folder = tmp_path_factory.mktemp("records")
    (folder / "case.toml").write_text(BASE)
    virtual_experiment(load_case(folder / "case.toml"), TRUTH, folder / "data", seed=3,
                       rate=200.0, duration=1.0, snr=0.0, offset=0.0, drift=0.0)
    return folder / "data"


class Hang(Exception):
    """Raised by the alarm when a case overruns its time limit."""


@contextlib.contextmanager
def time_limit(seconds: float) -> Iterator[None]:
    """Raise Hang in this (the main) thread after ``seconds``."""
    def fire(signum: int, frame: Any) -> None:
        raise Hang(f"still running after {seconds:g} s")

    previous = signal.signal(signal.SIGALRM, fire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


def _prepare(spec: dict[str, Any], folder: Path, records: Path) -> dict[str, str]:
    """The case's folder: the base case (edited) and its records (edited); the placeholders."""
    shutil.copytree(records, folder / "data")
    text = spec.get("case_text", BASE)
    for old, new, *count in spec.get("case_replace", []):
        assert old in text, f"case_replace: {old!r} is not in the base case"
        text = text.replace(old, new, *count)
    text = spec.get("case_prefix", "") + text + spec.get("case_append", "")
    (folder / "case.toml").write_text(text, encoding="utf-8")
    for name, content in spec.get("files", {}).items():
        path = folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(content, encoding="utf-8")
    for name, old, new, *count in spec.get("file_replace", []):
        path = folder / name
        content = path.read_text(encoding="utf-8")
        assert old in content, f"file_replace: {old!r} is not in {name}"
        path.write_text(content.replace(old, new, *count), encoding="utf-8")
    for name, n in spec.get("file_lines", {}).items():
        path = folder / name
        path.write_text("".join(path.read_text().splitlines(keepends=True)[:n]))
    for name in spec.get("file_remove", []):
        (folder / name).unlink()
    for name in spec.get("file_folder", []):
        (folder / name).unlink(missing_ok=True)
        (folder / name).mkdir(parents=True)
    return {"case": str(folder / "case.toml"), "dir": str(folder), "data": str(folder / "data"),
            "root": str(ROOT)}


def _show(path: Path, text: str) -> None:
    """With BAD_INPUTS_SHOW=FILE, append what the case printed or raised to FILE (to read
    the messages of the whole corpus at once)."""
    target = os.environ.get("BAD_INPUTS_SHOW")
    if target:
        with open(target, "a", encoding="utf-8") as f:
            f.write(f"=== {path.stem}\n{text.strip()}\n")


def _fill(text: str, places: dict[str, str]) -> str:
    """``text`` with ``{case}``, ``{dir}``, ``{data}`` and ``{root}`` filled in (and nothing
    else: JSON braces stay)."""
    for name, value in places.items():
        text = text.replace("{" + name + "}", value)
    return text


def _run_command(args: list[str], monkeypatch: pytest.MonkeyPatch,
                 capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    """``femupdate ARGS`` through the console entry point: (exit code, what it printed)."""
    monkeypatch.setattr(sys, "argv", ["femupdate", *args])
    monkeypatch.setattr(cli.console, "width", 200)  # a message stays on one line
    shown = warnings.showwarning
    code = 0
    try:
        cli.main()
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 1
    finally:
        warnings.showwarning = shown
    captured = capsys.readouterr()
    return code, captured.out + captured.err


def _namespace(places: dict[str, str]) -> dict[str, Any]:
    """What the Python cases may use: femupdate's public API and a few functions of x."""
    import femupdate
    from femupdate import minimize
    from femupdate.pipeline.run import run_case, validate_case

    def sphere(x: np.ndarray) -> float:
        return float(np.sum((x - 0.3) ** 2))

    def hang(x: np.ndarray) -> float:
        while True:
            time.sleep(0.05)

    def shift(x: np.ndarray) -> np.ndarray:
        return x - 0.3

    return {"femupdate": femupdate, "minimize": minimize, "np": np, "math": math,
            "time": time, "Path": Path, "load_case": load_case, "run_case": run_case,
            "validate_case": validate_case, "sphere": sphere, "hang": hang, "shift": shift,
            "case_path": Path(places["case"]), "tmp": Path(places["dir"]),
            "data": Path(places["data"])}


def _marked(path: Path) -> object:
    """A case as a parameter: ``slow = true`` in its file leaves it to the whole suite."""
    slow = tomllib.loads(path.read_text(encoding="utf-8")).get("slow", False)
    return pytest.param(path, id=path.stem, marks=[pytest.mark.slow] if slow else [])


@pytest.mark.parametrize("path", [_marked(p) for p in CASES])
def test_bad_input(path: Path, records: Path, tmp_path: Path,
                   monkeypatch: pytest.MonkeyPatch,
                   capsys: pytest.CaptureFixture[str]) -> None:
    spec = tomllib.loads(path.read_text(encoding="utf-8"))
    assert set(spec) <= KEYS, f"unknown keys {set(spec) - KEYS}"
    assert spec.get("about") and spec.get("expect"), "a case says what it is and expects"
    outcome = spec.get("outcome", "error")
    monkeypatch.chdir(tmp_path)
    places = _prepare(spec, tmp_path, records)
    expect = _fill(spec["expect"], places)
    with time_limit(float(spec.get("limit_s", LIMIT_S))):
        if spec.get("kind", "cli") == "cli":
            args = [_fill(a, places) for a in spec["args"]]
            with warnings.catch_warnings():
                warnings.simplefilter("always")
                code, text = _run_command(args, monkeypatch, capsys)
            _show(path, text)
            assert "Traceback" not in text, text
            if outcome == "error":
                assert code == 2, f"exit code {code}: {text}"
            else:  # a finished command: 0, or the code a case names (1: not the result asked)
                assert code == spec.get("exit", 0), f"exit code {code}: {text}"
            flat = " ".join(text.split())  # rich may wrap a usage error's box
            assert expect in text or " ".join(expect.split()) in flat, text
            return
        namespace = _namespace(places)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            if outcome == "error":
                with pytest.raises(FemupdateError) as info:
                    exec(spec["code"], namespace)
                _show(path, f"{type(info.value).__name__}: {info.value}")
                assert expect in str(info.value), str(info.value)
                return
            exec(spec["code"], namespace)
        if outcome == "warning":
            said = [str(w.message) for w in caught]
            _show(path, "\n".join(said))
            assert any(expect in s for s in said), said
        else:
            value = str(eval(spec["result"], namespace))
            _show(path, value)
            assert expect in value, value


@pytest.mark.slow
@pytest.mark.parametrize("name", ["run-out-is-file", "modes-json-read-only",
                                  "validate-params-not-json"])
def test_the_console_script_prints_the_same_one_line(name: str, records: Path,
                                                     tmp_path: Path) -> None:
    """A few cases through ``python -m femupdate`` in a process of its own: the in-process
    runner above sees what a user's terminal shows."""
    import subprocess

    import femupdate

    spec = tomllib.loads((HERE / "cases" / f"{name}.toml").read_text(encoding="utf-8"))
    places = _prepare(spec, tmp_path, records)
    src = str(Path(femupdate.__file__).resolve().parents[1])
    done = subprocess.run([sys.executable, "-m", "femupdate",
                           *(_fill(a, places) for a in spec["args"])],
                          capture_output=True, text=True, timeout=600, cwd=tmp_path,
                          env={**os.environ, "PYTHONPATH": src})
    text = done.stdout + done.stderr
    assert done.returncode == 2 and "Traceback" not in text, text
    lines = text.splitlines()
    errors = [i for i, line in enumerate(lines) if line.startswith("error: ")]
    assert len(errors) == 1, text
    # One message, wrapped to the console's width (80 columns when not a terminal): compared
    # without its white space, as the wrap may fall inside a long path.
    message = "".join("".join(lines[errors[0]:]).split())
    assert "".join(_fill(spec["expect"], places).split()) in message, text

"""`femupdate inspect RECORDS`: the channels of a network record, within 80 columns."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from data.test_data_io import need
from data.test_network import ARCHIVES, write_at2
from femupdate.cli.commands import app

WIDTH = 80
ROOT = Path(__file__).resolve().parents[1]


def _inspect(*args: str) -> str:
    result = CliRunner().invoke(app, ["inspect", *args], env={"COLUMNS": str(WIDTH)})
    assert result.exit_code == 0, result.output
    return result.output


def _fits(text: str) -> None:
    too_long = [line for line in text.splitlines() if len(line) > WIDTH]
    assert not too_long, "\n".join(too_long)
    assert "…" not in text  # nothing cut


@pytest.mark.parametrize(("archive", "count", "rates"),
                         [(ARCHIVES[0], 26, {"50", "100"}), (ARCHIVES[1], 28, {"100"})])
def test_inspect_lists_every_channel_of_the_shared_archives(archive: str, count: int,
                                                            rates: set[str],
                                                            tmp_path: Path) -> None:
    path = need(archive)
    out = tmp_path / "channels.json"
    text = _inspect(str(path), "--json", str(out))
    _fits(text)
    rows = [line.split() for line in text.splitlines()
            if re.match(r"^\s*\d+\s+\S", line) and "cm/s2" in line]
    assert [int(r[0]) for r in rows] == list(range(1, count + 1))
    assert {r[-5] for r in rows} == rates  # the Hz column, whole
    data = json.loads(out.read_text())
    assert len(data) == count
    # the peaks printed are the JSON's (m/s², 4 decimals), never cut
    for row, item in zip(rows, data, strict=True):
        assert row[-2] == f"{item['peak_m_s2']:.4f}"
        assert item["samples"] == int(row[-4])
    if count == 26:  # the 1979 archive: two recorders at two rates, said
        assert "0164: channels 1, 2" in " ".join(text.split())


def test_inspect_an_at2_file(tmp_path: Path) -> None:
    path = tmp_path / "RSN9_TEST_270.AT2"
    signal = 0.25 * np.sin(np.linspace(0, 20, 500))
    write_at2(path, signal, 0.01, component="270")
    text = _inspect(str(path))
    _fits(text)
    row = re.search(r"^\s*1\s+Test station\s+270\s+100\s+500\s+4\.99\s+(\S+)\s+g\s*$", text,
                    re.MULTILINE)
    assert row is not None, text
    assert row.group(1) == f"{np.max(np.abs(signal)) * 9.80665:.4f}"
    assert "RSN9_TEST_270.AT2: 1 channel, Test event, 1/1/2000" in " ".join(text.split())


def test_inspect_names_a_bad_record_in_one_line(tmp_path: Path) -> None:
    env = dict(os.environ, COLUMNS=str(WIDTH), PYTHONPATH=str(ROOT / "src"))
    proc = subprocess.run([sys.executable, "-m", "femupdate", "inspect",
                           str(tmp_path / "nothing.zip")],
                          capture_output=True, text=True, env=env, timeout=120)
    assert proc.returncode == 2
    said = " ".join((proc.stdout + proc.stderr).split())
    assert "nothing.zip: file not found" in said and "Traceback" not in said

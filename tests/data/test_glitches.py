"""Glitches of real exports: found with file, line and time; repaired only when asked, and said."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from femupdate.data.glitches import check_record
from femupdate.data.io import read_csv
from femupdate.errors import DataError

DT = 0.01


def _csv(path: Path, rows: list[tuple[float, str]]) -> Path:
    path.write_text("t,a\n" + "\n".join(f"{t!r},{v}" for t, v in rows) + "\n")
    return path


def _clean(n: int = 12) -> list[tuple[float, str]]:
    return [(round(k * DT, 10), str(float(k * k))) for k in range(n)]


def test_a_clean_record_passes_unchanged() -> None:
    t = np.arange(10) * DT
    t2, chans, notes = check_record(t, {"a": t**2}, np.arange(2, 12), "f.csv")
    assert notes == []
    np.testing.assert_array_equal(t2, t)
    np.testing.assert_array_equal(chans["a"], t**2)


def test_each_glitch_is_listed_with_line_and_time_and_refused(tmp_path: Path) -> None:
    rows = _clean()
    rows.insert(5, rows[4])                            # an exact duplicate row (line 7)
    del rows[9]                                        # a dropped sample after t = 0.07
    rows[2] = (rows[2][0], "nan")                      # a non-finite value (line 4)
    path = _csv(tmp_path / "g.csv", rows)
    with pytest.raises(DataError) as info:
        read_csv(path, time="t")
    message = str(info.value)
    assert str(path) in message and "3 glitch(es)" in message
    assert "line 7 (t = 0.04 s): repeated time stamp (an exact duplicate" in message
    assert "line 11 (t = 0.09 s): dropped samples (1 missing after t = 0.07 s)" in message
    assert "line 4 (t = 0.02 s): non-finite values (column 'a': 1 sample(s))" in message
    assert "repair = true" in message


def test_repair_mends_isolated_glitches_and_says_what_it_did(tmp_path: Path) -> None:
    rows = _clean()
    rows.insert(5, (rows[4][0], "inf"))                # a repeated stamp of an empty row
    del rows[9]                                        # one dropped sample
    rows[2] = (rows[2][0], "nan")
    m = read_csv(_csv(tmp_path / "g.csv", rows), time="t", repair=True)
    np.testing.assert_allclose(m.t, np.arange(12) * DT, atol=1e-12)
    expected = (np.arange(12) * 1.0) ** 2
    expected[2] = 0.5 * (expected[1] + expected[3])    # interpolated
    expected[8] = 0.5 * (expected[7] + expected[9])
    np.testing.assert_allclose(m["a"], expected)
    assert len(m.notes) == 3 and all(note.startswith(f"{tmp_path / 'g.csv'}: repaired")
                                     for note in m.notes)


@pytest.mark.parametrize(("rows", "why"), [
    ([(0.0, "1"), (0.01, "2"), (0.02, "3"), (0.02, "9"), (0.03, "4")], "other values"),
    ([(0.0, "1"), (0.01, "2"), (0.02, "3"), (0.015, "9"), (0.03, "4")], "time runs backwards"),
    ([(0.0, "1"), (0.01, "2"), (0.06, "3"), (0.07, "9"), (0.08, "4")], "more than 3"),
    ([(0.0, "nan"), (0.01, "2"), (0.02, "3"), (0.03, "9")], "at the record's end"),
])
def test_what_no_repair_can_mend_is_an_error(tmp_path: Path, rows: list, why: str) -> None:
    with pytest.raises(DataError, match=f"not repairable.*{why}"):
        read_csv(_csv(tmp_path / "g.csv", rows), time="t", repair=True)


def _shared() -> Path:
    root = Path(os.environ.get("FEMUPDATE_DATA")
                or Path(__file__).resolve().parents[3] / "shared" / "data")
    path = root / "minishake_1story" / "stiff1_northridge_t2_top.csv"
    if not path.is_file():
        pytest.skip(f"the glitched real export is absent ({path}); set FEMUPDATE_DATA")
    return path


def test_the_glitched_real_export(tmp_path: Path) -> None:
    # A dropped packet, then a repeated time stamp on a row of nan/inf (PROVENANCE.md).
    path = _shared()
    kw = dict(time="SampleTimeFine", time_scale=1e-6, skip_rows=1, columns=["Acc_X"])
    with pytest.raises(DataError) as info:
        read_csv(path, **kw)
    message = str(info.value)
    assert str(path) in message and "dropped samples" in message
    assert "line 2702 (t = 2487.79623 s): dropped samples (1 missing" in message
    assert "line 2703 (t = 2487.79623 s): repeated time stamp (a row without a finite" in message
    m = read_csv(path, **kw, repair=True)
    assert np.all(np.isfinite(m["Acc_X"])) and m.notes
    assert any("dropped samples" in note for note in m.notes)

"""Tests of femupdate.data.io: containers, readers, writers, time bases, bad inputs."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np
import pytest

from femupdate.data.datasets import read_elcentro, read_xsens_dot
from femupdate.data.io import (
    read,
    read_csv,
    read_npz,
    read_uff58,
    write_csv,
    write_npz,
    write_uff58,
)
from femupdate.data.measurement import Measurement, align, combine, fill_gaps, resample
from femupdate.errors import ConfigError, DataError, MissingDependencyError
from femupdate.units import STANDARD_GRAVITY as G


def shared_data() -> Path:
    """``../shared/data`` beside the checkout, or $FEMUPDATE_DATA."""
    env = os.environ.get("FEMUPDATE_DATA")
    return Path(env) if env else Path(__file__).resolve().parents[2] / ".." / "shared" / "data"


def need(relative: str) -> Path:
    path = shared_data() / relative
    if not path.is_file():
        pytest.skip(f"real data file {path} not found: put the shared data beside the "
                    f"checkout (../shared/data) or set FEMUPDATE_DATA")
    return path


@pytest.fixture
def sample() -> Measurement:
    t = 12.5 + np.arange(200) / 1035.0
    return Measurement(t, {"P1": np.sin(40 * t), "table": np.cos(7 * t) * 1e-3},
                       {"P1": "m/s^2", "table": "m/s^2"}, "sample")


def assert_same(a: Measurement, b: Measurement) -> None:
    assert a.names == b.names
    np.testing.assert_array_equal(a.t, b.t)
    for name in a.names:
        np.testing.assert_array_equal(a[name], b[name])
    assert a.units == b.units


# --------------------------------------------------------------------------- round trips


def test_csv_round_trip(tmp_path: Path, sample: Measurement) -> None:
    path = tmp_path / "m.csv"
    write_csv(path, sample)
    assert_same(read(path), sample)


def test_npz_round_trip(tmp_path: Path, sample: Measurement) -> None:
    path = tmp_path / "m.npz"
    write_npz(path, sample)
    assert_same(read_npz(path), sample)
    assert_same(read(path), sample)


@pytest.mark.parametrize("binary", [False, True])
def test_uff58_round_trip(tmp_path: Path, sample: Measurement, binary: bool) -> None:
    path = tmp_path / "m.uff"
    write_uff58(path, sample, binary=binary)
    back = read_uff58(path)
    np.testing.assert_allclose(back.t, sample.t, rtol=1e-15, atol=0)
    for name in sample.names:
        # ASCII UFF58 stores 12 significant digits
        np.testing.assert_allclose(back[name], sample[name], rtol=0,
                                   atol=0 if binary else 1e-11)
    assert back.units == sample.units
    assert read(path).names == sample.names


def test_uff58_foreign_file_uses_header_abscissa(tmp_path: Path) -> None:
    pyuff = pytest.importorskip("pyuff")
    t = np.arange(50) * 0.01
    path = tmp_path / "foreign.uff"
    pyuff.UFF(str(path)).write_sets([{
        "type": 58, "func_type": 1, "rsp_node": 3, "rsp_dir": 2, "ref_node": 0, "ref_dir": 0,
        "abscissa_spacing": 1, "orddenom_spec_data_type": 0, "x": t, "data": np.sin(t),
    }], mode="overwrite")
    m = read_uff58(path)
    assert m.names == ("node3dir2",)
    np.testing.assert_allclose(m.t, t, atol=1e-12)


def test_uff58_needs_pyuff(tmp_path: Path, sample: Measurement,
                           monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "pyuff", None)  # makes `import pyuff` fail
    with pytest.raises(MissingDependencyError, match=r"femupdate\[uff\]"):
        write_uff58(tmp_path / "m.uff", sample)


# --------------------------------------------------------------------------- CSV variants


@pytest.mark.parametrize("delimiter", [",", ";", "\t", " "])
def test_csv_delimiters_are_sniffed(tmp_path: Path, delimiter: str) -> None:
    path = tmp_path / "d.txt"
    rows = [f"{k * 0.5}{delimiter}{k * 2.0}{delimiter}{-k}" for k in range(5)]
    path.write_text("some title\ntime" + delimiter + "a" + delimiter + "b\n" + "\n".join(rows))
    m = read_csv(path, ["b", "a"], time="time")
    np.testing.assert_array_equal(m.t, np.arange(5) * 0.5)
    np.testing.assert_array_equal(m["a"], np.arange(5) * 2.0)
    np.testing.assert_array_equal(m["b"], -np.arange(5.0))


def test_csv_numbered_columns_and_rate(tmp_path: Path) -> None:
    path = tmp_path / "n.csv"
    path.write_text("\n".join(f"{k},{k * k}" for k in range(6)))
    m = read_csv(path, {"sq": 1}, rate=200.0, units="m")
    np.testing.assert_array_equal(m.t, np.arange(6) / 200.0)
    np.testing.assert_array_equal(m["sq"], np.arange(6.0) ** 2)
    assert m.units == {"sq": "m"}
    assert read_csv(path, rate=10.0).names == ("col0", "col1")


def test_csv_explicit_skip_lines(tmp_path: Path) -> None:
    path = tmp_path / "s.csv"
    path.write_text("meta 1\n42\nt,x\n0,1\n1,2\n")
    # auto-detection would take "42" as data; skip_lines says where the table starts
    m = read_csv(path, ["x"], time="t", skip_lines=2)
    np.testing.assert_array_equal(m["x"], [1.0, 2.0])


def test_time_scale_converts_microseconds(tmp_path: Path) -> None:
    path = tmp_path / "us.csv"
    path.write_text("us,x\n" + "\n".join(f"{1000 + 8333 * k},{k}" for k in range(4)))
    m = read_csv(path, ["x"], time="us", time_scale=1e-6)
    np.testing.assert_allclose(np.diff(m.t), 8.333e-3)


# --------------------------------------------------------------------------- bad inputs


def test_missing_file(tmp_path: Path) -> None:
    for reader in (read_npz, read_uff58, read_elcentro):
        with pytest.raises(DataError, match=r"nope\.dat: file not found"):
            reader(tmp_path / "nope.dat")
    with pytest.raises(DataError, match="file not found"):
        read_csv(tmp_path / "nope.csv", rate=1.0)


def test_missing_column_lists_available(tmp_path: Path, sample: Measurement) -> None:
    write_csv(tmp_path / "m.csv", sample)
    with pytest.raises(DataError, match=r"no column 'P9'; available columns: \['t', 'P1', "
                                        r"'table'\]"):
        read_csv(tmp_path / "m.csv", ["P9"], time="t")
    write_npz(tmp_path / "m.npz", sample)
    with pytest.raises(DataError, match=r"no column\(s\) \['P9'\].*\['P1', 'table'\]"):
        read_npz(tmp_path / "m.npz", ["P9"])
    with pytest.raises(DataError, match="out of range: the file has 3 columns"):
        read_csv(tmp_path / "m.csv", [5], time="t")


def test_non_numeric_names_file_line_column(tmp_path: Path) -> None:
    path = tmp_path / "bad.csv"
    path.write_text("t,a,b\n0,1,2\n1,1,2\n2,1,x7\n3,1,2\n")
    with pytest.raises(DataError, match=r"bad.csv: non-numeric value 'x7' at line 4, "
                                        r"column 'b'"):
        read_csv(path, time="t")
    # a column not asked for is not parsed
    assert read_csv(path, ["a"], time="t").n_samples == 4


def test_ragged_row(tmp_path: Path) -> None:
    path = tmp_path / "r.csv"
    path.write_text("t,a\n0,1\n1\n")
    with pytest.raises(DataError, match="line 3 has 1 fields, expected 2"):
        read_csv(path, time="t")


def test_nan_samples_are_flagged(tmp_path: Path) -> None:
    path = tmp_path / "nan.csv"
    values = ["1", "2", "", "4", "nan", "6", "7"]
    path.write_text("t,a\n" + "\n".join(f"{k},{v}" for k, v in enumerate(values)))
    with pytest.raises(DataError, match=r"2 glitch.*line 4 \(t = 2 s\): non-finite values "
                                        r"\(column 'a'.*line 6 \(t = 4 s\).*repair = true"):
        read_csv(path, time="t")
    m = read_csv(path, time="t", on_nan="interpolate", max_gap=1)
    np.testing.assert_array_equal(m["a"], np.arange(1.0, 8.0))


def test_nan_gap_longer_than_max_gap(tmp_path: Path) -> None:
    path = tmp_path / "gap.csv"
    values = ["1", "", "", "", "5"]
    path.write_text("t,a\n" + "\n".join(f"{k},{v}" for k, v in enumerate(values)))
    with pytest.raises(DataError, match=r"gap of 3 missing samples at samples 1\.\.3, longer "
                                        r"than max_gap=2"):
        read_csv(path, time="t", on_nan="interpolate", max_gap=2)
    with pytest.raises(DataError, match="at the start"):
        fill_gaps(np.array([np.nan, 1.0, 2.0]), 3)


def test_measurement_refuses_nan() -> None:
    y = np.ones(10)
    y[[3, 7]] = np.nan
    with pytest.raises(DataError, match=r"channel 'a' has 2 non-finite samples.*sample 3"):
        Measurement(np.arange(10.0), {"a": y})


def test_non_uniform_time(tmp_path: Path) -> None:
    path = tmp_path / "jump.csv"
    times = [0.0, 0.01, 0.02, 0.045, 0.055]  # 2.5 intervals: jitter, not a dropped sample
    path.write_text("t,a\n" + "\n".join(f"{t},{k}" for k, t in enumerate(times)))
    with pytest.raises(DataError, match=r"not uniform: the step ending at line 5 is 0\.025 s"):
        read_csv(path, time="t")
    with pytest.raises(DataError, match="not strictly increasing at sample 2"):
        Measurement(np.array([0.0, 1.0, 1.0, 2.0]), {"a": np.zeros(4)})


def test_channels_of_different_lengths(tmp_path: Path) -> None:
    with pytest.raises(DataError, match=r"channel 'b' has shape \(9,\)"):
        Measurement(np.arange(10.0), {"a": np.zeros(10), "b": np.zeros(9)})
    np.savez(tmp_path / "plain.npz", t=np.arange(10.0), a=np.zeros(10), b=np.zeros(8))
    with pytest.raises(DataError, match=r"channel 'b' has \(8,\) samples.*different lengths"):
        read_npz(tmp_path / "plain.npz")


def test_channels_of_different_sampling_rates(tmp_path: Path) -> None:
    pyuff = pytest.importorskip("pyuff")
    sets = [{"type": 58, "func_type": 1, "id1": name, "rsp_node": k + 1, "rsp_dir": 1,
             "ref_node": 0, "ref_dir": 0, "abscissa_spacing": 1,
             "orddenom_spec_data_type": 0, "x": np.arange(20) * dt, "data": np.ones(20)}
            for k, (name, dt) in enumerate([("a", 0.01), ("b", 0.02)])]
    path = tmp_path / "rates.uff"
    pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")
    with pytest.raises(DataError, match=r"'b' is sampled every 0\.02 s.*different sampling"):
        read_uff58(path)
    slow = Measurement(np.arange(10) * 0.02, {"b": np.ones(10)}, source="slow")
    fast = Measurement(np.arange(20) * 0.01, {"a": np.ones(20)}, source="fast")
    with pytest.raises(DataError, match=r"different rates \(fast: 100 Hz, slow: 50 Hz\)"):
        align(fast, slow)


def test_uff_without_data_sets(tmp_path: Path) -> None:
    pytest.importorskip("pyuff")
    path = tmp_path / "empty.uff"
    path.write_text("not a universal file\n")
    with pytest.raises(DataError, match="no UFF58 data sets"):
        read_uff58(path)


def test_read_rejects_unknown_extension(tmp_path: Path) -> None:
    with pytest.raises(DataError, match=r"unknown file type '\.xlsx'"):
        read(tmp_path / "m.xlsx")


def test_time_or_rate_required(tmp_path: Path) -> None:
    path = tmp_path / "x.csv"
    path.write_text("0,1\n1,2\n")
    with pytest.raises(ConfigError, match="exactly one of time="):
        read_csv(path)


# --------------------------------------------------------------------------- time bases


def test_resample_sine_matches_closed_form() -> None:
    t = np.arange(2000) / 100.0
    f = 3.0
    t2, y2 = resample(t, np.sin(2 * np.pi * f * t), 250.0)
    np.testing.assert_allclose(np.diff(t2), 1 / 250.0)
    inner = slice(200, -200)  # away from the filter's edge effects
    np.testing.assert_allclose(y2[inner], np.sin(2 * np.pi * f * t2[inner]), atol=2e-3)
    _, y3 = resample(t, np.column_stack([np.sin(t), np.cos(t)]), 50.0)
    assert y3.shape == (1000, 2)


def test_align_nearest_and_linear() -> None:
    dt = 0.01
    t_a = np.arange(100) * dt
    t_b = 0.0045 + np.arange(100) * dt  # starts 0.45 samples later
    a = Measurement(t_a, {"a": 2 * t_a + 1}, source="a")
    b = Measurement(t_b, {"b": 2 * t_b + 1}, source="b")
    na, nb = align(a, b)  # the shift rounds to 0 samples: samples pair up as they are
    assert na.n_samples == nb.n_samples == 100
    np.testing.assert_array_equal(nb["b"], b["b"])
    np.testing.assert_array_equal(na["a"], a["a"])
    late = Measurement(t_a + 0.006, {"b": np.arange(100.0)}, source="late")
    na, nl = align(a, late)  # 0.6 samples: a is shifted by one sample
    assert na.n_samples == nl.n_samples == 99
    np.testing.assert_array_equal(na["a"], a["a"][1:])
    np.testing.assert_array_equal(nl["b"], np.arange(99.0))
    la, lb = align(a, b, method="linear", zero=False)
    np.testing.assert_allclose(la["a"], 2 * lb.t + 1)  # linear data interpolate exactly
    np.testing.assert_array_equal(la.t, t_b[t_b <= t_a[-1]])
    both = combine(la, lb)
    assert both.names == ("a", "b")
    with pytest.raises(DataError, match="rename"):
        combine(la, la)


def test_align_resamples_to_common_rate() -> None:
    slow = Measurement(np.arange(200) * 0.02, {"s": np.sin(np.arange(200) * 0.02)})
    fast = Measurement(np.arange(400) * 0.01, {"f": np.sin(np.arange(400) * 0.01)})
    s, f = align(slow, fast, rate=100.0)
    assert s.rate == pytest.approx(100.0) and s.n_samples == f.n_samples


# --------------------------------------------------------------------------- real files


def test_real_xsens_files() -> None:
    ground = read_xsens_dot(need("minishake_1story/stiff1_elcentro_t1_ground.csv"),
                            {"table": "Acc_X"})
    top = read_xsens_dot(need("minishake_1story/stiff1_elcentro_t1_top.csv"),
                         {"roof": "Acc_X"})
    # figures from PROVENANCE.md (placeholder row dropped)
    assert ground.n_samples == top.n_samples == 2561
    assert ground.rate == pytest.approx(120.0, rel=1e-4)
    assert ground["table"].min() == pytest.approx(-4.861, abs=1e-3)
    assert top["roof"].max() == pytest.approx(10.25, abs=1e-2)
    assert ground.units == {"table": "m/s^2"}
    g, r = align(ground, top)
    assert g.n_samples == r.n_samples == 2560 and g.t[0] == 0.0
    generic = read_csv(need("minishake_1story/stiff1_sine2hz_t1_top.csv"), ["Acc_X"],
                       time="SampleTimeFine", time_scale=1e-6, skip_rows=1)
    assert generic.n_samples == 2792
    assert generic["Acc_X"].min() == pytest.approx(-9.730, abs=1e-3)


def test_real_elcentro_files() -> None:
    t, ag = read_elcentro(need("elcentro1940/elcentro_NS_1940_peknold_g_dt0.02.dat"))
    assert t.size == 1559  # the header's count; the padding zero is dropped
    assert t[1] == pytest.approx(0.02)
    assert np.argmin(ag) == 101 and ag.min() == pytest.approx(-0.31882 * G)
    t2, ag2 = read_elcentro(need("elcentro1940/elcentro_S00E_1940_cms2_dt0.02.dat"))
    assert t2.size == 2688 and np.argmin(ag2) == 106
    assert ag2.min() == pytest.approx(-3.41705)

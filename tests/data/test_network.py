"""Network records (femupdate.data.network): CSMIP V2 archives and PEER AT2 files.

The round trips on the shared Meloland archives skip when ../shared/data is absent; the AT2
round trip writes its own file from a known signal.
"""

from __future__ import annotations

import re
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest

from data.test_data_io import need
from femupdate.data.io import read, read_network
from femupdate.data.network import (
    compare_events,
    parse_at2,
    parse_cosmos,
    parse_csmip_v2,
    read_network_records,
    to_measurement,
)
from femupdate.errors import ConfigError, DataError
from femupdate.units import STANDARD_GRAVITY as G

ARCHIVES = ["cesmd_meloland/imperialvalley1979_ce01336.zip",
            "cesmd_meloland/calexico2010_ce01336.zip"]


def _members(path: Path) -> dict[str, str]:
    with zipfile.ZipFile(path) as z:
        return {n: z.read(n).decode("latin-1") for n in z.namelist()
                if n.upper().endswith(".V2")}


def _header_figures(text: str) -> tuple[int, float, float, float, int]:
    """(count, dt, peak, time of peak, field width) as the file's header writes them, read
    here independently of the parser."""
    block = re.search(r"^\s*(\d+)\s+points of accel data equally spaced at\s+([\d.]+)", text,
                      re.IGNORECASE | re.MULTILINE)
    peak = re.search(r"peak acceleration\s*=\s*(-?[\d.]+)\s+\S+\s+at\s+([\d.]+)", text,
                     re.IGNORECASE)
    fmt = re.search(r"\(8f(\d+)\.", text)
    assert block and peak
    return (int(block.group(1)), float(block.group(2)), float(peak.group(1)),
            float(peak.group(2)), int(fmt.group(1)) if fmt else 10)


def _samples(text: str, n: int, width: int) -> np.ndarray:
    """The first ``n`` acceleration samples of a V2 file, by numpy's fixed-width reader."""
    lines = text.splitlines()
    start = next(i for i, s in enumerate(lines) if "points of accel data" in s.lower())
    rows = lines[start + 1:start + 1 + -(-n // 8)]
    values = np.concatenate([np.genfromtxt([row], delimiter=[width] * 8).ravel()
                             for row in rows])
    return values[~np.isnan(values)]


@pytest.mark.parametrize("archive", ARCHIVES)
def test_every_channel_of_the_shared_archives_equals_its_file(archive: str) -> None:
    path = need(archive)
    members = _members(path)
    channels = read_network_records(path)
    assert len(channels) == len(members)  # 26 in 1979, 28 in 2010
    for ch in channels:
        name = next(n for n in members if int(re.sub(r"\D", "", n[:-3])) == ch.number)
        count, dt, peak, at, width = _header_figures(members[name])
        assert ch.n_samples == count and ch.dt == dt
        assert ch.file_unit == "cm/s2"
        in_file = ch.acceleration / 0.01
        # equal to the samples as numpy reads the file's fixed-width fields, to its precision
        np.testing.assert_allclose(in_file, _samples(members[name], count, width), rtol=0,
                                   atol=1e-9)
        # the header's peak (3 decimals) is the largest sample, at its time
        k = int(np.argmax(np.abs(in_file)))
        assert abs(abs(in_file[k]) - abs(peak)) <= 0.0005 + ch.resolution
        assert abs(k * dt - at) <= 0.5 * dt + 1e-9


def test_the_two_events_differ_by_channels_27_and_28_only() -> None:
    old, new = (read_network_records(need(a)) for a in ARCHIVES)
    conflicts, differences = compare_events({"1979": old, "2010": new}, range(1, 29))
    assert conflicts == []
    assert differences == ["1979 has no channel 27-28"]


def test_channels_by_number_or_by_location_and_direction() -> None:
    path = need(ARCHIVES[1])
    by_number = read_network_records(path, [7])[0]
    by_place = read_network_records(path, ["deck: middle of bridge / TRAN"])[0]
    assert by_place.number == by_number.number == 7
    assert read_network_records(path, ["Base of Center Column"])[0].number == 4
    with pytest.raises(DataError, match=r"matches 3 channels.*name the direction"):
        read_network_records(path, ["South Embankment"])
    with pytest.raises(DataError, match=r"no channel 29 \(allowed: channels 1-28\)"):
        read_network_records(path, [29])
    with pytest.raises(DataError, match="no channel at 'Roof / Up'"):
        read_network_records(path, ["Roof / Up"])


def test_a_measurement_of_one_recorder_and_a_refusal_across_rates() -> None:
    path = need(ARCHIVES[0])
    m = read_network(path, [2, 7])
    assert m.names == ("2", "7") and m.n_samples == 1138 and m.dt == pytest.approx(0.02)
    assert m.units == {"2": "m/s2", "7": "m/s2"}
    assert read(path, columns=[2]).n_samples == 1138  # dispatch by extension
    with pytest.raises(DataError, match=r"different intervals \(2: 0.02 s, 16: 0.01 s\)"):
        read_network(path, [2, 16])


# ----------------------------------------------------------------------------- bad headers


def _first_v2(archive: str) -> tuple[str, str]:
    members = _members(need(archive))
    name = sorted(members)[0]
    return name, members[name]


@pytest.mark.parametrize("archive", ARCHIVES)
def test_a_header_whose_count_disagrees_with_the_samples_is_refused(archive: str) -> None:
    name, text = _first_v2(archive)
    lines = text.splitlines()
    start = next(i for i, s in enumerate(lines) if "points of accel data" in s.lower())
    del lines[start + 5]  # 8 samples fewer than the header says
    with pytest.raises(DataError, match=r"says \d+ samples of acceleration but the block"):
        parse_csmip_v2("\n".join(lines), name)


@pytest.mark.parametrize("archive", ARCHIVES)
def test_a_header_whose_units_disagree_with_the_samples_is_refused(archive: str) -> None:
    name, text = _first_v2(archive)
    # the samples said to be in g while the peak line says cm/s²: the header contradicts itself
    lied = re.sub(r"(UNITS: )CM/SEC/SEC|(in )cm/sec2", lambda m: (m.group(1) or m.group(2))
                  + "g", text, count=1)
    with pytest.raises(DataError, match="disagrees with itself"):
        parse_csmip_v2(lied, name)
    # the peak given in g, its unit left as cm/s²: a figure the samples do not reach
    peak = _header_figures(text)[2]
    in_g = re.sub(r"(?i)(peak acceleration\s*=\s*)-?[\d.]+",
                  lambda m: f"{m.group(1)}{peak / 980.665:9.3f}", text, count=1)
    with pytest.raises(DataError, match=r"is not the samples' largest .* wrong units"):
        parse_csmip_v2(in_g, name)


@pytest.mark.parametrize("archive", ARCHIVES)
def test_a_header_whose_rate_disagrees_with_the_samples_is_refused(archive: str) -> None:
    name, text = _first_v2(archive)
    dt = _header_figures(text)[1]
    wrong = f"{2 * dt:.3f}".lstrip("0")
    spaced = re.compile(r"(?i)(points of accel data equally spaced at\s+)[\d.]+")
    with pytest.raises(DataError, match="gives two intervals"):
        parse_csmip_v2(spaced.sub(lambda m: m.group(1) + wrong, text, count=1), name)
    both = re.sub(r"(?i)(intervals of\s+)[\d.]+", lambda m: m.group(1) + wrong,
                  spaced.sub(lambda m: m.group(1) + wrong, text, count=1), count=1)
    with pytest.raises(DataError, match="wrong interval or sample count"):
        parse_csmip_v2(both, name)


def test_not_a_record() -> None:
    with pytest.raises(DataError, match="no 'Chan N:"):
        parse_csmip_v2("just text\n1 2 3\n", "x.V2")
    with pytest.raises(ConfigError, match="allowed: csmip, cosmos, at2"):
        read_network_records(".", format="sac")


def test_a_missing_file_and_an_empty_folder(tmp_path: Path) -> None:
    with pytest.raises(DataError, match="file not found"):
        read_network_records(tmp_path / "absent.zip")
    with pytest.raises(DataError, match=r"no CSMIP, COSMOS or PEER AT2 record files"):
        read_network_records(tmp_path)


# ----------------------------------------------------------------------------- AT2


def write_at2(path: Path, accel_g: np.ndarray, dt: float, component: str = "180") -> None:
    """An AT2 file as PEER writes it: 4 header lines, then 5 values a line in E15.7."""
    head = ["PEER NGA STRONG MOTION DATABASE RECORD",
            f"Test event, 1/1/2000, Test station, {component}",
            "ACCELERATION TIME SERIES IN UNITS OF G",
            f"NPTS= {accel_g.size:5d}, DT= {dt:.4f} SEC"]
    rows = ["".join(f"{v:15.7E}" for v in accel_g[i:i + 5]) for i in range(0, accel_g.size, 5)]
    path.write_text("\n".join(head + rows) + "\n")


def test_at2_round_trip(tmp_path: Path) -> None:
    rng = np.random.default_rng(35)
    t = np.arange(1203) * 0.005
    signal = 0.3 * np.sin(2 * np.pi * 1.7 * t) * np.exp(-0.2 * t) + 0.01 * rng.standard_normal(
        t.size)
    path = tmp_path / "RSN1_TEST_180.AT2"
    write_at2(path, signal, 0.005)
    (ch,) = read_network_records(path)
    assert (ch.number, ch.direction, ch.n_samples, ch.dt) == (1, "180", 1203, 0.005)
    assert (ch.location, ch.station) == ("Test station", "Test event, 1/1/2000")
    assert ch.file_unit == "g"
    # 8 significant digits in the file: equal to them
    np.testing.assert_allclose(ch.acceleration / G, signal, rtol=5e-8, atol=1e-12)
    m = read(path)
    assert m.names == ("1",) and m.dt == pytest.approx(0.005)


def test_at2_whose_count_disagrees_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "short.AT2"
    write_at2(path, np.linspace(-0.1, 0.1, 12), 0.01)
    text = path.read_text().replace("NPTS=    12", "NPTS=    13")
    with pytest.raises(DataError, match="NPTS = 13 but the file holds 12 samples"):
        parse_at2(text, "short.AT2")
    with pytest.raises(DataError, match="line 4 is"):
        parse_at2(text.replace("NPTS=", "N="), "short.AT2")


def test_a_folder_of_at2_files_is_numbered_by_file_name(tmp_path: Path) -> None:
    for name, component in (("b_090.AT2", "90"), ("a_000.AT2", "0"), ("c_up.AT2", "UP")):
        write_at2(tmp_path / name, np.linspace(-0.1, 0.2, 20), 0.02, component=component)
    channels = read_network_records(tmp_path)
    assert [(ch.number, ch.direction) for ch in channels] == [(1, "0"), (2, "90"), (3, "UP")]
    assert read_network_records(tmp_path, ["Test station / 90"])[0].number == 2


# ----------------------------------------------------------------------------- COSMOS V2


def cosmos_channel(accel: np.ndarray, dt: float, *, number: int = 3, direction: str = "360 deg",
                   location: str = "Roof", unit: str = "cm/sec2(04)") -> list[str]:
    """One channel as COSMOS v1.20 lays it out (as the V2c files of the USGS/CGS do): 13
    text lines, 100 integers (10I8), 100 reals (5F15.6; 34: interval, 64-65: the peak and
    its time), comment lines, the samples in 8F10.5 and an end line."""
    k = int(np.argmax(np.abs(accel)))
    reals = np.full(100, -999.0)
    reals[33], reals[34], reals[63], reals[64] = dt, accel.size * dt, accel[k], k * dt
    text = ["Corrected acceleration    (Format v01.20 with 13 text lines)",
            "Record of Test Earthquake of Fri Nov 30, 2018 17:29 UTC",
            "Hypocenter: 61.34640 -149.95520 H= 46km Mw=7.0",
            "Origin: 2018/11/30 17:29:29    UTC",
            "Statn No: 05-01234 Code:CE-01234  CGS  Test Building",
            "Coords: 60.9677 -144.6051  Site geology:",
            "Recorder: (see cmnt)      ( 3 Chns of   3 at Sta) Sensor: (see comment)",
            "Rcrd start time: 2018/11/30 17:29:39.137 UTC (Q=5) RcrdId: (see comment)",
            f"Sta Chan{number:4d}: {direction:<7s}(Rcrdr Chan{number:3d}) Location: {location}",
            "Raw record length = 210.000 sec, Uncor max =    101730, at  82.680 sec.",
            f"Processed:2019-03-03, Max = {accel[k]:8.3f} cm/sec2 at {k * dt:8.3f} sec",
            "Record filtered below  0.03 Hz (periods over 33.33 secs), and above 20.0 Hz",
            "Values used when parameter or data value is unknown/unspecified:   -999, -999.00"]
    ints = ["".join(f"{-999:8d}" for _ in range(10)) for _ in range(10)]
    real_lines = ["".join(f"{v:15.6f}" for v in reals[i:i + 5]) for i in range(0, 100, 5)]
    samples = ["".join(f"{v:10.5f}" for v in accel[i:i + 8]) for i in range(0, accel.size, 8)]
    return [*text, " 100 Integer-header values follow on  10 lines, Format= (10I8)", *ints,
            " 100 Real-header values follow on  20 lines, Format= (5F15.6)", *real_lines,
            '   1 Comment line(s) follow, each starting with a "|":', "| written by a test",
            f"{accel.size:8d} acceleration pts, approx {accel.size * dt:4.0f} secs, "
            f"units={unit},Format=(8F10.5)", *samples,
            f"End-of-data for Chan{number:4d} acceleration"]


def test_cosmos_round_trip(tmp_path: Path) -> None:
    rng = np.random.default_rng(12)
    a = np.round(50.0 * rng.standard_normal(203), 5)  # the file's precision, cm/s²
    b = np.round(20.0 * rng.standard_normal(203), 5)
    path = tmp_path / "CE01234.V2"  # two channels in one file, as COSMOS allows
    path.write_text("\n".join(cosmos_channel(a, 0.01, number=3) + cosmos_channel(
        b, 0.01, number=5, direction="Up", location="Ground level")) + "\n")
    first, second = read_network_records(path)
    assert (first.number, first.direction, first.location) == (3, "360 deg", "Roof")
    assert (second.number, second.direction, second.location) == (5, "Up", "Ground level")
    assert first.n_samples == 203 and first.dt == 0.01 and first.file_unit == "cm/s2"
    np.testing.assert_allclose(first.acceleration, a * 0.01, rtol=0, atol=1e-15)
    np.testing.assert_allclose(second.acceleration, b * 0.01, rtol=0, atol=1e-15)
    assert read_network_records(tmp_path, ["ground level / up"])[0].number == 5


def test_cosmos_headers_that_disagree_with_the_samples(tmp_path: Path) -> None:
    a = np.round(np.sin(np.linspace(0, 9, 100)) * 30, 5)
    lines = cosmos_channel(a, 0.02)
    short = "\n".join(lines[:-3] + lines[-2:])  # one line of samples fewer
    with pytest.raises(DataError, match="says 100 samples of acceleration but"):
        parse_cosmos(short, "x.V2")
    in_g = "\n".join(lines).replace("units=cm/sec2(04)", "units=g(02)")
    with pytest.raises(DataError, match="disagrees with itself"):
        parse_cosmos(in_g, "x.V2")
    # the samples divided by g, the headers left in cm/s²: the peak is not theirs
    k = int(np.argmax(np.abs(a)))
    rescaled = cosmos_channel(np.round(a / 980.665, 5), 0.02)
    peak_line = 13 + 1 + 10 + 1 + 12  # the real header's line holding entries 61-65
    rescaled[peak_line] = lines[peak_line]
    assert f"{a[k]:15.6f}" in rescaled[peak_line]
    with pytest.raises(DataError, match="wrong units"):
        parse_cosmos("\n".join(rescaled), "x.V2")
    slow = "\n".join(lines).replace(f"{0.02:15.6f}", f"{0.04:15.6f}", 1)
    with pytest.raises(DataError, match="wrong interval"):
        parse_cosmos(slow, "x.V2")


def test_to_measurement_cuts_to_the_shortest(tmp_path: Path) -> None:
    write_at2(tmp_path / "a.AT2", np.ones(10) * 0.1, 0.01)
    write_at2(tmp_path / "b.AT2", np.ones(12) * 0.2, 0.01)
    a, b = (read_network_records(tmp_path / f"{n}.AT2")[0] for n in "ab")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = to_measurement([a, b], ["a", "b"])
    assert m.n_samples == 10 and m["b"][0] == pytest.approx(0.2 * G)

"""Records of strong-motion networks: CSMIP V2 files (one per channel, zipped per event),
COSMOS V2 files (the COSMOS Strong-Motion Data Format v1.20) and PEER NGA ``.AT2`` ground
motions.

A CSMIP "V2" file (corrected accelerogram) holds a fixed-width text header (station,
channel, orientation, location on the structure, peaks, number of points and interval), an
integer and a real header, then the acceleration, velocity and displacement blocks in
``8f10.x``. The network distributes one file per channel, zipped per event; an archive (or a
folder, or one file) is read here as a list of `NetworkChannel`, accelerations in m/s².

Why a parser of our own rather than ``quakeio`` (0.1.21, the PyPI parser of CSMIP V2 and AT2,
evaluated on the Meloland archives): it reads the samples, but on the 1979 archive (upper-case
header of the older processing) its header parse fails inside a bare ``except`` and the
channel's orientation, location, interval and units come back as ``None`` without a word; it
checks input with ``assert``; and it requires the ``opensees`` and ``sees`` packages. The
format is small: the header lines are found by their words (not their line numbers, which
differ between processings), the samples are read by their fixed field width (fields may
touch: ``-107.12100-7.4588850``), and every figure of the header that the samples can confirm
is checked against them (sample count, interval through the time of the peak, units through
the peak's value), so a header that disagrees with its samples is refused, never fitted.

Why this file is long (about 650 lines): three formats' parsers, each checking its header
against its samples, beside what they share (the files of a zip or a folder, the choice of a
channel by number or place, the comparison of a station's events, its recorders' clocks).

Channels are numbered as the station numbers them (the ``Sta Chn`` of the header, the number
in the file name ``CHAN013.V2``): a recorder's own channel number (``Chan 1``) repeats across
the recorders of a station.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import re
import zipfile
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from femupdate.data.measurement import Measurement
from femupdate.errors import ConfigError, DataError
from femupdate.units import ACCELERATION_UNITS

__all__ = [
    "FORMATS",
    "NetworkChannel",
    "channel_label",
    "clock_note",
    "compare_events",
    "parse_at2",
    "parse_cosmos",
    "parse_csmip_v2",
    "read_network_records",
    "select_channel",
    "to_measurement",
]

#: The network formats femupdate reads, by their ``[data] format`` name.
FORMATS = ("csmip", "cosmos", "at2")

#: Spellings of acceleration units in network headers → femupdate's unit names.
_UNIT_NAMES = {
    "cm/sec/sec": "cm/s2", "cm/sec2": "cm/s2", "cm/s/s": "cm/s2", "cm/s2": "cm/s2",
    "cm/s^2": "cm/s2", "cm/sec^2": "cm/s2", "g": "g", "m/s2": "m/s2", "m/sec/sec": "m/s2",
    "m/s/s": "m/s2", "mm/s2": "mm/s2",
}


@dataclass(frozen=True)
class NetworkChannel:
    """One channel of a network record, as its file gives it.

    Attributes
    ----------
    number : int
        The station's channel number (CSMIP ``Sta Chn``; 1 for an AT2 file).
    location : str
        Where the sensor is (``"Deck: Middle of Bridge"``), as the header says it.
    direction : str
        Its orientation (``"Up"``, ``"Tran"``, ``"360 Deg"``), as the header says it.
    dt : float
        Sample interval, s.
    acceleration : ndarray (n,)
        The samples, m/s².
    file_unit : str
        The unit of the samples in the file (``"cm/s2"``, ``"g"``).
    peak : float
        The header's peak acceleration in ``file_unit`` (NaN when the header gives none).
    source : str
        The file (``archive.zip:CHAN013.V2`` inside an archive).
    station : str
        Station number and name.
    recorder : str
        The recorder's serial number (channels of one recorder share a clock), or ``""``.
    resolution : float
        The step of the file's decimal fields (0.001 for ``f10.3``), in ``file_unit``.
    start : str
        The recorder's start time as the header gives it (``"4/04/10, 22:40:45.2 UTC"``), or
        ``""``: the files' times start at 0 at each recorder's first sample.
    """

    number: int
    location: str
    direction: str
    dt: float
    acceleration: np.ndarray
    file_unit: str
    peak: float
    source: str
    station: str = ""
    recorder: str = ""
    resolution: float = 0.0
    start: str = ""

    @property
    def n_samples(self) -> int:
        return int(self.acceleration.size)

    @property
    def rate(self) -> float:
        """Sampling rate, Hz."""
        return 1.0 / self.dt


def channel_label(ch: NetworkChannel) -> str:
    """The selector that picks ``ch`` by its header: ``"location / direction"``."""
    return f"{ch.location} / {ch.direction}"


# --------------------------------------------------------------------------- CSMIP V2

_RE_CHAN = re.compile(r"^\s*chan\s+(\d+)\s*:\s*(.*?)\s*(?:\(\s*sta\s+chn\s*:\s*(\d+)\s*\))?"
                      r"\s*location\s*:\s*(.*?)\s*$", re.IGNORECASE)
_RE_STATION = re.compile(r"station\s+no\.\s*(\d+)", re.IGNORECASE)
_RE_RECORDER = re.compile(r"s/n\s*(\w+)", re.IGNORECASE)
_RE_PEAK = re.compile(r"peak\s+acceleration\s*=\s*(-?[\d.]+)\s+(\S+)\s+at\s+(-?[\d.]+)",
                      re.IGNORECASE)
_RE_BLOCK = re.compile(r"^\s*(\d+)\s+points\s+of\s+(accel|veloc|displ)\s+data\s+equally\s+"
                       r"spaced\s+at\s+([\d.]+)\s*sec", re.IGNORECASE)
_RE_BLOCK_UNITS = re.compile(r"(?:units\s*:\s*|,\s*in\s+)([a-z0-9/^]+)", re.IGNORECASE)
#: A Fortran format of the samples: (count per line, field width, decimals), "(8f10.5)".
_RE_FORMAT = re.compile(r"\(\s*(\d*)\s*[fe]\s*(\d+)\s*\.\s*(\d+)\s*\)", re.IGNORECASE)
_RE_START = re.compile(r"start\s+time\s*:\s*(.*?)\s*(?:\(|$)", re.IGNORECASE | re.MULTILINE)
_RE_INTERVAL = re.compile(r"intervals\s+of\s+([\d.]+)\s*sec", re.IGNORECASE)


def _unit(text: str, source: str, where: str) -> str:
    key = text.strip().rstrip(".,;)").lower()
    if key not in _UNIT_NAMES:
        raise DataError(f"{source}: {where}: unit {text.strip()!r} is not an acceleration "
                        f"unit femupdate reads (allowed: {', '.join(sorted(_UNIT_NAMES))})")
    return _UNIT_NAMES[key]


def _fixed_width(lines: Iterable[str], width: int, source: str, first_line: int) -> np.ndarray:
    """The numbers of fixed-width lines (fields may touch: no whitespace between them)."""
    values: list[float] = []
    for k, line in enumerate(lines):
        text = line.rstrip()
        for start in range(0, len(text), width):
            field = text[start:start + width].strip()
            if not field:
                continue
            try:
                values.append(float(field))
            except ValueError:
                raise DataError(f"{source}: line {first_line + k}: field {field!r} at column "
                                f"{start + 1} is not a number (allowed: {width}-character "
                                "numeric fields)") from None
    return np.array(values, dtype=float)


def _title(text: str) -> str:
    """Words as a header writes them, multiple spaces collapsed."""
    return " ".join(text.split())


def parse_csmip_v2(text: str, source: str) -> NetworkChannel:
    """Parse the acceleration of one CSMIP V2 file and check its header against the samples.

    Parameters
    ----------
    text : str
        The file's content.
    source : str
        Its name, used in messages.

    Returns
    -------
    NetworkChannel
        Accelerations in m/s², converted from the units the header gives.

    Raises
    ------
    DataError
        A header line missing; samples not as many as the header says; units of the block and
        the peak line that differ; a peak (value or time) the samples do not have, which is
        what a wrong unit or interval in the header shows as.
    """
    lines = text.splitlines()
    chan = next((m for m in map(_RE_CHAN.match, lines[:45]) if m), None)
    if chan is None:
        raise DataError(f"{source}: no 'Chan N: <direction> ... Location: <where>' line in the "
                        "header (allowed: a CSMIP V2 corrected accelerogram)")
    number = int(chan.group(3) or chan.group(1))
    direction = _title(chan.group(2)).title() if chan.group(2).isupper() else _title(
        chan.group(2))
    location = _title(chan.group(4))
    head = "\n".join(lines[:45])
    station = _RE_STATION.search(head)
    station_name = lines[6].strip()[:40].strip() if len(lines) > 6 else ""
    recorder = _RE_RECORDER.search(head)
    start_time = _RE_START.search(head)
    peak = _RE_PEAK.search(head)
    if peak is None:
        raise DataError(f"{source}: no 'Peak acceleration = <value> <unit> at <time> sec' "
                        "line in the header (allowed: a CSMIP V2 corrected accelerogram)")
    accel = next(((i, m) for i, s in enumerate(lines) if (m := _RE_BLOCK.match(s))
                  and m.group(2).lower() == "accel"), None)
    if accel is None:
        raise DataError(f"{source}: no 'N points of accel data equally spaced at DT sec' line "
                        "(allowed: a CSMIP V2 corrected accelerogram)")
    start, block = accel
    n, dt = int(block.group(1)), float(block.group(3))
    if not (dt > 0 and math.isfinite(dt)):
        raise DataError(f"{source}: line {start + 1}: interval {block.group(3)} s (allowed: a "
                        "positive interval)")
    interval = _RE_INTERVAL.search(head)
    if interval is not None and not math.isclose(float(interval.group(1)), dt, rel_tol=1e-9):
        raise DataError(f"{source}: the header gives two intervals: {interval.group(1)} s "
                        f"(intervals of) and {block.group(3)} s (line {start + 1})")
    units = _RE_BLOCK_UNITS.search(lines[start])
    file_unit = _unit(units.group(1) if units else peak.group(2), source,
                      f"line {start + 1}")
    peak_unit = _unit(peak.group(2), source, "Peak acceleration")
    if peak_unit != file_unit:
        raise DataError(f"{source}: the peak acceleration is in {peak.group(2)} but the samples "
                        f"(line {start + 1}) in {units.group(1) if units else '?'}: the header "
                        "disagrees with itself")
    fmt = _RE_FORMAT.search(lines[start])
    width, decimals = (int(fmt.group(2)), int(fmt.group(3))) if fmt else (10, 3)
    end = next((i for i in range(start + 1, len(lines)) if _RE_BLOCK.match(lines[i])
                or lines[i].startswith("/&")), len(lines))
    samples = _fixed_width(lines[start + 1:end], width, source, start + 2)
    if samples.size != n:
        raise DataError(f"{source}: line {start + 1} says {n} samples of acceleration but the "
                        f"block (lines {start + 2}-{end}) holds {samples.size}: the header "
                        "disagrees with the samples")
    resolution = 10.0 ** -decimals
    _check_peak(samples, dt, float(peak.group(1)), float(peak.group(3)), peak_unit,
                resolution, source)
    return NetworkChannel(
        number=number, location=location, direction=direction, dt=dt,
        acceleration=samples * ACCELERATION_UNITS[file_unit], file_unit=file_unit,
        peak=float(peak.group(1)), source=source,
        station=f"{int(station.group(1)):05d} {station_name}".strip() if station else
        station_name, recorder=recorder.group(1) if recorder else "", resolution=resolution,
        start=start_time.group(1) if start_time else "")


def _check_peak(samples: np.ndarray, dt: float, peak: float, at: float, unit: str,
                resolution: float, source: str) -> None:
    """The header's peak must be a sample's value (to the precision of both) at its time.

    A header whose unit or interval is wrong for its samples fails here: the largest sample
    differs from the peak by the unit's factor, or sits at another time.
    """
    tol = 0.5e-3 * max(1.0, abs(peak)) + resolution  # the header prints 3 decimals
    largest = float(np.max(np.abs(samples)))
    if abs(largest - abs(peak)) > tol:
        raise DataError(f"{source}: the header's peak acceleration {peak:g} {unit} is not "
                        f"the samples' largest magnitude {largest:.6g} (allowed: equal within "
                        f"{tol:.2g}): wrong units in the header or in the samples?")
    near = np.flatnonzero(np.abs(np.abs(samples) - abs(peak)) <= tol)
    times = near * dt
    if not np.any(np.abs(times - at) <= 0.5 * dt + 1e-6 * max(1.0, at)):
        raise DataError(f"{source}: the header's peak acceleration is at {at:g} s but the "
                        f"samples reach it at {', '.join(f'{t:.6g}' for t in times[:3])} s "
                        f"with dt = {dt:g} s: wrong interval or sample count in the header?")


# --------------------------------------------------------------------------- COSMOS V2

_RE_COSMOS_HEAD = re.compile(r"\(format\s+v[\d.]+\s+with\s+(\d+)\s+text\s+lines\)",
                             re.IGNORECASE)
_RE_COSMOS_CHAN = re.compile(r"sta\s+chan\s+(\S+?)\s*:\s*(.*?)\s*(?:\(\s*rcrdr\s+chan[^)]*\))?"
                             r"\s*location\s*:\s*(.*?)\s*$", re.IGNORECASE)
_RE_COSMOS_COUNT = re.compile(r"^\s*(\d+)\s+(integer|real)-header\s+values\s+follow\s+on\s+"
                              r"(\d+)\s+lines", re.IGNORECASE)
_RE_COSMOS_COMMENTS = re.compile(r"^\s*(\d+)\s+comment\s+line", re.IGNORECASE)
_RE_COSMOS_DATA = re.compile(r"^\s*(\d+)\s+(\w+)\s+pts.*?units\s*=\s*([^(,\s]+)",
                             re.IGNORECASE)
_RE_COSMOS_MAX = re.compile(r"processed.*max\s*=\s*-?[\d.]+\s+([a-z][a-z0-9/^]*)\s+at",
                            re.IGNORECASE)
#: Real-header entries (1-based, COSMOS v1.20): sampling interval (s), peak value, its time.
_COSMOS_DT, _COSMOS_PEAK, _COSMOS_PEAK_AT = 34, 64, 65


def parse_cosmos(text: str, source: str) -> list[NetworkChannel]:
    """Parse the acceleration channels of a COSMOS V2 file (COSMOS Strong-Motion Data
    Format v1.20: per channel, text lines, an integer and a real header, comment lines, then
    the samples with their count, unit and Fortran format on the line before them).

    The interval and the peak (value and time) are the real header's entries 34, 64 and 65;
    they and the count are checked against the samples as for a CSMIP file. The channel is
    the text header's ``Sta Chan`` (its position in the file when the header says ``?``).
    """
    lines = text.splitlines()
    channels: list[NetworkChannel] = []
    i = 0
    while i < len(lines) and lines[i].strip():
        head = _RE_COSMOS_HEAD.search(lines[i])
        if head is None:
            raise DataError(f"{source}: line {i + 1} is {lines[i].strip()[:60]!r} (allowed: "
                            "a COSMOS header line '... (Format v01.20 with N text lines)')")
        n_text = int(head.group(1))
        chan = next((m for m in map(_RE_COSMOS_CHAN.search, lines[i:i + n_text]) if m), None)
        j = i + n_text
        reals: list[float] = []
        for _ in range(2):  # the integer header, then the real header
            count = _RE_COSMOS_COUNT.match(lines[j]) if j < len(lines) else None
            if count is None:
                raise DataError(f"{source}: line {j + 1}: expected 'N Integer-header (or "
                                "Real-header) values follow on M lines'")
            block = " ".join(lines[j + 1:j + 1 + int(count.group(3))]).split()
            if count.group(2).lower() == "real":
                reals = [float(v) for v in block]
            j += 1 + int(count.group(3))
        comments = _RE_COSMOS_COMMENTS.match(lines[j]) if j < len(lines) else None
        if comments is None:
            raise DataError(f"{source}: line {j + 1}: expected 'N Comment line(s) follow'")
        j += 1 + int(comments.group(1))
        data = _RE_COSMOS_DATA.match(lines[j]) if j < len(lines) else None
        fmt = _RE_FORMAT.search(lines[j]) if j < len(lines) else None
        if data is None or fmt is None or data.group(2).lower() != "acceleration":
            raise DataError(f"{source}: line {j + 1}: expected 'N acceleration pts, ..., "
                            "units=..., Format=(...)' (allowed: COSMOS V2 acceleration)")
        if len(reals) < _COSMOS_PEAK_AT:
            raise DataError(f"{source}: the real header holds {len(reals)} values (allowed: "
                            f"at least {_COSMOS_PEAK_AT}, as COSMOS v1.20 writes)")
        n, dt = int(data.group(1)), reals[_COSMOS_DT - 1]
        if not (dt > 0 and math.isfinite(dt)):
            raise DataError(f"{source}: real header {_COSMOS_DT} (sampling interval): {dt} s "
                            "(allowed: a positive interval)")
        unit = _unit(data.group(3), source, f"line {j + 1}")
        said = next((m for m in map(_RE_COSMOS_MAX.search, lines[i:i + n_text]) if m), None)
        if said is not None and _unit(said.group(1), source, "the text header's Max") != unit:
            raise DataError(f"{source}: the text header gives the peak in {said.group(1)} but "
                            f"line {j + 1} the samples in {data.group(3)}: the header "
                            "disagrees with itself")
        per_line, width, decimals = int(fmt.group(1) or 1), int(fmt.group(2)), int(fmt.group(3))
        # the samples run to the end line ("End-of-data ...") or the next channel's header
        rows = next((k for k, line in enumerate(lines[j + 1:j + 1 + -(-n // per_line)])
                     if line.strip()[:1].isalpha()), -(-n // per_line))
        samples = _fixed_width(lines[j + 1:j + 1 + rows], width, source, j + 2)
        if samples.size != n:
            raise DataError(f"{source}: line {j + 1} says {n} samples of acceleration but "
                            f"lines {j + 2}-{j + 1 + rows} hold {samples.size}: the header "
                            "disagrees with the samples")
        exponent = "e" in fmt.group(0).lower()
        _check_peak(samples, dt, reals[_COSMOS_PEAK - 1], reals[_COSMOS_PEAK_AT - 1], unit,
                    0.0 if exponent else 10.0 ** -decimals, source)
        number_text = chan.group(1) if chan else "?"
        channels.append(NetworkChannel(
            number=int(number_text) if number_text.isdigit() else len(channels) + 1,
            location=_title(chan.group(3)) if chan else "",
            direction=_title(chan.group(2)) if chan else "", dt=dt,
            acceleration=samples * ACCELERATION_UNITS[unit], file_unit=unit,
            peak=reals[_COSMOS_PEAK - 1], source=source,
            station=_title(lines[i + 4]) if n_text > 4 else "",
            resolution=0.0 if exponent else 10.0 ** -decimals))
        i = j + 1 + rows
        if i < len(lines) and lines[i].lower().lstrip().startswith("end-of-data"):
            i += 1
    if not channels:
        raise DataError(f"{source}: no COSMOS channel in it")
    return channels


# --------------------------------------------------------------------------- PEER AT2

_RE_AT2_NPTS = re.compile(r"npts\s*=\s*(\d+)\s*,\s*dt\s*=\s*([\d.eE+-]+)", re.IGNORECASE)


def parse_at2(text: str, source: str) -> NetworkChannel:
    """Parse a PEER NGA ``.AT2`` record: 4 header lines (database; event, date, station and
    component; units; ``NPTS= n, DT= dt SEC``), then the accelerations in g, free-format.

    The count of line 4 is checked against the samples. The channel is number 1 (in a folder
    of AT2 files: numbered by file name), its location the station, its direction the
    component (the last two items of line 2).
    """
    lines = text.splitlines()
    if len(lines) < 5:
        raise DataError(f"{source}: {len(lines)} lines: an AT2 file has 4 header lines and "
                        "the samples")
    match = _RE_AT2_NPTS.search(lines[3])
    if match is None:
        raise DataError(f"{source}: line 4 is {lines[3].strip()!r} (allowed: 'NPTS= <n>, "
                        "DT= <s> SEC' as PEER writes it)")
    n, dt = int(match.group(1)), float(match.group(2))
    if not (dt > 0 and math.isfinite(dt)):
        raise DataError(f"{source}: line 4: DT = {match.group(2)} (allowed: a positive "
                        "interval in s)")
    if "units of g" not in lines[2].lower() and " g" not in f" {lines[2].lower()}":
        raise DataError(f"{source}: line 3 is {lines[2].strip()!r} (allowed: accelerations "
                        "'in units of g', as PEER writes them)")
    try:
        samples = np.array(" ".join(lines[4:]).split(), dtype=float)
    except ValueError as exc:
        raise DataError(f"{source}: the samples after line 4 are not all numbers ({exc})") \
            from None
    if samples.size != n:
        raise DataError(f"{source}: line 4 says NPTS = {n} but the file holds {samples.size} "
                        "samples: the header disagrees with the samples")
    # line 2: "event, date, station, component" (older files: fewer items)
    items = [item.strip() for item in lines[1].split(",")]
    direction = items[-1] if len(items) > 1 else ""
    place = items[-2] if len(items) > 2 else items[0]
    event = ", ".join(items[:-2]) if len(items) > 2 else ""
    fields = lines[4].split()
    # fixed-point fields: their last decimal; exponent fields (PEER's E15.7) are relative
    decimals = (0 if any("e" in f.lower() for f in fields) else
                max((len(f.split(".")[1]) for f in fields if "." in f), default=0))
    return NetworkChannel(number=1, location=place, direction=direction, dt=dt,
                          acceleration=samples * ACCELERATION_UNITS["g"], file_unit="g",
                          peak=float(np.max(np.abs(samples))), source=source, station=event,
                          resolution=10.0 ** -decimals if decimals else 0.0)


# --------------------------------------------------------------------------- files


def _decode(raw: bytes) -> str:
    # the headers are ASCII; latin-1 maps every byte, so a stray byte never stops a read
    return raw.decode("latin-1")


def _kind(name: str, text: str = "") -> str | None:
    """The format of a file by its name and, for ``.V2`` (both networks use it), its first
    line: COSMOS files say ``(Format v01.20 with 13 text lines)``."""
    suffix = Path(name).suffix.lower()
    if suffix == ".v2":
        return "cosmos" if _RE_COSMOS_HEAD.search(text.split("\n", 1)[0]) else "csmip"
    return {".v2c": "cosmos", ".at2": "at2"}.get(suffix)


def _members(path: Path) -> list[tuple[str, str, str]]:
    """(kind, source, text) of each record file in ``path`` (a zip, a folder or a file)."""
    if path.is_dir():
        files = sorted(p for p in path.iterdir() if p.is_file() and _kind(p.name))
        texts = [(str(p), p.name, _decode(p.read_bytes())) for p in files]
    elif not path.exists():
        raise DataError(f"{path}: file not found")
    elif zipfile.is_zipfile(path):
        with zipfile.ZipFile(path) as archive:
            names = sorted(n for n in archive.namelist() if _kind(n))
            texts = [(f"{path}:{n}", n, _decode(archive.read(n))) for n in names]
    elif _kind(path.name) is not None:
        texts = [(str(path), path.name, _decode(path.read_bytes()))]
    else:
        raise DataError(f"{path}: not a network record (allowed: a zip archive, a folder, a "
                        "CSMIP or COSMOS .V2 file, a COSMOS .V2c file or a PEER .AT2 file)")
    return [(_kind(name, text) or "", source, text) for source, name, text in texts]


def read_network_records(path: str | Path, channels: Sequence[int | str] | None = None, *,
                         format: str | None = None) -> list[NetworkChannel]:
    """Read the channels of a network record: a zip archive of an event, a folder, or a file.

    Parameters
    ----------
    path : str or Path
        A zip archive as the network distributes it (``*.V2`` members, CSMIP or COSMOS by
        their first line, ``*.V2c`` COSMOS; ``.V1``/``.V3`` are ignored), a folder of such
        files, or one file, or a PEER ``.AT2`` file.
    channels : sequence of int or str, optional
        Channels to return, in this order: station channel numbers, or selectors
        ``"location / direction"`` matched against the headers (case and spacing ignored; a
        location alone when it has one channel). None: all, by channel number.
    format : {"csmip", "cosmos", "at2"}, optional
        Read only files of this format (None: by their extension).

    Returns
    -------
    list of NetworkChannel
        Accelerations in m/s², each with its own interval (a station's recorders may differ:
        `to_measurement` puts channels on one time base).

    Raises
    ------
    DataError
        No record in ``path``; a channel the record lacks (the available ones are listed); two
        files with one channel number; a header that disagrees with its samples.
    """
    path = Path(path)
    if format is not None and format not in FORMATS:
        raise ConfigError(f"format: got {format!r} (allowed: {', '.join(FORMATS)})")
    if not path.exists():
        raise DataError(f"{path}: file not found")
    stat = path.stat()
    found = list(_read_all(str(path.resolve()), stat.st_mtime_ns, stat.st_size, format,
                           str(path)))
    if channels is None:
        return found
    return [select_channel(found, spec, str(path)) for spec in channels]


@functools.lru_cache(maxsize=8)
def _read_all(resolved: str, mtime_ns: int, size: int, format: str | None,
              shown: str) -> tuple[NetworkChannel, ...]:
    """Every channel of a record, parsed once per file version (a case reads one archive
    for each of its channels); the arrays are read-only, as they are shared."""
    del mtime_ns, size  # part of the cache key only: a changed file is read again
    path = Path(resolved)
    members = [m for m in _members(path) if format is None or m[0] == format]
    if not members:
        raise DataError(f"{shown}: no {format or 'CSMIP, COSMOS or PEER AT2'} record files "
                        "in it")
    parsed: list[NetworkChannel] = []
    for kind, source, text in members:
        if kind == "cosmos":
            parsed += parse_cosmos(text, source)
        else:
            parsed.append(parse_csmip_v2(text, source) if kind == "csmip"
                          else parse_at2(text, source))
    if sum(kind == "at2" for kind, _, _ in members) > 1:
        # an AT2 file holds one record: in a folder or an archive, number them by file name
        at2 = {source for kind, source, _ in members if kind == "at2"}
        parsed = [dataclasses.replace(ch, number=k) if ch.source in at2 else ch
                  for k, ch in enumerate(parsed, start=1)]
    by_number: dict[int, NetworkChannel] = {}
    for ch in sorted(parsed, key=lambda c: c.number):
        if ch.number in by_number:
            raise DataError(f"{shown}: two files hold channel {ch.number}: "
                            f"{by_number[ch.number].source} and {ch.source}")
        ch.acceleration.flags.writeable = False
        by_number[ch.number] = ch
    return tuple(by_number.values())


def _vertical(ch: NetworkChannel) -> bool:
    return _key(ch.direction) in ("up", "down", "vert", "vertical", "z")


def compare_events(events: Mapping[str, Sequence[NetworkChannel]],
                   used: Iterable[int]) -> tuple[list[str], list[str]]:
    """What differs between records of one station's events read by one case.

    Parameters
    ----------
    events : mapping
        Each record (its path) → its channels.
    used : iterable of int
        The channel numbers the case picks by number.

    Returns
    -------
    conflicts : list of str
        Channels picked by number that are at another place (location, or vertical against
        horizontal) in another event: the number does not name one sensor.
    differences : list of str
        Channel numbers present in some events only.
    """
    conflicts: list[str] = []
    places: dict[int, list[tuple[str, NetworkChannel]]] = {}
    for name, chans in events.items():
        for ch in chans:
            places.setdefault(ch.number, []).append((name, ch))
    for number in sorted(set(used)):
        seen = places.get(number, [])
        first_name, first = seen[0] if seen else ("", None)
        for name, ch in seen[1:]:
            if first is not None and (_key(ch.location) != _key(first.location)
                                      or _vertical(ch) != _vertical(first)):
                conflicts.append(f"channel {number} is {channel_label(first)!r} in {first_name} "
                                 f"but {channel_label(ch)!r} in {name}")
    every = set(places)
    differences = []
    for name, chans in events.items():
        lacks = sorted(every - {ch.number for ch in chans})
        if lacks:
            differences.append(f"{name} has no channel {_ranges(lacks)}")
    return conflicts, differences


def _key(text: str) -> str:
    return " ".join(text.replace(",", " ").replace(".", " ").casefold().split())


def select_channel(found: Sequence[NetworkChannel], spec: int | str,
                   source: str) -> NetworkChannel:
    """The channel of ``found`` that ``spec`` names: a channel number, or a selector
    ``"location / direction"`` (or a location with one channel), matched ignoring case,
    spacing and punctuation."""
    numbers = [ch.number for ch in found]
    if isinstance(spec, bool) or not isinstance(spec, int | str):
        raise ConfigError(f"{source}: channel {spec!r} (allowed: a channel number or "
                          "'location / direction')")
    if isinstance(spec, int) or spec.strip().isdigit():
        number = int(spec)
        for ch in found:
            if ch.number == number:
                return ch
        raise DataError(f"{source}: no channel {number} (allowed: channels "
                        f"{_ranges(numbers)})")
    location, _, direction = spec.rpartition("/") if "/" in spec else (spec, "", "")
    hits = [ch for ch in found if _key(ch.location) == _key(location)
            and (not direction.strip() or _key(ch.direction) == _key(direction))]
    if len(hits) == 1:
        return hits[0]
    if hits:
        listing = "; ".join(f"{ch.number}: {channel_label(ch)}" for ch in hits)
        raise DataError(f"{source}: channel {spec!r} matches {len(hits)} channels ({listing}); "
                        "name the direction too, or the channel number")
    raise DataError(f"{source}: no channel at {spec!r} (allowed: a channel number "
                    f"{_ranges(numbers)}, or 'location / direction' as `femupdate inspect` "
                    "lists them)")


def _ranges(numbers: Sequence[int]) -> str:
    """``1-13, 15`` for [1, ..., 13, 15]."""
    parts: list[str] = []
    for n in sorted(numbers):
        if parts and n == int(parts[-1].split("-")[-1]) + 1:
            parts[-1] = f"{parts[-1].split('-')[0]}-{n}"
        else:
            parts.append(str(n))
    return ", ".join(parts)


def clock_note(channels: Sequence[NetworkChannel]) -> str | None:
    """What to say when channels read together come from recorders that the headers do not
    put on one clock: each file's time starts at its own recorder's first sample, so their
    alignment at t = 0 is an assumption (None: one recorder, or one start time given by
    all)."""
    recorders = {ch.recorder for ch in channels}
    if len(recorders) < 2:
        return None
    starts = {ch.start for ch in channels}
    if len(starts) == 1 and "" not in starts:
        return None  # one start time, a common time signal (the 2010 files: WWVB)
    listing = "; ".join(
        f"recorder {rec or '?'}: channel{'s' if len(chans) > 1 else ''} "
        f"{', '.join(str(c.number) for c in chans)}, start "
        f"{chans[0].start or 'not given'}"
        for rec in sorted(recorders)
        for chans in [[c for c in channels if c.recorder == rec]])
    return (f"channels of different recorders ({listing}): the headers do not put them on "
            "one clock; each record starts at t = 0 at its recorder's first sample, and they "
            "are aligned there (check the alignment, e.g. by the arrival of the motion)")


def to_measurement(channels: Sequence[NetworkChannel], names: Sequence[str] | None = None,
                   source: str = "<network>") -> Measurement:
    """Channels of one interval as a `Measurement` in m/s², cut to the shortest.

    Channels of different recorders may differ in interval and length: those of another
    interval are refused (resample them with `femupdate.data.io.resample` first); a common
    start at t = 0 is the file's convention (each recorder's first sample).
    """
    if not channels:
        raise DataError(f"{source}: no channels")
    names = list(names) if names is not None else [str(ch.number) for ch in channels]
    dts = {ch.dt for ch in channels}
    if len(dts) > 1:
        listing = ", ".join(f"{ch.number}: {ch.dt:g} s" for ch in channels)
        raise DataError(f"{source}: the channels have different intervals ({listing}); read "
                        "them apart and resample (allowed: one interval)")
    n = min(ch.n_samples for ch in channels)
    dt = channels[0].dt
    return Measurement(np.arange(n) * dt, {name: ch.acceleration[:n] for name, ch in
                                           zip(names, channels, strict=True)},
                       dict.fromkeys(names, "m/s2"), source)

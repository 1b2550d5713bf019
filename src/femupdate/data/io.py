"""Measured data: the `Measurement` container, readers and writers (CSV, NPZ, UFF58).

A `Measurement` holds sampled channels on one uniform time base. It is validated when built:
finite values, equal lengths, a strictly increasing uniform time vector. Readers report bad
input with the file, the line and the column; missing samples (NaN or empty fields) are
refused with their count and first position, or filled by linear interpolation over short
gaps on request (``on_nan="interpolate"``).

Writers produce what a user would bring (virtual experiments write CSV, NPZ or UFF58), and
every writer has a reader that returns the same `Measurement`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import Literal

import numpy as np
import scipy.signal

from femupdate._optional import require
from femupdate.errors import ConfigError, DataError

__all__ = [
    "Measurement",
    "align",
    "combine",
    "fill_gaps",
    "read",
    "read_csv",
    "read_elcentro",
    "read_npz",
    "read_uff58",
    "read_xsens_dot",
    "resample",
    "write_csv",
    "write_npz",
    "write_uff58",
]

G = 9.80665  # standard gravity, m/s², to convert records given in g
TIME_RTOL = 1e-3  # allowed relative deviation of a time step from the median step
NanPolicy = Literal["raise", "interpolate"]
ColumnSpec = Sequence[str | int] | Mapping[str, str | int] | None


# --------------------------------------------------------------------------- the container


@dataclass(frozen=True)
class Measurement:
    """Channels sampled on one uniform time base.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Sample times in seconds, strictly increasing and uniform within ``time_rtol``.
    channels : dict of str to ndarray, shape (n,)
        The measured signals, finite floats.
    units : dict of str to str
        Unit of each channel (``""`` when unknown).
    source : str
        Where the data came from (a file path), used in messages.
    time_rtol : float
        Allowed relative deviation of any time step from the median step.
    """

    t: np.ndarray
    channels: dict[str, np.ndarray]
    units: dict[str, str] = field(default_factory=dict)
    source: str = "<memory>"
    time_rtol: float = TIME_RTOL

    def __post_init__(self) -> None:
        t = np.array(self.t, dtype=float)
        if t.ndim != 1 or t.size < 2:
            raise DataError(f"{self.source}: time vector must be 1-D with at least 2 samples, "
                            f"got shape {t.shape}")
        _check_finite(t, "time", self.source)
        _check_uniform(t, self.source, self.time_rtol)
        if not self.channels:
            raise DataError(f"{self.source}: no channels")
        channels: dict[str, np.ndarray] = {}
        for name, values in self.channels.items():
            y = np.array(values, dtype=float)
            if y.shape != t.shape:
                raise DataError(
                    f"{self.source}: channel {name!r} has shape {y.shape} but the time vector "
                    f"has {t.shape}: all channels must have one sample per time")
            _check_finite(y, f"channel {name!r}", self.source)
            channels[str(name)] = y
        unknown = set(self.units) - set(channels)
        if unknown:
            raise DataError(f"{self.source}: units given for unknown channels {sorted(unknown)}; "
                            f"channels are {list(channels)}")
        units = {name: str(self.units.get(name, "")) for name in channels}
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "channels", channels)
        object.__setattr__(self, "units", units)

    @classmethod
    def from_array(cls, t: np.ndarray, data: np.ndarray, names: Sequence[str],
                   units: Mapping[str, str] | str | None = None,
                   source: str = "<memory>") -> Measurement:
        """Build from a 2-D array ``data`` (n_samples, n_channels) and its channel names."""
        data = np.asarray(data, dtype=float)
        if data.ndim == 1:
            data = data[:, None]
        if data.ndim != 2 or data.shape[1] != len(names):
            raise DataError(f"{source}: data of shape {data.shape} does not match "
                            f"{len(names)} channel names {list(names)}")
        if len(set(names)) != len(names):
            raise DataError(f"{source}: duplicate channel names in {list(names)}")
        return cls(t, {n: data[:, j] for j, n in enumerate(names)},
                   _units_for(list(names), units), source)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.channels)

    @property
    def n_samples(self) -> int:
        return int(self.t.size)

    @property
    def dt(self) -> float:
        """Mean sample interval, s."""
        return float((self.t[-1] - self.t[0]) / (self.t.size - 1))

    @property
    def rate(self) -> float:
        """Sampling rate, Hz."""
        return 1.0 / self.dt

    def array(self, names: Sequence[str] | None = None) -> np.ndarray:
        """Channels as one array (n_samples, n_channels), in the order of ``names``."""
        names = self.names if names is None else names
        return np.column_stack([self[name] for name in names])

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.channels[name]
        except KeyError:
            raise DataError(f"{self.source}: no channel {name!r}; available: "
                            f"{list(self.channels)}") from None

    def select(self, names: Sequence[str]) -> Measurement:
        """The given channels only."""
        return Measurement(self.t, {n: self[n] for n in names},
                           {n: self.units[n] for n in names}, self.source, self.time_rtol)

    def rename(self, mapping: Mapping[str, str]) -> Measurement:
        """Channels renamed by ``mapping`` (old → new); others keep their names."""
        unknown = [old for old in mapping if old not in self.channels]
        if unknown:
            raise DataError(f"{self.source}: cannot rename {unknown}: no such channels; "
                            f"available: {list(self.channels)}")
        new = [mapping.get(n, n) for n in self.names]
        if len(set(new)) != len(new):
            raise DataError(f"{self.source}: renaming gives duplicate channel names {new}")
        return Measurement(self.t, {mapping.get(n, n): y for n, y in self.channels.items()},
                           {mapping.get(n, n): u for n, u in self.units.items()},
                           self.source, self.time_rtol)

    def slice(self, start: int = 0, stop: int | None = None) -> Measurement:
        """Samples ``start:stop`` (indices)."""
        idx = slice(start, stop)
        return Measurement(self.t[idx], {n: y[idx] for n, y in self.channels.items()},
                           self.units, self.source, self.time_rtol)

    def window(self, t_start: float, t_end: float) -> Measurement:
        """Samples with ``t_start <= t <= t_end``."""
        keep = np.flatnonzero((self.t >= t_start) & (self.t <= t_end))
        if keep.size < 2:
            raise DataError(f"{self.source}: window [{t_start}, {t_end}] s holds {keep.size} "
                            f"samples; the record spans [{self.t[0]}, {self.t[-1]}] s")
        return self.slice(int(keep[0]), int(keep[-1]) + 1)

    def shifted(self, t0: float = 0.0) -> Measurement:
        """The same samples with the time axis moved so that it starts at ``t0``."""
        return Measurement(self.t - self.t[0] + t0, self.channels, self.units, self.source,
                           self.time_rtol)


def _units_for(names: list[str], units: Mapping[str, str] | str | None) -> dict[str, str]:
    if units is None:
        return {}
    if isinstance(units, str):
        return dict.fromkeys(names, units)
    return dict(units)


def _check_finite(y: np.ndarray, what: str, source: str) -> None:
    bad = ~np.isfinite(y)
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise DataError(f"{source}: {what} has {int(bad.sum())} non-finite samples (NaN or "
                        f"inf), the first at sample {first}; fill them with fill_gaps() or read "
                        f"with on_nan='interpolate'")


def _check_uniform(t: np.ndarray, source: str, rtol: float,
                   lines: np.ndarray | None = None) -> None:
    step = np.diff(t)
    where = "sample {i}" if lines is None else "line {line}"
    if (step <= 0).any():
        i = int(np.flatnonzero(step <= 0)[0]) + 1
        at = where.format(i=i, line=None if lines is None else lines[i])
        raise DataError(f"{source}: time is not strictly increasing at {at} "
                        f"(t = {t[i - 1]!r} then {t[i]!r})")
    typical = np.median(step)  # robust: a gap does not shift it
    dev = np.abs(step - typical) / typical
    if (dev > rtol).any():
        i = int(np.argmax(dev > rtol)) + 1
        at = where.format(i=i, line=None if lines is None else lines[i])
        raise DataError(f"{source}: time vector is not uniform: the step ending at {at} is "
                        f"{step[i - 1]:.6g} s, the median step is {typical:.6g} s (allowed "
                        f"relative "
                        f"deviation {rtol:g}); a gap or jitter in the record: resample it or "
                        f"raise time_rtol")


# --------------------------------------------------------------------------- missing samples


def fill_gaps(y: np.ndarray, max_gap: int, *, name: str = "signal",
              source: str = "<memory>") -> np.ndarray:
    """Fill runs of at most ``max_gap`` NaN samples by linear interpolation.

    Parameters
    ----------
    y : ndarray, shape (n,)
        Signal with missing samples marked NaN.
    max_gap : int
        Longest run of consecutive NaN samples to fill, ≥ 1.
    name, source : str
        Channel and file, for messages.

    Raises
    ------
    DataError
        A gap longer than ``max_gap``, or a gap at either end (nothing to interpolate from).
    """
    if max_gap < 1:
        raise ConfigError(f"max_gap must be >= 1 sample, got {max_gap}")
    y = np.array(y, dtype=float)
    bad = np.isnan(y)
    if not bad.any():
        return y
    edges = np.diff(np.concatenate(([0], bad.view(np.int8), [0])))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    for a, b in zip(starts, stops, strict=True):
        if a == 0 or b == y.size:
            raise DataError(f"{source}: {name} has missing samples at the "
                            f"{'start' if a == 0 else 'end'} (samples {a}..{b - 1}) that cannot "
                            f"be interpolated; trim the record")
        if b - a > max_gap:
            raise DataError(f"{source}: {name} has a gap of {b - a} missing samples at samples "
                            f"{a}..{b - 1}, longer than max_gap={max_gap}")
    idx = np.arange(y.size)
    y[bad] = np.interp(idx[bad], idx[~bad], y[~bad])
    return y


def _apply_nan_policy(y: np.ndarray, on_nan: NanPolicy, max_gap: int, name: str, source: str,
                      lines: np.ndarray) -> np.ndarray:
    bad = np.isnan(y)
    if not bad.any():
        return y
    if on_nan == "interpolate":
        return fill_gaps(y, max_gap, name=f"column {name!r}", source=source)
    first = int(np.flatnonzero(bad)[0])
    raise DataError(f"{source}: column {name!r} has {int(bad.sum())} missing samples (empty or "
                    f"NaN), the first at line {lines[first]}; read with on_nan='interpolate' to "
                    f"fill gaps of up to max_gap={max_gap} samples")


def _check_nan_policy(on_nan: str, max_gap: int) -> None:
    if on_nan not in ("raise", "interpolate"):
        raise ConfigError(f"on_nan must be 'raise' or 'interpolate', got {on_nan!r}")
    if max_gap < 1:
        raise ConfigError(f"max_gap must be >= 1 sample, got {max_gap}")


# --------------------------------------------------------------------------- CSV


@dataclass(frozen=True)
class _Table:
    """Text table split into fields: column names (or None) and data rows with line numbers."""

    names: list[str] | None
    rows: list[list[str]]
    lines: np.ndarray  # 1-based file line of each row


def _read_lines(path: Path) -> list[str]:
    if not path.is_file():
        raise DataError(f"{path}: file not found")
    try:
        return path.read_text(encoding="utf-8-sig").splitlines()
    except UnicodeDecodeError as exc:
        raise DataError(f"{path}: not a UTF-8 text file ({exc.reason} at byte {exc.start})") \
            from None


def _split(line: str, delimiter: str | None) -> list[str]:
    return line.split() if delimiter is None else [f.strip() for f in line.split(delimiter)]


def _is_numeric(fields: list[str]) -> bool:
    try:
        for f in fields:
            float(f)
    except ValueError:
        return False
    return bool(fields)


def _sniff(line: str) -> str | None:
    """Delimiter under which ``line`` splits into the most numeric fields (None: whitespace)."""
    best, best_n = None, 0
    for delim in (",", ";", "\t", None):
        fields = _split(line, delim)
        if _is_numeric(fields) and len(fields) > best_n:
            best, best_n = delim, len(fields)
    return best if best_n else ""


def _parse_table(path: Path, delimiter: str | None, skip_lines: int | None,
                 header: bool | None, comments: str) -> _Table:
    lines = _read_lines(path)
    start = 0
    if lines and lines[0].lower().startswith("sep=") and len(lines[0]) >= 5:
        # Excel's delimiter hint, as in Xsens DOT exports
        delimiter = delimiter if delimiter is not None else lines[0][4]
        start = 1
    if skip_lines is not None:
        start = max(start, skip_lines)
    body = [(i, s) for i, s in enumerate(lines) if i >= start and s.strip()
            and not s.lstrip().startswith(comments)]
    if skip_lines is None:
        # the table starts at the first numeric row; the line before it holds the column
        # names when it has as many fields
        first = None
        for k, (_, s) in enumerate(body):
            delim = delimiter if delimiter is not None else _sniff(s)
            if delim != "" and _is_numeric(_split(s, delim)):
                first, delimiter = k, delim
                break
        if first is None:
            raise DataError(f"{path}: no numeric data rows found (delimiter "
                            f"{'sniffed' if delimiter is None else repr(delimiter)})")
        has_names = False
        if header is not False and first > 0:
            n_fields = len(_split(body[first][1], delimiter))
            has_names = len(_split(body[first - 1][1], delimiter)) == n_fields
        if header and not has_names:
            raise DataError(f"{path}: header=True but no line of column names precedes the "
                            f"data at line {body[first][0] + 1}")
    else:
        if not body:
            raise DataError(f"{path}: nothing left after skipping {skip_lines} lines")
        probe = body[1][1] if len(body) > 1 else body[0][1]
        if delimiter is None:
            delimiter = _sniff(probe) or None
        has_names = header if header is not None else not _is_numeric(
            _split(body[0][1], delimiter))
        first = 1 if has_names else 0
    names = _split(body[first - 1][1], delimiter) if has_names else None
    data = body[first:]
    rows = [_split(s, delimiter) for _, s in data]
    return _Table(names, rows, np.array([i + 1 for i, _ in data], dtype=int))


def _resolve(table: _Table, spec: str | int, path: Path) -> tuple[int, str]:
    n_cols = len(table.rows[0])
    if isinstance(spec, str):
        if table.names is None:
            raise DataError(f"{path}: column {spec!r} asked by name but the file has no header "
                            f"line; use column numbers 0..{n_cols - 1}")
        if spec not in table.names:
            raise DataError(f"{path}: no column {spec!r}; available columns: {table.names}")
        return table.names.index(spec), spec
    if isinstance(spec, bool) or not isinstance(spec, int) or not 0 <= spec < n_cols:
        raise DataError(f"{path}: column {spec!r} is out of range: the file has {n_cols} "
                        f"columns, numbered 0..{n_cols - 1}")
    return spec, table.names[spec] if table.names else f"col{spec}"


def _column(table: _Table, j: int, name: str, path: Path) -> np.ndarray:
    out = np.empty(len(table.rows))
    n_cols = len(table.rows[0])
    for k, row in enumerate(table.rows):
        if len(row) != n_cols:
            raise DataError(f"{path}: line {table.lines[k]} has {len(row)} fields, expected "
                            f"{n_cols} like the first data row")
        f = row[j]
        try:
            out[k] = float(f) if f else math.nan
        except ValueError:
            raise DataError(f"{path}: non-numeric value {f!r} at line {table.lines[k]}, column "
                            f"{name!r}") from None
    return out


def _column_list(spec: ColumnSpec, table: _Table, exclude: int | None,
                 path: Path) -> list[tuple[str, int]]:
    """(channel name, column index) pairs for a column specification."""
    if spec is None:
        picked = (_resolve(table, j, path) for j in range(len(table.rows[0])) if j != exclude)
        return [(name, j) for j, name in picked]
    if isinstance(spec, Mapping):
        return [(str(new), _resolve(table, col, path)[0]) for new, col in spec.items()]
    if isinstance(spec, str | int):
        spec = [spec]
    return [(name, j) for j, name in (_resolve(table, s, path) for s in spec)]


def read_csv(path: str | Path, columns: ColumnSpec = None, *, time: str | int | None = None,
             rate: float | None = None, time_scale: float = 1.0,
             delimiter: str | None = None, skip_lines: int | None = None,
             header: bool | None = None, skip_rows: int = 0, comments: str = "#",
             units: Mapping[str, str] | str | None = None, on_nan: NanPolicy = "raise",
             max_gap: int = 5, time_rtol: float = TIME_RTOL) -> Measurement:
    """Read a delimited text table.

    Parameters
    ----------
    path : str or Path
        The file.
    columns : sequence of str or int, mapping, or None
        Columns to read, by header name or 0-based number; a mapping ``{channel: column}``
        renames them; None reads all but the time column.
    time : str or int, optional
        Column holding the sample times (multiplied by ``time_scale``, e.g. 1e-6 for µs).
    rate : float, optional
        Sampling rate in Hz when there is no time column (the first sample at t = 0).
        Exactly one of ``time`` and ``rate`` is required.
    delimiter : str, optional
        Field delimiter; None sniffs ``,`` ``;`` tab or whitespace from the first data row
        (an Excel ``sep=`` first line is honoured).
    skip_lines : int, optional
        Lines to skip before the table. None finds the first numeric row and takes the line
        just before it as the column names when it has as many fields.
    header : bool, optional
        Whether the table starts with a line of column names (None: detected).
    skip_rows : int
        Data rows to drop at the start (e.g. a placeholder row).
    comments : str
        Lines starting with this are ignored.
    units : str or mapping, optional
        Unit of every channel, or per channel.
    on_nan : {"raise", "interpolate"}
        Empty or NaN fields raise a DataError (count and first line), or are filled by
        linear interpolation over gaps of at most ``max_gap`` samples.
    time_rtol : float
        Allowed relative deviation of a time step from the median step.
    """
    path = Path(path)
    _check_nan_policy(on_nan, max_gap)
    if (time is None) == (rate is None):
        raise ConfigError(f"{path}: give exactly one of time= (a column) and rate= (Hz); got "
                          f"time={time!r}, rate={rate!r}")
    if rate is not None and not (np.isfinite(rate) and rate > 0):
        raise ConfigError(f"rate must be a positive sampling rate in Hz, got {rate!r}")
    if skip_rows < 0:
        raise ConfigError(f"skip_rows must be >= 0, got {skip_rows}")
    table = _parse_table(path, delimiter, skip_lines, header, comments)
    table = _Table(table.names, table.rows[skip_rows:], table.lines[skip_rows:])
    if len(table.rows) < 2:
        raise DataError(f"{path}: fewer than 2 data rows")
    lines = table.lines
    time_col = None
    if time is not None:
        time_col, time_name = _resolve(table, time, path)
        t = _column(table, time_col, time_name, path)
        bad = ~np.isfinite(t)
        if bad.any():
            raise DataError(f"{path}: time column {time_name!r} has {int(bad.sum())} missing "
                            f"or non-finite values, the first at line "
                            f"{lines[np.flatnonzero(bad)[0]]}")
        t = t * time_scale
    else:
        t = np.arange(len(table.rows)) / float(rate)
    _check_uniform(t, str(path), time_rtol, lines)
    chans = {}
    for name, j in _column_list(columns, table, time_col, path):
        y = _column(table, j, name, path)
        chans[name] = _apply_nan_policy(y, on_nan, max_gap, name, str(path), lines)
    return Measurement(t, chans, _units_for(list(chans), units), str(path), time_rtol)


def write_csv(path: str | Path, m: Measurement, *, delimiter: str = ",",
              time_name: str = "t") -> None:
    """Write a header line ``t,<names>``, a units comment and full-precision rows."""
    if time_name in m.channels:
        raise ConfigError(f"time_name {time_name!r} clashes with a channel name")
    clash = [n for n in (time_name, *m.names) if delimiter in n or "\n" in n]
    if clash:
        raise ConfigError(f"names {clash} contain the delimiter {delimiter!r} or a newline; "
                          f"rename() the channels or choose another delimiter")
    units = ", ".join(f"{n}={u}" for n, u in m.units.items() if u)
    lines = [f"# femupdate measurement; units: {units or 'not given'}; time in s",
             delimiter.join([time_name, *m.names])]
    body = np.column_stack([m.t, m.array()])
    text = "\n".join(delimiter.join(repr(float(v)) for v in row) for row in body)
    Path(path).write_text("\n".join(lines) + "\n" + text + "\n", encoding="utf-8")


def _units_from_csv_comment(path: Path) -> dict[str, str]:
    with path.open(encoding="utf-8-sig") as fh:
        first = fh.readline()
    match = re.match(r"# femupdate measurement; units: (.*); time in s", first)
    if not match or match.group(1) == "not given":
        return {}
    pairs = (p.split("=", 1) for p in match.group(1).split(", "))
    return {k: v for k, v in pairs}


# --------------------------------------------------------------------------- NPZ


def write_npz(path: str | Path, m: Measurement) -> None:
    """Write ``t``, ``data`` (n, k), ``names`` and ``units`` to a compressed NPZ file."""
    np.savez_compressed(path, t=m.t, data=m.array(), names=np.array(m.names, dtype=str),
                        units=np.array([m.units[n] for n in m.names], dtype=str))


def read_npz(path: str | Path, columns: Sequence[str] | None = None, *,
             time_rtol: float = TIME_RTOL) -> Measurement:
    """Read an NPZ file.

    Two layouts are understood: femupdate's (``t``, ``data`` (n, k), ``names``, ``units``),
    and a plain one with ``t`` and one 1-D array per channel.
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: file not found")
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except (OSError, ValueError) as exc:
        raise DataError(f"{path}: not a readable NPZ file ({exc})") from None
    if "t" not in arrays:
        raise DataError(f"{path}: no time array 't'; arrays in the file: {sorted(arrays)}")
    t = arrays.pop("t")
    if {"data", "names"} <= set(arrays):
        data, names = np.atleast_2d(arrays["data"].T).T, [str(n) for n in arrays["names"]]
        units = [str(u) for u in arrays.get("units", [""] * len(names))]
        if data.ndim != 2 or data.shape[1] != len(names):
            raise DataError(f"{path}: 'data' has shape {data.shape} but there are "
                            f"{len(names)} names")
        chans = {n: data[:, j] for j, n in enumerate(names)}
        unit_map = dict(zip(names, units, strict=True))
    else:
        chans, unit_map = arrays, {}
    for name, y in chans.items():
        if y.shape != t.shape:
            raise DataError(f"{path}: channel {name!r} has {y.shape} samples but 't' has "
                            f"{t.shape}: channels of different lengths")
        if not np.issubdtype(y.dtype, np.number):
            raise DataError(f"{path}: channel {name!r} is not numeric (dtype {y.dtype})")
    if columns is not None:
        missing = [c for c in columns if c not in chans]
        if missing:
            raise DataError(f"{path}: no column(s) {missing}; available columns: {list(chans)}")
        chans = {c: chans[c] for c in columns}
    return Measurement(t, chans, {n: unit_map.get(n, "") for n in chans}, str(path), time_rtol)


# --------------------------------------------------------------------------- UFF58

_UFF_SPEC = {"m": 8, "m/s": 11, "m/s^2": 12, "m/s2": 12, "g": 12, "n": 13}
_UFF_TAG = "femupdate t0={t0!r} dt={dt!r}"


def write_uff58(path: str | Path, m: Measurement, *, binary: bool = False) -> None:
    """Write one UFF58 data set (time response, even abscissa) per channel.

    The UFF58 header holds the start time and the increment with 6 significant digits
    (format E13.5); the exact values are also written on ID line 2, which `read_uff58` uses.
    """
    pyuff = require("pyuff", "uff")
    sets = []
    for node, name in enumerate(m.names, start=1):
        unit = m.units[name]
        sets.append({
            "type": 58, "binary": int(binary), "func_type": 1, "id1": name,
            "id2": _UFF_TAG.format(t0=float(m.t[0]), dt=m.dt),
            "rsp_node": node, "rsp_dir": 1, "ref_node": 0, "ref_dir": 0,
            "abscissa_spacing": 1, "abscissa_spec_data_type": 17,
            "abscissa_axis_units_lab": "s",
            "ordinate_spec_data_type": _UFF_SPEC.get(unit.lower(), 0),
            "ordinate_axis_units_lab": unit or "NONE",
            "orddenom_spec_data_type": 0, "x": m.t, "data": m[name],
        })
    # start from an empty file and append: pyuff's "overwrite" mode truncates the header of
    # a binary first set when it reopens the file for the data
    Path(path).write_bytes(b"")
    pyuff.UFF(str(path)).write_sets(sets, mode="add")


def read_uff58(path: str | Path, columns: Sequence[str] | None = None, *,
               time_rtol: float = TIME_RTOL) -> Measurement:
    """Read the real-valued UFF58 data sets of a file as channels named by ID line 1."""
    pyuff = require("pyuff", "uff")
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: file not found")
    try:
        uff = pyuff.UFF(str(path))
        types = [int(k) for k in uff.get_set_types()]
        picked = [i for i, kind in enumerate(types) if kind == 58]
        sets = uff.read_sets(picked) if picked else []
    except Exception as exc:  # pyuff raises bare Exception for malformed files
        raise DataError(f"{path}: not a readable UFF file ({exc})") from exc
    if not picked:
        raise DataError(f"{path}: no UFF58 data sets (set types found: {sorted(set(types))})")
    sets = sets if isinstance(sets, list) else [sets]
    chans: dict[str, np.ndarray] = {}
    units: dict[str, str] = {}
    t_ref, ref_name = None, ""
    for s in sets:
        name = str(s.get("id1", "")).strip()
        if not name or name == "NONE":
            name = f"node{s['rsp_node']}dir{s['rsp_dir']}"
        y = np.asarray(s["data"])
        if np.iscomplexobj(y):
            raise DataError(f"{path}: data set {name!r} is complex (a spectrum or FRF); only "
                            f"real time histories are read")
        t = _uff_time(s)
        if t_ref is None:
            t_ref, ref_name = t, name
        elif t.shape != t_ref.shape:
            raise DataError(f"{path}: channel {name!r} has {t.size} samples but {ref_name!r} "
                            f"has {t_ref.size}: channels of different lengths")
        elif not np.allclose(t, t_ref, rtol=0, atol=1e-6 * abs(t_ref[1] - t_ref[0])):
            raise DataError(f"{path}: channel {name!r} is sampled every {t[1] - t[0]:.6g} s "
                            f"from {t[0]:.6g} s, {ref_name!r} every {t_ref[1] - t_ref[0]:.6g} s "
                            f"from {t_ref[0]:.6g} s: different sampling; resample first")
        if name in chans:
            raise DataError(f"{path}: two data sets named {name!r} (ID line 1)")
        chans[name] = y.astype(float)
        unit = str(s.get("ordinate_axis_units_lab", "")).strip()
        units[name] = "" if unit == "NONE" else unit
    if columns is not None:
        missing = [c for c in columns if c not in chans]
        if missing:
            raise DataError(f"{path}: no column(s) {missing}; available columns: {list(chans)}")
        chans = {c: chans[c] for c in columns}
        units = {c: units[c] for c in columns}
    return Measurement(t_ref, chans, units, str(path), time_rtol)


def _uff_time(s: dict) -> np.ndarray:
    n = len(s["data"])
    match = re.fullmatch(r"femupdate t0=(\S+) dt=(\S+)", str(s.get("id2", "")).strip())
    if match:
        t0, dt = float(match.group(1)), float(match.group(2))
        return t0 + dt * np.arange(n)
    return np.asarray(s["x"], dtype=float)


# --------------------------------------------------------------------------- dispatch


def read(path: str | Path, **options: object) -> Measurement:
    """Read a measurement, choosing the reader by extension (.csv/.txt/.dat, .npz, .uff/.unv).

    ``options`` go to the reader (`read_csv`, `read_npz`, `read_uff58`). Text files default
    to a time column named ``t``; the units written by `write_csv` are read back.
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext == ".npz":
        return read_npz(path, **options)  # type: ignore[arg-type]
    if ext in (".uff", ".unv"):
        return read_uff58(path, **options)  # type: ignore[arg-type]
    if ext in (".csv", ".txt", ".dat", ".tsv"):
        units = _units_from_csv_comment(path) if path.is_file() else {}
        if "time" not in options and "rate" not in options:
            options["time"] = "t"
        m = read_csv(path, **options)  # type: ignore[arg-type]
        if units and "units" not in options:
            m = Measurement(m.t, m.channels, {n: units.get(n, "") for n in m.names}, m.source,
                            m.time_rtol)
        return m
    raise DataError(f"{path}: unknown file type {ext!r}; expected .csv, .txt, .dat, .tsv, "
                    f".npz, .uff or .unv")


# --------------------------------------------------------------------------- specific formats


def read_elcentro(path: str | Path, *, units: str | None = None,
                  dt: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Read an El Centro 1940 record in the formats of ``shared/data/elcentro1940``.

    Values are whitespace-separated, several per line. A ``#`` header (the "Peknold version")
    states the number of points, the spacing and the units; its last line is padded with
    zeros, which are dropped. A file without a header is taken as the S00E corrected record:
    cm/s² at 0.02 s, unless ``units``/``dt`` say otherwise.

    Parameters
    ----------
    units : {"g", "cm/s2", "m/s2"}, optional
        Overrides the units stated in (or assumed for) the file.
    dt : float, optional
        Overrides the sample interval, s.

    Returns
    -------
    t : ndarray
        Times, s, the first sample at t = 0.
    ag : ndarray
        Ground acceleration, m/s².
    """
    path = Path(path)
    lines = _read_lines(path)
    head = " ".join(s for s in lines if s.lstrip().startswith("#")).lower()
    n_points = re.search(r"(\d+)\s+points", head)
    spacing = re.search(r"spacing of\s+([0-9.eE+-]+)\s*sec", head)
    head_units = re.search(r"units are\s*\(?\s*([a-z/0-9^*]+)", head)
    values = []
    for i, s in enumerate(lines):
        if s.lstrip().startswith("#") or not s.strip():
            continue
        for f in s.split():
            try:
                values.append(float(f))
            except ValueError:
                raise DataError(f"{path}: non-numeric value {f!r} at line {i + 1}") from None
    ag = np.array(values)
    if n_points:
        count = int(n_points.group(1))
        if count > ag.size:
            raise DataError(f"{path}: header states {count} points but the file holds "
                            f"{ag.size} values")
        ag = ag[:count]
    dt = dt if dt is not None else float(spacing.group(1)) if spacing else 0.02
    unit = (units or (head_units.group(1) if head_units else "cm/s2")).replace("^", "")
    scale = {"g": G, "cm/s2": 0.01, "m/s2": 1.0}.get(unit)
    if scale is None:
        raise ConfigError(f"{path}: unknown acceleration units {unit!r}; allowed: 'g', "
                          f"'cm/s2', 'm/s2'")
    if not dt > 0:
        raise ConfigError(f"dt must be positive, got {dt!r}")
    _check_finite(ag, "acceleration", str(path))
    return np.arange(ag.size) * dt, ag * scale


_XSENS_UNITS = {"Acc": "m/s^2", "Euler": "deg", "Gyr": "deg/s", "FreeAcc": "m/s^2"}


def read_xsens_dot(path: str | Path, columns: ColumnSpec = ("Acc_X",), *,
                   drop_placeholder: bool = True, time_rtol: float = TIME_RTOL) -> Measurement:
    """Read a Movella/Xsens DOT CSV export (as in ``shared/data/minishake_1story``).

    Times come from ``SampleTimeFine`` (µs, a 32-bit counter: wrap-arounds are undone), so
    two synchronised sensors can be aligned with `align`. The first row of an export is a
    placeholder with all accelerations 0; it is dropped when ``drop_placeholder``.
    Units follow the column prefix (Acc: m/s², Euler: deg, Gyr: deg/s).
    """
    path = Path(path)
    table = _parse_table(path, None, None, None, "#")
    if table.names is None or "SampleTimeFine" not in table.names:
        raise DataError(f"{path}: not an Xsens DOT export: no 'SampleTimeFine' column "
                        f"(columns: {table.names})")
    ticks = _column(table, table.names.index("SampleTimeFine"), "SampleTimeFine", path)
    wraps = np.concatenate(([0.0], np.cumsum(np.diff(ticks) < -2.0**31)))
    t = (ticks + wraps * 2.0**32) * 1e-6
    start = 0
    if drop_placeholder:
        acc = [c for c in ("Acc_X", "Acc_Y", "Acc_Z") if c in table.names]
        if acc and all(float(table.rows[0][table.names.index(c)]) == 0.0 for c in acc):
            start = 1
    sub = _Table(table.names, table.rows[start:], table.lines[start:])
    t = t[start:]
    _check_uniform(t, str(path), time_rtol, sub.lines)
    chans, units = {}, {}
    for name, j in _column_list(columns, sub, None, path):
        y = _column(sub, j, name, path)
        chans[name] = _apply_nan_policy(y, "raise", 1, name, str(path), sub.lines)
        units[name] = _XSENS_UNITS.get(table.names[j].split("_")[0], "")
    return Measurement(t, chans, units, str(path), time_rtol)


# --------------------------------------------------------------------------- time bases


def resample(t: np.ndarray, y: np.ndarray, rate: float, *,
             max_denominator: int = 1000) -> tuple[np.ndarray, np.ndarray]:
    """Resample a uniformly sampled signal to ``rate`` Hz (polyphase FIR, `resample_poly`).

    The rate ratio is approximated by a fraction with denominator ≤ ``max_denominator``;
    the ratio actually used is exact, and the returned time vector follows it.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Uniform sample times.
    y : ndarray, shape (n,) or (n, k)
        Samples on axis 0.
    rate : float
        New sampling rate, Hz.

    Returns
    -------
    t_new, y_new : ndarray
        Times starting at ``t[0]`` and the resampled signal.
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if not (np.isfinite(rate) and rate > 0):
        raise ConfigError(f"rate must be a positive sampling rate in Hz, got {rate!r}")
    if y.shape[0] != t.size:
        raise DataError(f"y has {y.shape[0]} samples on axis 0 but t has {t.size}")
    _check_uniform(t, "resample", TIME_RTOL)
    old = (t.size - 1) / (t[-1] - t[0])
    ratio = Fraction(rate / old).limit_denominator(max_denominator)
    if ratio == 0 or abs(float(ratio) * old - rate) > 1e-9 * rate:
        raise ConfigError(f"cannot resample from {old:.9g} Hz to {rate:.9g} Hz with a "
                          f"fraction of denominator <= {max_denominator}; raise max_denominator")
    if ratio == 1:
        return t.copy(), y.copy()
    out = scipy.signal.resample_poly(y, ratio.numerator, ratio.denominator, axis=0,
                                     padtype="line")
    return t[0] + np.arange(out.shape[0]) / rate, out


def align(*measurements: Measurement, rate: float | None = None,
          method: Literal["nearest", "linear"] = "nearest",
          zero: bool = True) -> tuple[Measurement, ...]:
    """Put measurements on one time base: their overlap, sampled alike.

    Parameters
    ----------
    *measurements : Measurement
        Records with synchronised clocks (their ``t`` on one time axis).
    rate : float, optional
        Common sampling rate, Hz. Without it all rates must agree (to 1e-6); with it each
        record is first resampled (`resample`).
    method : {"nearest", "linear"}
        "nearest" keeps the samples and shifts each record by a whole number of samples, so
        that sample times agree within half an interval. "linear" interpolates every record
        onto the grid of the one that starts last; linear interpolation attenuates high
        frequencies (gain cos(π f / fs) at a half-sample shift: 0.87 at 20 Hz for 120 Hz).
    zero : bool
        Start the common time axis at 0.
    """
    if not measurements:
        raise ConfigError("align needs at least one measurement")
    if method not in ("nearest", "linear"):
        raise ConfigError(f"method must be 'nearest' or 'linear', got {method!r}")
    ms = list(measurements)
    if rate is not None:
        ms = [_resampled(m, rate) for m in ms]
    rates = [m.rate for m in ms]
    if max(rates) - min(rates) > 1e-6 * max(rates):
        listing = ", ".join(f"{m.source}: {r:.6g} Hz" for m, r in zip(ms, rates, strict=True))
        raise DataError(f"cannot align records sampled at different rates ({listing}); pass "
                        f"rate= to resample them to a common rate")
    start = max(m.t[0] for m in ms)
    end = min(m.t[-1] for m in ms)
    if end <= start:
        raise DataError("records do not overlap in time: "
                        + ", ".join(f"{m.source}: [{m.t[0]:.6g}, {m.t[-1]:.6g}] s" for m in ms))
    ref = next(m for m in ms if m.t[0] == start)
    if method == "nearest":
        offsets = [round((start - m.t[0]) / m.dt) for m in ms]
        n = min(m.n_samples - k for m, k in zip(ms, offsets, strict=True))
        t = ref.t[:n]
        out = [Measurement(t, {c: y[k:k + n] for c, y in m.channels.items()}, m.units,
                           m.source, m.time_rtol) for m, k in zip(ms, offsets, strict=True)]
    else:
        t = ref.t[ref.t <= end]
        out = [Measurement(t, {c: np.interp(t, m.t, y) for c, y in m.channels.items()},
                           m.units, m.source, m.time_rtol) for m in ms]
    return tuple(o.shifted(0.0) if zero else o for o in out)


def _resampled(m: Measurement, rate: float) -> Measurement:
    t, y = resample(m.t, m.array(), rate)
    return Measurement.from_array(t, y, m.names, m.units, m.source)


def combine(*measurements: Measurement, source: str | None = None) -> Measurement:
    """Merge aligned measurements (same time vector) into one; channel names must differ."""
    if not measurements:
        raise ConfigError("combine needs at least one measurement")
    first = measurements[0]
    chans: dict[str, np.ndarray] = {}
    units: dict[str, str] = {}
    for m in measurements:
        if m.t.shape != first.t.shape or not np.allclose(m.t, first.t, rtol=0,
                                                          atol=1e-9 * first.dt):
            raise DataError(f"{m.source} and {first.source} have different time vectors; "
                            f"align() them first")
        clash = set(m.channels) & set(chans)
        if clash:
            raise DataError(f"channel names {sorted(clash)} occur in more than one record "
                            f"({m.source}); rename() them first")
        chans.update(m.channels)
        units.update(m.units)
    src = source or " + ".join(m.source for m in measurements)
    return Measurement(first.t, chans, units, src, first.time_rtol)

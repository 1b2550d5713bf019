"""Reading and writing records: CSV, NPZ and UFF58, each writer with its reader; the records
of strong-motion networks (CSMIP V2 archives, PEER AT2 files: :mod:`femupdate.data.network`)
are read only.

Readers report bad input with the file, the line and the column. Writers produce what a user
would bring (virtual experiments write CSV, NPZ or UFF58), and every writer has a reader that
returns the same `Measurement`. Readers of particular published records are in
:mod:`femupdate.data.datasets`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from femupdate._optional import require
from femupdate.data.glitches import check_record
from femupdate.data.measurement import (
    TIME_RTOL,
    Measurement,
    NanPolicy,
    align,
    apply_nan_policy,
    check_nan_policy,
    check_uniform,
    combine,
    fill_gaps,
    resample,
    units_for,
)
from femupdate.data.network import read_network_records, to_measurement
from femupdate.errors import ConfigError, DataError

__all__ = [
    "ColumnSpec",
    "Measurement",
    "align",
    "combine",
    "fill_gaps",
    "read",
    "read_csv",
    "read_network",
    "read_npz",
    "read_uff58",
    "resample",
    "write_csv",
    "write_npz",
    "write_uff58",
]

ColumnSpec = Sequence[str | int] | Mapping[str, str | int] | None


# --------------------------------------------------------------------------- CSV


@dataclass(frozen=True)
class Table:
    """Text table split into fields: column names (or None) and data rows with line numbers."""

    names: list[str] | None
    rows: list[list[str]]
    lines: np.ndarray  # 1-based file line of each row


def not_a_file(path: Path) -> str:
    """Why ``path`` cannot be read as a data file: a folder, or nothing there."""
    if path.is_dir():
        return f"{path}: a folder, not a data file (allowed: a file; name the file in it)"
    return f"{path}: file not found"


def read_lines(path: Path) -> list[str]:
    if not path.is_file():
        raise DataError(not_a_file(path))
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


def parse_table(path: Path, delimiter: str | None, skip_lines: int | None,
                 header: bool | None, comments: str) -> Table:
    lines = read_lines(path)
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
    return Table(names, rows, np.array([i + 1 for i, _ in data], dtype=int))


def _resolve(table: Table, spec: str | int, path: Path) -> tuple[int, str]:
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


def column_values(table: Table, j: int, name: str, path: Path) -> np.ndarray:
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


def column_list(spec: ColumnSpec, table: Table, exclude: int | None,
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
             max_gap: int = 5, time_rtol: float = TIME_RTOL,
             repair: bool = False) -> Measurement:
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
    repair : bool
        Repair isolated glitches of the export (repeated time stamps of duplicate or empty
        rows, a few dropped samples, a few non-finite values; see
        :mod:`femupdate.data.glitches`) and say so in the result's ``notes``; without it a
        record with glitches is refused with every glitch's line and time.
    """
    path = Path(path)
    check_nan_policy(on_nan, max_gap)
    if (time is None) == (rate is None):
        raise ConfigError(f"{path}: give exactly one of time= (a column) and rate= (Hz); got "
                          f"time={time!r}, rate={rate!r}")
    if rate is not None and not (np.isfinite(rate) and rate > 0):
        raise ConfigError(f"rate must be a positive sampling rate in Hz, got {rate!r}")
    if skip_rows < 0:
        raise ConfigError(f"skip_rows must be >= 0, got {skip_rows}")
    table = parse_table(path, delimiter, skip_lines, header, comments)
    table = Table(table.names, table.rows[skip_rows:], table.lines[skip_rows:])
    if len(table.rows) < 2:
        raise DataError(f"{path}: fewer than 2 data rows")
    lines = table.lines
    time_col = None
    if time is not None:
        time_col, time_name = _resolve(table, time, path)
        t = column_values(table, time_col, time_name, path)
        bad = ~np.isfinite(t)
        if bad.any():
            raise DataError(f"{path}: time column {time_name!r} has {int(bad.sum())} missing "
                            f"or non-finite values, the first at line "
                            f"{lines[np.flatnonzero(bad)[0]]}")
        t = t * time_scale
    else:
        t = np.arange(len(table.rows)) / float(rate)
    chans = {}
    for name, j in column_list(columns, table, time_col, path):
        y = column_values(table, j, name, path)
        # NaN fields: filled here on request (on_nan), else listed with the other glitches
        chans[name] = (apply_nan_policy(y, on_nan, max_gap, name, str(path), lines)
                       if on_nan == "interpolate" else y)
    t, chans, notes = check_record(t, chans, lines, str(path), repair=repair)
    check_uniform(t, str(path), time_rtol, lines if t.size == lines.size else None)
    return Measurement(t, chans, units_for(list(chans), units), str(path), time_rtol,
                       tuple(notes))


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


def _npz_problem(path: Path, exc: Exception) -> str:
    """What is wrong with a file numpy cannot load as NPZ, in words: numpy's own message
    suggests ``allow_pickle`` for anything that is not an archive, which femupdate never sets
    (a pickle runs code)."""
    with path.open("rb") as f:
        head = f.read(4)
    if head.startswith(b"PK"):
        return "a zip archive numpy cannot read as NPZ, or arrays of Python objects"
    if not head:
        return "the file is empty"
    if head.startswith(b"\x93NUM"):
        return "a single .npy array, not an .npz archive"
    return "not an NPZ (zip) archive: it does not start as one; a text file?"


def read_npz(path: str | Path, columns: Sequence[str] | None = None, *,
             time_rtol: float = TIME_RTOL) -> Measurement:
    """Read an NPZ file.

    Two layouts are understood: femupdate's (``t``, ``data`` (n, k), ``names``, ``units``),
    and a plain one with ``t`` and one 1-D array per channel.
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(not_a_file(path))
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except (OSError, ValueError, EOFError) as exc:  # EOFError: an empty file
        raise DataError(f"{path}: not a readable NPZ file ({_npz_problem(path, exc)}) "
                        "(allowed: an NPZ archive of numeric arrays, as numpy.savez writes; "
                        "a text table wants [data] format = \"csv\")") from None
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
        raise DataError(not_a_file(path))
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


# --------------------------------------------------------------------------- networks


def read_network(path: str | Path, columns: Sequence[str | int] | None = None, *,
                 format: str | None = None) -> Measurement:
    """Read channels of a network record (a zip archive, folder or file of CSMIP or COSMOS V2
    files, or a PEER AT2 file) as a `Measurement` in m/s², channels named by their number.

    The channels must share one interval (a station's recorders may differ: read them apart
    and resample); they are cut to the shortest. See
    :func:`femupdate.data.network.read_network_records` for ``columns`` (numbers or
    ``"location / direction"``) and the checks of each file's header against its samples.
    """
    picked = read_network_records(path, columns, format=format)
    names = [str(ch.number) for ch in picked]
    if len(set(names)) != len(names):
        raise DataError(f"{path}: channels {list(columns or [])} name one channel twice")
    # one channel: named by its own file (``archive.zip:CHAN07.V2``), as messages should
    return to_measurement(picked, names, picked[0].source if len(picked) == 1 else str(path))


# --------------------------------------------------------------------------- dispatch


def read(path: str | Path, **options: object) -> Measurement:
    """Read a measurement, choosing the reader by extension (.csv/.txt/.dat, .npz, .uff/.unv,
    and network records: .zip, .v2, .v2c, .at2 or a folder of them, `read_network`).

    ``options`` go to the reader (`read_csv`, `read_npz`, `read_uff58`). Text files default
    to a time column named ``t``; the units written by `write_csv` are read back.
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext == ".npz":
        return read_npz(path, **options)  # type: ignore[arg-type]
    if ext in (".uff", ".unv"):
        return read_uff58(path, **options)  # type: ignore[arg-type]
    if ext in (".zip", ".v2", ".v2c", ".at2") or path.is_dir():
        return read_network(path, **options)  # type: ignore[arg-type]
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
                    f".npz, .uff, .unv, or a network record .zip, .v2, .v2c, .at2")

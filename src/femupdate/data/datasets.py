"""Readers of particular published records: the El Centro 1940 files and Xsens DOT exports.

Both are the formats of the shared data directory beside femupdate (``elcentro1940`` and
``minishake_1story``); generic formats are read by :mod:`femupdate.data.io`.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from femupdate.data.io import ColumnSpec, Table, column_list, column_values, parse_table, read_lines
from femupdate.data.measurement import (
    TIME_RTOL,
    Measurement,
    apply_nan_policy,
    check_finite,
    check_uniform,
)
from femupdate.errors import ConfigError, DataError
from femupdate.units import STANDARD_GRAVITY

__all__ = ["read_elcentro", "read_xsens_dot"]


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
    lines = read_lines(path)
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
    scale = {"g": STANDARD_GRAVITY, "cm/s2": 0.01, "m/s2": 1.0}.get(unit)
    if scale is None:
        raise ConfigError(f"{path}: unknown acceleration units {unit!r}; allowed: 'g', "
                          f"'cm/s2', 'm/s2'")
    if not dt > 0:
        raise ConfigError(f"dt must be positive, got {dt!r}")
    check_finite(ag, "acceleration", str(path))
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
    table = parse_table(path, None, None, None, "#")
    if table.names is None or "SampleTimeFine" not in table.names:
        raise DataError(f"{path}: not an Xsens DOT export: no 'SampleTimeFine' column "
                        f"(columns: {table.names})")
    ticks = column_values(table, table.names.index("SampleTimeFine"), "SampleTimeFine", path)
    wraps = np.concatenate(([0.0], np.cumsum(np.diff(ticks) < -2.0**31)))
    t = (ticks + wraps * 2.0**32) * 1e-6
    start = 0
    if drop_placeholder:
        acc = [c for c in ("Acc_X", "Acc_Y", "Acc_Z") if c in table.names]
        if acc and all(float(table.rows[0][table.names.index(c)]) == 0.0 for c in acc):
            start = 1
    sub = Table(table.names, table.rows[start:], table.lines[start:])
    t = t[start:]
    check_uniform(t, str(path), time_rtol, sub.lines)
    chans, units = {}, {}
    for name, j in column_list(columns, sub, None, path):
        y = column_values(sub, j, name, path)
        chans[name] = apply_nan_policy(y, "raise", 1, name, str(path), sub.lines)
        units[name] = _XSENS_UNITS.get(table.names[j].split("_")[0], "")
    return Measurement(t, chans, units, str(path), time_rtol)

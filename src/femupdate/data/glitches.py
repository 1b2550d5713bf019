"""Glitches of real exports: repeated time stamps, dropped samples, non-finite values.

Data loggers and wireless sensors drop a packet now and then, write a row twice, or write a row
of NaN/inf. :func:`check_record` finds them all (file, line, time) and either refuses the record
with the full list, or, with ``repair=True``, repairs the isolated ones and says what it did:

- a repeated time stamp whose row is an exact duplicate of the one before, or holds no finite
  value, is dropped (nothing is lost);
- a step of k sample intervals (k ≥ 2: k − 1 dropped samples) is filled with k − 1 samples;
- non-finite values are interpolated linearly from their neighbours;

each only over at most ``max_gap`` consecutive samples, never at a record's ends. Anything else
(time running backwards, a repeated stamp with other values, a long gap, jitter) is an error.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from femupdate.errors import DataError

__all__ = ["MAX_REPAIR_GAP", "Glitch", "check_record"]

#: The longest run of samples a repair fills: "isolated" glitches.
MAX_REPAIR_GAP = 3
#: A step within this fraction of k sample intervals is k intervals (a dropped-packet gap).
_STEP_TOL = 0.05


@dataclass(frozen=True)
class Glitch:
    """One glitch: what, at which line of the file and at what time."""

    kind: str
    line: int
    time: float
    detail: str = ""
    repairable: bool = True

    def describe(self) -> str:
        text = f"line {self.line} (t = {self.time:.9g} s): {self.kind}"
        return f"{text} ({self.detail})" if self.detail else text


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) of each run of True."""
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist(),
                    strict=True))


def _repeated_stamps(t: np.ndarray, values: np.ndarray, lines: np.ndarray
                     ) -> tuple[list[Glitch], np.ndarray]:
    """Rows whose time equals the previous row's, and which of them can be dropped."""
    glitches, drop = [], np.zeros(t.size, dtype=bool)
    for i in (np.flatnonzero(np.diff(t) == 0.0) + 1).tolist():
        same = np.array_equal(values[i], values[i - 1], equal_nan=True)
        empty = not np.isfinite(values[i]).any()
        ok = same or empty
        why = ("an exact duplicate of the row before" if same else
               "a row without a finite value" if empty else
               "with other values than the row before: which one is right is unknown")
        glitches.append(Glitch("repeated time stamp", int(lines[i]), float(t[i]), why, ok))
        drop[i] = ok
    return glitches, drop


def _steps(t: np.ndarray, lines: np.ndarray, dt: float, max_gap: int
           ) -> tuple[list[Glitch], list[tuple[int, int]]]:
    """Time running backwards and gaps of whole sample intervals: (glitches, (row, missing))."""
    glitches, gaps = [], []
    step = np.diff(t)
    for i in np.flatnonzero(step < 0.0).tolist():
        glitches.append(Glitch("time runs backwards", int(lines[i + 1]), float(t[i + 1]),
                               f"after t = {t[i]:.9g} s", repairable=False))
    ratio = step / dt
    k = np.rint(ratio)
    for i in np.flatnonzero((k >= 2) & (np.abs(ratio - k) <= _STEP_TOL * k)).tolist():
        missing = int(k[i]) - 1
        ok = missing <= max_gap
        glitches.append(Glitch("dropped samples", int(lines[i + 1]), float(t[i + 1]),
                               f"{missing} missing after t = {t[i]:.9g} s" + (
                                   "" if ok else f", more than {max_gap}"), ok))
        if ok:
            gaps.append((i + 1, missing))
    return glitches, gaps


def _fill_gaps(t: np.ndarray, values: np.ndarray, lines: np.ndarray,
               gaps: list[tuple[int, int]], dt: float
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Insert ``missing`` NaN rows (their times on the sample grid) before each gap's row; the
    inserted rows carry the line of the row after the gap."""
    t_parts, v_parts, l_parts, start = [], [], [], 0
    for row, missing in gaps:
        t_parts += [t[start:row], t[row - 1] + dt * np.arange(1, missing + 1)]
        v_parts += [values[start:row], np.full((missing, values.shape[1]), np.nan)]
        l_parts += [lines[start:row], np.full(missing, lines[row])]
        start = row
    t_parts.append(t[start:])
    v_parts.append(values[start:])
    l_parts.append(lines[start:])
    return np.concatenate(t_parts), np.concatenate(v_parts), np.concatenate(l_parts)


def _kept_rows(gaps: list[tuple[int, int]], n: int) -> np.ndarray:
    """Positions, after the gaps are filled, of the ``n`` rows read."""
    shift = np.zeros(n, dtype=int)
    for row, missing in gaps:
        shift[row:] += missing
    return np.arange(n) + shift


def _non_finite(t: np.ndarray, values: np.ndarray, names: list[str], lines: np.ndarray,
                inserted: np.ndarray, max_gap: int) -> list[Glitch]:
    """Runs of non-finite values of each channel (the rows inserted for dropped samples are
    reported as such, not again here)."""
    glitches = []
    for j, name in enumerate(names):
        for a, b in _runs(~np.isfinite(values[:, j]) & ~inserted):
            at_end = a == 0 or b == t.size
            ok = b - a <= max_gap and not at_end
            why = (f"column {name!r}: {b - a} sample(s)"
                   + (", at the record's end" if at_end else "")
                   + ("" if b - a <= max_gap else f", more than {max_gap}"))
            glitches.append(Glitch("non-finite values", int(lines[a]), float(t[a]), why, ok))
    return glitches


def check_record(t: np.ndarray, channels: Mapping[str, np.ndarray], lines: np.ndarray,
                 source: str, *, repair: bool = False, max_gap: int = MAX_REPAIR_GAP
                 ) -> tuple[np.ndarray, dict[str, np.ndarray], list[str]]:
    """Find the glitches of a record and refuse it, or repair the isolated ones.

    Parameters
    ----------
    t : ndarray (n,)
        Sample times as read, s.
    channels : mapping of str to ndarray (n,)
        The columns read.
    lines : ndarray (n,)
        The file's line number of each row, for messages.
    source : str
        The file, for messages.
    repair : bool
        Repair isolated glitches (see the module's docstring) instead of refusing them.
    max_gap : int
        The longest run of samples a repair fills.

    Returns
    -------
    t, channels, notes
        The record (repaired, or as read when it had no glitch) and one note per repair.

    Raises
    ------
    DataError
        Glitches without ``repair`` (every one listed with its line and time), or ones no
        repair can mend.
    """
    names = list(channels)
    values = np.column_stack([np.asarray(channels[n], dtype=float) for n in names])
    lines = np.asarray(lines)
    found, drop = _repeated_stamps(t, values, lines)
    keep = ~drop
    t, values, lines = t[keep], values[keep], lines[keep]
    positive = np.diff(t)[np.diff(t) > 0]
    dt = float(np.median(positive)) if positive.size else 0.0
    step_glitches, gaps = _steps(t, lines, dt, max_gap) if dt > 0 else ([], [])
    found += step_glitches
    inserted = np.zeros(t.size, dtype=bool)
    if gaps:
        n_read = t.size
        t, values, lines = _fill_gaps(t, values, lines, gaps, dt)
        inserted = ~np.isin(np.arange(t.size), _kept_rows(gaps, n_read))
    found += _non_finite(t, values, names, lines, inserted, max_gap)
    if not found:
        return t, {n: values[:, j] for j, n in enumerate(names)}, []
    found.sort(key=lambda g: g.line)
    listing = "; ".join(g.describe() for g in found)
    if not repair or not all(g.repairable for g in found):
        bad = [g for g in found if not g.repairable]
        hint = ("set [data] repair = true to drop exact duplicates and fill isolated gaps of "
                f"up to {max_gap} samples" if not bad else
                f"not repairable: {'; '.join(g.describe() for g in bad)}; clean the file")
        raise DataError(f"{source}: {len(found)} glitch(es) in the record: {listing} ({hint})")
    idx = np.arange(t.size)
    for j in range(values.shape[1]):
        bad = ~np.isfinite(values[:, j])
        if bad.any():
            values[bad, j] = np.interp(idx[bad], idx[~bad], values[~bad, j])
    notes = [f"{source}: repaired {g.describe()}" for g in found]
    return t, {n: values[:, j] for j, n in enumerate(names)}, notes

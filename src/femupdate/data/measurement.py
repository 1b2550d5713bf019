"""The `Measurement` container: sampled channels on one uniform time base, and time bases.

A `Measurement` is validated when built: finite values, equal lengths, a strictly increasing
uniform time vector. Missing samples (NaN or empty fields) are refused with their count and
first position, or, from Python, filled by linear interpolation over short gaps on request
(``on_nan="interpolate"``, `fill_gaps`); the messages speak to a case file's user, who cleans
the file. `align`, `resample` and `combine` bring records to one time base.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Literal

import numpy as np
import scipy.signal

from femupdate.errors import ConfigError, DataError

__all__ = ["TIME_RTOL", "Measurement", "align", "combine", "fill_gaps", "resample"]

TIME_RTOL = 1e-3  # allowed relative deviation of a time step from the median step
NanPolicy = Literal["raise", "interpolate"]


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
    notes : tuple of str
        What the reader repaired (glitches of the export), to report; not carried further by
        the operations below.
    """

    t: np.ndarray
    channels: dict[str, np.ndarray]
    units: dict[str, str] = field(default_factory=dict)
    source: str = "<memory>"
    time_rtol: float = TIME_RTOL
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        t = np.array(self.t, dtype=float)
        if t.ndim != 1 or t.size < 2:
            raise DataError(f"{self.source}: time vector must be 1-D with at least 2 samples, "
                            f"got shape {t.shape}")
        check_finite(t, "time", self.source)
        check_uniform(t, self.source, self.time_rtol)
        if not self.channels:
            raise DataError(f"{self.source}: no channels")
        channels: dict[str, np.ndarray] = {}
        for name, values in self.channels.items():
            y = np.array(values, dtype=float)
            if y.shape != t.shape:
                raise DataError(
                    f"{self.source}: channel {name!r} has shape {y.shape} but the time vector "
                    f"has {t.shape}: all channels must have one sample per time")
            check_finite(y, f"channel {name!r}", self.source)
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
                   units_for(list(names), units), source)

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


def units_for(names: list[str], units: Mapping[str, str] | str | None) -> dict[str, str]:
    if units is None:
        return {}
    if isinstance(units, str):
        return dict.fromkeys(names, units)
    return dict(units)


def check_finite(y: np.ndarray, what: str, source: str) -> None:
    bad = ~np.isfinite(y)
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise DataError(f"{source}: {what} has {int(bad.sum())} non-finite samples (NaN or "
                        f"inf), the first at sample {first} (allowed: finite numbers); clean the "
                        f"file: fill the missing samples (e.g. by linear interpolation) or cut "
                        f"the record before them")


def check_uniform(t: np.ndarray, source: str, rtol: float,
                   lines: np.ndarray | None = None) -> None:
    step = np.diff(t)
    where = "sample {i}" if lines is None else "line {line}"
    if (step <= 0).any():
        i = int(np.flatnonzero(step <= 0)[0]) + 1
        at = where.format(i=i, line=None if lines is None else lines[i])
        raise DataError(f"{source}: time is not strictly increasing at {at} "
                        f"(t = {float(t[i - 1]):.10g} s then {float(t[i]):.10g} s) (allowed: "
                        f"strictly increasing sample times); clean the file: remove repeated or "
                        f"out-of-order rows")
    typical = np.median(step)  # robust: a gap does not shift it
    dev = np.abs(step - typical) / typical
    if (dev > rtol).any():
        i = int(np.argmax(dev > rtol)) + 1
        at = where.format(i=i, line=None if lines is None else lines[i])
        raise DataError(f"{source}: time vector is not uniform: the step ending at {at} is "
                        f"{float(step[i - 1]):.6g} s, the median step is {float(typical):.6g} s "
                        f"(allowed: steps within {rtol:g} of the median, relative); a gap or "
                        f"jitter in the record: clean the file (fill the gap, or resample the "
                        f"record to a uniform time base), or use the part before or after it "
                        f"in its own file")


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


def apply_nan_policy(y: np.ndarray, on_nan: NanPolicy, max_gap: int, name: str, source: str,
                      lines: np.ndarray) -> np.ndarray:
    bad = np.isnan(y)
    if not bad.any():
        return y
    if on_nan == "interpolate":
        return fill_gaps(y, max_gap, name=f"column {name!r}", source=source)
    first = int(np.flatnonzero(bad)[0])
    raise DataError(f"{source}: column {name!r} has {int(bad.sum())} missing samples (empty or "
                    f"NaN), the first at line {lines[first]} (allowed: a number in every row); "
                    f"clean the file: fill the missing samples (e.g. by linear interpolation) "
                    f"or cut the record before them")


def check_nan_policy(on_nan: str, max_gap: int) -> None:
    if on_nan not in ("raise", "interpolate"):
        raise ConfigError(f"on_nan must be 'raise' or 'interpolate', got {on_nan!r}")
    if max_gap < 1:
        raise ConfigError(f"max_gap must be >= 1 sample, got {max_gap}")


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
    check_uniform(t, "resample", TIME_RTOL)
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

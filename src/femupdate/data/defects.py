"""Defects of a trial's records that a fit would hide: found, said, and repaired on request.

A record can be read without an error and still be wrong: sensor clocks started seconds apart,
the same file exported twice, one absurd sample, a saturated sensor, a unit or time unit
mistaken, a sample rate or length that cannot show the model's first mode. Each check here is
a small pure function over the channels of one trial (in m/s², on the time base they were
read with) that returns :class:`Finding` records: the kind, the file, the channel, the
evidence in numbers and the repair that would mend it. Thresholds rest on robust statistics
or physics, not on one record (docs/data-checks.md says why each is where it is).

Kinds (`KINDS`): ``clock-offset``, ``clock-drift``, ``misaligned``, ``duplicate``, ``spike``,
``saturation``, ``unit``, ``time-unit``, ``rate``, ``short``. The ones a repair can mend
safely (`REPAIRABLE`): ``clock-offset`` (align the files by row) and ``spike`` (interpolate the
spike from its neighbours).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np
import scipy.ndimage
import scipy.signal

from femupdate.units import STANDARD_GRAVITY, TIME_UNITS

__all__ = [
    "KINDS",
    "REPAIRABLE",
    "ClockRecord",
    "Finding",
    "check_alignment",
    "check_clocks",
    "check_duplicates",
    "check_length_and_rate",
    "check_saturation",
    "check_spikes",
    "check_units",
    "interpolate_samples",
]

KINDS = ("clock-offset", "clock-drift", "misaligned", "duplicate", "spike", "saturation",
         "unit", "time-unit", "rate", "short")
REPAIRABLE = ("clock-offset", "spike")

#: Files with this many rows or fewer apart run "in step" (an export may drop its last row).
ROWS_IN_STEP = 1
#: Start stamps of files that run in step further apart than this many sample intervals are a
#: clock offset: well beyond a sensor latency (a few samples, removed by ``delay``).
OFFSET_SAMPLES = 10
#: Rates differing by less than this (relative) are one nominal rate on two clocks (crystal
#: clocks: ~1e-4); more is a different nominal rate, resampled on purpose.
DRIFT_MAX_REL = 0.01
#: A drift that moves the files by more than this many samples over the record is a defect.
DRIFT_SAMPLES = 0.5
#: A channel is a copy of another when a scale of the other matches it at every sample to
#: within this share of the two values (the rounding of an export to 6 significant digits
#: leaves at most 5e-6 of a value, single precision 6e-8) and this share of its rms (an
#: export with a fixed number of decimals).
DUPLICATE_ROUNDING = 1e-5
DUPLICATE_QUANTUM = 1e-6
#: A structure's response follows its base within `LAG_PERIODS` periods of its first mode
#: (its impulse response has its largest values there) or `LAG_SECONDS`, whichever is longer.
LAG_SECONDS = 0.5
LAG_PERIODS = 5.0
#: A best lag beyond that, with a correlation this many times the largest within it, is a
#: misalignment (a clear peak, not noise in the estimate or the next period of a sine).
LAG_GAIN = 2.0
#: The longest lag searched, s, and the share of the record it may reach.
LAG_SEARCH_S = 30.0
LAG_SEARCH_SHARE = 0.5
#: A spike: a sample further from the median of the 7 around it than this many times the
#: 90th percentile of the signal's steps |Δy| just before or after it, over `SPIKE_WINDOW`
#: // 2 steps (for Gaussian noise of σ: 10 × 2.3 σ).
SPIKE_FACTOR = 10.0
SPIKE_WINDOW = 121
#: The samples of a spike: at most this many in a row (of either sign).
SPIKE_WIDTH = 2
#: Samples beyond this many times the scale, less than `SPIKE_GAP` samples apart, are one event.
SPIKE_NEAR = 3.0
SPIKE_GAP = 3
#: Saturation: the record's extreme value reached by 2 samples or more (a float record never
#: repeats its peak value; a clipped sensor does); in a quantized record (equal neighbours
#: elsewhere) held over at least this many samples, in a run longer than any elsewhere.
SATURATION_SAMPLES = 4
SATURATION_RUN = 3
#: Values recur in a record when this many distinct values (away from its extremes) occur
#: more than once: a periodic signal sampled in step with its period, or a quantized one.
SATURATION_RECURRING = 3
#: The peak of the input beyond this many g: stronger than any earthquake record (about 4 g)
#: or shake-table test: data in m/s² declared as g, or cm/s² as m/s².
INPUT_PEAK_G = 4.0
#: Below the first mode the structure moves with its base: output/input gain ≈ 1. A gain
#: beyond this factor (either way) says the two channels are in different units.
GAIN_FACTOR = 3.0
#: Coherence needed at a frequency for its gain to count.
GAIN_COHERENCE = 0.8
#: The spectra's segments: at least this many (half-overlapping) in the record, each at
#: least this many periods of the first mode long (frequencies spaced by f1 / 6 or finer:
#: two or more below f1 / 3).
GAIN_SEGMENTS = 8
GAIN_RESOLUTION = 6.0
#: A record shorter than this many periods of the first mode cannot show it.
MIN_PERIODS = 5.0
#: Fewer samples than this: no statistics are meaningful, only the length is checked.
MIN_SAMPLES = 16
#: Factors of a time unit mistaken (ms or µs for s, and back).
TIME_FACTORS = (1e3, 1e6, 1e-3, 1e-6)


@dataclass(frozen=True)
class Finding:
    """One defect of a record.

    Attributes
    ----------
    kind : str
        One of `KINDS`.
    file : str
        The file (or files, joined by " / ") it was found in.
    channel : str
        The channel (``"input"`` or an output's label; "" for a whole file).
    severity : {"error", "warning"}
        ``"error"``: the record would be fitted wrong; a run on it is no success unless the
        defect is repaired or accepted. ``"warning"``: said, does not fail a run.
    evidence : str
        What was measured, in numbers.
    repair : str
        What would mend it (the option, or what to fix in the file).
    status : {"open", "repaired", "accepted"}
        What became of it.
    trial : str
        The trial it belongs to ("" for the case's ``[data]``).
    """

    kind: str
    file: str
    channel: str
    severity: str
    evidence: str
    repair: str
    status: str = "open"
    trial: str = ""

    def describe(self) -> str:
        """One line: file, channel, kind, evidence, and the repair or what became of it."""
        where = f"{self.file}: channel {self.channel!r}" if self.channel else self.file
        tail = {"open": f"fix: {self.repair}", "repaired": "repaired",
                "accepted": "accepted by [data] accept"}[self.status]
        trial = f"trial {self.trial!r}: " if self.trial else ""
        return f"{trial}{where}: {self.kind}: {self.evidence} ({tail})"

    def with_status(self, status: str) -> Finding:
        return replace(self, status=status)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True)
class ClockRecord:
    """A file's time stamps as read (s, on its own clock), for the clock checks."""

    file: str
    channel: str
    t: np.ndarray


# --------------------------------------------------------------------------- clocks


def _rate(t: np.ndarray) -> float:
    return float((t.size - 1) / (t[-1] - t[0]))


def check_clocks(records: Sequence[ClockRecord]) -> list[Finding]:
    """Clock offset and drift of each file against the first (the input's).

    Offset: files whose row counts agree (within `ROWS_IN_STEP`: the rows run in step) but
    whose first time stamps differ by more than `OFFSET_SAMPLES` sample intervals; aligned on
    their stamps they would be shifted against each other by that much. Drift: rates that
    differ by less than `DRIFT_MAX_REL` (one nominal rate) but enough to move the files apart
    by more than `DRIFT_SAMPLES` samples over the record.
    """
    if len(records) < 2:
        return []
    ref = records[0]
    findings, seen = [], {ref.file}
    for rec in records[1:]:
        if rec.file in seen or rec.t.size < 2 or ref.t.size < 2:
            continue
        seen.add(rec.file)
        rate_ref, rate = _rate(ref.t), _rate(rec.t)
        dt = 1.0 / rate_ref
        offset = float(rec.t[0] - ref.t[0])
        in_step = abs(rec.t.size - ref.t.size) <= ROWS_IN_STEP
        if in_step and abs(offset) > OFFSET_SAMPLES * dt:
            findings.append(Finding(
                "clock-offset", f"{ref.file} / {rec.file}", rec.channel, "error",
                f"{ref.t.size} and {rec.t.size} rows (in step) but the time stamps start "
                f"{offset:+.4g} s apart ({abs(offset) / dt:.0f} samples; t0 = "
                f"{ref.t[0]:.6g} s and {rec.t[0]:.6g} s): aligned on the stamps the channels "
                "would be shifted by that much",
                "align the files by row: [data] repair_defects = [\"clock-offset\"]"))
        rel = abs(rate - rate_ref) / rate_ref
        moved = rel * max(rec.t.size, ref.t.size)
        if 0.0 < rel < DRIFT_MAX_REL and moved > DRIFT_SAMPLES:
            findings.append(Finding(
                "clock-drift", f"{ref.file} / {rec.file}", rec.channel, "error",
                f"sample rates {rate_ref:.8g} Hz and {rate:.8g} Hz ({1e6 * rel:.0f} ppm apart): "
                f"the clocks drift by {moved:.1f} samples over the record",
                "resample the file on one clock before reading it (no safe repair here)"))
    return findings


def _detrended(y: np.ndarray) -> np.ndarray:
    return scipy.signal.detrend(np.asarray(y, dtype=float), type="linear")


def check_alignment(x: np.ndarray, outputs: Mapping[str, np.ndarray], rate: float,
                    files: Mapping[str, str], *, first_mode_hz: float | None = None
                    ) -> list[Finding]:
    """Outputs whose cross-correlation with the input peaks far from lag 0.

    The correlation (biased: the overlap's share weighs each lag) of the detrended signals is
    searched over ±`LAG_SEARCH_S` s (at most `LAG_SEARCH_SHARE` of the record). A structure's
    response follows its base within a few periods of its first mode; a best lag beyond both
    `LAG_SECONDS` and `LAG_PERIODS` periods, with a correlation `LAG_GAIN` times the largest
    within them, is a misalignment (clocks set apart, or a record of another test).
    """
    n = x.size
    if n < MIN_SAMPLES:
        return []
    with np.errstate(all="ignore"):
        xd = _detrended(x)
    reach = int(min(LAG_SEARCH_S * rate, LAG_SEARCH_SHARE * n))
    limit = LAG_SECONDS
    if first_mode_hz:
        limit = max(limit, LAG_PERIODS / first_mode_hz)
    findings = []
    for name, y in outputs.items():
        with np.errstate(all="ignore"):
            yd = _detrended(y)
            scale = float(np.linalg.norm(xd) * np.linalg.norm(yd))
        if scale == 0.0 or not np.isfinite(scale):
            continue
        corr = scipy.signal.correlate(yd, xd, mode="full", method="fft") / scale
        lags = scipy.signal.correlation_lags(n, n, mode="full")
        inside = np.abs(lags) <= reach
        corr, lags = corr[inside], lags[inside]
        near = np.abs(lags) <= limit * rate
        best = int(np.argmax(np.abs(corr)))
        within = float(np.max(np.abs(corr[near])))
        lag_s = lags[best] / rate
        if abs(lag_s) > limit and abs(corr[best]) >= LAG_GAIN * within:
            findings.append(Finding(
                "misaligned", files.get(name, ""), name, "error",
                f"its correlation with the input peaks at a lag of {lag_s:+.4g} s "
                f"(ρ = {corr[best]:.2f}, against at most {within:.2f} within ±{limit:.3g} s, "
                "where a structure's response follows its base)",
                "check the files' clocks and that they are records of the same test; align "
                "them (a time column with the right start, or [data] window)"))
    return findings


def copy_scale(a: np.ndarray, b: np.ndarray) -> tuple[float, float] | None:
    """``(s, worst)`` when ``b`` is a copy of ``a``: ``b = s·a`` at every sample to within
    the rounding of an export, ``|b − s·a| ≤ DUPLICATE_ROUNDING·(|b| + |s·a|) +
    DUPLICATE_QUANTUM·rms(b)``; ``worst`` is the largest share of that bound a sample uses.
    None otherwise (or when either channel is 0 throughout or not finite).

    A rounding error is proportional to the value rounded (or, for an export with a fixed
    number of decimals, a quantum): near a zero crossing it vanishes. The difference of two
    sensors does not: their own noise, and, noise-free, the modes they mix in other
    proportions (two adjacent top floors of a 200-storey building: 2.5e-4 of the rms).
    """
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        aa, ab, bb = float(a @ a), float(a @ b), float(b @ b)
        if not (np.isfinite(aa) and np.isfinite(bb) and aa > 0 and bb > 0):
            return None
        s = ab / aa
        bound = (DUPLICATE_ROUNDING * (np.abs(b) + np.abs(s * a))
                 + DUPLICATE_QUANTUM * np.sqrt(bb / b.size))
        worst = float(np.max(np.abs(b - s * a) / bound))
    return (s, worst) if worst <= 1.0 else None


def check_duplicates(channels: Mapping[str, np.ndarray], files: Mapping[str, str]
                     ) -> list[Finding]:
    """Channels that are copies of another: the same samples, noise and all, up to a unit
    factor and the rounding of an export (see `copy_scale`).

    A copy is what a file exported twice, or a column read twice, gives; two sensors never
    give one, however alike they move (a correlation of 0.99999 between two floors of a
    tall building, or in a steady sine test below the first mode, is no evidence).
    """
    names = list(channels)
    if len(names) < 2 or next(iter(channels.values())).size < MIN_SAMPLES:
        return []
    findings = []
    for j, b in enumerate(names):
        for a in names[:j]:
            same = np.array_equal(channels[a], channels[b])
            fit = None if same else copy_scale(np.asarray(channels[a], dtype=float),
                                               np.asarray(channels[b], dtype=float))
            if not same and fit is None:
                continue
            how = (" sample for sample" if same else
                   f" × {fit[0]:.6g} to within the rounding of an export at every sample"
                   if fit else "")
            findings.append(Finding(
                "duplicate", " / ".join(dict.fromkeys((files.get(a, ""), files.get(b, "")))),
                b, "error", f"identical to channel {a!r}{how}: a copy, not a second sensor",
                "read each channel from its own record (the same file exported twice?)"))
            break
    return findings


# --------------------------------------------------------------------------- single channels


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) of each run of True."""
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist(),
                    strict=True))


def _step_scale(y: np.ndarray, half: int) -> np.ndarray:
    """At each sample, the larger of the 90th percentiles of the sample-to-sample steps
    ``|Δy|`` over the ``half`` steps just before it and just after it (windows that leave a
    spike's own steps out). At the record's ends only the side inside the record counts."""
    n = y.size
    with np.errstate(over="ignore", invalid="ignore"):
        step = np.abs(np.diff(y))
    step = np.where(np.isfinite(step), step, np.finfo(float).max)
    centred = scipy.ndimage.percentile_filter(step, 90, size=half, mode="reflect")
    positions = np.arange(n)
    shift = half // 2 + SPIKE_WIDTH + 2
    before_at, after_at = positions - shift - 1, positions + shift
    before = np.where(before_at >= 0, centred[np.clip(before_at, 0, n - 2)], 0.0)
    after = np.where(after_at <= n - 2, centred[np.clip(after_at, 0, n - 2)], 0.0)
    return np.maximum(before, after)


def spike_samples(y: np.ndarray) -> np.ndarray:
    """Indices of the spikes of ``y``: its non-finite samples, and isolated samples far off
    the signal (see `check_spikes`), anywhere in the record, its first and last samples
    included."""
    y = np.asarray(y, dtype=float)
    bad = ~np.isfinite(y)
    if y.size < MIN_SAMPLES:
        return np.flatnonzero(bad)
    if bad.all():
        return np.arange(y.size)
    work = interpolate_samples(y, np.flatnonzero(bad)) if bad.any() else y
    # each sample's distance from the median of the 7 samples around it (mirrored at the
    # ends): a median is not moved by a spike of up to 3 samples, even at the record's end,
    # and follows a monotone stretch of the signal exactly
    with np.errstate(over="ignore", invalid="ignore"):
        deviation = work - scipy.ndimage.median_filter(work, size=7, mode="mirror")
    off = np.where(np.isfinite(deviation), np.abs(deviation), np.finfo(float).max)
    # against the signal's own steps around it: a crest, a cusp or a kink (a hysteretic
    # reversal) is a step or two off its median, a spike many times the steps on both sides
    half = min(SPIKE_WINDOW // 2, y.size // 2)
    with np.errstate(over="ignore", invalid="ignore"):
        steps = np.abs(np.diff(work))
    finite_steps = steps[np.isfinite(steps)]
    positive = finite_steps[finite_steps > 0]
    # a floor: a twentieth of the record's typical step, and its quantum (the smallest step):
    # a quiet or quantized stretch does not make a sample one step off a spike
    floor = max(0.05 * float(np.percentile(finite_steps, 90)) if finite_steps.size else 0.0,
                float(positive.min()) if positive.size else 0.0)
    scale = np.maximum(_step_scale(work, half), floor)
    with np.errstate(over="ignore"):
        far, near = off > SPIKE_FACTOR * scale, off > SPIKE_NEAR * scale
    # a burst of motion (a knock) is many samples off, a glitch one or two (+A, -A: two-sided):
    # samples above SPIKE_NEAR × the scale less than SPIKE_GAP apart are one event
    bridged = scipy.ndimage.binary_closing(near, structure=np.ones(SPIKE_GAP + 1, dtype=bool))
    bridged |= near
    keep = bad.copy()
    for a, b in _runs(bridged):
        if b - a <= SPIKE_WIDTH and far[a:b].any():
            keep[a:b] |= near[a:b]
    return np.flatnonzero(keep)


def check_spikes(name: str, y: np.ndarray, t: np.ndarray, file: str, *,
                 within: tuple[float, float] | None = None) -> list[Finding]:
    """Spikes, said with their values, times and the rest of the record's peak.

    Each sample is measured by its distance from the median of the 7 samples around it
    (mirrored at the record's ends, so that the first and last samples are measured like any
    other; a median is not moved by a glitch of up to 3 samples). Its scale is the signal's
    own step there: the larger of the 90th percentiles of ``|Δy|`` over the `SPIKE_WINDOW`
    // 2 steps just before and just after it (windows that leave the glitch's own steps out;
    at the ends, the side inside the record). A spike is more than `SPIKE_FACTOR` times that
    scale off, in an event of at most `SPIKE_WIDTH` samples more than `SPIKE_NEAR` times it
    off (either sign: +A then -A is a two-sided glitch), where a burst of motion (the table
    starting, a knock) is many samples off. A crest, a cusp or a kink of the signal (a
    hysteretic reversal, a linearly interpolated record) is a step or two off its median,
    never ten. Non-finite samples are spikes of any size.

    ``within``: only the spikes at times in this closed interval are said (``t``'s clock).
    """
    y = np.asarray(y, dtype=float)
    idx = spike_samples(y)
    if within is not None and idx.size:
        idx = idx[(t[idx] >= within[0]) & (t[idx] <= within[1])]
    if idx.size == 0:
        return []
    others = np.delete(np.abs(y), spike_samples(y))  # every spike, said or not
    peak = float(others.max()) if others.size else 0.0
    shown = ", ".join(f"{y[i]:.4g} m/s² at t = {t[i]:.6g} s (sample {i} of {y.size})"
                      for i in idx[:3])
    more = f" and {idx.size - 3} more" if idx.size > 3 else ""
    return [Finding("spike", file, name, "error",
                    f"{idx.size} isolated sample(s) far off the signal: {shown}{more}; the "
                    f"rest of the record peaks at {peak:.4g} m/s²",
                    'interpolate them from their neighbours: [data] repair_defects = ["spike"]')]


def check_saturation(name: str, y: np.ndarray, file: str) -> list[Finding]:
    """A flat top: a sensor at the end of its range holds its extreme value.

    A record whose samples never recur (floating-point samples of a noisy signal) never
    repeats its peak value: there, the extreme value reached by 2 samples or more, at the top
    or the bottom, is a flat top. Where values recur anyway (a quantized record: equal
    neighbours; a noise-free periodic signal sampled in step with its period: each crest's
    value again at every period), only a run is evidence: at least `SATURATION_RUN` equal
    samples in a row at the extreme (a smooth crest holds at most two, symmetric about it),
    longer than any run of equal values elsewhere, and at least `SATURATION_SAMPLES` held in
    all. Runs at the record's start or end are the structure at rest, not evidence. A
    constant channel (one value throughout) is a dead sensor.
    """
    y = np.asarray(y, dtype=float)
    if y.size < MIN_SAMPLES or not np.all(np.isfinite(y)):
        return []
    if y.max() == y.min():
        return [Finding(
            "saturation", file, name, "error",
            f"constant: all {y.size} samples are {y[0]:.6g} m/s² (a dead sensor, or a column "
            "that holds no record)",
            "read the channel's own column, or record it again")]
    findings = []
    extremes = (y == y.max()) | (y == y.min())
    # equal neighbours away from the extremes: a quantized record, where holding a value is
    # no evidence by itself
    held_elsewhere = [b - a for a, b in
                      _runs(np.concatenate(([False], np.diff(y) == 0.0)) & ~extremes)]
    _, counts = np.unique(y[~extremes], return_counts=True)
    recurring = bool(held_elsewhere) or int(np.sum(counts > 1)) >= SATURATION_RECURRING
    for side, extreme in (("top", float(y.max())), ("bottom", float(y.min()))):
        # a run at the record's start or end is the structure at rest (a noise-free record
        # of a pulse is 0 before and after it, and 0 is its bottom), not a sensor clipping
        at_rest = [(a, b) for a, b in _runs(y == extreme) if a == 0 or b == y.size]
        at = y == extreme
        for a, b in at_rest:
            at[a:b] = False
        if not at.any():
            continue
        runs = [b - a for a, b in _runs(at)]
        held = int(at.sum())
        if recurring:
            longest = max(runs)
            if (longest < SATURATION_RUN or sum(r for r in runs if r >= 2) < SATURATION_SAMPLES
                    or longest <= max(held_elsewhere, default=0) + 1):
                continue
        elif held < 2:
            continue
        findings.append(Finding(
            "saturation", file, name, "error",
            f"{held} samples at exactly its {side} value {extreme:.6g} m/s² (longest run "
            f"{max(runs)}): a sensor at the end of its range",
            "record again with a larger range, or fit a window without the clipped part"))
    return findings


# --------------------------------------------------------------------------- units and rates


def check_units(x: np.ndarray, outputs: Mapping[str, np.ndarray], rate: float,
                declared: Mapping[str, str], files: Mapping[str, str], *,
                first_mode_hz: float | None = None) -> list[Finding]:
    """Accelerations in a unit other than the one declared.

    The input's peak beyond `INPUT_PEAK_G` g is stronger than any earthquake record or
    shake-table test: m/s² declared as g (×9.81) or cm/s² as m/s². Below the first mode a
    base-excited structure moves with its base, so the output/input gain there is about 1; a
    median gain (where the coherence is at least `GAIN_COHERENCE`) off by more than
    `GAIN_FACTOR` either way says the two channels are in different units (g against m/s² is
    a factor 9.81).
    """
    findings = []
    if x.size >= MIN_SAMPLES:
        peak_g = float(np.max(np.abs(x))) / STANDARD_GRAVITY
        if peak_g > INPUT_PEAK_G:
            findings.append(Finding(
                "unit", files.get("input", ""), "input", "error",
                f"the input peaks at {peak_g:.3g} g in the declared unit "
                f"{declared.get('input', '?')!r} (allowed: up to {INPUT_PEAK_G:g} g, stronger "
                "than any earthquake record)",
                "declare the unit the file holds: [data] unit (m/s² declared as g is 9.81× "
                "too large)"))
    if first_mode_hz is None or x.size < 4 * MIN_SAMPLES:
        return findings
    # segments long enough for frequencies below a third of the first mode, and few enough
    # in the record for `GAIN_SEGMENTS` averages: a coherence of fewer is near 1 whatever
    # the signals (of one segment it is 1), and a gain where the record has no energy passes
    nperseg = int(2 ** np.ceil(np.log2(GAIN_RESOLUTION * rate / first_mode_hz)))
    if nperseg < 8 or x.size < (GAIN_SEGMENTS + 1) * nperseg // 2:
        return findings
    for name, y in outputs.items():
        with np.errstate(all="ignore"):  # absurd values give inf and NaN: no gain, no finding
            f, pxy = scipy.signal.csd(x, y, fs=rate, nperseg=nperseg, detrend="linear")
            _, pxx = scipy.signal.welch(x, fs=rate, nperseg=nperseg, detrend="linear")
            _, coh = scipy.signal.coherence(x, y, fs=rate, nperseg=nperseg, detrend="linear")
        band = ((f > 0) & (f <= first_mode_hz / 3) & (coh >= GAIN_COHERENCE) & (pxx > 0)
                & np.isfinite(pxx) & np.isfinite(pxy))
        if band.sum() < 2:
            continue
        gain = float(np.median(np.abs(pxy[band]) / pxx[band]))
        if gain > GAIN_FACTOR or gain < 1.0 / GAIN_FACTOR:
            findings.append(Finding(
                "unit", files.get(name, ""), name, "error",
                f"below the first mode ({first_mode_hz:.3g} Hz, where the structure moves with "
                f"its base) its gain over the input is {gain:.3g} (allowed: within "
                f"{GAIN_FACTOR:g}× of 1; g against m/s² is 9.81×); declared "
                f"{declared.get(name, '?')!r} against the input's "
                f"{declared.get('input', '?')!r}",
                "declare each channel's unit ([data] unit, or the channel's unit)"))
    return findings


def _plausible(rate: float, duration: float, first_mode_hz: float) -> tuple[bool, bool]:
    return rate >= 2.0 * first_mode_hz, duration >= MIN_PERIODS / first_mode_hz


def check_length_and_rate(n: int, rate: float, first_mode_hz: float | None, file: str, *,
                          time_unit: str | None = None) -> list[Finding]:
    """A sample rate below twice the model's first natural frequency (it cannot be seen), a
    record shorter than `MIN_PERIODS` periods of it; when a factor of 1000 or 10⁶ on the
    times would make both plausible (and the times came from a time column, ``time_unit``
    given), a time unit mistaken."""
    duration = n / rate
    if first_mode_hz is None or not first_mode_hz > 0:
        if n < MIN_SAMPLES:
            return [Finding("short", file, "", "error",
                            f"{n} samples: too few to fit anything",
                            "a record of the whole test")]
        return []
    rate_ok, long_ok = _plausible(rate, duration, first_mode_hz)
    if rate_ok and long_ok:
        return []
    period = 1.0 / first_mode_hz
    if time_unit is not None and n >= MIN_SAMPLES:
        for factor in TIME_FACTORS:
            if all(_plausible(rate * factor, duration / factor, first_mode_hz)):
                scale = TIME_UNITS.get(time_unit, 1.0) / factor
                likely = [u for u, v in TIME_UNITS.items() if np.isclose(v, scale)]
                return [Finding(
                    "time-unit", file, "", "error",
                    f"{n} samples at {rate:.4g} Hz ({duration:.4g} s) with time_unit = "
                    f"{time_unit!r}, for a model whose first mode is at {first_mode_hz:.4g} Hz: "
                    f"with times {factor:g}× {'larger' if factor < 1 else 'smaller'} "
                    f"({rate * factor:.4g} Hz, {duration / factor:.4g} s) the record would "
                    "be plausible" + (f": times in {likely[0]}?" if likely else ""),
                    "declare the unit of the time column: [data] time_unit"
                    + (f" = \"{likely[0]}\"" if likely else ""))]
    findings = []
    if not rate_ok:
        findings.append(Finding(
            "rate", file, "", "error",
            f"sampled at {rate:.4g} Hz, below twice the model's first natural frequency "
            f"{first_mode_hz:.4g} Hz (nominal parameters): the mode cannot be seen",
            "a record sampled faster, or check [data] rate / time_unit"))
    if not long_ok:
        findings.append(Finding(
            "short", file, "", "error",
            f"{n} samples, {duration:.4g} s: shorter than {MIN_PERIODS:g} periods of the "
            f"model's first mode ({MIN_PERIODS * period:.4g} s at {first_mode_hz:.4g} Hz)",
            "a record of the whole test, or a wider [data] window"))
    return findings


# --------------------------------------------------------------------------- repairs


def interpolate_samples(y: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """``y`` with the samples ``idx`` replaced by linear interpolation from the others."""
    y = np.array(y, dtype=float)
    if idx.size == 0:
        return y
    bad = np.zeros(y.size, dtype=bool)
    bad[idx] = True
    positions = np.arange(y.size)
    y[bad] = np.interp(positions[bad], positions[~bad], y[~bad])
    return y

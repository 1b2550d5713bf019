"""Measured data of a case, read and processed as the paper did (its §5.2; docs/method.md).

files ─► Measurement (SI units, one time base, window) ─► channel delays removed ─► high-pass
─► the base input a_g and, per output channel, the target: relative displacement (channel −
table, integrated twice by the trapezoidal rule) or absolute acceleration.

A case may hold several trials (``[[trials]]``): each is read and processed on its own
(:func:`load_experiments`), with its own delays; the model is shared.

Why this file is long (about 630 lines): every check that needs the records themselves (files
present and in step, rates, windows past the end, delays that disagree between trials, the band
against the model's modes) runs where the records are read, so that each names the file,
channel and field it is about; the checks of the signals' defects are apart (trial_checks).
"""

from __future__ import annotations

import math
import warnings
import zipfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from femupdate.case import Case, Data, TrialSpec, format_value
from femupdate.case.schema import Channel
from femupdate.data import io, network, signal
from femupdate.data.defects import Finding
from femupdate.errors import ConfigError, DataError, FemupdateError, FemupdateWarning
from femupdate.trials import checks as trial_checks
from femupdate.units import ACCELERATION_UNITS, TIME_UNITS

__all__ = ["Experiment", "apply_delays", "data_files", "load_experiment", "load_experiments",
           "process",
           "read_measurement"]

#: Samples trimmed beyond those a shift leaves undefined: where the band-limited shift of
#: `signal.advance` is approximate (within 0.5 % of the record's scale on measured records).
DELAY_TRIM_EXTRA = 4
#: An estimated delay longer than this many samples, where the median coherence in the band is
#: below ``DELAY_COHERENCE``, is reported as doubtful: a large shift on a poor estimate.
DELAY_SAMPLES_DOUBTFUL = 3
DELAY_COHERENCE = 0.8


@dataclass(frozen=True)
class Experiment:
    """The processed measurement of a case.

    Attributes
    ----------
    t : ndarray (n,)
        Sample times from 0 (s).
    ag : ndarray (n,) or (n, g)
        Processed base (table) acceleration, m/s², the model's input; with support groups
        (``[[model.support_groups]]``) a column per group, in the model's order; with
        several components (``[[data.components]]``, an input's ``angle``) a column per
        direction, in ``Data.base_directions``'s order.
    accelerations : ndarray (n, k)
        Processed accelerations of the output channels, m/s² (absolute, or as recorded with
        support groups).
    target : ndarray (n, k)
        What the error function compares: relative displacements (m) or absolute
        accelerations (m/s²), by ``quantity``.
    quantity : {"displacement", "acceleration"}
    channels : tuple of str
        Output channel labels.
    weights : ndarray (k,)
    delays : dict of str to float
        Delay (s) removed from each output channel whose ``delay`` is not 0 (given, or
        estimated for ``"auto"``); empty when none was.
    ag_unfiltered : ndarray (n,) or (n, g) or None
        The base acceleration before the high-pass (None: there was none), the input of a model
        whose prediction is filtered instead (``Case.filters_prediction``).
    name, role, weight : str, str, float
        The trial's name, ``"fit"`` or ``"validate"``, and its weight in φ.
    start_s : float
        Record time of the first sample (the window's start, after the samples a delay trims).
    score : slice
        The samples the error function scores (all, unless the trial has a ``score_window``).
    notes : tuple of str
        What was noticed while reading and processing (repairs, doubtful delays), to report.
    defects : tuple of Finding
        The defects the checks found in the trial's records (:mod:`femupdate.data.defects`),
        each open, repaired or accepted.
    """

    t: np.ndarray
    ag: np.ndarray
    accelerations: np.ndarray
    target: np.ndarray
    quantity: str
    channels: tuple[str, ...]
    weights: np.ndarray
    delays: dict[str, float] = field(default_factory=dict)
    ag_unfiltered: np.ndarray | None = None
    name: str = ""
    role: str = "fit"
    weight: float = 1.0
    start_s: float = 0.0
    score: slice = field(default_factory=lambda: slice(None))
    notes: tuple[str, ...] = ()
    defects: tuple[Finding, ...] = ()

    @property
    def dt(self) -> float:
        return float(self.t[1] - self.t[0])


def _read(data: Data, file: Path, column: str | int, name: str) -> io.Measurement:
    """One channel of a file, renamed ``name`` once read: read errors name the file's column."""
    if data.format == "csv":
        rec = io.read_csv(
            file, [column], time=data.time_column, rate=data.rate,
            time_scale=TIME_UNITS[data.time_unit], delimiter=data.delimiter,
            skip_lines=data.skip_lines, header=data.header, skip_rows=data.skip_rows,
            comments=data.comments, repair=data.repair,
        )
    elif data.format == "npz":
        rec = io.read_npz(file, [str(column)])
    elif data.format in network.FORMATS:  # in m/s² from the header's units
        rec = io.read_network(file, [column], format=data.format)
    else:
        rec = io.read_uff58(file, [str(column)])
    (read_as,) = rec.names
    return replace(rec.rename({read_as: name}), notes=rec.notes)


def _check_rates(case: Case, records: list[io.Measurement]) -> None:
    """Files at different rates need ``resample_hz``; say so in the case file's words."""
    rates = {rec.source: rec.rate for rec in records}  # one entry per file
    fastest = max(rates.values())
    if max(rates.values()) - min(rates.values()) <= 1e-6 * fastest:
        return
    listing = ", ".join(f"{source}: {rate:.6g} Hz" for source, rate in rates.items())
    raise DataError(f"{case.label}: the data files are sampled at different rates ({listing}); "
                    f"set [preprocess] resample_hz = {format_value(float(f'{fastest:.6g}'))} "
                    "(or another rate) to resample all channels to one rate")


def data_files(case: Case) -> dict[str, Path]:
    """The files the case reads (every trial's): each ``file`` as written → its path."""
    return {channel.file: case.data_path(channel, spec.data) for spec in case.trial_specs()
            for channel in _channels(spec.data)}


def _channels(data: Data) -> list[Channel]:
    """The input channels (the table's, or each support group's), then the outputs."""
    return [c for _, _, c in data.input_channels()] + list(data.outputs)


def input_names(case: Case) -> tuple[str, ...]:
    """The names of the input channels once read, in the model's order: ``("input",)``,
    ``"input.<group>"`` for each of ``[[model.support_groups]]``, or ``"input.<direction>"``
    for each of ``[[data.components]]``."""
    groups = case.model.support_groups
    if groups:
        return tuple(f"input.{g.name}" for g in groups)
    if case.data is not None and case.data.components is not None:
        return tuple(f"input.{c.direction}" for c in case.data.components)
    return ("input",)


def header_recipe(case: Case) -> str | None:
    """The ``femupdate synth`` command in the case file's header comments, if it gives one.

    Example case files say how their records are made (a virtual experiment); the command may
    continue over comment lines ending in a backslash.
    """
    if case.source is None:
        return None
    try:
        lines = Path(case.source).read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError):
        return None
    parts: list[str] = []
    for line in lines:
        if not line.startswith("#"):
            break  # the header ends at the first line that is not a comment
        text = line.lstrip("#").strip()
        if parts or text.startswith("femupdate synth "):
            parts.append(text.removesuffix("\\").strip())
            if not text.endswith("\\"):
                break
    return " ".join(parts) or None


def _check_files(case: Case, data: Data) -> None:
    """Every data file must exist: the missing ones are named with the fields that read them."""
    folder = case.data_directory(data)
    if folder.is_file():
        raise DataError(f"{case.label}: data.directory = {data.directory!r} is a file, not a "
                        f"folder ({folder}) (allowed: the folder that holds the data files, "
                        "relative to the case file's folder)")
    fields: dict[Path, list[str]] = {}
    channels = [(f"data.{path}", c) for _, path, c in data.input_channels()] + [
        (f"data.outputs[{i}]", c) for i, c in enumerate(data.outputs)]
    for where, channel in channels:
        fields.setdefault(case.data_path(channel, data), []).append(f"{where}.file")
    # a network record may be a folder of the network's files, one per channel
    folders = {path: where for path, where in fields.items()
               if path.is_dir() and data.format not in network.FORMATS}
    if folders:
        listing = "; ".join(f"{path} ({', '.join(where)})" for path, where in folders.items())
        raise DataError(f"{case.label}: a folder, not a data file: {listing} (allowed: a "
                        "file; name the file in the folder)")
    missing = {path: where for path, where in fields.items() if not path.exists()}
    if not missing:
        return
    listing = "; ".join(f"{path} ({', '.join(where)})" for path, where in missing.items())
    directory = (f"data.directory = {data.directory!r}" if data.directory is not None
                 else "no data.directory: the case file's folder")
    recipe = header_recipe(case)
    hint = (f"the case file's header says how to make them: {recipe}" if recipe is not None
            else "check [data] directory and the file names, or point the run at the records "
                 "with --data DIR")
    raise DataError(f"{case.label}: data file not found: {listing}; {directory}, relative to "
                    f"the case file's folder; {hint}")


def _check_overlap(case: Case, records: list[io.Measurement], used: io.Measurement,
                   rate: float | None) -> None:
    """Warn when alignment dropped samples of a file: only the files' overlap is used.

    One sample is not worth a word: aligning two clocks that differ by more than half a sample
    drops it from one end of each record.
    """
    n = used.n_samples
    if rate is None:  # the records keep their samples: compare the counts
        cut = any(rec.n_samples > n + 1 for rec in records)
    else:  # resampled: compare the durations
        cut = any(float(rec.t[-1] - rec.t[0]) - (n - 1) / rate > 2.5 / rate for rec in records)
    if not cut:
        return
    spans = {rec.source: (rec.n_samples, float(rec.t[0]), float(rec.t[-1])) for rec in records}
    listing = ", ".join(f"{source}: {k} samples, t = {a:.6g} … {b:.6g} s"
                        for source, (k, a, b) in spans.items())
    counts = [k for k, _, _ in spans.values()]
    differ = ("hold as many samples but their time stamps start apart"
              if max(counts) - min(counts) <= 1 else "differ in length")
    warnings.warn(f"{case.label}: the data files {differ} ({listing}); only their "
                  f"overlap is used: {n} samples, {(n - 1) / used.rate:.6g} s (allowed: "
                  "records of the same test; set [data] window to choose the part used)",
                  FemupdateWarning, stacklevel=3)


def _check_motion(case: Case, data: Data, merged: io.Measurement) -> None:
    """Refuse channels without motion: φ would be the same for every parameter value."""
    channels = [(name, f"data.{path}", c) for name, path, c in data.input_channels()] + [
        (c.label, f"data.outputs[{i}]", c) for i, c in enumerate(data.outputs)]
    for name, where, channel in channels:
        if not np.any(merged[name]):
            what = ("the table did not move: the model has no input, and every parameter value "
                    "predicts the same response (φ = 1)" if name == "input" else
                    "this component of the base motion is 0 (allowed: a record with motion; "
                    "leave out a direction the base did not move along)"
                    if data.components is not None and name.startswith("input.") else
                    "this support did not move: its group has no input (allowed: a record "
                    "with motion; fix the support in no group to keep it still)"
                    if name.startswith("input.") else
                    "this sensor did not move: its error (NMSE) is undefined")
            raise DataError(f"{case.data_path(channel, data)}: column {channel.column!r} "
                            f"({where}) is 0 in every sample used: {what} (allowed: a record "
                            "with motion; check the column and [data] window)")


def read_measurement(case: Case, data: Data | None = None) -> io.Measurement:
    """The input and output channels of a trial's ``data`` (default the case's ``[data]``) in
    m/s² on one time base, windowed.

    The input channel is named ``"input"``; outputs by their labels. With
    ``[preprocess] resample_hz`` every record is resampled to that rate before alignment;
    without it, all files must have the same rate. Times are record times (0 at the first
    sample common to all files). Missing files are named with the fields that read them (and
    the command that makes them, when the case file's header gives one); records that span
    different times are cut to their overlap with a warning
    (:class:`~femupdate.errors.FemupdateWarning`); a channel that is 0 throughout is refused.
    """
    return _read_checked(case, data)[0]


def _read_checked(case: Case, data: Data | None = None, trial: str = ""
                  ) -> tuple[io.Measurement, list[Finding]]:
    """`read_measurement`, and the findings of the clock checks (the files aligned by row
    when ``[data] repair_defects`` says so)."""
    data = data or case.data
    if data is None:
        raise DataError(f"{case.label}: the case has no [data] section: nothing to fit")
    _check_files(case, data)
    specs = [(name, c) for name, _, c in data.input_channels()] + [
        (c.label, c) for c in data.outputs]
    records = []
    notes: list[str] = []
    for name, channel in specs:
        rec = _read(data, case.data_path(channel, data), channel.column, name)
        notes += [n for n in rec.notes if n not in notes]  # a file read for several channels
        scale = ACCELERATION_UNITS[channel.unit or data.unit]
        records.append(io.Measurement(rec.t, {name: rec[name] * scale}, {name: "m/s2"},
                                      rec.source))
    if data.format in network.FORMATS:
        note = network.clock_note([
            network.read_network_records(case.data_path(channel, data), [channel.column],
                                         format=data.format)[0] for _, channel in specs])
        if note is not None:
            warnings.warn(f"{case.label}: {note}", FemupdateWarning, stacklevel=3)
            notes.append(note)
    records, clocks = trial_checks.clock_findings(
        [(rec.source, name, rec) for (name, _), rec in zip(specs, records, strict=True)],
        data, trial)
    rate = case.preprocess.resample_hz
    records, spikes = trial_checks.spike_findings(
        [(rec.source, name, rec) for (name, _), rec in zip(specs, records, strict=True)],
        data, trial, *_used_span(records, rate, data.window))
    clocks += spikes
    drift = [f for f in trial_checks.open_defects(clocks) if f.kind == "clock-drift"]
    if rate is None and drift:
        raise DataError(f"{case.label}: {drift[0].describe()}")
    if rate is None:
        _check_rates(case, records)
    try:
        aligned = io.align(*records, rate=rate)
    except DataError as exc:
        offsets = [f.describe() for f in clocks if f.kind == "clock-offset"]
        if not offsets:
            raise
        raise DataError(f"{exc}; {offsets[0]}") from None
    if not any(f.kind == "clock-offset" for f in clocks):  # the finding says it better
        _check_overlap(case, records, aligned[0], rate)
    merged = io.Measurement(
        aligned[0].t, {k: v for m in aligned for k, v in m.channels.items()},
        {k: "m/s2" for m in aligned for k in m.channels}, str(case.data_directory(data)),
    )
    if data.window is not None:
        _say_overhang(f"{case.label}: data.window", tuple(data.window), merged.t,
                      "as read")
        merged = merged.window(*data.window)
    _check_motion(case, data, merged)
    return replace(merged, notes=tuple(notes)), clocks


def _used_span(records: list[io.Measurement], rate: float | None,
               window: Sequence[float] | None) -> tuple[float, tuple[float, float] | None]:
    """The record time's origin on the files' clock (their first common sample, where the
    trial's time starts at 0), and the span of time on that clock whose samples the trial
    uses: the records' overlap as `io.align` takes it, within ``window``, widened by half a
    sample (an alignment moves a file by less). The span is None when the records cannot be
    aligned (that error comes later, said by the alignment)."""
    try:
        common = io.align(*records, rate=rate, zero=False)[0]
    except (DataError, ConfigError):
        return max(float(r.t[0]) for r in records), None
    t = common.t
    if window is not None:
        t = t[(t - t[0] >= window[0]) & (t - t[0] <= window[1])]
        if t.size == 0:
            return float(common.t[0]), None
    half = 0.5 * max(float(np.max([r.dt for r in records])), common.dt)
    return float(common.t[0]), (float(t[0]) - half, float(t[-1]) + half)


def apply_delays(
    measurement: io.Measurement,
    delays: Mapping[str, float | str],
    *,
    input_name: str = "input",
    band: tuple[float, float] = (1.0, 10.0),
    highpass_hz: float = 0.0,
    highpass_order: int = 4,
    zero_phase: bool = False,
) -> tuple[io.Measurement, dict[str, float]]:
    """Shift output channels back by their delay behind the input channel.

    ``"auto"`` delays are estimated by `signal.estimate_delay` in ``band`` on copies
    high-passed at ``highpass_hz`` (when > 0: offsets and drift removed); every delay is then
    removed from the record itself by `signal.advance`. The samples a shift leaves undefined,
    and `DELAY_TRIM_EXTRA` more where it is approximate, are trimmed from both ends of every
    channel (so that all stay simultaneous); time restarts at 0. Zero delays change nothing.

    Parameters
    ----------
    measurement : Measurement
        Aligned channels, the input among them.
    delays : mapping
        Channel name to its delay (s, positive when the channel lags the input) or ``"auto"``.

    Returns
    -------
    measurement : Measurement
        The realigned channels (the same object when no delay is removed).
    delays : dict
        Delay (s) removed from each channel with a non-zero (or "auto") delay.
    """
    rate = measurement.rate
    if any(d == "auto" for d in delays.values()):
        x = measurement[input_name]
        if highpass_hz > 0.0:
            x = signal.highpass(x, rate, highpass_hz, order=highpass_order,
                                zero_phase=zero_phase)
    applied: dict[str, float] = {}
    for name, delay in delays.items():
        if delay == "auto":
            y = measurement[name]
            if highpass_hz > 0.0:
                y = signal.highpass(y, rate, highpass_hz, order=highpass_order,
                                    zero_phase=zero_phase)
            try:
                applied[name] = signal.estimate_delay(x, y, rate, band=band)
            except DataError as exc:
                raise DataError(f"{measurement.source}: channel {name!r}: delay = \"auto\": "
                                f"{exc} (allowed: a band where input and channel are coherent, "
                                "or the delay as a number of seconds)") from None
        elif not (isinstance(delay, int | float) and math.isfinite(delay)):
            raise ConfigError(f"delay of channel {name!r}: got {delay!r} (allowed: a finite "
                              "number of seconds, or \"auto\")")
        elif delay != 0.0:
            applied[name] = float(delay)
    if not applied:
        return measurement, applied
    longest = max(applied, key=lambda name: abs(applied[name]))
    trim = math.ceil(abs(applied[longest]) * rate) + DELAY_TRIM_EXTRA
    if measurement.n_samples <= 2 * trim + 2:
        raise DataError(f"{measurement.source}: channel {longest!r}: a delay of "
                        f"{applied[longest]:.4g} s would trim {trim} samples from each end of "
                        f"records of {measurement.n_samples} samples: too few left (allowed: a "
                        f"delay under "
                        f"{(measurement.n_samples / 2 - DELAY_TRIM_EXTRA - 2) / rate:.4g} s for "
                        "these records)")
    channels = dict(measurement.channels)
    for name, delay in applied.items():
        channels[name] = signal.advance(measurement[name], delay, rate)
    shifted = io.Measurement(measurement.t, channels, measurement.units, measurement.source,
                             measurement.time_rtol)
    return shifted.slice(trim, measurement.n_samples - trim).shifted(0.0), applied


def process(
    measurement: io.Measurement,
    channels: tuple[str, ...],
    weights: np.ndarray,
    *,
    quantity: str = "displacement",
    highpass_hz: float = 0.0,
    highpass_order: int = 4,
    zero_phase: bool = False,
    delays: Mapping[str, float] | None = None,
    influence: np.ndarray | None = None,
    lowpass_hz: float | None = None,
    lowpass_order: int = 4,
    inputs: tuple[str, ...] = ("input",),
    angle: float | None = None,
) -> Experiment:
    """Filter (high-pass, then low-pass) and (for displacements) integrate the measured
    accelerations.

    ``delays`` (those `apply_delays` removed) are only recorded in the `Experiment`.
    ``influence`` (one per channel, default all 1): how far a unit table displacement moves
    each channel; a channel across the shaking (a 3-D frame's ``uy`` under motion along ``x``)
    has 0, and its relative displacement is its own.
    ``inputs``: the input channels' names; several (support groups, ``input.<group>``) make
    ``ag`` a column per input, and the outputs are taken as recorded (``influence`` 0); the
    components of a uniform base motion (``input.<direction>``) make ``ag`` a column per
    direction, with ``influence`` (n_channels, k) a channel's share of each. ``angle``
    (degrees): the one input is split into its x and y components (a column each).
    """
    rate = measurement.rate
    acc = measurement.array((*inputs, *channels))
    g = len(inputs)
    first = slice(0, g) if g > 1 or inputs != ("input",) else 0
    ag_unfiltered = None
    if highpass_hz > 0.0 or lowpass_hz is not None:
        ag_unfiltered = acc[:, first].copy()
        acc = signal.band(acc, rate, highpass_hz, lowpass_hz, highpass_order=highpass_order,
                          lowpass_order=lowpass_order, zero_phase=zero_phase)
    ag, outputs = acc[:, first], acc[:, g:]
    if angle is not None:  # linear: split before or after the filters, the same record
        from femupdate.simulate.components import angle_split

        ag = angle_split(ag, angle)
        ag_unfiltered = None if ag_unfiltered is None else angle_split(ag_unfiltered, angle)
    if quantity == "displacement":
        relative = (signal.relative(outputs, ag) if influence is None
                    else outputs - np.outer(ag, influence) if ag.ndim == 1
                    else outputs - ag @ influence.T if influence.ndim == 2 else outputs)
        target = signal.integrate_twice(relative, measurement.dt)
    else:
        target = outputs
    t = measurement.t - measurement.t[0]
    return Experiment(t=t, ag=ag, accelerations=outputs, target=target, quantity=quantity,
                      channels=channels, weights=np.asarray(weights, dtype=float),
                      delays=dict(delays or {}), ag_unfiltered=ag_unfiltered)


def _check_band(case: Case, rate: float) -> tuple[float, float]:
    low, high = case.preprocess.delay_band_hz
    if not 0.0 < low < high < rate / 2:
        raise ConfigError(f"{case.label}: preprocess.delay_band_hz: got "
                          f"{format_value([low, high])} for data at {rate:.6g} Hz (used by "
                          f"delay = \"auto\") (allowed: 0 < low < high < the Nyquist frequency "
                          f"{rate / 2:.6g} Hz, well below the first resonance)")
    return low, high


def load_experiment(case: Case, trial: TrialSpec | None = None) -> Experiment:
    """Read the measured data of a trial of ``case`` (default its first), remove the channel
    delays, process them.

    Reading, alignment and window (`read_measurement`), then the ``delay`` of each output
    channel (`apply_delays`), then the high-pass and the quantity compared (`process`); the
    trial's ``score_window`` says which samples the error function compares.
    """
    specs = case.trial_specs()
    if not specs:
        raise DataError(f"{case.label}: the case has no [data] section: nothing to fit")
    spec = trial or specs[0]
    data = spec.data
    measurement, found = _read_checked(case, data, spec.name)
    measurement, more = _channel_checks(case, data, spec.name, measurement)
    found += more
    trial_checks.say(found)
    try:
        experiment = _processed(case, spec, measurement)
        trial_checks.check_scorable(experiment.channels, experiment.target,
                                    f"{case.label}: trial {spec.name!r}")
    except (DataError, ConfigError) as exc:  # a defect found may be why: name it
        blocking = trial_checks.open_defects(found)
        if not blocking:
            raise
        raise type(exc)(f"{exc}; the checks found: "
                        + "; ".join(f.describe() for f in blocking)) from None
    return replace(experiment, defects=tuple(found))


def _processed(case: Case, spec: TrialSpec, measurement: io.Measurement) -> Experiment:
    """The delays, the filters and the quantity of a trial's checked record."""
    data = spec.data
    start_record = float(measurement.t[0])
    notes: list[str] = list(measurement.notes)
    pre = case.preprocess
    rate = measurement.rate
    for name, cutoff, off in (("highpass_hz", pre.highpass_hz, "0 (off) or "),
                              ("lowpass_hz", pre.lowpass_hz, "")):
        if cutoff is not None and cutoff >= rate / 2:
            raise ConfigError(f"{case.label}: preprocess.{name}: got {cutoff:g} Hz for data at "
                              f"{rate:.6g} Hz (the rate of "
                              f"{case.data_path(data.input_channels()[0][2], data)}) "
                              f"(allowed: {off}below the Nyquist frequency {rate / 2:.6g} Hz)")
    labels = tuple(c.label for c in data.outputs)
    wanted = {c.label: c.delay for c in data.outputs}
    low, high = pre.delay_band_hz
    inputs = input_names(case)  # delays are estimated against the first
    if "auto" in wanted.values():
        band = _check_band(case, measurement.rate)
        notes += _check_band_below_modes(case, band)
        notes += _doubtful_delays(measurement, wanted, band, pre.highpass_hz,
                                  pre.highpass_order, pre.zero_phase, inputs[0])
    else:
        band = (low, high)
    measurement, delays = apply_delays(
        replace(measurement, source=case.label), wanted, input_name=inputs[0], band=band,
        highpass_hz=pre.highpass_hz, highpass_order=pre.highpass_order,
        zero_phase=pre.zero_phase)
    experiment = process(
        measurement, labels, np.array([c.weight for c in data.outputs]),
        quantity=case.objective.quantity, highpass_hz=pre.highpass_hz,
        highpass_order=pre.highpass_order, zero_phase=pre.zero_phase, delays=delays,
        influence=_channel_influence(case, data), lowpass_hz=pre.lowpass_hz,
        lowpass_order=pre.lowpass_order, inputs=inputs, angle=data.angle,
    )
    # apply_delays trims samples at both ends and restarts the time at 0: the record time of
    # the first sample kept
    start_s = start_record + (_trimmed_samples(delays, measurement.rate) / measurement.rate
                              if delays else 0.0)
    score = _score_slice(case, spec, experiment.t + start_s)
    return replace(experiment, name=spec.name, role=spec.role, weight=spec.weight,
                   start_s=start_s, score=score, notes=tuple(notes))


def _channel_influence(case: Case, data: Data) -> np.ndarray | None:
    """Per output channel of femupdate's own model, 1 along the shaking and 0 across it (the
    rigid translation ``Structure.influence_vector`` gives); 0 with support groups (channels
    compared as recorded); None (all 1) otherwise."""
    model = case.model
    if model.support_groups:
        return np.zeros(len(data.outputs))
    if model.external is not None or any(c.dof is None for c in data.outputs):
        return None
    if data.base_directions:  # (n_channels, k): a channel moves with the components along it
        return np.array([[1.0 if c.dof == f"u{d}" else 0.0 for d in data.base_directions]
                         for c in data.outputs])
    along = "u" + model.excitation_direction
    return np.array([1.0 if c.dof == along else 0.0 for c in data.outputs])


def _channel_checks(case: Case, data: Data, trial: str, merged: io.Measurement
                    ) -> tuple[io.Measurement, list[Finding]]:
    """The defect checks of a trial's channels on one time base (`trial_checks`)."""
    specs = [(name, c) for name, _, c in data.input_channels()] + [
        (c.label, c) for c in data.outputs]
    files = {name: str(case.data_path(channel, data)) for name, channel in specs}
    units = {name: channel.unit or data.unit for name, channel in specs}
    time_unit = data.time_unit if data.format == "csv" and data.time_column is not None else None
    checked, found = trial_checks.channel_findings(
        merged, files, units, data, trial, f1=trial_checks.first_mode_hz(case),
        time_unit=time_unit, inputs=input_names(case))
    return replace(checked, notes=merged.notes), found


def _check_band_below_modes(case: Case, band: tuple[float, float]) -> list[str]:
    """Refuse a delay band that holds a natural frequency of the model (nominal values), and
    note one that reaches within 1.5× below a natural frequency.

    The estimate reads the table → channel phase as a pure delay, which holds only well below
    the first resonance: near a mode the structure's own phase (−90° at resonance) would be
    taken for a sensor delay of a quarter period.
    """
    from femupdate.model.modes import natural_frequencies
    from femupdate.problem.case_model import CaseModel
    from femupdate.problem.reduced_path import lowest_frequencies

    try:
        model = CaseModel(case)
        freqs = lowest_frequencies(model, case.nominal(), 24)  # a large model's, sparse
        if freqs is None:
            freqs = natural_frequencies(model.system(case.nominal())).freqs_hz
    except FemupdateError:
        return []  # a model that cannot be assembled at its nominal values is reported elsewhere
    listed = ", ".join(f"{f:.4g}" for f in freqs[:4])
    inside = [f for f in freqs if band[0] <= f <= band[1]]
    if inside:
        raise ConfigError(
            f"{case.label}: preprocess.delay_band_hz: got {format_value(list(band))} Hz, but "
            f"the model at its nominal parameters has a natural frequency at {inside[0]:.4g} Hz "
            f"in it (modes: {listed} Hz); near a mode the structure's own phase would be read "
            "as a sensor delay (allowed: a band whose top is below "
            f"{inside[0] / 1.5:.4g} Hz, two thirds of that frequency, or the delay as a number "
            "of seconds)")
    near = [f for f in freqs if band[1] < f < 1.5 * band[1]]
    if near:
        return [f"preprocess.delay_band_hz {format_value(list(band))} Hz reaches within 1.5× "
                f"below the model's natural frequency {near[0]:.4g} Hz (nominal parameters): "
                "the structure's own phase may bias the estimated delays"]
    return []


def _doubtful_delays(measurement: io.Measurement, wanted: Mapping[str, float | str],
                     band: tuple[float, float], highpass_hz: float, order: int,
                     zero_phase: bool, input_name: str = "input") -> list[str]:
    """Notes on "auto" delays longer than a few samples estimated where coherence is poor."""
    rate = measurement.rate
    x = measurement[input_name]
    if highpass_hz > 0.0:
        x = signal.highpass(x, rate, highpass_hz, order=order, zero_phase=zero_phase)
    notes = []
    for name, delay in wanted.items():
        if delay != "auto":
            continue
        y = measurement[name]
        if highpass_hz > 0.0:
            y = signal.highpass(y, rate, highpass_hz, order=order, zero_phase=zero_phase)
        try:
            tau, coherence = signal.estimate_delay(x, y, rate, band=band, full_output=True)
        except DataError:
            continue  # apply_delays says why with the channel's name
        if abs(tau) * rate > DELAY_SAMPLES_DOUBTFUL and coherence < DELAY_COHERENCE:
            notes.append(f"channel {name!r}: the estimated delay {1e3 * tau:.3g} ms "
                         f"({abs(tau) * rate:.2g} samples) rests on a median coherence of "
                         f"{coherence:.2f} in {format_value(list(band))} Hz (below "
                         f"{DELAY_COHERENCE}): doubtful; check the band or give the delay")
    return notes


def load_experiments(case: Case) -> list[Experiment]:
    """Every trial of ``case``, read and processed on its own (its own delays); a warning
    when a channel's estimated delays disagree between trials (see `delay_disagreements`)."""
    experiments = [load_experiment(case, spec) for spec in case.trial_specs()]
    _compare_network_events(case)
    for text in delay_disagreements(experiments):
        warnings.warn(f"{case.label}: {text}", FemupdateWarning, stacklevel=2)
    return experiments


def _compare_network_events(case: Case) -> None:
    """Trials that read different records of a station's events: a channel picked by number
    must be the same sensor in each (else a DataError); channels present in some records only
    are said (a FemupdateWarning)."""
    specs = case.trial_specs()
    if not specs or specs[0].data.format not in network.FORMATS:
        return
    used: set[int] = set()
    paths: dict[str, Path] = {}
    for spec in specs:
        for channel in _channels(spec.data):
            path = case.data_path(channel, spec.data)
            if path.is_dir() or zipfile.is_zipfile(path):  # an event's record, not one file
                paths[str(path)] = path
            if isinstance(channel.column, int) or channel.column.strip().isdigit():
                used.add(int(channel.column))
    if len(paths) < 2:
        return
    fmt = specs[0].data.format
    events = {name: network.read_network_records(path, format=fmt)
              for name, path in paths.items()}
    conflicts, differences = network.compare_events(events, used)
    if conflicts:
        raise DataError(f"{case.label}: the trials read records whose channel numbers name "
                        f"different sensors: {'; '.join(conflicts)} (allowed: one sensor per "
                        "channel number, or pick the channel as 'location / direction')")
    if differences:
        warnings.warn(f"{case.label}: the trials' records hold different channel sets: "
                      f"{'; '.join(differences)}; the channels the case reads are in each",
                      FemupdateWarning, stacklevel=3)


#: Estimated delays of one channel in two trials disagree beyond this many samples …
DELAY_SPREAD_SAMPLES = 2.0
#: … and by more than this fraction of the larger one (a sensor's delay is the same in every
#: trial of one set-up).
DELAY_SPREAD_RELATIVE = 0.5


def delay_disagreements(experiments: Sequence[Experiment]) -> list[str]:
    """Channels whose delays removed in different trials have opposite signs or differ
    widely: one sensor pair has one delay, so at least one estimate is wrong (a periodic
    input, a sine, makes the phase-slope estimate ambiguous by whole periods)."""
    by_channel: dict[str, list[tuple[str, float, float]]] = {}
    for e in experiments:
        for name, tau in e.delays.items():
            by_channel.setdefault(name, []).append((e.name, float(tau), float(e.dt)))
    notes = []
    for name, seen in by_channel.items():
        if len(seen) < 2:
            continue
        low = min(seen, key=lambda item: item[1])
        high = max(seen, key=lambda item: item[1])
        dt = max(item[2] for item in seen)
        spread = high[1] - low[1]
        opposite = low[1] < -dt and high[1] > dt
        wide = (spread > DELAY_SPREAD_SAMPLES * dt
                and spread > DELAY_SPREAD_RELATIVE * max(abs(low[1]), abs(high[1])))
        if opposite or wide:
            notes.append(
                f"channel {name!r}: the delays removed disagree between trials ({low[0]} "
                f"{1e3 * low[1]:+.3g} ms, {high[0]} {1e3 * high[1]:+.3g} ms"
                + (", opposite signs" if opposite else "") + "), though one sensor pair has "
                "one delay: at least one estimate is wrong (a periodic input such as a sine "
                "leaves the estimate ambiguous by whole periods); give the channel's delay in "
                "seconds (delay = ...) as estimated on a broad-band trial")
    return notes


def _trimmed_samples(delays: Mapping[str, float], rate: float) -> int:
    """Samples `apply_delays` trims from each end for these delays."""
    return math.ceil(max(abs(d) for d in delays.values()) * rate) + DELAY_TRIM_EXTRA


def _score_slice(case: Case, spec: TrialSpec, t_record: np.ndarray) -> slice:
    """The samples inside the trial's ``score_window`` (record time), or all of them."""
    if spec.score_window is None:
        return slice(None)
    low, high = spec.score_window
    tol = 1e-6 * float(t_record[1] - t_record[0])
    inside = np.flatnonzero((t_record >= low - tol) & (t_record <= high + tol))
    if inside.size < 3:
        raise DataError(f"{case.label}: {spec.path}.score_window: got {format_value([low, high])}"
                        f" s, which holds {inside.size} samples of the trial's record (record "
                        f"time {t_record[0]:.6g} to {t_record[-1]:.6g} s after the delays) "
                        "(allowed: a part of the record with at least 3 samples)")
    _say_overhang(f"{case.label}: {spec.path}.score_window", (low, high), t_record,
                  "after the delays")
    return slice(int(inside[0]), int(inside[-1]) + 1)


def _say_overhang(where: str, window: tuple[float, float], t: np.ndarray, when: str) -> None:
    """Warn when a window reaches past either end of the record: only the part inside is
    used, which the user did not write."""
    low, high = window
    tol = 0.5 * float(t[1] - t[0])
    first, last = float(t[0]), float(t[-1])
    if (low >= first - tol and high <= last + tol) or low > last or high < first:
        return  # inside, or outside altogether (an error follows, naming it)
    used = [max(low, first), min(high, last)]
    warnings.warn(f"{where}: got {format_value([low, high])} s, which reaches past the record "
                  f"(record time {first:.6g} to {last:.6g} s {when}): only "
                  f"{format_value([round(used[0], 6), round(used[1], 6)])} s is used; give a "
                  "window inside the record to silence this", FemupdateWarning, stacklevel=3)

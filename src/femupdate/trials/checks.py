"""The defect checks of :mod:`femupdate.data.defects` run on a case's trial as it is read.

:func:`femupdate.trials.experiment.load_experiment` calls these on every read (``run``,
``validate``,
the benchmarks, the report's fits): the clocks of the files as read (`clock_findings`, before
they are aligned; the offset repaired by row on request), the spikes of each channel as read
(`spike_findings`, interpolated on request), then the channels on one time base
(`channel_findings`). Every finding is said on the console (a
:class:`~femupdate.errors.FemupdateWarning`, one line each), kept in the `Experiment` and in
``summary.json``; one neither repaired nor accepted (``[data] accept``) makes a run no success.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from femupdate.case import Case, Data
from femupdate.data import defects
from femupdate.data.io import Measurement
from femupdate.errors import DataError, FemupdateError, FemupdateWarning

__all__ = [
    "channel_findings",
    "check_scorable",
    "clock_findings",
    "first_mode_hz",
    "nonfinite_causes",
    "open_defects",
    "say",
    "settle",
    "spike_findings",
]

#: Values whose square overflows a float (|y| above about 1.3e154): a sum of squares of a
#: channel holding one is inf.
_SQUARE_OVERFLOW = float(np.sqrt(np.finfo(float).max))


def first_mode_hz(case: Case) -> float | None:
    """The model's first natural frequency at the nominal parameters (None: not available,
    as for an external model, which is not built here: it may load a script). A model on the
    reduced path gets it from the sparse eigensolver (a dense eigenproblem of its 1,000 DOFs
    took 1.9 s of a run's fixed cost)."""
    from femupdate.model.modes import natural_frequencies
    from femupdate.problem.case_model import CaseModel

    if case.model.external is not None:
        return None
    try:
        model = CaseModel(case)
        if model.reduced is not None:  # a large model: its lowest mode, sparse (never dense)
            freqs = model.reduced.frequencies(case.nominal(), count=1)
        else:
            freqs = natural_frequencies(model.system(case.nominal())).freqs_hz
    except (FemupdateError, ValueError, np.linalg.LinAlgError):
        return None
    positive = [float(f) for f in freqs if np.isfinite(f) and f > 0]
    return min(positive) if positive else None


def settle(findings: Sequence[defects.Finding], data: Data, trial: str
           ) -> list[defects.Finding]:
    """Each finding with its trial and its status: accepted by ``[data] accept``, repaired
    (the caller mended it: ``[data] repair_defects``), or open."""
    out = []
    for f in findings:
        status = ("repaired" if f.kind in data.repair_defects and f.kind in defects.REPAIRABLE
                  else "accepted" if f.kind in data.accept else "open")
        out.append(replace(f, status=status, trial=trial))
    return out


def clock_findings(records: Sequence[tuple[str, str, Measurement]], data: Data, trial: str
                   ) -> tuple[list[Measurement], list[defects.Finding]]:
    """The clock checks over the files of a trial as read, and the records, aligned by row
    when an offset is found and ``repair_defects`` holds ``"clock-offset"``.

    ``records``: (file, channel, record) of the input first, then each output.
    """
    clocks = [defects.ClockRecord(file, channel, rec.t) for file, channel, rec in records]
    found = settle(defects.check_clocks(clocks), data, trial)
    recs = [rec for _, _, rec in records]
    if any(f.kind == "clock-offset" and f.status == "repaired" for f in found):
        t0 = recs[0].t[0]
        recs = [replace(rec, t=rec.t - rec.t[0] + t0) for rec in recs]
    return recs, found


def spike_findings(records: Sequence[tuple[str, str, Measurement]], data: Data, trial: str,
                   origin: float, used: tuple[float, float] | None
                   ) -> tuple[list[Measurement], list[defects.Finding]]:
    """The spikes of each channel as read from its file (before alignment or resampling
    moves, drops or smears a sample), and the records with their spikes interpolated when
    ``repair_defects`` holds ``"spike"``.

    ``records``: (file, channel, record of that one channel, m/s²); ``origin``: the time on
    the files' clock where the trial's time starts (times are said from there, as
    ``[data] window`` gives them); ``used``: the span of time (on the files' clock) whose
    samples the trial uses (None: all); spikes outside it (a sample an alignment drops, or
    outside ``[data] window``) do not touch the fit and are not said.
    """
    found: list[defects.Finding] = []
    within = None if used is None else (used[0] - origin, used[1] - origin)
    for file, channel, rec in records:
        found += defects.check_spikes(channel, rec[channel], rec.t - origin, file,
                                      within=within)
    found = settle(found, data, trial)
    recs = [rec for _, _, rec in records]
    if any(f.status == "repaired" for f in found):
        recs = [replace(rec, channels={channel: defects.interpolate_samples(
                    rec[channel], defects.spike_samples(rec[channel]))})
                for (_, channel, _), rec in zip(records, recs, strict=True)]
    return recs, found


def channel_findings(merged: Measurement, files: dict[str, str], units: dict[str, str],
                     data: Data, trial: str, *, f1: float | None, time_unit: str | None,
                     inputs: tuple[str, ...] = ("input",),
                     ) -> tuple[Measurement, list[defects.Finding]]:
    """The checks of the channels on one time base (``"input"`` and the outputs, m/s²), and the
    record with its spikes interpolated when ``repair_defects`` holds ``"spike"``.

    Several ``inputs`` (support groups, components of a base motion) have no one table to
    compare the outputs with: the alignment and unit-gain checks against the input are left
    out, each input's peak is checked alone."""
    n, rate = merged.n_samples, merged.rate
    found = defects.check_length_and_rate(n, rate, f1, files[inputs[0]], time_unit=time_unit)
    clean = dict(merged.channels)
    if n >= defects.MIN_SAMPLES:
        # the other checks see the channels without their spikes (found and said on the
        # files as read, `spike_findings`): one 1e308 sample would otherwise make every
        # statistic of its channel say something
        for name in merged.names:
            clean[name] = defects.interpolate_samples(merged[name],
                                                      defects.spike_samples(merged[name]))
        found += defects.check_duplicates(clean, files)
        for name, y in clean.items():
            found += defects.check_saturation(name, y, files[name])
        if inputs != ("input",):
            for name in inputs:
                found += [replace(f, channel=name) for f in defects.check_units(
                    clean[name], {}, rate, {"input": units[name]}, {"input": files[name]})]
        elif not found or all(f.kind in ("duplicate", "saturation") for f in found):
            x = clean["input"]
            outputs = {name: y for name, y in clean.items() if name != "input"}
            # lags and spectra in seconds and hertz mean nothing on a wrong time base
            found += defects.check_alignment(x, outputs, rate, files, first_mode_hz=f1)
            found += defects.check_units(x, outputs, rate, units, files, first_mode_hz=f1)
    return merged, settle(found, data, trial)


def say(findings: Sequence[defects.Finding]) -> None:
    """Each finding on the console, one line (a FemupdateWarning)."""
    for f in findings:
        warnings.warn(f"defect: {f.describe()}", FemupdateWarning, stacklevel=3)


def open_defects(findings: Sequence[defects.Finding]) -> list[defects.Finding]:
    """The findings that make a run no success: errors neither repaired nor accepted."""
    return [f for f in findings if f.status == "open" and f.severity == "error"]


def _first_bad(y: np.ndarray) -> str:
    bad = np.flatnonzero(~np.isfinite(y))
    return f"{bad.size} non-finite sample(s), the first at scored sample {bad[0]}"


def nonfinite_causes(channels: Sequence[str], per_channel: np.ndarray, measured: np.ndarray,
                     predicted: np.ndarray | None, failure: str | None = None) -> list[str]:
    """Why each channel's NMSE is not a finite number: one line per such channel.

    Parameters
    ----------
    channels : sequence of str
        The channels' labels.
    per_channel : ndarray (k,)
        Each channel's NMSE as computed.
    measured, predicted : ndarray (n, k)
        The scored measurement and prediction (``predicted`` None: the simulation failed).
    failure : str, optional
        What the simulation said when it failed.
    """
    lines = []
    with np.errstate(over="ignore", invalid="ignore"):
        for j, name in enumerate(channels):
            if np.isfinite(per_channel[j]):
                continue
            y = measured[:, j]
            yhat = None if predicted is None else predicted[:, j]
            if not np.all(np.isfinite(y)):
                cause = f"the measurement holds {_first_bad(y)}"
            elif np.max(np.abs(y)) > _SQUARE_OVERFLOW:
                cause = (f"the measurement peaks at {np.max(np.abs(y)):.4g}, beyond what a sum "
                         "of squares can hold (an absurd sample: see the defect checks)")
            elif yhat is None:
                cause = ("the simulation failed at these parameter values"
                         + (f" ({failure})" if failure else ""))
            elif not np.all(np.isfinite(yhat)):
                cause = (f"the prediction holds {_first_bad(yhat)} (the model's output diverged, "
                         "or overflowed in its processing)")
            elif np.max(np.abs(yhat)) > _SQUARE_OVERFLOW:
                cause = (f"the prediction peaks at {np.max(np.abs(yhat)):.4g}, beyond what a sum "
                         "of squares can hold (the model's output diverged)")
            elif not np.any(y):
                cause = "the measurement is 0 over the scored samples: it has no energy to scale by"
            else:
                cause = "the error's sum of squares overflows"
            lines.append(f"channel {name!r}: NMSE {per_channel[j]}: {cause}")
    return lines


def check_scorable(channels: Sequence[str], target: np.ndarray, where: str) -> None:
    """A DataError naming the first channel of a processed record that no NMSE can be formed
    on: non-finite samples, or values whose squares overflow (an absurd sample integrated)."""
    target = np.asarray(target, dtype=float).reshape(len(target), -1)
    for j, name in enumerate(channels):
        y = target[:, j]
        if not np.all(np.isfinite(y)):
            raise DataError(f"{where}: channel {name!r}: the processed record holds "
                            f"{_first_bad(y)}: no NMSE can be formed on it")
        peak = float(np.max(np.abs(y))) if y.size else 0.0
        if peak > _SQUARE_OVERFLOW:
            raise DataError(f"{where}: channel {name!r}: the processed record peaks at "
                            f"{peak:.4g}, beyond what a sum of squares can hold: no NMSE can "
                            "be formed on it")

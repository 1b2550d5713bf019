"""Measured data of a case, read and processed as the paper did (METHOD.md §8).

files ─► Measurement (SI units, one time base, window) ─► high-pass ─► the base input a_g and,
per output channel, the target: relative displacement (channel − table, integrated twice by the
trapezoidal rule) or absolute acceleration.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from femupdate.case import ACCELERATION_UNITS, TIME_UNITS, Case
from femupdate.data import io, signal
from femupdate.errors import DataError


@dataclass(frozen=True)
class Experiment:
    """The processed measurement of a case.

    Attributes
    ----------
    t : ndarray (n,)
        Sample times from 0 (s).
    ag : ndarray (n,)
        Processed base (table) acceleration, m/s², the model's input.
    accelerations : ndarray (n, k)
        Processed absolute accelerations of the output channels, m/s².
    target : ndarray (n, k)
        What the error function compares: relative displacements (m) or absolute
        accelerations (m/s²), by ``quantity``.
    quantity : {"displacement", "acceleration"}
    channels : tuple of str
        Output channel labels.
    weights : ndarray (k,)
    """

    t: np.ndarray
    ag: np.ndarray
    accelerations: np.ndarray
    target: np.ndarray
    quantity: str
    channels: tuple[str, ...]
    weights: np.ndarray

    @property
    def dt(self) -> float:
        return float(self.t[1] - self.t[0])


def _read(case: Case, file: Path, column: str | int, name: str) -> io.Measurement:
    data = case.data
    assert data is not None  # checked by the caller
    fmt = data.format
    if fmt == "csv":
        time_unit = TIME_UNITS[data.time_unit]
        return io.read_csv(
            file, {name: column}, time=data.time_column, rate=data.rate, time_scale=time_unit,
            delimiter=data.delimiter, skip_lines=data.skip_lines, header=data.header,
            skip_rows=data.skip_rows, comments=data.comments,
        )
    if fmt == "npz":
        return io.read_npz(file, [str(column)]).rename({str(column): name})
    return io.read_uff58(file, [str(column)]).rename({str(column): name})


def read_measurement(case: Case) -> io.Measurement:
    """The input and output channels of ``case`` in m/s² on one time base, windowed.

    The input channel is named ``"input"``; outputs by their labels.
    """
    data = case.data
    if data is None:
        raise DataError(f"{case.source}: the case has no [data] section: nothing to fit")
    specs = [("input", data.input)] + [(c.label, c) for c in data.outputs]
    records = []
    for name, channel in specs:
        rec = _read(case, case.data_path(channel), channel.column, name)
        scale = ACCELERATION_UNITS[channel.unit or data.unit]
        records.append(io.Measurement(rec.t, {name: rec[name] * scale}, {name: "m/s2"},
                                      rec.source))
    aligned = io.align(*records)
    merged = io.Measurement(
        aligned[0].t, {k: v for m in aligned for k, v in m.channels.items()},
        {k: "m/s2" for m in aligned for k in m.channels}, str(case.data_directory()),
    )
    if data.window is not None:
        merged = merged.window(*data.window).shifted(0.0)
    if case.preprocess.resample_hz is not None:
        t_new = None
        channels = {}
        for name, y in merged.channels.items():
            t_new, channels[name] = io.resample(merged.t, y, case.preprocess.resample_hz)
        merged = io.Measurement(t_new - t_new[0], channels, merged.units, merged.source)
    return merged


def process(
    measurement: io.Measurement,
    channels: tuple[str, ...],
    weights: np.ndarray,
    *,
    quantity: str = "displacement",
    highpass_hz: float = 0.0,
    highpass_order: int = 4,
    zero_phase: bool = True,
) -> Experiment:
    """Filter and (for displacements) integrate the measured accelerations."""
    rate = measurement.rate
    acc = measurement.array(("input", *channels))
    if highpass_hz > 0.0:
        acc = signal.highpass(acc, rate, highpass_hz, order=highpass_order,
                              zero_phase=zero_phase)
    ag, outputs = acc[:, 0], acc[:, 1:]
    if quantity == "displacement":
        target = signal.integrate_twice(signal.relative(outputs, ag), measurement.dt)
    else:
        target = outputs
    t = measurement.t - measurement.t[0]
    return Experiment(t=t, ag=ag, accelerations=outputs, target=target, quantity=quantity,
                      channels=channels, weights=np.asarray(weights, dtype=float))


def load_experiment(case: Case) -> Experiment:
    """Read and process the measured data of ``case``."""
    measurement = read_measurement(case)
    assert case.data is not None  # read_measurement checked it
    labels = tuple(c.label for c in case.data.outputs)
    pre = case.preprocess
    return process(
        measurement, labels, np.array([c.weight for c in case.data.outputs]),
        quantity=case.objective.quantity, highpass_hz=pre.highpass_hz,
        highpass_order=pre.highpass_order, zero_phase=pre.zero_phase,
    )

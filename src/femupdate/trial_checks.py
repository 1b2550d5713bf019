"""The defect checks of :mod:`femupdate.data.defects` run on a case's trial as it is read.

:func:`femupdate.experiment.load_experiment` calls these on every read (``run``, ``validate``,
the benchmarks, the report's fits): the clocks of the files as read (`clock_findings`, before
they are aligned; the offset repaired by row on request), then the channels on one time base
(`channel_findings`, spikes interpolated on request). Every finding is said on the console (a
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
from femupdate.errors import FemupdateError, FemupdateWarning

__all__ = ["channel_findings", "clock_findings", "first_mode_hz", "open_defects", "say",
           "settle"]


def first_mode_hz(case: Case) -> float | None:
    """The model's first natural frequency at the nominal parameters (None: not available,
    as for an external model, which is not built here: it may load a script). A model on the
    reduced path gets it from the sparse eigensolver (a dense eigenproblem of its 1,000 DOFs
    took 1.9 s of a run's fixed cost)."""
    from femupdate.case import CaseModel
    from femupdate.model.modes import natural_frequencies

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


def channel_findings(merged: Measurement, files: dict[str, str], units: dict[str, str],
                     data: Data, trial: str, *, f1: float | None, time_unit: str | None
                     ) -> tuple[Measurement, list[defects.Finding]]:
    """The checks of the channels on one time base (``"input"`` and the outputs, m/s²), and the
    record with its spikes interpolated when ``repair_defects`` holds ``"spike"``."""
    n, rate = merged.n_samples, merged.rate
    found = defects.check_length_and_rate(n, rate, f1, files["input"], time_unit=time_unit)
    clean = dict(merged.channels)
    if n >= defects.MIN_SAMPLES:
        # the other checks see the channels without their spikes: one 1e308 sample would
        # otherwise make every statistic of its channel say something
        for name in merged.names:
            found += defects.check_spikes(name, merged[name], merged.t, files[name])
            clean[name] = defects.interpolate_samples(merged[name],
                                                      defects.spike_samples(merged[name]))
        x = clean["input"]
        outputs = {name: y for name, y in clean.items() if name != "input"}
        found += defects.check_duplicates(clean, files)
        for name, y in clean.items():
            found += defects.check_saturation(name, y, files[name])
        if not found or all(f.kind in ("spike", "duplicate", "saturation") for f in found):
            # lags and spectra in seconds and hertz mean nothing on a wrong time base
            found += defects.check_alignment(x, outputs, rate, files, first_mode_hz=f1)
            found += defects.check_units(x, outputs, rate, units, files, first_mode_hz=f1)
    found = settle(found, data, trial)
    if any(f.kind == "spike" and f.status == "repaired" for f in found):
        merged = Measurement(merged.t, clean, merged.units, merged.source, merged.time_rtol)
    return merged, found


def say(findings: Sequence[defects.Finding]) -> None:
    """Each finding on the console, one line (a FemupdateWarning)."""
    for f in findings:
        warnings.warn(f"defect: {f.describe()}", FemupdateWarning, stacklevel=3)


def open_defects(findings: Sequence[defects.Finding]) -> list[defects.Finding]:
    """The findings that make a run no success: errors neither repaired nor accepted."""
    return [f for f in findings if f.status == "open" and f.severity == "error"]

"""Measured data: reading and writing records, signal processing, virtual experiments.

- `femupdate.data.measurement`: `Measurement`, `align`, `resample`, `combine`, `fill_gaps`.
- `femupdate.data.io`: readers and writers (CSV, NPZ, UFF58).
- `femupdate.data.datasets`: readers of the El Centro 1940 files and Xsens DOT exports.
- `femupdate.data.signal`: filters, relative accelerations, integration, substeps, spectra.
- `femupdate.data.synth`: EC8 spectra, artificial accelerograms, sensor imperfections.
"""

from femupdate.data.datasets import read_elcentro, read_xsens_dot
from femupdate.data.io import (
    read,
    read_csv,
    read_npz,
    read_uff58,
    write_csv,
    write_npz,
    write_uff58,
)
from femupdate.data.measurement import Measurement, align, combine, fill_gaps, resample
from femupdate.data.signal import (
    detrend,
    fourier_amplitude,
    highpass,
    integrate,
    integrate_twice,
    peak_frequency,
    relative,
    remove_polynomial,
    substep_times,
    substeps,
    transfer_function,
)
from femupdate.data.synth import (
    Accelerogram,
    EC8Spectrum,
    artificial_accelerogram,
    baseline_correct,
    ec8_spectrum,
    response_spectrum,
    scale_time,
    sensor_record,
)

__all__ = [
    "Accelerogram",
    "EC8Spectrum",
    "Measurement",
    "align",
    "artificial_accelerogram",
    "baseline_correct",
    "combine",
    "detrend",
    "ec8_spectrum",
    "fill_gaps",
    "fourier_amplitude",
    "highpass",
    "integrate",
    "integrate_twice",
    "peak_frequency",
    "read",
    "read_csv",
    "read_elcentro",
    "read_npz",
    "read_uff58",
    "read_xsens_dot",
    "relative",
    "remove_polynomial",
    "resample",
    "response_spectrum",
    "scale_time",
    "sensor_record",
    "substep_times",
    "substeps",
    "transfer_function",
    "write_csv",
    "write_npz",
    "write_uff58",
]

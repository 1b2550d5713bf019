"""Support-motion records read together: one length, one sample interval, finite samples.

A multi-support input is a column per record; the records come from separate files (a 3-D
frame case's ``[[ground_motion]]``) and must be sampled alike before they are stacked.
:mod:`femupdate.simulate.multisupport` re-exports :func:`check_records`.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from femupdate.errors import DataError

__all__ = ["check_records"]


def check_records(records: Mapping[str, tuple[np.ndarray, float]]) -> tuple[np.ndarray, float]:
    """Stack acceleration records sampled alike; a one-line ``DataError`` otherwise.

    Parameters
    ----------
    records : mapping name → (acceleration (n_samples,), dt)

    Returns
    -------
    stack : ndarray (n_samples, n_records), dt : float
    """
    if not records:
        raise DataError("support motion: no record given")
    names = list(records)
    lengths = {n: np.asarray(records[n][0]).shape for n in names}
    rates = {n: float(records[n][1]) for n in names}
    for n in names:
        if len(lengths[n]) != 1 or lengths[n][0] < 2:
            raise DataError(f"support record {n!r}: shape {lengths[n]}; expected (n_samples,) "
                            "with n_samples >= 2")
        if not (np.isfinite(rates[n]) and rates[n] > 0):
            raise DataError(f"support record {n!r}: dt = {rates[n]!r}; it must be finite and > 0")
    first = names[0]
    for n in names[1:]:
        if lengths[n] != lengths[first]:
            raise DataError(f"support records {first!r} and {n!r} differ in length "
                            f"({lengths[first][0]} and {lengths[n][0]} samples); they must share "
                            "length and rate")
        if abs(rates[n] - rates[first]) > 1e-12 * rates[first]:
            raise DataError(f"support records {first!r} and {n!r} differ in rate (dt "
                            f"{rates[first]!r} and {rates[n]!r} s); they must share length and "
                            "rate")
    stack = np.column_stack([np.asarray(records[n][0], dtype=float) for n in names])
    bad = np.argwhere(~np.isfinite(stack))
    if bad.size:
        raise DataError(f"support record {names[bad[0][1]]!r} has NaN or inf at sample "
                        f"{bad[0][0]}")
    return stack, rates[first]

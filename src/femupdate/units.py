"""Physical constants and the units femupdate reads, each named once."""

from __future__ import annotations

#: Standard gravity, m/s² (CGPM 1901): converts accelerations given in g.
STANDARD_GRAVITY = 9.80665

#: Factor from each accepted acceleration unit to m/s².
ACCELERATION_UNITS: dict[str, float] = {
    "m/s2": 1.0,
    "g": STANDARD_GRAVITY,
    "cm/s2": 0.01,
    "mm/s2": 0.001,
}

#: Factor from each accepted time unit to seconds.
TIME_UNITS: dict[str, float] = {"s": 1.0, "ms": 1e-3, "us": 1e-6}

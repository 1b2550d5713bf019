"""A storey whose damping rises with the table's motion: the model the study found to predict
the specimen's six trials (a user's model, run through ``[model.python]``).

    m ü + c(t) u̇ + k u = −m a_g(t),       c(t) = c0 + cv · s(t),

u the roof's displacement relative to the table, s(t) the table's speed: the rms of its velocity
(the table record integrated, high-passed at 0.5 Hz against drift) over a causal exponential
window of 0.1 s. The roof's absolute acceleration ü + a_g = −(c u̇ + k u)/m is returned.

Why such a form: in free decay the storey damps at ζ ≈ 0.3–0.4 % (all four decays measured), in
strong El Centro shaking a linear storey fits with ζ = 0.6 %, in Northridge with 1.6–2.1 % and
in the 2 Hz sine with 2.0–2.5 %, at similar roof amplitudes: the dissipation follows the table's
slow motion, not the storey's own amplitude, which friction (Jenkins, Iwan) elements cannot give
(their small 22 Hz loops superposed on slow motion stay elastic). It is phenomenological: energy
likely leaves the in-plane mode into the table's roll (its gyro reads 7–10 times its El Centro
level in those trials), for which a planar one-storey model has no degree of freedom.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.signal
from numba import njit

MASS = 0.179  # kg, the roof's lumped mass (fixed; as elcentro.toml)
#: Time constant of the table-speed envelope, s.
TAU = 0.1
#: High-pass of the table velocity against the drift of an integrated record, Hz.
VELOCITY_HIGHPASS_HZ = 0.5
#: Of the record, before integration (the case's own high-pass: the gravity offset).
RECORD_HIGHPASS_HZ = 1.0
#: Integration steps per sample: ω h ≤ 0.08 for the storey's 22 Hz (period error 0.03 %).
SUBSTEPS = 15


def table_speed(ag: np.ndarray, dt: float) -> np.ndarray:
    """s(t): the rms of the table's velocity over a causal exponential window of TAU."""
    fs = 1.0 / dt
    record = scipy.signal.sosfilt(scipy.signal.butter(4, RECORD_HIGHPASS_HZ, "highpass", fs=fs,
                                                      output="sos"), ag)
    velocity = scipy.signal.sosfilt(
        scipy.signal.butter(2, VELOCITY_HIGHPASS_HZ, "highpass", fs=fs, output="sos"),
        np.cumsum(record) * dt)
    a = math.exp(-dt / TAU)
    return np.sqrt(scipy.signal.lfilter([1.0 - a], [1.0, -a], velocity * velocity))


@njit(cache=True)
def _roof_acceleration(ag: np.ndarray, c: np.ndarray, k: float, dt: float, m: float,
                       substeps: int) -> np.ndarray:
    """Central differences with ``substeps`` per sample, the input linear between samples,
    ``c`` held over each sample interval."""
    n = ag.size
    h = dt / substeps
    out = np.empty(n)
    u_prev = 0.0
    u = 0.0
    for i in range(n):
        last = i == n - 1
        for j in range(1 if last else substeps):
            g = ag[i] if last else ag[i] + (j / substeps) * (ag[i + 1] - ag[i])
            u_next = (h * h * (-k * u - m * g) + 2.0 * m * u
                      - (m - 0.5 * c[i] * h) * u_prev) / (m + 0.5 * c[i] * h)
            if j == 0:
                out[i] = -(k * u + c[i] * (u_next - u_prev) / (2.0 * h)) / m
            u_prev, u = u, u_next
    return out


def predict(values: dict[str, float], ag: np.ndarray, dt: float) -> np.ndarray:
    """The roof's absolute acceleration (m/s²) under the table record ``ag``."""
    c = values["c0"] + values["cv"] * table_speed(ag, dt)
    return _roof_acceleration(np.ascontiguousarray(ag, dtype=float), c, values["k"], dt, MASS,
                              SUBSTEPS)


def frequencies(values: dict[str, float]) -> list[float]:
    """The storey's undamped natural frequency, Hz."""
    return [math.sqrt(values["k"] / MASS) / (2.0 * math.pi)]

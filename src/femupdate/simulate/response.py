"""The result of a simulation."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Response:
    """Response at the requested output DOFs, one row per input sample.

    Attributes
    ----------
    t : ndarray, shape (n_samples,)
        Sample times.
    displacement, velocity : ndarray, shape (n_samples, n_out)
        Displacement and velocity relative to the base.
    acceleration : ndarray, shape (n_samples, n_out)
        Absolute acceleration (relative acceleration plus ``r · a_g``).
    diverged : bool
        True when the solution overflowed or became NaN; the arrays are then not meaningful.
    friction_force, slip : ndarray, shape (n_samples, n_friction) or None
        Force in, and slip offset of, each elasto-slip element (nonlinear simulations only).
    hysteretic_force, hysteretic_z : ndarray, shape (n_samples, n_bouc_wen) or None
        Force in, and hysteretic displacement ``z`` of, each Bouc–Wen element (nonlinear
        simulations of systems with Bouc–Wen elements only).
    """

    t: np.ndarray
    displacement: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    diverged: bool = False
    friction_force: np.ndarray | None = None
    slip: np.ndarray | None = None
    hysteretic_force: np.ndarray | None = None
    hysteretic_z: np.ndarray | None = None

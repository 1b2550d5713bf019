"""Uniform base motion with several components: one record per direction, every support moving
with all of them.

The supports move together, rigidly, along ``x`` by ``a_x(t)``, along ``y`` by ``a_y(t)`` (and
``z``); the equations of the motion relative to the ground are

    M ÿ + C ẏ + K y (+ friction, Bouc–Wen) = -Σ_c p_c a_c(t),   p_c = M r_c,

with ``r_c`` the rigid translation along direction ``c`` (``System.seismic_load`` of the system
assembled for that direction, which also holds the consistent beam mass at the supports). The
absolute acceleration at a DOF is ``ÿ + Σ_c r_c a_c``. A nonlinear model sees the components
together, as it must: its response is not the sum of its responses to each alone.

Every integrator takes the sum as nodal forces (``Simulator.run(force=...)``, linear between
samples as a base record is), so the same loads reach the exact, Newmark, central-difference,
explicit nonlinear and implicit schemes. One record at an angle θ from x in the horizontal
plane is the two components ``a cos θ`` along x and ``a sin θ`` along y (:func:`angle_split`).
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from femupdate.errors import DataError
from femupdate.simulate.response import Response

__all__ = ["angle_split", "component_forces", "components_response"]


class _Runner(Protocol):
    def run(self, ag: np.ndarray | None = None, force: np.ndarray | None = None) -> Response: ...


def angle_split(a: np.ndarray, angle_deg: float) -> np.ndarray:
    """One record along ``angle_deg`` (degrees from x towards y) as its x and y components.

    Parameters
    ----------
    a : ndarray (n,)
        The record.
    angle_deg : float
        Its direction in the horizontal plane, degrees from x.

    Returns
    -------
    ndarray (n, 2)
        ``a cos θ`` (along x) and ``a sin θ`` (along y).
    """
    theta = math.radians(float(angle_deg))
    return np.outer(np.asarray(a, dtype=float), [math.cos(theta), math.sin(theta)])


def component_forces(ag: np.ndarray, loads: np.ndarray) -> np.ndarray:
    """Nodal forces ``-Σ_c p_c a_c(t)`` of a uniform base motion with several components.

    Parameters
    ----------
    ag : ndarray (n_samples, k)
        The components' accelerations, a column per direction.
    loads : ndarray (n_dof, k)
        ``p_c = M r_c`` of each direction, in the columns' order.

    Returns
    -------
    ndarray (n_samples, n_dof)
    """
    ag = np.asarray(ag, dtype=float)
    loads = np.asarray(loads, dtype=float)
    if ag.ndim != 2 or ag.shape[1] != loads.shape[1]:
        raise DataError(f"base motion of shape {ag.shape}; expected (n_samples, "
                        f"{loads.shape[1]}), a column per component")
    return -(ag @ loads.T)


def components_response(simulator: _Runner, ag: np.ndarray, loads: np.ndarray,
                        r_out: np.ndarray) -> Response:
    """Response of a prepared integrator to a uniform base motion with several components.

    Parameters
    ----------
    simulator
        A prepared integrator (``femupdate.simulate.prepare``) of the system; its own
        influence vector is not used.
    ag : ndarray (n_samples, k)
        The components' accelerations.
    loads : ndarray (n_dof, k)
        ``p_c`` of each component (:func:`component_forces`).
    r_out : ndarray (n_outputs, k)
        The rigid translation of each component at the simulator's outputs.

    Returns
    -------
    Response
        Displacement and velocity relative to the ground; absolute acceleration
        ``ÿ + Σ_c r_c a_c`` (NaN when the simulation diverged).
    """
    response = simulator.run(None, component_forces(ag, loads))
    if not response.diverged:
        response.acceleration[...] += np.asarray(ag, dtype=float) @ np.asarray(r_out).T
    return response


"""Multi-support excitation: different ground motions at different supports.

The supports' displacements are ``u_s(t) = E d(t)``: ``E`` (n_support × n_records) says which
support DOFs follow which record ``d_g(t)`` (acceleration ``a_g``). The free DOFs' total
displacement is split into a pseudo-static and a dynamic part,

    u(t) = R d(t) + y(t),   R = -K_ff⁻¹ K_fs E,

where ``R d`` is the static response to the support displacements, and ``y`` solves

    M_ff ÿ + C_ff ẏ + K_ff y = -(M_ff R + M_fs E) a(t) - (C_ff R + C_fs E) v(t)

(the damping term vanishes for stiffness-proportional damping; ``damping_coupling=False`` drops
it, as is usual). This is exact: the equations of the total motion with the supports' motion
imposed (``M_ff ü + C_ff u̇ + K_ff u = -M_fs ü_s - C_fs u̇_s - K_fs u_s``) with ``u = R d + y``.
For a single record moving every support rigidly, ``R`` is the rigid-body influence vector and
this is the uniform base excitation of :func:`femupdate.simulate.simulate`.

Outputs: ``total`` displacement and velocity (absolute), absolute acceleration, the
``pseudo_static`` part and the ``dynamic`` part (the response relative to the pseudo-static
configuration: the multi-support counterpart of the relative response).

The model is anything with the free-DOF ``system``, the coupling blocks ``K_fs``, ``M_fs``,
``C_fs`` and the ``support_labels`` (:class:`SupportedModel`): a 3-D frame's
:class:`~femupdate.model.frame3d.Frame3DModel`, or :class:`SupportCoupling` built from a
``Structure`` (:meth:`femupdate.model.structure.Structure.support_coupling`) for the case
files' ``[[model.support_groups]]``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from femupdate.data.records import check_records
from femupdate.errors import ConfigError, DataError
from femupdate.model.system import System
from femupdate.simulate import simulate

__all__ = ["MultiSupportResponse", "SupportCoupling", "SupportedModel", "check_records",
           "integrate_record", "multi_support_response", "pseudo_static_matrix"]


class SupportedModel(Protocol):
    """What the multi-support solution needs of a model (a ``Frame3DModel`` has it)."""

    @property
    def system(self) -> System: ...
    @property
    def support_labels(self) -> tuple[str, ...]: ...
    @property
    def K_fs(self) -> np.ndarray: ...
    @property
    def M_fs(self) -> np.ndarray: ...
    @property
    def C_fs(self) -> np.ndarray: ...


@dataclass(frozen=True)
class SupportCoupling:
    """The free-DOF system and its coupling blocks (n_free × n_support) to the support DOFs
    ``support_labels`` (``"A.uy"``), in their column order."""

    system: System
    support_labels: tuple[str, ...]
    K_fs: np.ndarray
    M_fs: np.ndarray
    C_fs: np.ndarray


@dataclass(frozen=True)
class MultiSupportResponse:
    """Response of the free DOFs (columns: ``model.system.dof_labels``, or the ``outputs``
    asked for) at every sample."""

    t: np.ndarray
    total: np.ndarray
    total_velocity: np.ndarray
    acceleration: np.ndarray  # absolute
    pseudo_static: np.ndarray
    dynamic: np.ndarray
    diverged: bool = False


def integrate_record(acceleration: np.ndarray, dt: float, scheme: str = "exact"
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and displacement from rest of accelerations (along axis 0).

    ``scheme="exact"``: acceleration linear between samples (trapezoidal velocity, displacement
    ``d + h v + h²(a_k/3 + a_{k+1}/6)``); ``"newmark"``: the average-acceleration relations
    (``h²(a_k + a_{k+1})/4``), so that Newmark's method sees support motions of its own family.
    """
    if scheme not in ("exact", "newmark"):
        raise ConfigError(f"scheme = {scheme!r}; allowed 'exact' or 'newmark'")
    a = np.asarray(acceleration, dtype=float)
    wa, wb = (1 / 3, 1 / 6) if scheme == "exact" else (0.25, 0.25)
    zero = np.zeros_like(a[:1])
    # np.cumsum adds in sample order, as a loop over the samples would
    v = np.concatenate([zero, np.cumsum(0.5 * dt * (a[:-1] + a[1:]), axis=0)])
    d = np.concatenate([zero, np.cumsum(dt * v[:-1] + dt * dt * (wa * a[:-1] + wb * a[1:]),
                                        axis=0)])
    return v, d


def support_matrix(model: SupportedModel, groups: Sequence[Sequence[str]]) -> np.ndarray:
    """``E`` (n_support × n_records): 1 where support DOF ``i`` follows record ``g``."""
    index = {lab: i for i, lab in enumerate(model.support_labels)}
    e = np.zeros((len(index), len(groups)))
    for g, dofs in enumerate(groups):
        if isinstance(dofs, str) or not len(dofs):  # a record that drives nothing
            raise ConfigError(f"support motion: group {g} is {dofs!r}; allowed: a non-empty "
                              "list of the support DOFs that follow its record, e.g. "
                              "[\"A.ux\", \"B.ux\"]")
        for lab in dofs:
            if lab not in index:
                raise ConfigError(f"support motion: {lab!r} is not a support DOF; the fixed "
                                  f"DOFs are {', '.join(model.support_labels)}")
            if e[index[lab]].any():
                raise ConfigError(f"support motion: {lab!r} is given two records")
            e[index[lab], g] = 1.0
    return e


def pseudo_static_matrix(model: SupportedModel, e: np.ndarray) -> np.ndarray:
    """``R = -K_ff⁻¹ K_fs E``: free-DOF displacements for unit support records."""
    return -np.linalg.solve(model.system.K, model.K_fs @ e)


def multi_support_response(
    model: SupportedModel,
    groups: Sequence[Sequence[str]],
    acceleration: np.ndarray,
    dt: float,
    *,
    method: str = "exact",
    substeps: int = 1,
    damping_coupling: bool = True,
    velocity: np.ndarray | None = None,
    displacement: np.ndarray | None = None,
    outputs: Sequence[int] | np.ndarray | None = None,
) -> MultiSupportResponse:
    """Response of a model to support records, from rest.

    Parameters
    ----------
    model : SupportedModel
        The assembled model and its coupling to the supports (a ``Frame3DModel``, a
        :class:`SupportCoupling`).
    groups : sequence of sequences of str
        For each record, the support DOFs (``"A.ux"``) that follow it.
    acceleration : ndarray (n_samples, n_records)
        Support accelerations (linear between samples), e.g. from :func:`check_records`.
    dt : float
        Sample interval (s).
    method, substeps
        As in :func:`femupdate.simulate.simulate` (linear methods).
    damping_coupling : bool
        Include the ``-(C_ff R + C_fs E) v`` load.
    velocity, displacement : ndarray (n_samples, n_records), optional
        Support velocities and displacements; by default integrated from the accelerations
        (:func:`integrate_record`, ``scheme="exact"``).
    outputs : sequence of int, optional
        Free-DOF indices whose response is returned (default all, in ``dof_labels`` order).
    """
    a = np.asarray(acceleration, dtype=float)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2 or a.shape[1] != len(groups):
        raise DataError(f"acceleration has shape {a.shape}; expected (n_samples, {len(groups)}) "
                        "(one column per record)")
    given = {"velocity": velocity, "displacement": displacement}
    for name, value in given.items():
        if value is None:
            continue
        arr = np.asarray(value, dtype=float)
        if arr.ndim == 1 and a.shape[1] == 1:
            arr = arr[:, None]
        if arr.shape != a.shape:  # numpy's broadcast error named neither the field nor why
            raise DataError(f"{name} has shape {arr.shape}; expected {a.shape}, the shape of "
                            "acceleration (n_samples, one column per record)")
        if not np.all(np.isfinite(arr)):
            raise DataError(f"{name} has non-finite values (allowed: finite numbers)")
        given[name] = arr
    velocity, displacement = given["velocity"], given["displacement"]
    if velocity is None or displacement is None:
        v_int, d_int = integrate_record(a, dt)
        velocity = v_int if velocity is None else velocity
        displacement = d_int if displacement is None else displacement
    e = support_matrix(model, groups)
    s = model.system
    r = pseudo_static_matrix(model, e)
    p = s.M @ r + model.M_fs @ e
    force = -a @ p.T
    if damping_coupling:
        force = force - np.asarray(velocity) @ (s.C @ r + model.C_fs @ e).T
    resp = simulate(s, dt, force=force, method=method, substeps=substeps, outputs=outputs)
    if outputs is not None:
        r = r[np.asarray(outputs, dtype=np.int64)]
    ps = np.asarray(displacement) @ r.T
    return MultiSupportResponse(
        t=resp.t, total=resp.displacement + ps,
        total_velocity=resp.velocity + np.asarray(velocity) @ r.T,
        acceleration=resp.acceleration + a @ r.T, pseudo_static=ps,
        dynamic=resp.displacement, diverged=resp.diverged)

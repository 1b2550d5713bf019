"""The 3-D Timoshenko beam-column element as small pure functions.

Local DOF order of an element (node 1 then node 2): ``(u, v, w, θx, θy, θz)``, ``x`` along the
element from node 1 to node 2, ``y`` and ``z`` its principal axes. Each bending plane uses the
planar Timoshenko matrices of :mod:`femupdate.model.elements` (interdependent interpolation,
exact for end loads, with the same consistent mass: translational ``μ = ρA`` and rotary ``ρI``
inertia):

- bending in the ``xy`` plane on ``(v1, θz1, v2, θz2)`` with ``E Iz`` and the shear area
  ``Avy`` (``Φy = 12 E Iz / (G Avy L²)``), ``θz = dv/dx``;
- bending in the ``xz`` plane on ``(w1, θy1, w2, θy2)`` with ``E Iy`` and ``Avz``; here
  ``θy = -dw/dx`` (right-handed axes), hence the sign flips of the rotations;
- axial ``EA/L`` and torsion ``GJ/L`` bars, with consistent masses ``μL/6·[[2, 1], [1, 2]]`` and
  ``ρ Ip L/6·[[2, 1], [1, 2]]``, ``Ip`` the polar moment of the section; it defaults to the
  torsion constant ``J`` as in OpenSees's ``ElasticTimoshenkoBeam3d`` (exact for circular
  sections; give ``Ip = Iy + Iz`` for others).

The orientation follows OpenSees's ``geomTransf Linear``: a vector ``vecxz`` in the local
``xz`` plane gives ``y = vecxz × x`` and ``z = x × y`` (normalised).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from femupdate.errors import ModelError
from femupdate.model.elements import beam_mass, beam_stiffness, check_value

__all__ = [
    "frame3d_element",
    "frame3d_mass",
    "frame3d_rotation",
    "frame3d_stiffness",
]

FloatArray = np.ndarray

_XY = np.array([1, 5, 7, 11])  # v1, θz1, v2, θz2
_XZ = np.array([2, 4, 8, 10])  # w1, θy1, w2, θy2
_FLIP_XZ = np.diag([1.0, -1.0, 1.0, -1.0])  # θy = -dw/dx


def _bar(value: float, base: FloatArray, out: FloatArray, i: int) -> None:
    out[np.ix_([i, i + 6], [i, i + 6])] += value * base


def _shear_phi(EI: float, G: float, Av: float, L: float) -> float:
    return 0.0 if math.isinf(G) else 12.0 * EI / (G * Av * L * L)


def frame3d_stiffness(
    E: ArrayLike, G: ArrayLike, A: ArrayLike, Iy: ArrayLike, Iz: ArrayLike, J: ArrayLike,
    Avy: ArrayLike, Avz: ArrayLike, L: ArrayLike,
) -> FloatArray:
    """Local 12 × 12 stiffness of a 3-D Timoshenko beam-column (``G = inf``: no shear strain).

    Every argument may be an array (one entry per element): the result is then a stack
    (..., 12, 12), computed in one pass (a 3-D frame's assembly calls it once per evaluation
    for all its beams).

    Parameters
    ----------
    E, G : array_like
        Young's and shear moduli.
    A, Iy, Iz, J : array_like
        Area, second moments about local ``y`` and ``z``, torsion constant.
    Avy, Avz : array_like
        Shear areas along local ``y`` and ``z`` (``κ A``).
    L : array_like
        Length.
    """
    E, G, A, Iy, Iz, J, Avy, Avz, L = np.broadcast_arrays(
        *(np.asarray(v, dtype=float) for v in (E, G, A, Iy, Iz, J, Avy, Avz, L)))
    rigid = np.isinf(G)
    k = np.zeros((*E.shape, 12, 12))
    with np.errstate(invalid="ignore"):  # inf · 0 where rigid in shear: masked below
        for i, value in ((0, E * A / L), (3, np.where(rigid, 0.0, G * J / L))):
            k[..., i, i] = k[..., i + 6, i + 6] = value
            k[..., i, i + 6] = k[..., i + 6, i] = -value
        phi_y = np.where(rigid, 0.0, 12.0 * (E * Iz) / (G * Avy * L * L))
        phi_z = np.where(rigid, 0.0, 12.0 * (E * Iy) / (G * Avz * L * L))
    k[..., _XY[:, None], _XY[None, :]] += beam_stiffness(E * Iz, L, phi_y)
    k[..., _XZ[:, None], _XZ[None, :]] += _FLIP_XZ @ beam_stiffness(E * Iy, L, phi_z) @ _FLIP_XZ
    return k


def frame3d_mass(
    mu: float, rho: float, E: float, G: float, A: float, Iy: float, Iz: float, Avy: float,
    Avz: float, L: float, *, Ip: float, rotary_inertia: bool = True,
    torsional_inertia: bool | None = None,
) -> FloatArray:
    """Local 12 × 12 consistent mass of a 3-D Timoshenko beam-column.

    Parameters
    ----------
    mu : float
        Mass per length ``ρA`` (plus any non-structural mass per length).
    rho : float
        Density, for the rotary (``ρIy``, ``ρIz``) and torsional (``ρIp``) inertia.
    E, G, A, Iy, Iz, Avy, Avz, L : float
        As in :func:`frame3d_stiffness` (the shear parameters enter the shape functions).
    Ip : float
        Polar moment of the section for the torsional inertia.
    rotary_inertia : bool
        Include the rotary inertia of the bending rotations (and the torsional inertia, unless
        ``torsional_inertia`` is given).
    torsional_inertia : bool, optional
        Include the torsional inertia ``ρ Ip`` (default: as ``rotary_inertia``).
    """
    m = np.zeros((12, 12))
    consistent = np.array([[2.0, 1.0], [1.0, 2.0]]) * L / 6.0
    _bar(mu, consistent, m, 0)
    r = rho if rotary_inertia else 0.0
    twist = rotary_inertia if torsional_inertia is None else torsional_inertia
    _bar((rho if twist else 0.0) * Ip, consistent, m, 3)
    m[np.ix_(_XY, _XY)] += beam_mass(mu, r * Iz, L, _shear_phi(E * Iz, G, Avy, L))
    m[np.ix_(_XZ, _XZ)] += _FLIP_XZ @ beam_mass(
        mu, r * Iy, L, _shear_phi(E * Iy, G, Avz, L)) @ _FLIP_XZ
    return m


def frame3d_rotation(xyz1: ArrayLike, xyz2: ArrayLike, vecxz: ArrayLike) -> FloatArray:
    """Transformation ``T`` (12 × 12) from global to local DOFs, ``q_local = T q_global``.

    Raises
    ------
    ModelError
        When the nodes coincide or ``vecxz`` is parallel to the element axis.
    """
    d = np.asarray(xyz2, dtype=float) - np.asarray(xyz1, dtype=float)
    length = float(np.linalg.norm(d))
    if not length > 0.0:
        raise ModelError("3-D beam: its nodes coincide (length 0)")
    x = d / length
    v = np.asarray(vecxz, dtype=float)
    y = np.cross(v, x)
    ny = float(np.linalg.norm(y))
    if not ny > 1e-9 * max(float(np.linalg.norm(v)), 1e-300):
        raise ModelError(
            f"3-D beam: vecxz = {v.tolist()} is parallel to the element axis {x.tolist()}; "
            "give a vector in the local xz plane not along the axis")
    y /= ny
    z = np.cross(x, y)
    rot = np.vstack([x, y, z])
    return np.kron(np.eye(4), rot)


def frame3d_element(
    xyz1: ArrayLike, xyz2: ArrayLike, vecxz: ArrayLike, *, E: float, A: float, Iy: float,
    Iz: float, J: float, G: float = math.inf, kappa_y: float = 5 / 6, kappa_z: float = 5 / 6,
    rho: float = 0.0, mass_per_length: float = 0.0, rotary_inertia: bool = True,
    Ip: float | None = None, name: str = "beam", shear_deformation: bool = True,
    torsional_inertia: bool | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Checked global stiffness and consistent mass (12 × 12) of one 3-D beam-column.

    Global DOFs ``(ux, uy, uz, rx, ry, rz)`` of node 1 then node 2. Shear areas are
    ``Avy = kappa_y A`` and ``Avz = kappa_z A``; ``G = inf`` (the default) is Euler–Bernoulli
    bending (and no torsional stiffness: give ``G`` for a frame that must resist torsion).
    ``Ip`` (default ``J``) is the polar moment for the torsional inertia.
    ``shear_deformation=False`` makes the bending Euler–Bernoulli with a finite ``G`` (its
    torsional stiffness ``G J`` kept: infinite shear areas); ``torsional_inertia`` (default
    ``rotary_inertia``) switches ``ρ Ip`` apart from the bending rotations' inertia.
    """
    label = f"3-D beam {name!r}"
    E = check_value(label, "E", E)
    for what, v in (("A", A), ("Iy", Iy), ("Iz", Iz), ("J", J), ("kappa_y", kappa_y),
                    ("kappa_z", kappa_z)):
        check_value(label, what, v, low_open=True)
    check_value(label, "rho", rho)
    Ip = J if Ip is None else check_value(label, "Ip", Ip, low_open=True)
    check_value(label, "mass_per_length", mass_per_length)
    if not (isinstance(G, int | float) and math.isinf(G) and G > 0):
        check_value(label, "G", G, low_open=True)
    try:
        t = frame3d_rotation(xyz1, xyz2, vecxz)
    except ModelError as exc:
        raise ModelError(f"{label}: {str(exc).removeprefix('3-D beam: ')}") from None
    L = float(np.linalg.norm(np.asarray(xyz2, float) - np.asarray(xyz1, float)))
    avy, avz = (kappa_y * A, kappa_z * A) if shear_deformation else (math.inf, math.inf)
    k = frame3d_stiffness(E, G, A, Iy, Iz, J, avy, avz, L)
    m = frame3d_mass(rho * A + mass_per_length, rho, E, G, A, Iy, Iz, avy, avz, L, Ip=Ip,
                     rotary_inertia=rotary_inertia, torsional_inertia=torsional_inertia)
    return t.T @ k @ t, t.T @ m @ t

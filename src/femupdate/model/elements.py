"""Element matrices as small pure functions.

Two layers:

- kernels (``beam_stiffness``, ``beam_mass``, ``frame_stiffness``, ``frame_mass``,
  ``frame_rotation``, ``spring_matrix``) take arrays of element properties of any common
  shape ``S`` (scalars included) and return stacks of matrices of shape ``S + (d, d)``; they do
  not validate, so ``Structure`` can call them once per assembly for all elements together;
- checked front ends (``timoshenko_beam``, ``frame_element``, ``spring``, ``lumped_mass``) for one
  element, which validate every input and raise ``ModelError`` naming the element.

Beams follow the interdependent interpolation of Friedman & Kosmatka (1993): cubic transverse
and quadratic rotation shape functions that satisfy the homogeneous Timoshenko equations, so
the stiffness is exact for end loads and both matrices reduce to the Euler–Bernoulli Hermite
ones when the shear parameter ``Φ = 12 EI / (κ G A L²)`` tends to zero. DOF order of a beam:
``(v1, θ1, v2, θ2)`` with ``θ = dv/dx`` (counter-clockwise); of a plane frame element:
``(u1, v1, θ1, u2, v2, θ2)``.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from femupdate.errors import ModelError

__all__ = [
    "beam_mass",
    "beam_stiffness",
    "check_value",
    "frame_element",
    "frame_mass",
    "frame_rotation",
    "frame_stiffness",
    "lumped_mass",
    "shear_parameter",
    "spring",
    "spring_matrix",
    "timoshenko_beam",
]

FloatArray = np.ndarray


# ----------------------------------------------------------------------------- validation


def check_value(
    element: str,
    what: str,
    value: float,
    low: float = 0.0,
    high: float = math.inf,
    *,
    low_open: bool = False,
) -> float:
    """Return ``value`` as a float if finite and in range, else raise ``ModelError``.

    Parameters
    ----------
    element : str
        Element name for the message, e.g. ``"beam 'deck1'"``.
    what : str
        Property name, e.g. ``"E"``.
    value : float
        The value to check.
    low, high : float
        Allowed range; ``low`` is excluded when ``low_open`` (``high`` is always included).
    """
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise ModelError(f"{element}: {what} must be a number, got {value!r}")
    v = float(value)
    ok = math.isfinite(v) and (v > low if low_open else v >= low) and v <= high
    if not ok:
        raise ModelError(
            f"{element}: {what} = {v!r} is out of range; allowed {_range_text(low, high, low_open)}"
        )
    return v


def _range_text(low: float, high: float, low_open: bool) -> str:
    left = "(" if low_open else "["
    right = ")" if math.isinf(high) else "]"
    return f"{left}{low:g}, {high:g}{right}"


# ----------------------------------------------------------------------------- kernels


def _arrays(*values: ArrayLike) -> list[FloatArray]:
    return np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in values))


def _symmetric(
    shape: tuple[int, ...], d: int, upper: dict[tuple[int, int], FloatArray]
) -> FloatArray:
    """A stack of symmetric ``d × d`` matrices from their upper-triangle entries (rest zero)."""
    out = np.zeros((*shape, d, d))
    for (i, j), v in upper.items():
        out[..., i, j] = v
        out[..., j, i] = v
    return out


def shear_parameter(
    E: ArrayLike,
    I: ArrayLike,  # noqa: E741
    G: ArrayLike,
    A: ArrayLike,
    L: ArrayLike,
    kappa: ArrayLike,
) -> FloatArray:
    """Timoshenko shear parameter ``Φ = 12 E I / (κ G A L²)`` (0 for ``G = inf``).

    Parameters
    ----------
    E, G : array_like
        Young's and shear moduli (``G`` may be ``inf``: rigid in shear, Euler–Bernoulli).
    I, A : array_like
        Second moment of area and area of the cross-section.
    L : array_like
        Element length.
    kappa : array_like
        Shear-area factor (5/6 for a solid rectangle).
    """
    E, I, G, A, L, kappa = _arrays(E, I, G, A, L, kappa)  # noqa: E741
    with np.errstate(divide="ignore", invalid="ignore"):
        phi = 12.0 * E * I / (kappa * G * A * L * L)
    return np.where(np.isinf(G), 0.0, phi)


#: A float or an array of them: the ``*_terms`` functions take either.
Real = float | FloatArray

#: The upper-triangle entries of a 4 × 4 beam matrix, in the order the ``*_terms`` functions
#: return them.
BEAM_UPPER = ((0, 0), (0, 1), (0, 2), (0, 3), (1, 1), (1, 2), (1, 3), (2, 2), (2, 3), (3, 3))


def beam_stiffness_terms(EI: Real, L: Real, L3: Real, phi: Real) -> tuple[Real, ...]:
    """The BEAM_UPPER entries of :func:`beam_stiffness` from ``EI``, ``L``, ``L³`` and ``Φ``.

    Plain arithmetic on floats or arrays: ``evaluation.assembly`` compiles this same function
    with numba, so the two assemblies share one formula (and its rounding).
    """
    f = EI / ((1.0 + phi) * L3)
    L2 = L * L
    return (12.0 * f, 6.0 * L * f, -12.0 * f, 6.0 * L * f, (4.0 + phi) * L2 * f, -6.0 * L * f,
            (2.0 - phi) * L2 * f, 12.0 * f, -6.0 * L * f, (4.0 + phi) * L2 * f)


def beam_mass_terms(mu: Real, rho_i: Real, L: Real, phi: Real) -> tuple[Real, ...]:
    """The BEAM_UPPER entries of :func:`beam_mass` (see :func:`beam_stiffness_terms`)."""
    p2 = phi * phi
    L2 = L * L
    a = mu * L / (1.0 + phi) ** 2
    m11 = (13 / 35 + 7 / 10 * phi + 1 / 3 * p2) * a
    m12 = (11 / 210 + 11 / 120 * phi + 1 / 24 * p2) * L * a
    m13 = (9 / 70 + 3 / 10 * phi + 1 / 6 * p2) * a
    m14 = -(13 / 420 + 3 / 40 * phi + 1 / 24 * p2) * L * a
    m22 = (1 / 105 + 1 / 60 * phi + 1 / 120 * p2) * L2 * a
    m24 = -(1 / 140 + 1 / 60 * phi + 1 / 120 * p2) * L2 * a
    b = rho_i / ((1.0 + phi) ** 2 * L)
    r11 = 6 / 5 * b
    r12 = (1 / 10 - 1 / 2 * phi) * L * b
    r22 = (2 / 15 + 1 / 6 * phi + 1 / 3 * p2) * L2 * b
    r24 = (-1 / 30 - 1 / 6 * phi + 1 / 6 * p2) * L2 * b
    return (m11 + r11, m12 + r12, m13 - r11, m14 + r12, m22 + r22, -m14 - r12, m24 + r24,
            m11 + r11, -m12 - r12, m22 + r22)


def beam_stiffness(EI: ArrayLike, L: ArrayLike, phi: ArrayLike = 0.0) -> FloatArray:
    """Bending + shear stiffness of a planar Timoshenko beam, DOFs ``(v1, θ1, v2, θ2)``.

    Parameters
    ----------
    EI : array_like
        Bending stiffness.
    L : array_like
        Length.
    phi : array_like
        Shear parameter ``12 EI / (κ G A L²)``; 0 gives the Euler–Bernoulli matrix.

    Returns
    -------
    ndarray, shape ``S + (4, 4)``
    """
    EI, L, phi = _arrays(EI, L, phi)
    terms = beam_stiffness_terms(EI, L, L**3, phi)
    return _symmetric(EI.shape, 4, dict(zip(BEAM_UPPER, terms, strict=True)))


def beam_mass(
    mass_per_length: ArrayLike, rotary_per_length: ArrayLike, L: ArrayLike, phi: ArrayLike = 0.0
) -> FloatArray:
    """Consistent mass of a planar Timoshenko beam, DOFs ``(v1, θ1, v2, θ2)``.

    Translational inertia ``μ = ρA`` (plus any non-structural mass per length) and rotary
    inertia ``ρI`` per length, integrated with the interdependent shape functions.

    Parameters
    ----------
    mass_per_length : array_like
        ``μ``, mass per unit length.
    rotary_per_length : array_like
        ``ρ I``, rotary inertia per unit length (0 to neglect rotary inertia).
    L : array_like
        Length.
    phi : array_like
        Shear parameter (see ``beam_stiffness``).

    Returns
    -------
    ndarray, shape ``S + (4, 4)``
    """
    mu, rho_i, L, phi = _arrays(mass_per_length, rotary_per_length, L, phi)
    terms = beam_mass_terms(mu, rho_i, L, phi)
    return _symmetric(mu.shape, 4, dict(zip(BEAM_UPPER, terms, strict=True)))


_BENDING = (1, 2, 4, 5)


def _frame_from(axial: FloatArray, bending: FloatArray) -> FloatArray:
    out = np.zeros((*axial.shape[:-2], 6, 6))
    out[..., [[0], [3]], [0, 3]] = axial
    idx = np.array(_BENDING)
    out[..., idx[:, None], idx] = bending
    return out


def frame_stiffness(EA: ArrayLike, EI: ArrayLike, L: ArrayLike, phi: ArrayLike = 0.0) -> FloatArray:
    """Stiffness of a plane frame element in local axes, DOFs ``(u1, v1, θ1, u2, v2, θ2)``.

    Returns
    -------
    ndarray, shape ``S + (6, 6)``
        Axial bar terms ``EA/L`` on ``u`` and the Timoshenko bending block on ``(v, θ)``.
    """
    EA, EI, L, phi = _arrays(EA, EI, L, phi)
    ka = EA / L
    axial = np.stack([np.stack([ka, -ka], -1), np.stack([-ka, ka], -1)], -2)
    return _frame_from(axial, beam_stiffness(EI, L, phi))


def frame_mass(
    mass_per_length: ArrayLike, rotary_per_length: ArrayLike, L: ArrayLike, phi: ArrayLike = 0.0
) -> FloatArray:
    """Consistent mass of a plane frame element in local axes (axial ``μL/6·[[2, 1], [1, 2]]``).

    Returns
    -------
    ndarray, shape ``S + (6, 6)``
    """
    mu, rho_i, L, phi = _arrays(mass_per_length, rotary_per_length, L, phi)
    m = mu * L / 6.0
    axial = np.stack([np.stack([2 * m, m], -1), np.stack([m, 2 * m], -1)], -2)
    return _frame_from(axial, beam_mass(mu, rho_i, L, phi))


def frame_rotation(c: ArrayLike, s: ArrayLike) -> FloatArray:
    """Transformation ``T`` from global to local DOFs, ``q_local = T q_global``.

    Parameters
    ----------
    c, s : array_like
        Cosine and sine of the angle from the global x axis to the element axis (node 1 → 2).

    Returns
    -------
    ndarray, shape ``S + (6, 6)``
        Global matrices follow as ``Tᵀ K_local T``.
    """
    c, s = _arrays(c, s)
    t = np.zeros((*c.shape, 6, 6))
    for o in (0, 3):
        t[..., o, o] = c
        t[..., o, o + 1] = s
        t[..., o + 1, o] = -s
        t[..., o + 1, o + 1] = c
        t[..., o + 2, o + 2] = 1.0
    return t


def spring_matrix(k: ArrayLike) -> FloatArray:
    """Two-DOF spring (or viscous damper) matrix ``k [[1, -1], [-1, 1]]``, shape ``S + (2, 2)``."""
    k = np.asarray(k, dtype=float)
    return k[..., None, None] * np.array([[1.0, -1.0], [-1.0, 1.0]])


# ----------------------------------------------------------------------------- checked front ends


def _beam_properties(
    name: str,
    E: float,
    A: float,
    I: float,  # noqa: E741
    L: float,
    rho: float,
    G: float,
    kappa: float,
    mass_per_length: float,
) -> None:
    check_value(name, "length L", L, low_open=True)
    check_value(name, "E", E)
    check_value(name, "A", A, low_open=True)
    check_value(name, "I", I, low_open=True)
    check_value(name, "rho", rho)
    check_value(name, "kappa", kappa, low_open=True)
    check_value(name, "mass_per_length", mass_per_length)
    if not (isinstance(G, int | float) and math.isinf(G) and G > 0):
        check_value(name, "G", G, low_open=True)


def timoshenko_beam(
    E: float,
    A: float,
    I: float,  # noqa: E741
    L: float,
    rho: float = 0.0,
    *,
    G: float = math.inf,
    kappa: float = 5 / 6,
    mass_per_length: float = 0.0,
    rotary_inertia: bool = True,
    name: str = "beam",
) -> tuple[FloatArray, FloatArray]:
    """Stiffness and consistent mass of one planar Timoshenko beam, DOFs ``(v1, θ1, v2, θ2)``.

    Parameters
    ----------
    E, G : float
        Young's modulus (≥ 0) and shear modulus (> 0; ``inf``, the default, neglects shear
        deformation: Euler–Bernoulli).
    A, I : float
        Area and second moment of area (> 0).
    L : float
        Length (> 0).
    rho : float
        Density (≥ 0).
    kappa : float
        Shear-area factor (> 0).
    mass_per_length : float
        Non-structural mass per unit length (≥ 0), translational inertia only.
    rotary_inertia : bool
        Include the rotary inertia ``ρ I``.
    name : str
        Element name used in error messages.

    Returns
    -------
    K, M : ndarray, shape (4, 4)
    """
    label = f"beam {name!r}"
    _beam_properties(label, E, A, I, L, rho, G, kappa, mass_per_length)
    phi = shear_parameter(E, I, G, A, L, kappa)
    mu = rho * A + mass_per_length
    rho_i = rho * I if rotary_inertia else 0.0
    return beam_stiffness(E * I, L, phi), beam_mass(mu, rho_i, L, phi)


def frame_element(
    E: float,
    A: float,
    I: float,  # noqa: E741
    x1: float,
    y1: float,
    x2: float,
    y2: float,
    rho: float = 0.0,
    *,
    G: float = math.inf,
    kappa: float = 5 / 6,
    mass_per_length: float = 0.0,
    rotary_inertia: bool = True,
    name: str = "frame",
) -> tuple[FloatArray, FloatArray]:
    """Stiffness and consistent mass of one plane frame element in global axes.

    DOFs ``(ux1, uy1, rz1, ux2, uy2, rz2)``; the element runs from ``(x1, y1)`` to ``(x2, y2)``.
    Other parameters as in ``timoshenko_beam``.

    Returns
    -------
    K, M : ndarray, shape (6, 6)
    """
    label = f"frame element {name!r}"
    for what, v in (("x1", x1), ("y1", y1), ("x2", x2), ("y2", y2)):
        check_value(label, what, v, -math.inf)
    L = math.hypot(x2 - x1, y2 - y1)
    _beam_properties(label, E, A, I, L, rho, G, kappa, mass_per_length)
    phi = shear_parameter(E, I, G, A, L, kappa)
    mu = rho * A + mass_per_length
    rho_i = rho * I if rotary_inertia else 0.0
    t = frame_rotation((x2 - x1) / L, (y2 - y1) / L)
    k = t.T @ frame_stiffness(E * A, E * I, L, phi) @ t
    m = t.T @ frame_mass(mu, rho_i, L, phi) @ t
    return k, m


def spring(k: float, *, name: str = "spring") -> FloatArray:
    """Checked 2 × 2 matrix of a linear spring or viscous damper (``k ≥ 0``) between two DOFs.

    To ground, keep the ``[0, 0]`` entry (the other DOF is the ground).
    """
    return spring_matrix(check_value(f"spring {name!r}", "k", k))


def lumped_mass(
    m: float,
    J: float = 0.0,
    dofs_per_node: Literal[1, 2, 3] = 2,
    *,
    name: str = "mass",
) -> FloatArray:
    """Diagonal nodal mass matrix: ``m`` on the node's translations, ``J`` on its rotation.

    Parameters
    ----------
    m, J : float
        Mass and rotary inertia (≥ 0).
    dofs_per_node : {1, 2, 3}
        1: ``(ux,)``; 2: ``(uy, rz)``; 3: ``(ux, uy, rz)``.
    """
    label = f"mass {name!r}"
    m = check_value(label, "m", m)
    J = check_value(label, "J", J)
    if dofs_per_node == 1:
        if J != 0.0:
            raise ModelError(f"{label}: J = {J!r} needs a rotational DOF; this node has only ux")
        return np.array([[m]])
    if dofs_per_node == 2:
        return np.diag([m, J])
    if dofs_per_node == 3:
        return np.diag([m, m, J])
    raise ModelError(f"{label}: dofs_per_node = {dofs_per_node!r}; allowed 1, 2 or 3")

"""The Bouc–Wen hysteretic element (Bouc 1967, Wen 1976), as OpenSees's ``BoucWen`` material.

An element of deformation ``y`` (``y_i - y_j``, or ``y_i`` to the ground) carries the force

    f = α k y + (1 − α) k z,
    ż = A ẏ − β |ẏ| |z|^(n−1) z − γ ẏ |z|^n,

with ``k`` the initial stiffness (for ``A = 1``), ``α`` the ratio of post-yield to initial
stiffness, and the hysteretic displacement ``z`` (same unit as ``y``) bounded by the ultimate
value ``z_u = (A / (β + γ))^(1/n)``: the yield force is about ``(1 − α) k z_u``. ``β`` and
``γ`` have the unit 1/length^n.

The law is rate independent: divided by ``ẏ``, it is an ordinary differential equation of
``z`` in ``y``, ``dz/dy = A − (β sign(Δy z) + γ) |z|^n``, whose right-hand side is constant in
sign over an increment ``Δy`` of one sign. The integrators move ``y`` linearly over each step,
so ``z`` is advanced over the step's ``Δy`` by the classical Runge–Kutta scheme (fourth order
in ``Δy``) in as many equal parts as keep ``|part| · λ ≤ 1/2``, ``λ`` the largest slope of the
right-hand side (:func:`bouc_wen_step_limit`): stable for any ``n`` and step, and with
errors far below the central-difference scheme's own (second order in ``h``), so the element
adds no error of its own to the integrator. An implicit (backward-Euler) update, as OpenSees
uses, is first order in ``Δy``; the exact solution exists for ``n = 1`` only.

Parameters are checked by :func:`check_bouc_wen_parameters`: ``k > 0``, ``0 ≤ α ≤ 1``,
``A > 0``, ``n > 0``, and ``β > 0`` with ``−β < γ ≤ β`` (Baber and Wen's thermodynamic
admissibility with a bounded ``z``): outside that the loop dissipates no energy, or ``z``
grows without bound on loading (``β + γ ≤ 0``), and there is no hysteresis to fit.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from femupdate.errors import ModelError

__all__ = [
    "BOUC_WEN_PARAMETERS",
    "Z_U_RANGE",
    "bouc_wen_force",
    "bouc_wen_initial_tangent",
    "bouc_wen_loop",
    "bouc_wen_max_tangent",
    "bouc_wen_rate",
    "bouc_wen_step_limit",
    "bouc_wen_update",
    "check_bouc_wen_parameters",
    "ultimate_deformation_issue",
]

#: Order of the columns of a Bouc–Wen parameter table (``BoucWenElements.table``).
BOUC_WEN_PARAMETERS = ("k", "alpha", "A", "beta", "gamma", "n")


@njit(cache=True, inline="always")
def bouc_wen_rate(z: float, direction: float, A: float, beta: float, gamma: float,
                  n: float) -> float:
    """``dz/dy`` for a deformation moving in ``direction`` (+1 or −1)."""
    az = abs(z)
    if az == 0.0:
        return A
    psi = gamma + (beta if direction * z > 0.0 else -beta)
    # the common exponents without pow (the same values: both are correctly rounded)
    power = az if n == 1.0 else (az * az if n == 2.0 else az ** n)
    return A - psi * power


@njit(cache=True, inline="always")
def bouc_wen_update(z: float, dy: float, A: float, beta: float, gamma: float, n: float,
                    dy_max: float) -> float:
    """``z`` after the deformation moved by ``dy`` (linearly), by fourth-order Runge–Kutta in
    ``y`` over ``ceil(|dy| / dy_max)`` equal parts (one when ``dy`` is small)."""
    if dy == 0.0:
        return z
    direction = 1.0 if dy > 0.0 else -1.0
    parts = 1
    if abs(dy) > dy_max:
        parts = math.ceil(abs(dy) / dy_max)
    d = dy / parts
    for _ in range(parts):
        k1 = bouc_wen_rate(z, direction, A, beta, gamma, n)
        k2 = bouc_wen_rate(z + 0.5 * d * k1, direction, A, beta, gamma, n)
        k3 = bouc_wen_rate(z + 0.5 * d * k2, direction, A, beta, gamma, n)
        k4 = bouc_wen_rate(z + d * k3, direction, A, beta, gamma, n)
        z += d * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
    return z


@njit(cache=True, inline="always")
def bouc_wen_force(y: float, z: float, k: float, alpha: float) -> float:
    """Force ``α k y + (1 − α) k z``, positive in tension."""
    return k * (alpha * y + (1.0 - alpha) * z)


@njit(cache=True)
def _loop(y: np.ndarray, table: np.ndarray, dy_max: float) -> tuple[np.ndarray, np.ndarray]:
    k, alpha, A, beta, gamma, n = table
    z = np.zeros(y.shape[0])
    f = np.zeros(y.shape[0])
    f[0] = bouc_wen_force(y[0], 0.0, k, alpha)
    for i in range(1, y.shape[0]):
        z[i] = bouc_wen_update(z[i - 1], y[i] - y[i - 1], A, beta, gamma, n, dy_max)
        f[i] = bouc_wen_force(y[i], z[i], k, alpha)
    return f, z


def bouc_wen_loop(y: np.ndarray, k: float, alpha: float, A: float, beta: float,
                  gamma: float, n: float) -> tuple[np.ndarray, np.ndarray]:
    """Force and ``z`` of one element driven through the deformations ``y`` (from ``z = 0``).

    The update the integrators use between two steps, applied between consecutive samples
    (the deformation linear in between): a hysteresis loop under a prescribed history.

    Returns
    -------
    force, z : ndarray, shape like ``y``
    """
    table = np.array([k, alpha, A, beta, gamma, n], dtype=float)
    check_bouc_wen_parameters(table[None, :])
    y = np.ascontiguousarray(y, dtype=float)
    if y.ndim != 1 or y.size == 0 or not np.all(np.isfinite(y)):
        raise ModelError(f"bouc_wen_loop: y must be a finite 1-D array, got shape {y.shape}")
    dy_max = float(bouc_wen_step_limit(A, beta, gamma, n))
    return _loop(y, table, dy_max)


def bouc_wen_step_limit(A: np.ndarray, beta: np.ndarray, gamma: np.ndarray,
                        n: np.ndarray) -> np.ndarray:
    """The largest deformation increment of one Runge–Kutta part, ``1 / (2 λ)``.

    ``λ = n (β + |γ|) z_u^(n−1)`` bounds ``|∂(dz/dy)/∂z|`` for ``|z| ≤ z_u`` when ``n ≥ 1``;
    for ``n < 1`` the slope is unbounded at ``z = 0`` but ``z`` there moves at the finite rate
    ``A``, and the bound at ``z_u`` keeps the parts as fine as the loop's curvature needs.
    """
    A, beta, gamma, n = (np.asarray(v, dtype=float) for v in (A, beta, gamma, n))
    # z_u^(n−1) from log z_u: (A/(β+γ))^(1/n) itself under- or overflows for a small n.
    log_z_u = np.log(A / (beta + gamma)) / n
    slope = n * (beta + np.abs(gamma)) * np.exp((n - 1.0) * log_z_u)
    return 0.5 / slope


#: The range allowed for the ultimate hysteretic deformation ``z_u = (A / (β + γ))^(1/n)``
#: (m, or rad for a rotation). Outside it the loop is not representable: with n = 0.01 and
#: A/(β + γ) = 1/2500, z_u = 1e-340 underflowed to 0, and the Runge–Kutta parts (about
#: |Δy| n / z_u per step) divided by zero; near it a step needs billions of parts.
Z_U_RANGE = (1e-9, 1e9)


def ultimate_deformation_issue(A: float, beta: float, gamma: float, n: float
                               ) -> tuple[str, str] | None:
    """``(what, allowed)`` when ``z_u = (A / (β + γ))^(1/n)`` is outside :data:`Z_U_RANGE`
    (None when inside): allowed, the values of ``A / (β + γ)`` that ``n`` admits. Needs
    β + γ > 0."""
    log10_z_u = math.log10(A / (beta + gamma)) / n
    low, high = (math.log10(v) for v in Z_U_RANGE)
    if low <= log10_z_u <= high:
        return None
    return (f"z_u = (A / (beta + gamma))^(1/n) = 1e{log10_z_u:+.0f} (the largest hysteretic "
            f"deformation, with A = {A!r}, beta + gamma = {beta + gamma!r}, n = {n!r}) is out of "
            "range", f"z_u from {Z_U_RANGE[0]:g} to {Z_U_RANGE[1]:g}, i.e. with n = {n!r}, "
            f"A / (beta + gamma) in [{Z_U_RANGE[0] ** n:.4g}, {Z_U_RANGE[1] ** n:.4g}]")


def bouc_wen_initial_tangent(k: np.ndarray, alpha: np.ndarray, A: np.ndarray) -> np.ndarray:
    """Stiffness at ``z = 0``: ``k (α + (1 − α) A)`` (what the linear modes use)."""
    return np.asarray(k) * (np.asarray(alpha) + (1.0 - np.asarray(alpha)) * np.asarray(A))


def bouc_wen_max_tangent(k: np.ndarray, alpha: np.ndarray, A: np.ndarray, beta: np.ndarray,
                         gamma: np.ndarray) -> np.ndarray:
    """The largest tangent stiffness over ``|z| ≤ z_u``, for the stable step.

    ``dz/dy`` is largest at ``z = 0`` (``A``) or on unloading from ``z_u``, where it is
    ``A + (β − γ) z_u^n = 2 β A / (β + γ)``.
    """
    A, beta, gamma = (np.asarray(v, dtype=float) for v in (A, beta, gamma))
    slope = np.maximum(A, 2.0 * beta * A / (beta + gamma))
    return np.asarray(k) * (np.asarray(alpha) + (1.0 - np.asarray(alpha)) * slope)


def check_bouc_wen_parameters(table: np.ndarray, names: tuple[str, ...] | None = None) -> None:
    """Raise ModelError unless every row of ``table`` (k, α, A, β, γ, n) gives hysteresis.

    Parameters
    ----------
    table : ndarray, shape (n_elements, 6)
        One row per element, columns :data:`BOUC_WEN_PARAMETERS`.
    names : tuple of str, optional
        Element names for the message (default ``"Bouc–Wen element <e>"``).
    """
    table = np.asarray(table, dtype=float).reshape(-1, 6)
    for e, (k, alpha, A, beta, gamma, n) in enumerate(table):
        label = f"bouc_wen {names[e]!r}" if names else f"Bouc–Wen element {e}"
        rules = (
            ("k", k, np.isfinite(k) and k > 0.0, "> 0 (the initial stiffness)"),
            ("alpha", alpha, 0.0 <= alpha <= 1.0, "in [0, 1] (post-yield / initial stiffness)"),
            ("A", A, np.isfinite(A) and A > 0.0, "> 0"),
            ("n", n, np.isfinite(n) and n > 0.0,
             "> 0 (the sharpness of yield; n <= 0 gives no hysteresis)"),
            ("beta", beta, np.isfinite(beta) and beta > 0.0,
             "> 0 (with -beta < gamma <= beta; beta <= 0 dissipates no energy)"),
        )
        for what, value, ok, allowed in rules:
            if not ok:
                raise ModelError(f"{label}: {what} = {float(value)!r} is out of range; "
                                 f"allowed {allowed}")
        if not (np.isfinite(gamma) and -beta < gamma <= beta):
            raise ModelError(
                f"{label}: gamma = {float(gamma)!r} with beta = {float(beta)!r} gives no "
                f"bounded hysteresis loop; allowed -beta < gamma <= beta, i.e. in "
                f"({-float(beta)!r}, {float(beta)!r}]")
        issue = ultimate_deformation_issue(float(A), float(beta), float(gamma), float(n))
        if issue is not None:
            raise ModelError(f"{label}: {issue[0]}; allowed {issue[1]}")

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

Degradation (Baber and Wen 1981), as OpenSees's material has it: with the hysteretic energy

    e = ∫ (1 − α) k z dy

(the work of the hysteretic part of the force, a state of the element that starts at 0),

    ż = (A(e) ẏ − ν(e) (β |ẏ| |z|^(n−1) z + γ ẏ |z|^n)) / η(e),
    A(e) = A − δ_A e,   ν(e) = 1 + δ_ν e,   η(e) = 1 + δ_η e:

``δ_A`` lowers the stiffness of the loop, ``δ_ν`` its strength (``z_u`` falls as
``ν^(−1/n)``), ``δ_η`` both. With every ``δ = 0`` the law above runs unchanged (the same code,
bit for bit); otherwise ``(z, e)`` advance together by the same Runge–Kutta rule
(:func:`bouc_wen_degrading_update`), in parts as fine as the degraded slope needs
(:func:`bouc_wen_degrading_step_limit`). ``A(e)`` is used as written: a history long enough to
drive it to 0 leaves the element without hysteretic stiffness.

Parameters are checked by :func:`check_bouc_wen_parameters`: ``k > 0``, ``0 ≤ α ≤ 1``,
``A > 0``, ``n > 0``, and ``β > 0`` with ``−β < γ ≤ β`` (Baber and Wen's thermodynamic
admissibility with a bounded ``z``): outside that the loop dissipates no energy, or ``z``
grows without bound on loading (``β + γ ≤ 0``), and there is no hysteresis to fit; the
degradation rates ``δ_A, δ_ν, δ_η ≥ 0`` (unit 1/energy: 1/J = 1/(N·m)).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from femupdate.errors import ModelError

__all__ = [
    "BOUC_WEN_PARAMETERS",
    "DEGRADATION_PARAMETERS",
    "MAX_DEGRADING_PARTS",
    "Z_U_RANGE",
    "bouc_wen_degrading_parts",
    "bouc_wen_degrading_rate",
    "bouc_wen_degrading_step_limit",
    "bouc_wen_degrading_update",
    "bouc_wen_degrading_update_tangent",
    "bouc_wen_force",
    "bouc_wen_history",
    "bouc_wen_initial_tangent",
    "bouc_wen_loop",
    "bouc_wen_max_tangent",
    "bouc_wen_rate",
    "bouc_wen_step_limit",
    "bouc_wen_table",
    "bouc_wen_update",
    "check_bouc_wen_parameters",
    "is_degrading",
    "row_degrades",
    "ultimate_deformation_issue",
]

#: Order of the columns of a Bouc–Wen parameter table (``BoucWenElements.table``); the last
#: three, the degradation rates δ_A, δ_ν, δ_η, default to 0 (no degradation).
BOUC_WEN_PARAMETERS = ("k", "alpha", "A", "beta", "gamma", "n", "delta_a", "delta_nu",
                       "delta_eta")
#: The degradation columns of :data:`BOUC_WEN_PARAMETERS`.
DEGRADATION_PARAMETERS = BOUC_WEN_PARAMETERS[6:]
#: The most Runge–Kutta parts of one degrading update: an increment of a law degraded so far
#: that it needs more (a small n with a large ν: z_u(e) shrinks as ν^(−1/n)) is integrated
#: coarser rather than stall the simulation.
MAX_DEGRADING_PARTS = 1 << 16


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
def bouc_wen_degrading_rate(z: float, e: float, direction: float, A: float, beta: float,
                            gamma: float, n: float, delta_a: float, delta_nu: float,
                            delta_eta: float) -> float:
    """``dz/dy`` of the degrading law at the hysteretic energy ``e`` for a deformation moving
    in ``direction`` (+1 or −1): ``(A − δ_A e − (1 + δ_ν e) ψ |z|^n) / (1 + δ_η e)``."""
    az = abs(z)
    a = A - delta_a * e
    eta = 1.0 + delta_eta * e
    if az == 0.0:
        return a / eta
    psi = gamma + (beta if direction * z > 0.0 else -beta)
    power = az if n == 1.0 else (az * az if n == 2.0 else az ** n)
    return (a - (1.0 + delta_nu * e) * psi * power) / eta


@njit(cache=True, inline="always")
def bouc_wen_degrading_step_limit(z: float, e: float, A: float, beta: float, gamma: float,
                                  n: float, delta_a: float, delta_nu: float, delta_eta: float,
                                  c: float, dy_max: float) -> float:
    """The largest deformation increment of one Runge–Kutta part of the degrading law from
    ``(z, e)``: ``1 / (2 (λ_z + λ_e))``.

    ``λ_z`` is :func:`bouc_wen_step_limit`'s slope bound (``1 / (2 dy_max)`` undegraded) at
    the reach ``z_m = max(|z|, z_u(e))``, ``z_u(e) = (A(e) / (ν (β + γ)))^(1/n)``: it grows as
    ``ν(e) z_m^(n−1) / η(e)``. ``λ_e = √(c |∂(dz/dy)/∂e|)`` (``c = (1 − α) k``, the slope of
    ``de/dy``) bounds what the coupling of ``z`` and ``e`` adds to the eigenvalues of the
    pair's Jacobian. For ``n < 1``, ``(z_m / z_u)^n`` is held above ``10⁻⁶`` (the slope is
    unbounded at ``z = 0``; undegraded, the bound at ``z_u`` serves the same way).
    """
    a = A - delta_a * e
    nu = 1.0 + delta_nu * e
    eta = 1.0 + delta_eta * e
    bg = beta + gamma
    # (z_m / z_u)^n, z_u the undegraded reach: the larger of |z|'s and z_u(e)'s
    reach = max(abs(z) ** n * bg / A, max(a, 0.0) / (A * nu))
    if n < 1.0:
        reach = max(reach, 1e-6)
    slope = (0.5 / dy_max) * nu / eta * reach ** ((n - 1.0) / n) if reach > 0.0 else 0.0
    zn = reach * A / bg  # z_m^n
    b = beta + abs(gamma)
    coupling = c * (delta_a + delta_nu * b * zn + delta_eta * (abs(a) + nu * b * zn) / eta) / eta
    return 0.5 / (slope + math.sqrt(coupling))


@njit(cache=True, inline="always")
def _degrading_parts(limit: float, dy: float) -> int:
    """``ceil(|dy| / limit)`` parts, at least 1, at most :data:`MAX_DEGRADING_PARTS`."""
    ratio = abs(dy) / limit
    if not ratio < MAX_DEGRADING_PARTS:  # NaN too
        return MAX_DEGRADING_PARTS
    return max(1, math.ceil(ratio))


@njit(cache=True, inline="always")
def bouc_wen_degrading_parts(z: float, e: float, dy: float, A: float, beta: float,
                             gamma: float, n: float, delta_a: float, delta_nu: float,
                             delta_eta: float, c: float, dy_max: float) -> int:
    """The number of Runge–Kutta parts of the degrading update of ``dy`` from ``(z, e)``."""
    limit = bouc_wen_degrading_step_limit(z, e, A, beta, gamma, n, delta_a, delta_nu,
                                          delta_eta, c, dy_max)
    return _degrading_parts(limit, dy)


@njit(cache=True, inline="always")
def _degrading_rk4(z: float, e: float, dy: float, A: float, beta: float, gamma: float,
                   n: float, delta_a: float, delta_nu: float, delta_eta: float, c: float,
                   parts: int) -> tuple[float, float]:
    direction = 1.0 if dy > 0.0 else -1.0
    d = dy / parts
    for _ in range(parts):
        k1 = bouc_wen_degrading_rate(z, e, direction, A, beta, gamma, n, delta_a, delta_nu,
                                     delta_eta)
        z2 = z + 0.5 * d * k1
        e2 = e + 0.5 * d * c * z
        k2 = bouc_wen_degrading_rate(z2, e2, direction, A, beta, gamma, n, delta_a, delta_nu,
                                     delta_eta)
        z3 = z + 0.5 * d * k2
        e3 = e + 0.5 * d * c * z2
        k3 = bouc_wen_degrading_rate(z3, e3, direction, A, beta, gamma, n, delta_a, delta_nu,
                                     delta_eta)
        z4 = z + d * k3
        e4 = e + d * c * z3
        k4 = bouc_wen_degrading_rate(z4, e4, direction, A, beta, gamma, n, delta_a, delta_nu,
                                     delta_eta)
        e += d * c * (z + 2.0 * z2 + 2.0 * z3 + z4) / 6.0
        z += d * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
    return z, e


@njit(cache=True, inline="always")
def bouc_wen_degrading_update(z: float, e: float, dy: float, A: float, beta: float,
                              gamma: float, n: float, delta_a: float, delta_nu: float,
                              delta_eta: float, c: float, dy_max: float) -> tuple[float, float]:
    """``(z, e)`` after the deformation moved by ``dy`` (linearly): the classical Runge–Kutta
    rule in ``y`` on the pair ``dz/dy`` (:func:`bouc_wen_degrading_rate`), ``de/dy = c z``
    (``c = (1 − α) k``), in :func:`bouc_wen_degrading_parts` equal parts; ``dy_max`` is the
    undegraded part limit (:func:`bouc_wen_step_limit`)."""
    if dy == 0.0:
        return z, e
    parts = bouc_wen_degrading_parts(z, e, dy, A, beta, gamma, n, delta_a, delta_nu,
                                     delta_eta, c, dy_max)
    return _degrading_rk4(z, e, dy, A, beta, gamma, n, delta_a, delta_nu, delta_eta, c, parts)


@njit(cache=True, inline="always")
def _degrading_slopes(z: float, e: float, direction: float, rate: float, beta: float,
                      gamma: float, n: float, delta_a: float, delta_nu: float,
                      delta_eta: float) -> tuple[float, float]:
    """``∂(dz/dy)/∂z`` (0 at ``z = 0``) and ``∂(dz/dy)/∂e`` of the degrading rate ``rate``."""
    eta = 1.0 + delta_eta * e
    az = abs(z)
    if az == 0.0:
        return 0.0, (-delta_a - delta_eta * rate) / eta
    psi = gamma + (beta if direction * z > 0.0 else -beta)
    power = az ** n
    dz = -(1.0 + delta_nu * e) * psi * n * (power / az) * (1.0 if z > 0.0 else -1.0) / eta
    de = (-delta_a - delta_nu * psi * power - delta_eta * rate) / eta
    return dz, de


@njit(cache=True)
def bouc_wen_degrading_update_tangent(z: float, e: float, dy: float, A: float, beta: float,
                                      gamma: float, n: float, delta_a: float, delta_nu: float,
                                      delta_eta: float, c: float, parts: int
                                      ) -> tuple[float, float, float]:
    """``(z, e)`` after the deformation moved by ``dy`` in ``parts`` parts (as
    :func:`bouc_wen_degrading_update`) and ``∂z/∂dy``, the exact derivative of the discrete
    update (the sensitivities of ``z`` and ``e`` carried through the four stages). At
    ``dy = 0`` the derivative is the loading rate in the positive direction."""
    direction = 1.0 if dy >= 0.0 else -1.0
    d = dy / parts
    dd = 1.0 / parts  # ∂d/∂dy
    sz = 0.0  # ∂z/∂dy
    se = 0.0  # ∂e/∂dy
    for _ in range(parts):
        k1 = bouc_wen_degrading_rate(z, e, direction, A, beta, gamma, n, delta_a, delta_nu,
                                     delta_eta)
        gz, ge = _degrading_slopes(z, e, direction, k1, beta, gamma, n, delta_a, delta_nu,
                                   delta_eta)
        s1 = gz * sz + ge * se
        z2 = z + 0.5 * d * k1
        e2 = e + 0.5 * d * c * z
        tz2 = sz + 0.5 * (dd * k1 + d * s1)
        te2 = se + 0.5 * c * (dd * z + d * sz)
        k2 = bouc_wen_degrading_rate(z2, e2, direction, A, beta, gamma, n, delta_a, delta_nu,
                                     delta_eta)
        gz, ge = _degrading_slopes(z2, e2, direction, k2, beta, gamma, n, delta_a, delta_nu,
                                   delta_eta)
        s2 = gz * tz2 + ge * te2
        z3 = z + 0.5 * d * k2
        e3 = e + 0.5 * d * c * z2
        tz3 = sz + 0.5 * (dd * k2 + d * s2)
        te3 = se + 0.5 * c * (dd * z2 + d * tz2)
        k3 = bouc_wen_degrading_rate(z3, e3, direction, A, beta, gamma, n, delta_a, delta_nu,
                                     delta_eta)
        gz, ge = _degrading_slopes(z3, e3, direction, k3, beta, gamma, n, delta_a, delta_nu,
                                   delta_eta)
        s3 = gz * tz3 + ge * te3
        z4 = z + d * k3
        e4 = e + d * c * z3
        tz4 = sz + dd * k3 + d * s3
        te4 = se + c * (dd * z3 + d * tz3)
        k4 = bouc_wen_degrading_rate(z4, e4, direction, A, beta, gamma, n, delta_a, delta_nu,
                                     delta_eta)
        gz, ge = _degrading_slopes(z4, e4, direction, k4, beta, gamma, n, delta_a, delta_nu,
                                   delta_eta)
        s4 = gz * tz4 + ge * te4
        se += c * (dd * (z + 2.0 * z2 + 2.0 * z3 + z4)
                   + d * (sz + 2.0 * tz2 + 2.0 * tz3 + tz4)) / 6.0
        e += d * c * (z + 2.0 * z2 + 2.0 * z3 + z4) / 6.0
        sz += (dd * (k1 + 2.0 * k2 + 2.0 * k3 + k4) + d * (s1 + 2.0 * s2 + 2.0 * s3 + s4)) / 6.0
        z += d * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
    return z, e, sz


@njit(cache=True, inline="always")
def bouc_wen_force(y: float, z: float, k: float, alpha: float) -> float:
    """Force ``α k y + (1 − α) k z``, positive in tension."""
    return k * (alpha * y + (1.0 - alpha) * z)


@njit(cache=True, inline="always")
def row_degrades(table: np.ndarray, e: int) -> bool:
    """Whether row ``e`` of a parameter table has a non-zero degradation rate (the compiled
    kernels' test; :func:`is_degrading` for whole tables)."""
    return table[e, 6] != 0.0 or table[e, 7] != 0.0 or table[e, 8] != 0.0


def is_degrading(table: np.ndarray) -> np.ndarray:
    """Per row of a parameter table, whether any degradation rate is non-zero."""
    table = np.asarray(table, dtype=float)
    return np.any(table[..., 6:9] != 0.0, axis=-1)


@njit(cache=True)
def _loop(y: np.ndarray, table: np.ndarray, dy_max: float, energy: bool
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    k, alpha, A, beta, gamma, n, delta_a, delta_nu, delta_eta = table
    c = (1.0 - alpha) * k
    z = np.zeros(y.shape[0])
    e = np.zeros(y.shape[0])
    f = np.zeros(y.shape[0])
    f[0] = bouc_wen_force(y[0], 0.0, k, alpha)
    for i in range(1, y.shape[0]):
        dy = y[i] - y[i - 1]
        if energy:
            z[i], e[i] = bouc_wen_degrading_update(z[i - 1], e[i - 1], dy, A, beta, gamma, n,
                                                   delta_a, delta_nu, delta_eta, c, dy_max)
        else:
            z[i] = bouc_wen_update(z[i - 1], dy, A, beta, gamma, n, dy_max)
        f[i] = bouc_wen_force(y[i], z[i], k, alpha)
    return f, z, e


def _loop_input(y: np.ndarray, params: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray,
                                                                     float]:
    table = np.array(params, dtype=float)
    check_bouc_wen_parameters(table[None, :])
    y = np.ascontiguousarray(y, dtype=float)
    if y.ndim != 1 or y.size == 0 or not np.all(np.isfinite(y)):
        raise ModelError(f"bouc_wen_loop: y must be a finite 1-D array, got shape {y.shape}")
    return y, table, float(bouc_wen_step_limit(*table[2:6]))


def bouc_wen_loop(y: np.ndarray, k: float, alpha: float, A: float, beta: float,
                  gamma: float, n: float, delta_a: float = 0.0, delta_nu: float = 0.0,
                  delta_eta: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Force and ``z`` of one element driven through the deformations ``y`` (from ``z = 0``).

    The update the integrators use between two steps, applied between consecutive samples
    (the deformation linear in between): a hysteresis loop under a prescribed history. With
    every ``δ = 0`` the undegraded update, else the degrading one.

    Returns
    -------
    force, z : ndarray, shape like ``y``
    """
    y, table, dy_max = _loop_input(y, (k, alpha, A, beta, gamma, n, delta_a, delta_nu,
                                       delta_eta))
    f, z, _ = _loop(y, table, dy_max, bool(is_degrading(table)))
    return f, z


def bouc_wen_history(y: np.ndarray, k: float, alpha: float, A: float, beta: float,
                     gamma: float, n: float, delta_a: float = 0.0, delta_nu: float = 0.0,
                     delta_eta: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """As :func:`bouc_wen_loop`, with the hysteretic energy: the degrading update on the pair
    ``(z, e)`` whatever the rates (with every ``δ = 0`` it is the undegraded law, integrated
    in the degrading update's parts).

    Returns
    -------
    force, z, e : ndarray, shape like ``y``
        ``e = ∫ (1 − α) k z dy`` from ``y[0]``.
    """
    y, table, dy_max = _loop_input(y, (k, alpha, A, beta, gamma, n, delta_a, delta_nu,
                                       delta_eta))
    return _loop(y, table, dy_max, True)


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


def bouc_wen_table(table: np.ndarray) -> np.ndarray:
    """``table`` as float rows of :data:`BOUC_WEN_PARAMETERS`; a table of the first six
    columns gets the degradation rates 0."""
    table = np.asarray(table, dtype=float)
    table = table.reshape(-1, table.shape[-1]) if table.ndim else table.reshape(1, 1)
    width = len(BOUC_WEN_PARAMETERS)
    if table.shape[1] == 6:
        table = np.hstack([table, np.zeros((table.shape[0], width - 6))])
    if table.shape[1] != width:
        raise ModelError(f"a Bouc–Wen table has {table.shape[1]} columns; expected {width} "
                         f"({', '.join(BOUC_WEN_PARAMETERS)}) or the first 6")
    return table


def check_bouc_wen_parameters(table: np.ndarray, names: tuple[str, ...] | None = None) -> None:
    """Raise ModelError unless every row of ``table`` (k, α, A, β, γ, n and optionally the
    degradation rates δ_A, δ_ν, δ_η) gives hysteresis.

    Parameters
    ----------
    table : ndarray, shape (n_elements, 9) or (n_elements, 6)
        One row per element, columns :data:`BOUC_WEN_PARAMETERS` (or its first six).
    names : tuple of str, optional
        Element names for the message (default ``"Bouc–Wen element <e>"``).
    """
    table = bouc_wen_table(table)
    for e, (k, alpha, A, beta, gamma, n, *deltas) in enumerate(table):
        label = f"bouc_wen {names[e]!r}" if names else f"Bouc–Wen element {e}"
        rules = [
            ("k", k, np.isfinite(k) and k > 0.0, "> 0 (the initial stiffness)"),
            ("alpha", alpha, 0.0 <= alpha <= 1.0, "in [0, 1] (post-yield / initial stiffness)"),
            ("A", A, np.isfinite(A) and A > 0.0, "> 0"),
            ("n", n, np.isfinite(n) and n > 0.0,
             "> 0 (the sharpness of yield; n <= 0 gives no hysteresis)"),
            ("beta", beta, np.isfinite(beta) and beta > 0.0,
             "> 0 (with -beta < gamma <= beta; beta <= 0 dissipates no energy)"),
        ]
        rules += [(what, value, np.isfinite(value) and value >= 0.0,
                   ">= 0 and finite (a degradation rate per unit of hysteretic energy; 0: none)")
                  for what, value in zip(DEGRADATION_PARAMETERS, deltas, strict=True)]
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

"""Implicit integration of hysteretic systems: Newmark (average acceleration) or HHT-α, with
Newton–Raphson iterations on the deformations of the nonlinear elements.

    M ÿ + C ẏ + K y + Bᵀ f(B y) = -p a_g(t) + f(t)

``B`` stacks the connectivity rows of the elasto-slip friction elements and of the Bouc–Wen
elements; ``f`` their forces. With HHT-α (Hilber, Hughes and Taylor 1977; ``α`` in
[-1/3, 0], ``β = (1 - α)²/4``, ``γ = (1 - 2α)/2``; ``α = 0`` is Newmark's average
acceleration) the equation at ``t_{n+1}`` is

    M a_{n+1} + (1+α)(C v_{n+1} + K u_{n+1} + Bᵀ f_{n+1}) - α(C v_n + K u_n + Bᵀ f_n)
        = F(t_{n+1+α}),

and Newmark's relations give ``a_{n+1}`` and ``v_{n+1}`` from ``u_{n+1}``. The linear part is
factorised once per step size, ``K̂ = M/(βh²) + (1+α)γ C/(βh) + (1+α) K``, so

    u_{n+1} = u_lin - (1+α) K̂⁻¹ Bᵀ f(B u_{n+1}),

with ``u_lin`` linear in the previous state and the load. Only the element deformations
``y = B u_{n+1}`` are unknown: Newton–Raphson solves the condensed equations

    R(y) = y - B u_lin + S f(y) = 0,      S = (1+α) B K̂⁻¹ Bᵀ   (m × m, constant),

with the iteration matrix ``I + S diag(∂f/∂y)``. The friction element's return mapping
(:func:`femupdate.model.friction.elasto_slip`, the slider's offset from the previous step) is
backward Euler by itself; its tangent is ``k_r`` while stuck and 0 while slipping. The
Bouc–Wen ``z`` follows its rate-independent law over the step's deformation increment: for
``n = 1`` exactly (the law is linear in ``z`` on either side of ``z = 0``,
:func:`bouc_wen_update_exponential`: one exponential whatever the increment), otherwise by
the same fourth-order Runge–Kutta rule as the explicit path
(:func:`femupdate.model.hysteresis.bouc_wen_update`, in parts of at most ``1/(2λ)``),
differentiated exactly (:func:`bouc_wen_update_tangent`); with degradation (δA, δν, δη), the
pair ``z`` and hysteretic energy by Runge–Kutta with both sensitivities
(:func:`femupdate.model.hysteresis.bouc_wen_degrading_update_tangent`). Each gives the
consistent tangent ``k (α + (1 - α) ∂z/∂y)``, which the iteration matrix takes; where a line search
has to shorten a correction (the law has a kink where the deformation turns, and the tangent
can overshoot across it) the rest of the step takes the secants over the step instead (on
the 100-link frame of benchmarks/hysteretic_frame.py, 5 steps per sample: 11.9 iterations per
step against 12.0 with the secants throughout).
Newton starts from the last increment extrapolated. The iteration matrix is factorised when
the iterations stop contracting by half and reused otherwise, across steps too (on a
zero-length-link frame the tangents change little from step to step: most steps need no
factorisation). Each iteration costs ``m × m`` work, whatever the number of DOFs; the
``n × n`` work per step is three matrix-vector products, as linear Newmark.

The scheme is unconditionally stable for the linear part (``α`` in [-1/3, 0]); it needs no
step below the highest frequency, so stiff zero-length links do not set the step. Its error is
second order in ``h`` (period elongation ``(ωh)²/12`` per cycle for ``α = 0``): the step is
chosen for the modes that carry the response, and :func:`step_halving_error` states the error
at a given step by comparing with half of it.

Why this file is long (about 650 lines): the scheme is one compiled time loop with what it calls
inside the loop (the element laws with their exact tangents, the condensed Newton solve and its
small LU), and the simulator that prepares its matrices; apart, they would still be compiled
and read together.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import scipy.linalg as sla
from numba import njit

from femupdate.errors import ConfigError, SimulationError
from femupdate.model.hysteresis import (
    BOUC_WEN_PARAMETERS,
    bouc_wen_degrading_parts,
    bouc_wen_degrading_update_tangent,
    bouc_wen_force,
    bouc_wen_rate,
    bouc_wen_step_limit,
    row_degrades,
)
from femupdate.model.system import System
from femupdate.simulate._common import (
    DIVERGENCE_LIMIT,
    Simulator,
    element_histories,
    omega_max,
)

__all__ = ["HHT_ALPHA_RANGE", "ImplicitSimulator", "bouc_wen_update_exponential",
           "bouc_wen_update_tangent",
           "check_hht_alpha", "explicit_stable_step", "prepare_implicit", "step_halving_error"]

#: Allowed Hilber–Hughes–Taylor ``α`` (0: Newmark's average acceleration, no numerical damping).
HHT_ALPHA_RANGE = (-1.0 / 3.0, 0.0)

#: Newton–Raphson stops when every deformation moved by less than this, relative to the
#: element's own scale (its ``|y|`` plus its yield deformation).
NEWTON_TOLERANCE = 1e-10
NEWTON_MAX_ITERATIONS = 100
#: Halvings of a Newton correction before the line search takes the last one (at the rounding
#: floor the residual cannot fall: more halvings only cost evaluations; 40 cost 2.4× the time
#: of 4 on the 100-link frame of benchmarks/hysteretic_frame.py, with the same result).
LINE_SEARCH_HALVINGS = 4


def check_hht_alpha(alpha: float) -> float:
    """``alpha`` as float after checking it lies in :data:`HHT_ALPHA_RANGE`."""
    try:
        alpha = float(alpha)
    except (TypeError, ValueError):
        raise ConfigError(f"hht_alpha = {alpha!r} is not a number; give a value in "
                          "[-1/3, 0]") from None
    if not HHT_ALPHA_RANGE[0] <= alpha <= HHT_ALPHA_RANGE[1]:
        raise ConfigError(f"hht_alpha = {alpha!r} is not allowed; it must lie in [-1/3, 0] "
                          "(0: Newmark's average acceleration; negative values damp the "
                          "highest modes)")
    return alpha


@njit(cache=True, inline="always")
def _rate_slope(z: float, direction: float, beta: float, gamma: float, n: float) -> float:
    """``∂(dz/dy)/∂z`` of :func:`bouc_wen_rate` (0 at ``z = 0``, where the rate is ``A``)."""
    az = abs(z)
    if az == 0.0:
        return 0.0
    psi = gamma + (beta if direction * z > 0.0 else -beta)
    power = 1.0 if n == 1.0 else (az if n == 2.0 else az ** (n - 1.0))
    return -psi * n * power * (1.0 if z > 0.0 else -1.0)


@njit(cache=True)
def bouc_wen_update_tangent(z: float, dy: float, A: float, beta: float, gamma: float,
                            n: float, parts: int) -> tuple[float, float]:
    """``z`` after the deformation moved by ``dy`` and its derivative ``∂z/∂dy``.

    The same classical Runge–Kutta rule in ``y`` as
    :func:`femupdate.model.hysteresis.bouc_wen_update`, in ``parts`` equal parts, with the
    sensitivity carried through the four stages (exact derivative of the discrete update).
    At ``dy = 0`` the derivative is the loading rate in the positive direction.
    """
    direction = 1.0 if dy >= 0.0 else -1.0
    d = dy / parts
    dd = 1.0 / parts  # ∂d/∂dy
    s = 0.0  # ∂z/∂dy
    for _ in range(parts):
        k1 = bouc_wen_rate(z, direction, A, beta, gamma, n)
        s1 = _rate_slope(z, direction, beta, gamma, n) * s
        z2 = z + 0.5 * d * k1
        t2 = s + 0.5 * (dd * k1 + d * s1)
        k2 = bouc_wen_rate(z2, direction, A, beta, gamma, n)
        s2 = _rate_slope(z2, direction, beta, gamma, n) * t2
        z3 = z + 0.5 * d * k2
        t3 = s + 0.5 * (dd * k2 + d * s2)
        k3 = bouc_wen_rate(z3, direction, A, beta, gamma, n)
        s3 = _rate_slope(z3, direction, beta, gamma, n) * t3
        z4 = z + d * k3
        t4 = s + dd * k3 + d * s3
        k4 = bouc_wen_rate(z4, direction, A, beta, gamma, n)
        s4 = _rate_slope(z4, direction, beta, gamma, n) * t4
        z += d * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
        s += (dd * (k1 + 2.0 * k2 + 2.0 * k3 + k4) + d * (s1 + 2.0 * s2 + 2.0 * s3 + s4)) / 6.0
    return z, s


@njit(cache=True)
def bouc_wen_update_exponential(z: float, dy: float, A: float, beta: float,
                                gamma: float) -> tuple[float, float]:
    """``z`` after the deformation moved by ``dy`` and ``∂z/∂dy``, exactly, for ``n = 1``.

    Measured along the motion (``u = z sign(dy)``, ``x = |dy|``) the law is linear on either
    side of ``u = 0``: ``du/dx = A - (β + γ) u`` for ``u ≥ 0`` and ``A - (β - γ) u`` for
    ``u < 0``, so ``u`` relaxes exponentially, towards ``z_u`` after crossing zero. The
    derivative of the exact flow with respect to its length is the rate at its end,
    ``dz/dy`` at the new ``z``; at ``dy = 0`` the loading rate in the positive direction.
    """
    if dy == 0.0:
        return z, bouc_wen_rate(z, 1.0, A, beta, gamma, 1.0)
    sign = 1.0 if dy > 0.0 else -1.0
    x = abs(dy)
    u = sign * z
    if u < 0.0:  # unloading towards u = 0 at the rate A + (β - γ)|u|
        r = beta - gamma  # ≥ 0
        t = -r * u / A
        x0 = math.log1p(t) / r if t > 0.0 else -u / A  # the length that reaches u = 0
        if x < x0:
            u = u * math.exp(-r * x) - A * math.expm1(-r * x) / r if t > 0.0 else u + A * x
            return sign * u, A - r * u
        x -= x0
        u = 0.0
    p = beta + gamma  # > 0
    # exp(-px) below 1e-304 is 0 to the result; taken as 0 it stays out of the subnormals
    decay = math.exp(-p * x) if p * x < 700.0 else 0.0
    u = u * decay + A * (1.0 - decay) / p
    return sign * u, A - p * u


@njit(cache=True, inline="always")
def _element_laws(y: np.ndarray, y_old: np.ndarray, state: np.ndarray, nf: int,
                  kr: np.ndarray, fu: np.ndarray, bw: np.ndarray, dy_max: np.ndarray,
                  f: np.ndarray, df: np.ndarray, sec: np.ndarray, trial: np.ndarray) -> None:
    """Forces ``f``, consistent tangents ``df``, secants over the step ``sec`` and the trial
    internal state (slip offset or ``z``) of every element at deformations ``y`` from the
    committed ``state`` (friction first; after the ``m`` elements, the Bouc–Wen elements'
    hysteretic energies)."""
    m = nf + bw.shape[0]
    for e in range(nf):
        k_r = kr[e]
        if k_r <= 0.0:
            f[e] = 0.0
            df[e] = sec[e] = 0.0
            trial[e] = state[e]
            continue
        limit = fu[e] / k_r
        d = y[e] - state[e]
        if abs(d) <= limit:  # stuck: the spring alone
            f[e] = k_r * d
            df[e] = sec[e] = k_r
            trial[e] = state[e]
        else:  # slipping: the slider follows, the force stays at ±f_u
            sign = 1.0 if d > 0.0 else -1.0
            f[e] = sign * fu[e]
            df[e] = sec[e] = 0.0
            trial[e] = y[e] - sign * limit
    for b in range(bw.shape[0]):
        e = nf + b
        step = y[e] - y_old[e]
        count = max(1, math.ceil(abs(step) / dy_max[b]))  # parts of at most 1/(2λ)
        if row_degrades(bw, b):
            # degradation: z and the energy together, as fine as the degraded law needs
            c = (1.0 - bw[b, 1]) * bw[b, 0]
            count = max(count, bouc_wen_degrading_parts(
                state[e], state[m + b], step, bw[b, 2], bw[b, 3], bw[b, 4], bw[b, 5], bw[b, 6],
                bw[b, 7], bw[b, 8], c, dy_max[b]))
            z, trial[m + b], s = bouc_wen_degrading_update_tangent(
                state[e], state[m + b], step, bw[b, 2], bw[b, 3], bw[b, 4], bw[b, 5], bw[b, 6],
                bw[b, 7], bw[b, 8], c, count)
        else:
            trial[m + b] = state[m + b]
            if bw[b, 5] == 1.0:  # the exact update: no sub-steps, whatever the increment
                z, s = bouc_wen_update_exponential(state[e], step, bw[b, 2], bw[b, 3],
                                                   bw[b, 4])
            else:  # Runge–Kutta in parts of at most 1/(2λ)
                z, s = bouc_wen_update_tangent(state[e], step, bw[b, 2], bw[b, 3], bw[b, 4],
                                               bw[b, 5], count)
        trial[e] = z
        f[e] = bouc_wen_force(y[e], z, bw[b, 0], bw[b, 1])
        df[e] = bw[b, 0] * (bw[b, 1] + (1.0 - bw[b, 1]) * s)
        # the secant over the step; below 1e-7 of the law's own scale z - z_n is rounding
        # (n = 1 at 1e-12 z_u: off by 1.5e-4; at 1e-30 z_u: 0), and the secant the tangent
        sec[e] = bw[b, 0] * (bw[b, 1] + (1.0 - bw[b, 1]) * ((z - state[e]) / step
                                                              if abs(step) > 1e-7 * dy_max[b]
                                                              else s))


@njit(cache=True)
def _lu_factor(a: np.ndarray, piv: np.ndarray) -> bool:
    """LU factorisation with partial pivoting of ``a`` in place (Doolittle); False if singular."""
    m = a.shape[0]
    for c in range(m):
        p = c
        big = abs(a[c, c])
        for r in range(c + 1, m):
            if abs(a[r, c]) > big:
                big = abs(a[r, c])
                p = r
        piv[c] = p
        if big == 0.0:
            return False
        if p != c:
            for j in range(m):
                a[c, j], a[p, j] = a[p, j], a[c, j]
        inv = 1.0 / a[c, c]
        for r in range(c + 1, m):
            lrc = a[r, c] * inv
            a[r, c] = lrc
            if lrc != 0.0:
                for j in range(c + 1, m):
                    a[r, j] -= lrc * a[c, j]
    return True


@njit(cache=True)
def _lu_solve_transposed(a: np.ndarray, piv: np.ndarray, b: np.ndarray) -> None:
    """Solve ``A x = b`` in place, ``a`` and ``piv`` the factors of ``Aᵀ`` by
    :func:`_lu_factor` (``P Aᵀ = L U``, so ``Uᵀ Lᵀ P x = b``).

    Factorising the transpose makes both triangular solves sweep rows of ``a`` (contiguous
    updates the compiler vectorises) instead of sequential inner products: at ``m = 100``
    2.7 µs a solve against 4.3 µs.
    """
    m = a.shape[0]
    for c in range(m):  # Uᵀ w = b: column c of Uᵀ is row c of U
        wc = b[c] / a[c, c]
        b[c] = wc
        for i in range(c + 1, m):
            b[i] -= a[c, i] * wc
    for c in range(m - 1, -1, -1):  # Lᵀ v = w (unit diagonal): column c of Lᵀ is row c of L
        vc = b[c]
        for i in range(c):
            b[i] -= a[c, i] * vc
    for c in range(m - 1, -1, -1):  # x = Pᵀ v
        p = piv[c]
        if p != c:
            b[c], b[p] = b[p], b[c]


@njit(cache=True, inline="always")
def _residual(y: np.ndarray, ylin: np.ndarray, ST: np.ndarray, f: np.ndarray,
              res: np.ndarray) -> float:
    """``R = y - y_lin + S f`` into ``res``; returns ``‖R‖₂``.

    ``ST`` is ``Sᵀ``: ``S f`` as a sum of its rows, contiguous updates the compiler
    vectorises (at ``m = 100`` 0.8 µs against 2.7 µs as inner products).
    """
    m = y.shape[0]
    for r in range(m):
        res[r] = y[r] - ylin[r]
    for c in range(m):
        fc = f[c]
        for r in range(m):
            res[r] += ST[c, r] * fc
    total = 0.0
    for r in range(m):
        total += res[r] * res[r]
    return math.sqrt(total)


@njit(cache=True)
def _implicit_kernel(AuT, AvT, AaT, HT, ST, q, substeps, h, alpha, beta, gamma, u0, v0, a0,
                     out, ei, ej, kr, fu, bw, dy_max, y_scale, tol, max_iter):
    """HHT-α / Newmark time stepping with Newton–Raphson on the element deformations.

    ``AuT, AvT, AaT`` (n, n) the transposes of ``K̂⁻¹`` times the coefficients of ``u_n, v_n,
    a_n`` in the right-hand side; ``HT`` (m, n) the transpose of ``K̂⁻¹ Bᵀ``; ``ST`` (m, m)
    the transpose of ``S = (1+α) B K̂⁻¹ Bᵀ``; ``q`` (ns, n) ``K̂⁻¹ F`` at the samples, linear in
    between; ``ei, ej`` the elements' DOFs (friction then Bouc–Wen; -1: ground).

    Each step starts Newton from the last increment extrapolated. The iteration matrix
    ``I + S diag(∂f/∂y)`` (consistent tangents; the secants over the step once a line search
    has had to shorten a correction in that step) is factorised when the iterations need it:
    at the first step, after a shortened correction, and whenever an iteration shrinks the
    correction by less than half. Between, the factors are reused across iterations and
    steps (modified Newton): each iteration costs an ``m × m`` back-substitution instead of a
    factorisation, and the contraction of at most ½ keeps the error below the last
    correction.

    Returns displacement, velocity and relative acceleration at the outputs, friction force
    and slip, Bouc–Wen force and z at the samples, whether the solution diverged, the index
    of the first sample whose step failed to converge (-1: none), the total number of Newton
    iterations and of factorisations.
    """
    ns = q.shape[0]
    n = u0.shape[0]
    m = ei.shape[0]
    nf = kr.shape[0]
    nb = bw.shape[0]
    no = out.shape[0]
    disp, vel, acc = np.empty((ns, no)), np.empty((ns, no)), np.empty((ns, no))
    ff, slip = np.empty((ns, nf)), np.empty((ns, nf))
    bf, bz = np.empty((ns, nb)), np.empty((ns, nb))
    u = u0.copy()
    v = v0.copy()
    a = a0.copy()
    ulin = np.empty(n)
    ut = np.empty(n)
    y_old = np.empty(m)  # committed deformations, forces and internal state
    f_old = np.empty(m)
    state = np.zeros(m + nb)  # then the Bouc–Wen energies
    y = np.empty(m)
    ylin = np.empty(m)
    f = np.empty(m)
    df = np.empty(m)
    sec = np.empty(m)
    trial = np.empty(m + nb)
    y_prev = np.empty(m)  # the deformations a step before the committed ones
    dy = np.empty(m)
    y_try = np.empty(m)
    res = np.empty(m)
    lu = np.empty((m, m))
    piv = np.zeros(m, dtype=np.int64)
    c0, cu, cv = 1.0 / (beta * h * h), h * h * (0.5 - beta), h * (1.0 - gamma)
    iterations = factorisations = 0
    stale = True  # no factors yet
    for e in range(m):
        d = u[ei[e]] - (u[ej[e]] if ej[e] >= 0 else 0.0)
        y_old[e] = d
        y_prev[e] = d
        y[e] = d
    # the forces at the initial state (slip offsets and z start at zero)
    _element_laws(y, y_old, state, nf, kr, fu, bw, dy_max, f_old, df, sec, trial)
    for k in range(ns):
        s = 0.0
        for i in range(n):
            s += abs(u[i]) + abs(v[i])
        if not s < DIVERGENCE_LIMIT:  # NaN fails too
            return disp, vel, acc, ff, slip, bf, bz, True, -1, iterations, factorisations
        for o in range(no):
            d = out[o]
            disp[k, o] = u[d]
            vel[k, o] = v[d]
            acc[k, o] = a[d]
        for e in range(nf):
            ff[k, e] = f_old[e]
            slip[k, e] = state[e]
        for b in range(nb):
            bf[k, b] = f_old[nf + b]
            bz[k, b] = state[nf + b]
        if k == ns - 1:
            break
        for j in range(substeps):
            frac = (j + 1.0 + alpha) / substeps  # the load at t_{n+1+α}
            for i in range(n):
                ulin[i] = q[k, i] + frac * (q[k + 1, i] - q[k, i])
            for c in range(n):
                uc = u[c]
                vc = v[c]
                ac = a[c]
                for i in range(n):
                    ulin[i] += AuT[c, i] * uc + AvT[c, i] * vc + AaT[c, i] * ac
            if alpha != 0.0:
                for e in range(m):
                    fe = alpha * f_old[e]
                    for i in range(n):
                        ulin[i] += HT[e, i] * fe
            # Newton–Raphson on the deformations
            for e in range(m):
                ylin[e] = ulin[ei[e]] - (ulin[ej[e]] if ej[e] >= 0 else 0.0)
                y[e] = 2.0 * y_old[e] - y_prev[e]  # from the last increment, extrapolated
            it = 0
            converged = m == 0
            secant = False  # the iteration matrix takes the consistent tangents
            if m:
                _element_laws(y, y_old, state, nf, kr, fu, bw, dy_max, f, df, sec, trial)
                norm = _residual(y, ylin, ST, f, res)
            last = np.inf
            while not converged and it < max_iter:
                it += 1
                if stale:
                    slope = sec if secant else df
                    for r in range(m):  # (I + S diag(slope))ᵀ, for _lu_solve_transposed
                        for c in range(m):
                            lu[r, c] = ST[r, c] * slope[r]
                        lu[r, r] += 1.0
                    if not _lu_factor(lu, piv):
                        return disp, vel, acc, ff, slip, bf, bz, False, k, iterations, \
                            factorisations
                    factorisations += 1
                    stale = False
                for e in range(m):
                    dy[e] = -res[e]
                _lu_solve_transposed(lu, piv, dy)
                size = 0.0
                for e in range(m):
                    size = max(size, abs(dy[e]) / (abs(y[e]) + y_scale[e] + 1e-300))
                if size <= tol:  # the correction is below the tolerance: take it, done
                    converged = True
                    for e in range(m):
                        y[e] += dy[e]
                    _element_laws(y, y_old, state, nf, kr, fu, bw, dy_max, f, df, sec, trial)
                else:
                    # backtracking: the residual must fall (a kink of the law at a turning
                    # point can make the full step overshoot)
                    t = 1.0
                    for _ in range(LINE_SEARCH_HALVINGS):
                        for e in range(m):
                            y_try[e] = y[e] + t * dy[e]
                        _element_laws(y_try, y_old, state, nf, kr, fu, bw, dy_max, f, df, sec,
                                      trial)
                        norm_try = _residual(y_try, ylin, ST, f, res)
                        if norm_try <= (1.0 - 1e-4 * t) * norm:
                            break
                        t *= 0.5
                        # the tangent led astray (a kink where the deformation turns): the
                        # secants, factorised afresh, for the rest of the step
                        stale = secant = True
                    for e in range(m):
                        y[e] = y_try[e]
                    norm = norm_try
                    if t * size > 0.5 * last:  # contracting too slowly: a fresh tangent
                        stale = True
                    last = t * size
            iterations += it
            if not converged:
                return disp, vel, acc, ff, slip, bf, bz, False, k, iterations, factorisations
            for i in range(n):
                ut[i] = u[i] + h * v[i] + cu * a[i]  # the predictor ũ
            for e in range(m):
                fe = (1.0 + alpha) * f[e]
                for i in range(n):
                    ulin[i] -= HT[e, i] * fe
            for i in range(n):
                a_new = c0 * (ulin[i] - ut[i])
                v[i] += cv * a[i] + gamma * h * a_new
                a[i] = a_new
                u[i] = ulin[i]
            for e in range(m):
                y_prev[e] = y_old[e]
                y_old[e] = y[e]
                f_old[e] = f[e]
            for e in range(m + nb):
                state[e] = trial[e]
    return disp, vel, acc, ff, slip, bf, bz, False, -1, iterations, factorisations


@njit(cache=True)
def _force_loads(force: np.ndarray, GT: np.ndarray) -> np.ndarray:
    """``K̂⁻¹ f_k`` for every sample, ``GT`` the transpose of ``K̂⁻¹``, by a compiled loop.

    Not ``force @ G.T``: OpenBLAS's threads keep spinning after the product and take the
    core from the time loop that follows; on the 100-link frame of
    benchmarks/hysteretic_frame.py (2 s of record, 2 shared cores, runs interleaved) a run
    took a median of 147 ms of wall time after the BLAS product and 80 ms after this loop
    (54 and 55 ms at best).
    """
    ns, n = force.shape
    q = np.zeros((ns, GT.shape[1]))
    for k in range(ns):
        for j in range(n):
            fj = force[k, j]
            if fj != 0.0:
                for i in range(GT.shape[1]):
                    q[k, i] += GT[j, i] * fj
    return q


def _sample_loads(ag: np.ndarray | None, force: np.ndarray | None, g: np.ndarray,
                  GT: np.ndarray) -> np.ndarray:
    """``q_k = g a_g,k + K̂⁻¹ f_k`` for every sample: (n_samples, n), C-contiguous."""
    q = np.outer(ag, g) if ag is not None else None
    if force is not None:
        fq = _force_loads(np.ascontiguousarray(force, dtype=float), GT)
        q = fq if q is None else q + fq
    return np.ascontiguousarray(q)


def explicit_stable_step(system: System) -> float:
    """Largest stable step of central differences for ``system`` (``2/ω_max`` with the sliders
    stuck and every Bouc–Wen element at its largest tangent); inf without stiffness."""
    K = system.K
    n = system.n_dof
    if system.friction is not None and system.friction.count:
        fr = system.friction
        active = fr.f_u > 0
        b = fr.connectivity(n)[active]
        K = K + b.T @ (fr.k_r[active, None] * b)
    if system.bouc_wen is not None and system.bouc_wen.count:
        K = K + system.bouc_wen.max_stiffness(n)
    w = omega_max(system.M, K)
    return math.inf if w <= 0.0 else 2.0 / w


class ImplicitSimulator(Simulator):
    """HHT-α (Newmark's average acceleration for ``alpha = 0``) with Newton–Raphson on the
    friction and Bouc–Wen elements, prepared for one system, sample interval and step.

    Attributes
    ----------
    alpha, beta, gamma : float
        The HHT parameters and the Newmark ones they imply.
    iterations, factorisations : int
        Newton iterations and factorisations of the tangent in the last run.
    """

    def __init__(
        self,
        system: System,
        dt: float,
        outputs: Sequence[int] | np.ndarray | None = None,
        substeps: int = 1,
        alpha: float = 0.0,
    ) -> None:
        super().__init__(system, dt, outputs, substeps)
        self.alpha = check_hht_alpha(alpha)
        self.beta = (1.0 - self.alpha) ** 2 / 4.0
        self.gamma = 0.5 - self.alpha
        self.iterations = self.factorisations = 0
        n, h, al, be, ga = self.n_dof, self.h, self.alpha, self.beta, self.gamma
        M, C, K = system.M, system.C, system.K
        c0 = 1.0 / (be * h * h)
        P = c0 * M + (1.0 + al) * ga * h * c0 * C
        try:
            lu = sla.lu_factor(P + (1.0 + al) * K, check_finite=False)
        except (sla.LinAlgError, ValueError):
            raise SimulationError(f"implicit: the effective stiffness is singular at h = "
                                  f"{h:.6g} s; check M, C and K") from None
        solve = lambda x: sla.lu_solve(lu, x, check_finite=False)  # noqa: E731
        self._AuT = np.ascontiguousarray(solve(P + al * K).T)
        self._AvT = np.ascontiguousarray(solve(h * P - C).T)
        self._AaT = np.ascontiguousarray(
            solve(h * h * (0.5 - be) * P - (1.0 + al) * h * (1.0 - ga) * C).T)
        self._g = solve(-system.seismic_load)
        self._GT = np.ascontiguousarray(solve(np.eye(n)).T)
        fr, bw = system.friction, system.bouc_wen
        nf = 0 if fr is None else fr.count
        nb = 0 if bw is None else bw.count
        self.n_friction, self.n_bouc_wen = nf, nb
        ei = [np.zeros(0, dtype=np.int64)]
        ej = [np.zeros(0, dtype=np.int64)]
        scale = [np.zeros(0)]
        if nf:
            ei.append(fr.dof_i)
            ej.append(fr.dof_j)
            with np.errstate(divide="ignore", invalid="ignore"):
                lim = np.where(fr.k_r > 0, fr.f_u / np.where(fr.k_r > 0, fr.k_r, 1.0), 0.0)
            scale.append(np.where(np.isfinite(lim), lim, 0.0))
            self._kr = np.ascontiguousarray(fr.k_r, dtype=float)
            self._fu = np.ascontiguousarray(fr.f_u, dtype=float)
        else:
            self._kr = self._fu = np.zeros(0)
        if nb:
            t = np.ascontiguousarray(bw.table, dtype=float)
            ei.append(bw.dof_i)
            ej.append(bw.dof_j)
            scale.append((t[:, 2] / (t[:, 3] + t[:, 4])) ** (1.0 / t[:, 5]))  # z_u
            self._bw = t
            self._dy_max = np.ascontiguousarray(
                bouc_wen_step_limit(t[:, 2], t[:, 3], t[:, 4], t[:, 5]), dtype=float)
        else:
            self._bw = np.zeros((0, len(BOUC_WEN_PARAMETERS)))
            self._dy_max = np.zeros(0)
        self._ei = np.ascontiguousarray(np.concatenate(ei), dtype=np.int64)
        self._ej = np.ascontiguousarray(np.concatenate(ej), dtype=np.int64)
        self._y_scale = np.ascontiguousarray(np.concatenate(scale), dtype=float)
        m = self._ei.size
        B = np.zeros((m, n))
        B[np.arange(m), self._ei] = 1.0
        ground = self._ej < 0
        B[np.arange(m)[~ground], self._ej[~ground]] = -1.0
        self._B = B
        H = solve(B.T) if m else np.zeros((n, 0))
        self._HT = np.ascontiguousarray(H.T)
        self._ST = np.ascontiguousarray(((1.0 + al) * (B @ H)).T)

    def _initial_force(self, x0: np.ndarray) -> np.ndarray:
        """Element forces on the DOFs at the initial state (slip offsets and ``z`` zero)."""
        y = self._B @ x0
        nf = self.n_friction
        f = np.zeros(y.size)
        if nf:
            d = y[:nf]
            with np.errstate(divide="ignore", invalid="ignore"):
                lim = np.where(self._kr > 0, self._fu / np.where(self._kr > 0, self._kr, 1.0),
                               0.0)
            f[:nf] = self._kr * np.clip(d, -lim, lim)
        if self.n_bouc_wen:
            f[nf:] = self._bw[:, 0] * self._bw[:, 1] * y[nf:]  # α k y at z = 0
        return self._B.T @ f

    def _integrate(
        self, ag: np.ndarray | None, force: np.ndarray | None, ns: int, x0: np.ndarray,
        v0: np.ndarray,
    ) -> tuple:
        q = _sample_loads(ag, force, self._g, self._GT)
        a0 = self._initial_acceleration(ag, force, x0, v0, self._initial_force(x0))
        (disp, vel, acc, ff, slip, bf, bz, diverged, failed, self.iterations,
         self.factorisations) = _implicit_kernel(
            self._AuT, self._AvT, self._AaT, self._HT, self._ST, q, self.substeps, self.h,
            self.alpha, self.beta, self.gamma, x0, v0, a0, self.outputs, self._ei, self._ej,
            self._kr, self._fu, self._bw, self._dy_max, self._y_scale, NEWTON_TOLERANCE,
            NEWTON_MAX_ITERATIONS)
        if failed >= 0:
            # not a diverged response the search can score: the step is too large for Newton
            raise SimulationError(
                f"implicit: Newton–Raphson did not converge in {NEWTON_MAX_ITERATIONS} "
                f"iterations in the step after sample {failed} (t = {failed * self.dt:.6g} s) "
                f"at h = {self.h:.6g} s; use more substeps")
        return (disp, vel, acc, diverged,
                *element_histories(self.n_friction, self.n_bouc_wen, ff, slip, bf, bz))


def prepare_implicit(
    system: System,
    dt: float,
    outputs: Sequence[int] | np.ndarray | None = None,
    substeps: int = 1,
    alpha: float = 0.0,
) -> ImplicitSimulator:
    """Prepare HHT-α with Newton–Raphson on the nonlinear elements at ``h = dt / substeps``.

    Parameters
    ----------
    system : System
        Linear, or with friction and/or Bouc–Wen elements.
    dt : float
        Sample interval of the inputs and outputs (s).
    outputs : sequence of int, optional
        DOF indices to output (default: all).
    substeps : int
        Integration steps per sample interval; the input is interpolated linearly.
    alpha : float
        HHT ``α`` in [-1/3, 0]; 0 (default) is Newmark's average acceleration.

    Returns
    -------
    ImplicitSimulator
        Call ``.run(ag, force, x0=..., v0=...)``; the response carries the friction and
        Bouc–Wen forces and states as the explicit path's does.

    Raises
    ------
    ConfigError
        For ``alpha`` out of range.
    SimulationError
        When a step's Newton iterations do not converge (at run time; more substeps help).
    """
    return ImplicitSimulator(system, dt, outputs, substeps, alpha)


def step_halving_error(system: System, dt: float, ag: np.ndarray, substeps: int = 1,
                       alpha: float = 0.0,
                       outputs: Sequence[int] | np.ndarray | None = None) -> float:
    """The error of the implicit scheme at ``h = dt/substeps`` estimated by halving the step.

    Returns the normalised mean squared difference (over every output) between the responses
    at ``h`` and ``h/2``, times ``(4/3)²``: for a second-order scheme the error at ``h`` is
    ``4/3`` of that difference (Richardson). The displacements are compared.
    """
    coarse = prepare_implicit(system, dt, outputs, substeps, alpha).run(ag).displacement
    fine = prepare_implicit(system, dt, outputs, 2 * substeps, alpha).run(ag).displacement
    power = float(np.sum(fine**2))
    if power == 0.0:
        return 0.0
    return (4.0 / 3.0) ** 2 * float(np.sum((coarse - fine) ** 2)) / power

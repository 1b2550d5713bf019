"""Numerics of bounded trust-region least squares on the unit cube (small pure functions).

Used by :mod:`femupdate.optimize.multistart`: space-filling samples, the noise of a simulation
(from a difference table), forward-difference steps chosen for that noise, the Jacobian's
Gram factor, the bounded Levenberg–Marquardt step and its gain ratio, the classification of a
minimum at a bound, and a damped BFGS update for the scalar mode.

A local quadratic model of φ around x is written throughout as

    m(p) = φ + gᵀp + ½ pᵀ H p,    H = Rᵀ R,

with ``g`` the gradient of φ: for residuals (φ = ‖r‖²) H = 2 JᵀJ and g = 2 Jᵀr (Gauss–Newton);
in the scalar mode H is a BFGS approximation of ∇²φ.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import cho_solve, cholesky, solve_triangular
from scipy.optimize import lsq_linear

#: Relative rounding of double precision.
EPS = float(np.finfo(float).eps)
#: Forward-difference steps are kept in [H_MIN, H_MAX] (unit cube).
H_MIN = 1e-10
H_MAX = 1e-2


def latin_hypercube(rng: np.random.Generator, k: int, n: int) -> np.ndarray:
    """``k`` points of a random Latin hypercube in [0, 1]^n: each coordinate has one point in
    each of its ``k`` equal strata (a space-filling start pool)."""
    strata = np.argsort(rng.random((k, n)), axis=0)
    return (strata + rng.random((k, n))) / k


def noise_level(table: np.ndarray) -> float:
    """Noise of a function from its values at equally spaced points (ECnoise, Moré & Wild 2011).

    Parameters
    ----------
    table : ndarray (k + 1, m)
        Values of m functions (the residual components, or φ alone with m = 1) at
        x + i·δ·d, i = 0 … k, with δ so small that the smooth part of the differences of order
        ≥ 2 is negligible against the noise.

    Returns
    -------
    float
        The standard deviation of the noise of one component: the RMS over components of the
        j-th differences scaled by γ_j = (j!)²/(2j)! (the variance of a j-th difference of
        i.i.d. noise is Var/γ_j), taken at the order j ≥ 2 where it is smallest (the orders
        agree when the table sees noise; the smallest is the least contaminated by the
        smooth part or by kinks).
    """
    diffs = np.asarray(table, dtype=float)
    best = math.inf
    for j in range(1, diffs.shape[0]):
        diffs = np.diff(diffs, axis=0)
        if j < 2:
            continue
        gamma = math.factorial(j) ** 2 / math.factorial(2 * j)
        best = min(best, math.sqrt(gamma * float(np.mean(diffs * diffs))))
    return best


def forward_steps(noise: float, slopes: np.ndarray, scale: float) -> np.ndarray:
    """Forward-difference steps h_i = 2 √(ε / μ_i) for noise ε, clipped to [H_MIN, H_MAX].

    The error of a forward difference, h·μ/2 + 2ε/h, is smallest at h = 2√(ε/μ) with μ the
    size of the second derivative. μ is taken as the size of the slope (the function varies
    over the unit cube by about its slope: its curvature is of the same order), per column
    ``slopes`` (RMS over components), so a parameter with a small sensitivity gets a larger
    step. The noise is never taken below rounding of the function's size ``scale``.
    """
    eps = max(noise, EPS * scale, 1e-300)
    mu = np.maximum(np.asarray(slopes, dtype=float), 1e-300)
    return np.clip(2.0 * np.sqrt(eps / mu), H_MIN, H_MAX)


def central_steps(noise: float, slopes: np.ndarray, scale: float) -> np.ndarray:
    """Central-difference steps h_i = (3ε / μ_i)^(1/3), clipped to [H_MIN, H_MAX].

    The error of a central difference, h²μ₃/6 + ε/h, is smallest at h = (3ε/μ₃)^(1/3); μ₃ is
    taken as the slope's size, as in :func:`forward_steps`. The gradient's error is then of
    order ε^(2/3) instead of ε^(1/2).
    """
    eps = max(noise, EPS * scale, 1e-300)
    mu = np.maximum(np.asarray(slopes, dtype=float), 1e-300)
    return np.clip(np.cbrt(3.0 * eps / mu), H_MIN, H_MAX)


def step_signs(x: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Signed steps: forward (+h) unless that leaves the unit cube, then backward."""
    return np.where(x + h <= 1.0, h, -h)


#: Second-order difference stencils: offsets (in steps) of the two points beside x and the
#: weights of (f(x), f(x + o1 h), f(x + o2 h)): central, and one-sided at a bound.
STENCILS = {
    "central": ((1.0, -1.0), (0.0, 0.5, -0.5)),
    "forward": ((1.0, 2.0), (-1.5, 2.0, -0.5)),
    "backward": ((-1.0, -2.0), (1.5, -2.0, 0.5)),
}


def second_order_stencils(x: np.ndarray, h: float | np.ndarray
                          ) -> tuple[np.ndarray, np.ndarray]:
    """Per coordinate, the offsets (n, 2) and weights (n, 3) of a second-order difference with
    step h: central where x ± h is in [0, 1], else one-sided (three points) into the cube."""
    kind = np.where(x - h < 0.0, "forward", np.where(x + h > 1.0, "backward", "central"))
    offsets = np.array([STENCILS[k][0] for k in kind])
    weights = np.array([STENCILS[k][1] for k in kind])
    return offsets, weights


def forward_columns(base: np.ndarray, values: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """Jacobian (m, n) by forward (or backward: negative steps) differences.

    ``base`` (m,) is f(x); ``values`` (n, m) holds f(x + steps_i e_i). A column with a
    non-finite value is 0: no information rather than a wrong one.
    """
    cols = (values - base) / steps[:, None]
    cols[~np.all(np.isfinite(values), axis=1)] = 0.0
    return cols.T


def second_order_columns(base: np.ndarray, values: np.ndarray, weights: np.ndarray,
                         h: float | np.ndarray) -> np.ndarray:
    """Jacobian (m, n) by the second-order stencils of :func:`second_order_stencils`.

    ``values`` (2n, m): f at x + o1_i h e_i for every i, then at x + o2_i h e_i.
    """
    n = weights.shape[0]
    first, second = values[:n], values[n:]
    h = np.broadcast_to(np.asarray(h, dtype=float), (n,))[:, None]
    cols = (weights[:, :1] * base + weights[:, 1:2] * first + weights[:, 2:] * second) / h
    ok = np.all(np.isfinite(first), axis=1) & np.all(np.isfinite(second), axis=1)
    cols[~ok] = 0.0
    return cols.T


def gram_factor(jac: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The Gauss–Newton model of φ = ‖r‖² at a point with Jacobian ``jac`` (m, n).

    Returns
    -------
    hess, grad, colnorm2 : ndarray
        H = 2 JᵀJ (n, n), g = 2 Jᵀr (n,) and the squared column norms of J (the diagonal of
        JᵀJ, for Marquardt's scaling). One product with [J r] (m × (n+1)): QR of the tall
        matrix costs ~10× more, and the damping below keeps H's solve well conditioned.
    """
    aug = np.column_stack([jac, r])
    gram = aug.T @ aug
    n = jac.shape[1]
    return 2.0 * gram[:n, :n], 2.0 * gram[:n, n], np.diag(gram[:n, :n]).copy()


def bounded_step(hess: np.ndarray, grad: np.ndarray, lam: float, d2: np.ndarray,
                 lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Minimiser of gᵀp + ½ pᵀ(H + λ D²)p over lower ≤ p ≤ upper (a damped, bounded step).

    The unconstrained solve is tried first (a Cholesky factor); only when it leaves the box is
    the bounded problem solved exactly, as the linear least-squares problem
    min ‖[L; √λ D] p + [L⁻¹g; 0]‖² (H = L Lᵀ) by bounded-variable least squares.
    """
    n = grad.size
    a = hess + lam * np.diag(d2)
    # A tiny ridge keeps the factor defined when H is singular and λ has fallen to 0.
    ridge = 1e-14 * max(float(np.max(np.diag(a))), 1e-300)
    try:
        low = cholesky(a + ridge * np.eye(n), lower=True, check_finite=False)
    except np.linalg.LinAlgError:
        return np.zeros(n)
    p = -cho_solve((low, True), grad, check_finite=False)
    if np.all(p >= lower) and np.all(p <= upper) and np.all(np.isfinite(p)):
        return p
    rhs = solve_triangular(low, -grad, lower=True, check_finite=False)
    with np.errstate(over="ignore", invalid="ignore"):  # a huge model: no step, said below
        res = lsq_linear(low.T, rhs, bounds=(lower, upper), method="bvls")
    if not np.all(np.isfinite(res.x)):
        return np.zeros(n)
    return np.clip(res.x, lower, upper)


def model_decrease(hess: np.ndarray, grad: np.ndarray, p: np.ndarray) -> float:
    """The decrease of φ the quadratic model predicts for step p: −(gᵀp + ½ pᵀHp)."""
    return float(-(grad @ p + 0.5 * p @ hess @ p))


def gain_ratio(phi: float, phi_new: float, predicted: float) -> float:
    """Actual over predicted decrease (−inf for a failed or non-decreasing prediction)."""
    if not (predicted > 0.0 and math.isfinite(phi_new)):
        return -math.inf
    return (phi - phi_new) / predicted


def damping_update(lam: float, nu: float, rho: float, accept: float) -> tuple[float, float]:
    """Nielsen's update of the Levenberg–Marquardt damping λ (and its growth factor ν).

    A step with gain ratio ρ > ``accept`` shrinks λ by max(1/3, 1 − (2ρ − 1)³) (more the
    better the model predicted) and resets ν = 2; a rejected one multiplies λ by ν and doubles
    ν, so repeated failures grow λ geometrically faster.
    """
    if rho > accept:
        return lam * max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3), 2.0
    return lam * nu, 2.0 * nu


def broyden_update(jac: np.ndarray, step: np.ndarray, change: np.ndarray) -> np.ndarray:
    """Broyden's rank-1 update of a Jacobian (m, n): the least change that maps ``step`` (n,)
    to the observed ``change`` of the residuals (m,): J + (Δr − J s) sᵀ / sᵀs."""
    ss = float(step @ step)
    if not ss > 0.0:
        return jac
    return jac + np.outer(change - jac @ step, step / ss)


def bfgs_update(hess: np.ndarray, s: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Powell's damped BFGS update of a Hessian approximation (stays positive definite).

    When sᵀy < 0.2 sᵀHs (negative curvature along s, or too little), y is replaced by
    θ y + (1 − θ) Hs so that sᵀy = 0.2 sᵀHs.
    """
    hs = hess @ s
    shs = float(s @ hs)
    if not shs > 0.0:
        return hess
    sy = float(s @ y)
    if sy < 0.2 * shs:
        theta = 0.8 * shs / (shs - sy)
        y = theta * y + (1.0 - theta) * hs
        sy = float(s @ y)
    return hess - np.outer(hs, hs) / shs + np.outer(y, y) / sy

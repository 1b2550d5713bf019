"""Single-DOF responses of every integrator against closed-form solutions.

System: m ẍ + c ẋ + k x = u(t), ω = 20 rad/s, ζ = 0.05. Inputs are sampled at 20 samples per
undamped period. The integrators all treat the input as linear between samples, so the
references below are closed forms for that piecewise-linear input (a sum of ramp responses),
which makes the comparison exact for the exact discretisation. Central differences and Newmark
are checked (a) against the closed-form solution of their own recurrences at 20 steps per
period, to rounding, and (b) against the continuous closed form at 20 samples per period with
10 substeps, within 1e-3, with the second-order convergence that tolerance relies on.
"""

from __future__ import annotations

import numpy as np
import pytest

from femupdate.model.system import System
from femupdate.simulate import simulate

MASS, OMEGA, ZETA = 2.0, 20.0, 0.05
STIFF = MASS * OMEGA**2
DAMP = 2.0 * ZETA * OMEGA * MASS
PERIOD = 2.0 * np.pi / OMEGA
DT = PERIOD / 20.0
N = 61  # three periods


def sdof() -> System:
    return System(
        M=np.array([[MASS]]), C=np.array([[DAMP]]), K=np.array([[STIFF]]), r=np.array([1.0])
    )


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(np.ravel(a) - np.ravel(b)) / np.linalg.norm(np.ravel(b)))


def free(t: np.ndarray, x0: float, v0: float) -> tuple[np.ndarray, np.ndarray]:
    """Displacement and velocity of damped free vibration from (x0, v0)."""
    t = np.asarray(t, dtype=float)
    sigma = ZETA * OMEGA
    wd = OMEGA * np.sqrt(1.0 - ZETA**2)
    a, b = x0, (v0 + sigma * x0) / wd
    env = np.exp(-sigma * t)
    x = env * (a * np.cos(wd * t) + b * np.sin(wd * t))
    v = env * ((b * wd - sigma * a) * np.cos(wd * t) - (a * wd + sigma * b) * np.sin(wd * t))
    return x, v


def step(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Response to a unit force applied at t = 0 (zero for t < 0)."""
    x, v = free(np.maximum(t, 0.0), -1.0 / STIFF, 0.0)
    on = t >= 0
    return np.where(on, 1.0 / STIFF + x, 0.0), np.where(on, v, 0.0)


def ramp(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Response to the unit ramp force u = t for t >= 0."""
    tp = np.maximum(t, 0.0)
    x, v = free(tp, 2.0 * ZETA / (OMEGA * STIFF), -1.0 / STIFF)
    on = t >= 0
    x_ramp = np.where(on, (tp - 2.0 * ZETA / OMEGA) / STIFF + x, 0.0)
    return x_ramp, np.where(on, 1.0 / STIFF + v, 0.0)


def piecewise_linear(u: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Response at the samples to the force linear between samples ``u``: step + ramps."""
    t = np.arange(u.size) * dt
    slope = np.diff(u) / dt
    kinks = np.concatenate([[slope[0]], np.diff(slope)])  # slope change at t_0 .. t_{N-2}
    lag = t[:, None] - t[None, : u.size - 1]
    xr, vr = ramp(lag)
    xs, vs = step(t)
    return u[0] * xs + xr @ kinks, u[0] * vs + vr @ kinks


def acceleration(u: np.ndarray, x: np.ndarray, v: np.ndarray) -> np.ndarray:
    return (u - DAMP * v - STIFF * x) / MASS


def harmonic_force(n: int = N, dt: float = DT) -> np.ndarray:
    t = np.arange(n) * dt
    return 30.0 * np.sin(0.7 * OMEGA * t) + 10.0 * np.cos(1.6 * OMEGA * t)


# ---------------------------------------------------------------- exact discretisation


def test_exact_free_vibration():
    x0, v0 = 0.01, -0.3
    t = np.arange(N) * DT
    r = simulate(sdof(), DT, force=np.zeros((N, 1)), x0=[x0], v0=[v0])
    x, v = free(t, x0, v0)
    assert rel(r.displacement, x) <= 1e-6
    assert rel(r.velocity, v) <= 1e-6
    assert rel(r.acceleration, acceleration(0.0, x, v)) <= 1e-6


def test_exact_step_response():
    f = np.full((N, 1), 5.0)
    r = simulate(sdof(), DT, force=f)
    x, v = step(np.arange(N) * DT)
    assert rel(r.displacement, 5.0 * x) <= 1e-6
    assert rel(r.velocity, 5.0 * v) <= 1e-6
    assert rel(r.acceleration, acceleration(5.0, 5.0 * x, 5.0 * v)) <= 1e-6


def test_exact_harmonic_force():
    u = harmonic_force()
    r = simulate(sdof(), DT, force=u[:, None])
    x, v = piecewise_linear(u, DT)
    assert rel(r.displacement, x) <= 1e-6
    assert rel(r.velocity, v) <= 1e-6
    assert rel(r.acceleration, acceleration(u, x, v)) <= 1e-6


def test_exact_harmonic_base_motion_absolute_acceleration():
    ag = harmonic_force() / 10.0
    r = simulate(sdof(), DT, ag=ag)
    x, v = piecewise_linear(-MASS * ag, DT)
    assert rel(r.displacement, x) <= 1e-6
    assert rel(r.velocity, v) <= 1e-6
    # absolute acceleration: ẍ + a_g = -(c ẋ + k x)/m
    assert rel(r.acceleration, -(DAMP * v + STIFF * x) / MASS) <= 1e-6


def test_exact_smooth_harmonic_converges_to_continuous_steady_plus_transient():
    """Finely sampled, the piecewise-linear input tends to the sine: the classical solution."""
    w = 0.7 * OMEGA
    dt = PERIOD / 2000
    t = np.arange(6001) * dt
    r = simulate(sdof(), dt, force=(30.0 * np.sin(w * t))[:, None])
    # steady state X sin(wt - θ) plus the free vibration that starts the system from rest
    rr, two_zr = w / OMEGA, 2 * ZETA * w / OMEGA
    amp = 30.0 / STIFF / np.hypot(1 - rr**2, two_zr)
    th = np.arctan2(two_zr, 1 - rr**2)
    xs, vs = amp * np.sin(w * t - th), amp * w * np.cos(w * t - th)
    xh, _ = free(t, -xs[0], -vs[0])
    assert rel(r.displacement, xs + xh) <= 1e-5


# ---------------------------------------------------------------- central differences, Newmark


def test_central_difference_free_vibration_equals_its_recurrence():
    """x_n = c1 ρ1^n + c2 ρ2^n, ρ the roots of (1+ζΩ)ρ² - (2-Ω²)ρ + (1-ζΩ) = 0 (20 steps/period),
    started from x_{-1} = x0 - h v0 + h²/2 a0."""
    x0, v0 = 0.01, -0.3
    h, big_w = DT, OMEGA * DT
    rho = np.roots([1 + ZETA * big_w, -(2 - big_w**2), 1 - ZETA * big_w])
    xm1 = x0 - h * v0 + 0.5 * h * h * acceleration(0.0, x0, v0)
    c = np.linalg.solve(np.array([[1, 1], 1 / rho]), np.array([x0, xm1], dtype=complex))
    n = np.arange(-1, N + 1)
    xn = np.real((c[None, :] * rho[None, :] ** n[:, None]).sum(axis=1))
    r = simulate(sdof(), DT, force=np.zeros((N, 1)), method="central_difference", x0=[x0], v0=[v0])
    assert rel(r.displacement, xn[1:-1]) <= 1e-10
    assert rel(r.velocity, (xn[2:] - xn[:-2]) / (2 * h)) <= 1e-10
    assert rel(r.acceleration, (xn[2:] - 2 * xn[1:-1] + xn[:-2]) / h**2) <= 1e-10


def test_newmark_average_acceleration_free_vibration_equals_trapezoidal_rule():
    """Average acceleration is the trapezoidal rule on the state: each continuous eigenvalue λ
    becomes μ = (1 + λh/2)/(1 - λh/2) per step (20 steps per period)."""
    x0, v0 = 0.01, -0.3
    lam = np.roots([MASS, DAMP, STIFF])
    mu = (1 + lam * DT / 2) / (1 - lam * DT / 2)
    c = np.linalg.solve(np.array([[1, 1], lam]), np.array([x0, v0], dtype=complex))
    n = np.arange(N)[:, None]
    x = np.real((c * mu**n).sum(axis=1))
    v = np.real((c * lam * mu**n).sum(axis=1))
    r = simulate(sdof(), DT, force=np.zeros((N, 1)), method="newmark", x0=[x0], v0=[v0])
    assert rel(r.displacement, x) <= 1e-10
    assert rel(r.velocity, v) <= 1e-10


CASES = ["free", "step", "harmonic"]


def reference_and_run(case: str, method: str, substeps: int) -> tuple[float, float]:
    t = np.arange(N) * DT
    if case == "free":
        u = np.zeros(N)
        x, v = free(t, 0.01, -0.3)
        r = simulate(sdof(), DT, force=u[:, None], method=method, substeps=substeps,
                     x0=[0.01], v0=[-0.3])  # fmt: skip
    else:
        u = np.full(N, 5.0) if case == "step" else harmonic_force()
        x, v = piecewise_linear(u, DT)
        r = simulate(sdof(), DT, force=u[:, None], method=method, substeps=substeps)
    return rel(r.displacement, x), rel(r.velocity, v)


@pytest.mark.parametrize("method", ["central_difference", "newmark"])
@pytest.mark.parametrize("case", CASES)
def test_twenty_samples_per_period_ten_substeps_within_1e3(method, case):
    err_x, err_v = reference_and_run(case, method, 10)
    assert err_x <= 1e-3
    assert err_v <= 1e-3


@pytest.mark.parametrize("method", ["central_difference", "newmark"])
def test_second_order_convergence_and_tolerance_is_meaningful(method):
    """Error ∝ h²: halving h divides it by about 4, and at one step per sample (20 steps per
    period) the error is well above 1e-3 (period error ~Ω²/24 or Ω²/12 per cycle)."""
    e1, _ = reference_and_run("harmonic", method, 1)
    e10, _ = reference_and_run("harmonic", method, 10)
    e20, _ = reference_and_run("harmonic", method, 20)
    assert e1 > 1e-2
    assert 3.6 < e10 / e20 < 4.4

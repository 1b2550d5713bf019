"""Virtual experiments: design spectra, artificial accelerograms and sensor imperfections.

- `ec8_spectrum`: the Eurocode 8 horizontal elastic response spectrum (EN 1998-1 §3.2.2.2).
- `response_spectrum`: pseudo-acceleration spectrum by the exact recursion for a
  piecewise-linear ground acceleration (Nigam & Jennings 1969; Chopra, *Dynamics of
  Structures*, §5.2), compiled with numba, all periods in one call.
- `artificial_accelerogram`: a spectrum-compatible record: stationary random phases, an
  envelope, iterative scaling of the Fourier amplitudes, baseline correction.
- `scale_time`: Cauchy/Froude similitude for small-scale shaking-table models.
- `sensor_record`: what an accelerometer records (noise, offset, drift).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numba import njit

from femupdate.data.signal import integrate, integrate_twice
from femupdate.errors import ConfigError, DataError

__all__ = [
    "EC8_GROUND",
    "Accelerogram",
    "EC8Spectrum",
    "artificial_accelerogram",
    "baseline_correct",
    "ec8_spectrum",
    "envelope",
    "response_spectrum",
    "saragoni_hart",
    "scale_time",
    "sensor_record",
    "trapezoidal",
]

# EN 1998-1 Tables 3.2 (Type 1) and 3.3 (Type 2): ground type -> (S, TB, TC, TD), s
EC8_GROUND: dict[int, dict[str, tuple[float, float, float, float]]] = {
    1: {"A": (1.00, 0.15, 0.4, 2.0), "B": (1.20, 0.15, 0.5, 2.0), "C": (1.15, 0.20, 0.6, 2.0),
        "D": (1.35, 0.20, 0.8, 2.0), "E": (1.40, 0.15, 0.5, 2.0)},
    2: {"A": (1.00, 0.05, 0.25, 1.2), "B": (1.35, 0.05, 0.25, 1.2), "C": (1.50, 0.10, 0.25, 1.2),
        "D": (1.80, 0.10, 0.30, 1.2), "E": (1.60, 0.05, 0.25, 1.2)},
}
EC8_MAX_PERIOD = 4.0  # the spectrum is defined up to 4 s


# --------------------------------------------------------------------------- EC8 spectrum


def ec8_spectrum(periods: np.ndarray | float, ag: float, ground: str = "B", kind: int = 1,
                 damping: float = 5.0) -> np.ndarray:
    """Eurocode 8 horizontal elastic response spectrum Se(T) (EN 1998-1 Eqs. 3.2–3.6).

    Parameters
    ----------
    periods : array_like
        Periods T, s, in [0, 4].
    ag : float
        Design ground acceleration on type A ground (ag = γI·agR), any unit; Se has its unit.
    ground : {"A", "B", "C", "D", "E"}
        Ground type (Tables 3.2, 3.3).
    kind : {1, 2}
        Spectrum type: 1 for surface-wave magnitude Ms > 5.5, 2 otherwise.
    damping : float
        Viscous damping ratio ξ in percent; η = √(10 / (5 + ξ)) ≥ 0.55 (Eq. 3.6).
    """
    if kind not in EC8_GROUND:
        raise ConfigError(f"EC8 spectrum kind must be 1 or 2, got {kind!r}")
    if ground not in EC8_GROUND[kind]:
        raise ConfigError(f"EC8 ground type must be one of A, B, C, D, E, got {ground!r}")
    if not (np.isfinite(ag) and ag > 0):
        raise ConfigError(f"ag must be a positive acceleration, got {ag!r}")
    if not (np.isfinite(damping) and 0 <= damping < 100):
        raise ConfigError(f"damping must be a ratio in percent in [0, 100), got {damping!r}")
    t = np.asarray(periods, dtype=float)
    if np.any(~np.isfinite(t)) or np.any(t < 0) or np.any(t > EC8_MAX_PERIOD):
        raise ConfigError(f"periods must lie in [0, {EC8_MAX_PERIOD}] s (EN 1998-1 defines "
                          f"Se up to 4 s), got [{np.min(t)!r}, {np.max(t)!r}]")
    s, tb, tc, td = EC8_GROUND[kind][ground]
    eta = max(np.sqrt(10.0 / (5.0 + damping)), 0.55)
    plateau = ag * s * eta * 2.5
    with np.errstate(divide="ignore"):
        return np.select(
            [t <= tb, t <= tc, t <= td],
            [ag * s * (1.0 + t / tb * (eta * 2.5 - 1.0)), np.full_like(t, plateau),
             plateau * tc / t],
            plateau * tc * td / t**2)


@dataclass(frozen=True)
class EC8Spectrum:
    """A configured EC8 spectrum, callable on periods (picklable target for the generator)."""

    ag: float
    ground: str = "B"
    kind: int = 1
    damping: float = 5.0

    def __post_init__(self) -> None:
        ec8_spectrum(0.0, self.ag, self.ground, self.kind, self.damping)  # validates

    def __call__(self, periods: np.ndarray) -> np.ndarray:
        return ec8_spectrum(periods, self.ag, self.ground, self.kind, self.damping)


# --------------------------------------------------------------------------- response spectrum


def _recursion_coefficients(omega: np.ndarray, zeta: float,
                            dt: float | np.ndarray) -> np.ndarray:
    """Coefficients (m, 8) of the exact step for u'' + 2ζωu' + ω²u = p, p piecewise linear.

    u₊ = A u + B v + C p + D p₊;  v₊ = A' u + B' v + C' p + D' p₊  (Chopra Table 5.2.1, m=1).
    """
    k = omega**2
    sq = np.sqrt(1.0 - zeta**2)
    wd = omega * sq
    e = np.exp(-zeta * omega * dt)
    s, c = np.sin(wd * dt), np.cos(wd * dt)
    r = zeta / sq
    zw = 2.0 * zeta / (omega * dt)
    a = e * (r * s + c)
    b = e * s / wd
    cc = (zw + e * (((1.0 - 2.0 * zeta**2) / (wd * dt) - r) * s - (1.0 + zw) * c)) / k
    d = (1.0 - zw + e * ((2.0 * zeta**2 - 1.0) / (wd * dt) * s + zw * c)) / k
    a1 = -e * omega / sq * s
    b1 = e * (c - r * s)
    c1 = (-1.0 / dt + e * ((omega / sq + zeta / (dt * sq)) * s + c / dt)) / k
    d1 = (1.0 - e * (r * s + c)) / (k * dt)
    return np.column_stack([a, b, cc, d, a1, b1, c1, d1])


@njit(cache=True)
def _peak_displacements(p: np.ndarray, coef: np.ndarray,
                        sub: np.ndarray) -> np.ndarray:  # pragma: no cover
    """max |u| per period; period j steps ``sub[j]`` times per sample interval."""
    m = coef.shape[0]
    out = np.zeros(m)
    for j in range(m):
        a, b, c, d, a1, b1, c1, d1 = (coef[j, 0], coef[j, 1], coef[j, 2], coef[j, 3],
                                      coef[j, 4], coef[j, 5], coef[j, 6], coef[j, 7])
        ns = sub[j]
        u = 0.0
        v = 0.0
        peak = 0.0
        for i in range(p.shape[0] - 1):
            step = (p[i + 1] - p[i]) / ns
            for q in range(ns):
                p0 = p[i] + q * step
                p1 = p0 + step
                u_new = a * u + b * v + c * p0 + d * p1
                v = a1 * u + b1 * v + c1 * p0 + d1 * p1
                u = u_new
                if abs(u) > peak:
                    peak = abs(u)
        out[j] = peak
    return out


def response_spectrum(ag: np.ndarray, dt: float, periods: np.ndarray,
                      zeta: float = 0.05, points_per_period: int = 20) -> np.ndarray:
    """Pseudo-acceleration response spectrum PSA(T) = ω² max|u(t)|.

    Exact for a ground acceleration linear between samples (at rest at t = 0), over the
    record's duration. Short periods are stepped in substeps of the sample interval (the
    input interpolated linearly, which is the same input) so that the peak is searched at
    least ``points_per_period`` times per period: the peak is then underestimated by at most
    1 − cos(π / points_per_period) (1.2 % for 20). A period of 0 gives the peak ground
    acceleration.

    Parameters
    ----------
    ag : ndarray, shape (n,)
        Ground acceleration.
    dt : float
        Sample interval, s.
    periods : array_like, shape (m,)
        Periods, s, ≥ 0.
    zeta : float
        Damping ratio, in [0, 1).
    points_per_period : int
        Minimum number of response samples per period, ≥ 1.
    """
    ag = np.ascontiguousarray(ag, dtype=float)
    if ag.ndim != 1 or ag.size < 2 or not np.all(np.isfinite(ag)):
        raise DataError(f"ag must be a finite 1-D record of >= 2 samples, got shape {ag.shape}")
    if not (np.isfinite(dt) and dt > 0):
        raise ConfigError(f"dt must be a positive time step in s, got {dt!r}")
    if not 0 <= zeta < 1:
        raise ConfigError(f"zeta must be a damping ratio in [0, 1), got {zeta!r}")
    if not (isinstance(points_per_period, int) and points_per_period >= 1):
        raise ConfigError(f"points_per_period must be an integer >= 1, got "
                          f"{points_per_period!r}")
    t = np.atleast_1d(np.asarray(periods, dtype=float))
    if np.any(~np.isfinite(t)) or np.any(t < 0):
        raise ConfigError("periods must be finite and >= 0 s")
    out = np.full(t.shape, np.max(np.abs(ag)))
    pos = t > 0
    sub = np.maximum(1, np.ceil(points_per_period * dt / t[pos] - 1e-9)).astype(np.int64)
    omega = 2.0 * np.pi / t[pos]
    coef = _recursion_coefficients(omega, zeta, dt / sub)
    out[pos] = omega**2 * _peak_displacements(-ag, coef, sub)
    return out


# --------------------------------------------------------------------------- envelopes


def saragoni_hart(t: np.ndarray, duration: float, eps: float = 0.2,
                  eta: float = 0.05) -> np.ndarray:
    """Saragoni–Hart envelope w = (x/ε)^b e^{-c(x-ε)}, x = t/duration (Boore 2003).

    Peak 1 at ``t = ε·duration``; ``w(duration) = η``; b = -ε ln η / (1 + ε(ln ε - 1)),
    c = b / ε.
    """
    if not (0 < eps < 1 and 0 < eta < 1 and duration > 0):
        raise ConfigError(f"need 0 < eps < 1, 0 < eta < 1 and duration > 0; got eps={eps!r}, "
                          f"eta={eta!r}, duration={duration!r}")
    b = -eps * np.log(eta) / (1.0 + eps * (np.log(eps) - 1.0))
    c = b / eps
    x = np.maximum(np.asarray(t, dtype=float), 0.0) / duration
    return (x / eps) ** b * np.exp(-c * (x - eps))


def trapezoidal(t: np.ndarray, duration: float, rise: float = 0.1,
                decay: float = 0.3) -> np.ndarray:
    """Trapezoidal envelope: linear rise over ``rise·duration``, 1, linear decay to 0 over
    the last ``decay·duration``."""
    if not (rise > 0 and decay > 0 and rise + decay <= 1 and duration > 0):
        raise ConfigError(f"need rise > 0, decay > 0, rise + decay <= 1 and duration > 0; "
                          f"got rise={rise!r}, decay={decay!r}, duration={duration!r}")
    x = np.asarray(t, dtype=float) / duration
    return np.clip(np.minimum(x / rise, (1.0 - x) / decay), 0.0, 1.0)


def envelope(t: np.ndarray, duration: float,
             kind: Literal["saragoni_hart", "trapezoidal"] = "saragoni_hart") -> np.ndarray:
    """Envelope by name with its default shape parameters."""
    if kind == "saragoni_hart":
        return saragoni_hart(t, duration)
    if kind == "trapezoidal":
        return trapezoidal(t, duration)
    raise ConfigError(f"envelope must be 'saragoni_hart' or 'trapezoidal', got {kind!r}")


# --------------------------------------------------------------------------- baseline


def _baseline_operator(weight: np.ndarray, dt: float,
                       order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Arrays of the linear map ``a -> a - basis @ c(a)`` of `baseline_correct`."""
    n = weight.size
    x = np.arange(n) / (n - 1)
    basis = weight[:, None] * x[:, None] ** np.arange(order + 1)
    # orthonormalise the displacements of the basis functions: a well-conditioned KKT system
    g, r = np.linalg.qr(integrate_twice(basis, dt))
    basis = np.linalg.solve(r.T, basis.T).T
    v_end = integrate(basis, dt)[-1]
    ends = np.vstack([v_end, g[-1]])
    kkt = np.block([[np.eye(order + 1), ends.T], [ends, np.zeros((2, 2))]])
    return basis, g, np.linalg.inv(kkt)[: order + 1]


def _apply_baseline(ag: np.ndarray, dt: float,
                    op: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
    basis, g, kinv = op
    d = integrate_twice(ag, dt)
    v_end = integrate(ag, dt)[-1]
    rhs = np.concatenate([g.T @ d, v_end[None], d[-1][None]]) if ag.ndim == 2 else \
        np.concatenate([g.T @ d, [v_end, d[-1]]])
    return ag - basis @ (kinv @ rhs)


def baseline_correct(ag: np.ndarray, dt: float, weight: np.ndarray | None = None,
                     order: int = 3) -> np.ndarray:
    """Subtract a small correction so that ground velocity and displacement end at 0.

    The correction is Σ c_j w(t) (t/T)^j, j = 0..order (``w`` = 1 by default; with the
    record's envelope it vanishes where the envelope does). Its coefficients minimise the
    squared displacement over the record subject to zero final velocity and displacement
    (trapezoidal integration, zero initial values): a constrained least-squares problem, so
    the correction is a linear map of the record. ``ag`` may be (n,) or (n, k).
    """
    ag = np.asarray(ag, dtype=float)
    if ag.ndim not in (1, 2) or ag.shape[0] < order + 3:
        raise DataError(f"ag must be (n,) or (n, k) with n >= order + 3, got {ag.shape}")
    if not isinstance(order, int) or not 0 <= order <= 8:
        raise ConfigError(f"order must be an integer in 0..8, got {order!r}")
    if not (np.isfinite(dt) and dt > 0):
        raise ConfigError(f"dt must be a positive time step in s, got {dt!r}")
    w = np.ones(ag.shape[0]) if weight is None else np.asarray(weight, dtype=float)
    if w.shape != (ag.shape[0],):
        raise DataError(f"weight has shape {w.shape}, expected ({ag.shape[0]},)")
    return _apply_baseline(ag, dt, _baseline_operator(w, dt, order))


# --------------------------------------------------------------------------- generator


@dataclass(frozen=True)
class Accelerogram:
    """An artificial accelerogram and how well it matches its target spectrum.

    Attributes
    ----------
    t, acceleration : ndarray, shape (n,)
        Times, s, and ground acceleration (units of the target spectrum).
    periods : ndarray, shape (m,)
        Control periods of the matching, s.
    spectrum, target : ndarray, shape (m,)
        The record's pseudo-acceleration spectrum and the target at the control periods.
    iterations : int
        Amplitude corrections computed.
    max_deviation : float
        max |spectrum/target - 1| at the control periods.
    converged : bool
        Whether ``max_deviation <= tol``.
    """

    t: np.ndarray
    acceleration: np.ndarray
    periods: np.ndarray
    spectrum: np.ndarray
    target: np.ndarray
    iterations: int
    max_deviation: float
    converged: bool


@njit(cache=True)
def _responses(p: np.ndarray, coef: np.ndarray,
               sub: np.ndarray) -> np.ndarray:  # pragma: no cover
    """Displacement u (m, n) of each oscillator at the sample times, at rest at sample 0."""
    m = coef.shape[0]
    n = p.shape[0]
    out = np.zeros((m, n))
    for j in range(m):
        a, b, c, d, a1, b1, c1, d1 = (coef[j, 0], coef[j, 1], coef[j, 2], coef[j, 3],
                                      coef[j, 4], coef[j, 5], coef[j, 6], coef[j, 7])
        ns = sub[j]
        u = 0.0
        v = 0.0
        for i in range(n - 1):
            step = (p[i + 1] - p[i]) / ns
            for q in range(ns):
                p0 = p[i] + q * step
                p1 = p0 + step
                u_new = a * u + b * v + c * p0 + d * p1
                v = a1 * u + b1 * v + c1 * p0 + d1 * p1
                u = u_new
            out[j, i + 1] = u
    return out


@dataclass(frozen=True)
class _Matching:
    """Fixed arrays of one spectral-matching run (built once, used at every iteration)."""

    dt: float
    n: int
    env: np.ndarray
    phase: np.ndarray  # e^{iφ} per frequency bin
    periods: np.ndarray
    goal: np.ndarray
    zeta: float
    baseline: tuple[np.ndarray, np.ndarray, np.ndarray] | None

    def record(self, amp: np.ndarray) -> np.ndarray:
        """Enveloped (and baseline-corrected) record(s) for amplitudes (bins,) or (bins, k)."""
        spec = amp * (self.phase if amp.ndim == 1 else self.phase[:, None])
        env = self.env if amp.ndim == 1 else self.env[:, None]
        acc = env * np.fft.irfft(spec, self.n, axis=0)
        return acc if self.baseline is None else _apply_baseline(acc, self.dt, self.baseline)

    def spectrum(self, acc: np.ndarray) -> np.ndarray:
        return response_spectrum(acc, self.dt, self.periods, self.zeta)


def _sensitivity(mt: _Matching, amp: np.ndarray, acc: np.ndarray, psi: np.ndarray,
                 coef: np.ndarray, sub: np.ndarray, impulse: np.ndarray) -> np.ndarray:
    """d PSA_i / d δ_j for amplitudes ``amp · (1 + Σ δ_j ψ_j)``, at the current peaks.

    The peak of oscillator i is held at its current sample and sign; the displacement there
    is linear in the record: u_i(k) = Σ_s h_i[k - s] p_s (``impulse`` = h, the response to a
    unit hat at one sample).
    """
    u = _responses(-acc, coef, sub)
    rows = np.arange(u.shape[0])
    peak = np.argmax(np.abs(u), axis=1)
    sign = np.sign(u[rows, peak])
    columns = mt.record(amp[:, None] * psi)
    omega2 = (2.0 * np.pi / mt.periods) ** 2
    sens = np.empty((u.shape[0], psi.shape[1]))
    for i, k in enumerate(np.maximum(peak, 1)):
        sens[i] = -sign[i] * omega2[i] * (impulse[i, k - 1::-1] @ columns[1:k + 1])
    return sens


def artificial_accelerogram(target: Callable[[np.ndarray], np.ndarray], duration: float,
                            dt: float, rng: np.random.Generator, *,
                            envelope_kind: Literal["saragoni_hart", "trapezoidal"]
                            = "saragoni_hart",
                            zeta: float = 0.05, period_range: tuple[float, float] = (0.05, 4.0),
                            n_periods: int = 200, n_knots: int = 60, tol: float = 0.08,
                            max_iter: int = 40, baseline: bool = True) -> Accelerogram:
    """Generate a ground acceleration whose response spectrum matches ``target``.

    A stationary signal with random phases (uniform on [0, 2π), drawn once from ``rng``) and
    Fourier amplitudes A(f) shaped like the target is multiplied by an envelope and baseline
    corrected (`baseline_correct`, weighted by the envelope). The amplitudes are then scaled
    iteratively in the frequency domain until the ``zeta``-damped pseudo-acceleration
    spectrum is within ``tol`` of the target at every control period:

    1. three classic corrections A(f) ← A(f)·target/actual (interpolated in log-period);
    2. Levenberg–Marquardt corrections A(f) ← A(f)·(1 + Σ δ_j ψ_j(f)), ψ_j hat functions at
       ``n_knots`` log-spaced frequencies, δ fitted to the ``n_periods`` control periods by
       damped least squares on log(target/actual), with the exact sensitivity of each
       oscillator's peak (held at its sample) to each ψ_j; a step is kept only if the rms log
       deviation decreases.

    The phases never change; the best record seen (smallest maximum deviation) is returned.
    With fixed phases a pointwise match is limited by the record's frequency resolution
    1/duration: longer records (≥ 20 s, EC8 §3.2.3.1.2 asks for a 10 s stationary part)
    match more closely.

    Parameters
    ----------
    target : callable
        PSA(T) for an array of periods, e.g. ``EC8Spectrum(ag=0.25 * 9.81, ground="B")``.
    duration, dt : float
        Record length and sample interval, s.
    rng : numpy.random.Generator
        Source of the random phases: the same generator state gives the same record.
    envelope_kind : {"saragoni_hart", "trapezoidal"}
        Envelope with its default shape (`saragoni_hart`, `trapezoidal`).
    period_range : (float, float)
        Periods to match, s, within (2·dt, 4].
    n_periods, n_knots : int
        Control periods (log-spaced over ``period_range``) and amplitude-correction knots.
    tol : float
        Allowed relative deviation at the control periods.
    max_iter : int
        Most amplitude corrections.
    baseline : bool
        Apply the baseline correction (velocity and displacement end at 0).

    Returns
    -------
    Accelerogram
        ``converged`` is False when ``max_iter`` corrections did not reach ``tol``.
    """
    if not (np.isfinite(dt) and dt > 0):
        raise ConfigError(f"dt must be a positive time step in s, got {dt!r}")
    if not (np.isfinite(duration) and duration >= 50 * dt):
        raise ConfigError(f"duration must be at least 50 samples ({50 * dt:g} s), "
                          f"got {float(duration):g} s")
    t_lo, t_hi = period_range
    if not (2 * dt < t_lo < t_hi <= EC8_MAX_PERIOD):
        raise ConfigError(f"period_range must satisfy 2·dt ({2 * dt:g} s, Nyquist) < low < "
                          f"high <= {EC8_MAX_PERIOD} s, got {period_range!r}")
    if not (n_periods >= 2 and 2 <= n_knots <= n_periods):
        raise ConfigError(f"need n_periods >= 2 and 2 <= n_knots <= n_periods; got "
                          f"n_periods={n_periods!r}, n_knots={n_knots!r}")
    if not (tol > 0 and max_iter >= 0):
        raise ConfigError(f"need tol > 0 and max_iter >= 0; got tol={tol!r}, "
                          f"max_iter={max_iter!r}")
    if not 0 <= zeta < 1:
        raise ConfigError(f"zeta must be a damping ratio in [0, 1), got {zeta!r}")
    n = round(duration / dt) + 1
    t = np.arange(n) * dt
    env = envelope(t, t[-1], envelope_kind)
    periods = np.geomspace(t_lo, t_hi, n_periods)
    goal = np.asarray(target(periods), dtype=float)
    if goal.shape != periods.shape or not np.all(goal > 0):
        raise ConfigError("target must return positive values, one per period")
    freq = np.fft.rfftfreq(n, dt)
    mt = _Matching(dt, n, env, np.exp(2j * np.pi * rng.random(freq.size)), periods, goal,
                   zeta, _baseline_operator(env, dt, 3) if baseline else None)

    # initial amplitudes shaped like the target, decaying as f² beyond the longest period
    t_f = 1.0 / np.maximum(freq, freq[1])
    amp = np.asarray(target(np.minimum(t_f, EC8_MAX_PERIOD)), dtype=float)
    amp *= np.minimum(1.0, EC8_MAX_PERIOD / t_f) ** 2
    amp[0] = 0.0
    log_f = np.log(np.maximum(freq, freq[1]))
    log_f_ctrl = np.log(1.0 / periods[::-1])
    knots = np.linspace(log_f_ctrl[0], log_f_ctrl[-1], n_knots)
    psi = np.stack([np.interp(log_f, knots, np.eye(n_knots)[j]) for j in range(n_knots)], 1)
    psi[0] = 0.0

    acc = mt.record(amp)
    psa = mt.spectrum(acc)
    best = (float(np.max(np.abs(psa / goal - 1.0))), acc, psa)
    omega = 2.0 * np.pi / periods
    sub = np.maximum(1, np.ceil(20 * dt / periods - 1e-9)).astype(np.int64)
    coef = _recursion_coefficients(omega, zeta, dt / sub)
    impulse = None
    lam = 1e-2
    it = 0
    while best[0] > tol and it < max_iter:
        it += 1
        if it <= 3:
            amp = amp * np.interp(log_f, log_f_ctrl, (goal / psa)[::-1])
            acc = mt.record(amp)
            psa = mt.spectrum(acc)
        else:
            if impulse is None:
                hat = np.zeros(n + 1)
                hat[1] = 1.0
                impulse = _responses(hat, coef, sub)[:, 1:]
            jac = _sensitivity(mt, amp, acc, psi, coef, sub, impulse) / psa[:, None]
            resid = np.log(goal / psa)
            cost = float(np.sum(resid**2))
            jtj, grad = jac.T @ jac, jac.T @ resid
            damp = np.diag(np.diag(jtj)) + 1e-12 * np.trace(jtj) * np.eye(n_knots)
            while lam < 1e6:
                step = np.linalg.solve(jtj + lam * damp, grad)
                trial = amp * np.clip(1.0 + psi @ step, 0.2, 5.0)
                acc_t = mt.record(trial)
                psa_t = mt.spectrum(acc_t)
                if float(np.sum(np.log(goal / psa_t) ** 2)) < cost:
                    amp, acc, psa, lam = trial, acc_t, psa_t, max(lam / 3.0, 1e-6)
                    break
                lam *= 10.0
            else:
                break  # no step improves the fit: stalled
        dev = float(np.max(np.abs(psa / goal - 1.0)))
        if dev < best[0]:
            best = (dev, acc, psa)
    dev, acc, psa = best
    return Accelerogram(t, acc, periods, psa, goal, it, dev, dev <= tol)


# --------------------------------------------------------------------------- similitude, sensors


def scale_time(t: np.ndarray, length_scale: float = 1 / 50) -> np.ndarray:
    """Model times under Cauchy/Froude similitude: t_model = t_prototype · √λ.

    With λ = L_model / L_prototype (1/50 for the paper's bridge) accelerations are the same
    in model and prototype, times scale by √λ and frequencies by 1/√λ (×7.07 for 1/50).
    """
    if not (np.isfinite(length_scale) and 0 < length_scale <= 1):
        raise ConfigError(f"length_scale must be in (0, 1], got {length_scale!r}")
    return np.asarray(t, dtype=float) * np.sqrt(length_scale)


def sensor_record(signal: np.ndarray, rng: np.random.Generator, *, snr: float = 0.0,
                  offset: float | np.ndarray = 0.0, drift: float | np.ndarray = 0.0,
                  dt: float | None = None) -> np.ndarray:
    """What an accelerometer records: signal + white noise + offset + linear drift.

    Parameters
    ----------
    signal : ndarray, shape (n,) or (n, k)
        The true signal (samples on axis 0).
    rng : numpy.random.Generator
        Source of the noise.
    snr : float
        Noise level as the ratio rms(noise) / rms(signal), per channel (0.05: 5 % noise).
        The Gaussian noise drawn is rescaled to exactly this ratio.
    offset : float or ndarray (k,)
        Constant offset.
    drift : float or ndarray (k,)
        Drift rate, units of the signal per second (needs ``dt``).
    dt : float, optional
        Sample interval, s.
    """
    y = np.asarray(signal, dtype=float)
    if y.ndim not in (1, 2) or y.shape[0] < 2:
        raise DataError(f"signal must be (n,) or (n, k) with n >= 2, got {y.shape}")
    if not (np.isfinite(snr) and snr >= 0):
        raise ConfigError(f"snr (rms noise / rms signal) must be >= 0, got {snr!r}")
    drift = np.asarray(drift, dtype=float)
    if np.any(drift != 0) and dt is None:
        raise ConfigError("a drift (units per second) needs dt, the sample interval in s")
    noise = rng.standard_normal(y.shape)
    noise -= noise.mean(axis=0)
    rms_signal = np.sqrt(np.mean(y**2, axis=0))
    rms_noise = np.sqrt(np.mean(noise**2, axis=0))
    out = y + noise * (snr * rms_signal / rms_noise)
    t = np.arange(y.shape[0]) * (dt or 0.0)
    return out + offset + (drift * t[:, None] if y.ndim == 2 else drift * t)

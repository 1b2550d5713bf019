"""The paper's bounded adaptive Beta sampling: isotropic (IB) and anisotropic (AB) (METHOD.md §3–5).

Each parameter ξ_i of the unit cube is drawn from Beta(a_i, b_i) whose mode is the best point
so far and whose variance shrinks or grows with the success of the steps (after Kern et al.):

* success (φ < φ_m; the first step always is): mode ← ξ, σ ← σ·α, with α = 2^(1/n);
* failure: σ ← σ·α^(−1/4);
* IB: var_i = σ²; AB: var_i = w_i σ², w_i = ν_i / max ν, ν_i the mean of Δξ_i² over the last
  n successful increments Δξ = ξ − mode (Eqs. 12–15);
* (a_i, b_i) from (mode_i, var_i) (Eq. 11), solved by :func:`beta_parameters`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from femupdate.errors import ConfigError
from femupdate.optimize.base import (
    KeepsBest,
    Restarts,
    check_batch,
    check_option_names,
    real_option,
    restart_options,
)

#: The largest variance of a Beta distribution with a, b ≥ 1 (the uniform one, Eq. 7).
VARIANCE_CAP = 1.0 / 12.0
#: The cap on σ, "just below √(1/12)": var = σ² < 1/12 keeps a, b > 1 (a proper mode).
SIGMA_CAP = math.sqrt(VARIANCE_CAP) * (1.0 - 1e-6)
#: Lower floor on every variance the optimizers use (see :class:`BetaSearch`).
VARIANCE_FLOOR = 1e-30
#: Variances below this are raised to it by :func:`beta_parameters` (a, b stay below ~1e300).
_VARIANCE_MIN = 1e-300
#: Default of the option ``sigma_min``: see :class:`BetaSearch`.
SIGMA_MIN_DEFAULT = 1e-12


# ---------------------------------------------------------------------------------------------
# (mode, variance) -> (a, b)
# ---------------------------------------------------------------------------------------------


@njit(cache=True)
def _residual(s: float, c: float, v: float) -> tuple[float, float]:
    """F(s) = N(s) − v·D(s) and F'(s), divided by s³ when s > 1 (same Newton step, no overflow).

    N(s) = 1 + s + c s², D(s) = (s + 2)²(s + 3), c = m(1 − m); F > 0 left of the root, < 0 right.
    """
    if s <= 1.0:
        p = s + 2.0
        q = s + 3.0
        f = 1.0 + s + c * s * s - v * p * p * q
        fp = 1.0 + 2.0 * c * s - v * (2.0 * p * q + p * p)
        return f, fp
    u = 1.0 / s
    p = 1.0 + 2.0 * u
    q = 1.0 + 3.0 * u
    f = u * u * u + u * u + c * u - v * p * p * q
    fp = u * u * u + 2.0 * c * u * u - v * u * (2.0 * p * q + p * p)
    return f, fp


@njit(cache=True)
def _concentration(m: float, v: float) -> float:
    """The root s = a + b − 2 ≥ 0 of v(s) = v for mode m (a safeguarded Newton iteration).

    The start is the positive root of the quadratic v s² + (7v − c) s − 1 = 0 (F without its
    lowest-order terms), exact to first order for small v, pushed right of the root if needed.
    F is concave right of the root, so Newton then decreases monotonically onto it; a bracket
    [lo, s] guards the rare step that would leave it.
    """
    c = m * (1.0 - m)
    if 1.0 - 12.0 * v <= 0.0:
        return 0.0  # at the cap: the uniform distribution
    d = c - 7.0 * v
    sq = math.sqrt(d * d + 4.0 * v)
    s = (d + sq) / (2.0 * v) if d >= 0.0 else 2.0 / (sq - d)
    lo = 0.0
    f, fp = _residual(s, c, v)
    while f >= 0.0:  # left of the root (or on it): move right
        lo = s
        s = 2.0 * s + 1.0
        f, fp = _residual(s, c, v)
    for _ in range(200):
        step = f / fp if fp < 0.0 else math.inf
        s_new = s - step
        if not s_new > lo:
            s_new = 0.5 * (lo + s)
            step = s - s_new
        if step <= 1e-15 * s:
            return s_new
        f, fp = _residual(s_new, c, v)
        if f >= 0.0:
            return s_new  # on the root to rounding
        s = s_new
    return s


@njit(cache=True)
def _fill_beta_parameters(mode: np.ndarray, var: np.ndarray, a: np.ndarray, b: np.ndarray) -> None:
    for i in range(mode.size):
        m = mode[i]
        s = _concentration(m, var[i])
        a[i] = 1.0 + m * s
        b[i] = 1.0 + (1.0 - m) * s


def beta_parameters(mode: Any, variance: Any) -> tuple[np.ndarray, np.ndarray]:
    """Beta(a, b) with the given mode and variance (Eq. 11), element-wise.

    With s = a + b − 2, a = 1 + m·s and b = 1 + (1 − m)·s give the mode m for any s ≥ 0, and
    the variance v(s) = (1 + s + m(1−m)s²) / ((s+2)²(s+3)) falls monotonically from 1/12 at
    s = 0: the solve is a one-dimensional root (a cubic in s), found by a safeguarded Newton
    iteration that always succeeds, for any mode in [0, 1] (0 and 1 included) and any variance
    in (0, 1/12]. At the cap a = b = 1 (uniform); a and b are always finite, ≥ 1.

    Parameters
    ----------
    mode : array_like
        Modes in [0, 1].
    variance : array_like
        Variances in (0, 1/12] (broadcast against ``mode``). Values below 1e-300 are raised to
        it (a and b near 1e300: a point mass to double precision).

    Returns
    -------
    a, b : ndarray
        Arrays of the broadcast shape.

    Raises
    ------
    ConfigError
        A mode outside [0, 1] or a variance outside (0, 1/12], or NaN.
    """
    m, v = np.broadcast_arrays(np.asarray(mode, dtype=float), np.asarray(variance, dtype=float))
    if not np.all((m >= 0.0) & (m <= 1.0)):
        bad = m[~((m >= 0.0) & (m <= 1.0))].flat[0]
        raise ConfigError(f"mode must be in [0, 1], got {bad!r}")
    if not np.all((v > 0.0) & (v <= VARIANCE_CAP)):
        bad = v[~((v > 0.0) & (v <= VARIANCE_CAP))].flat[0]
        raise ConfigError(f"variance must be in (0, 1/12], got {bad!r}")
    m_flat = np.ascontiguousarray(m).ravel()
    v_flat = np.maximum(np.ascontiguousarray(v).ravel(), _VARIANCE_MIN)
    a = np.empty_like(m_flat)
    b = np.empty_like(m_flat)
    _fill_beta_parameters(m_flat, v_flat, a, b)
    return a.reshape(m.shape), b.reshape(m.shape)


def beta_mode_variance(a: Any, b: Any) -> tuple[np.ndarray, np.ndarray]:
    """Mode (Eq. 5) and variance (Eq. 6) of Beta(a, b) for a, b ≥ 1 (a = b = 1: mode 1/2)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    s = (a - 1.0) + (b - 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mode = np.where(s > 0.0, (a - 1.0) / s, 0.5)
    t = a + b
    return mode, a * b / (t * t * (t + 1.0))


# ---------------------------------------------------------------------------------------------
# The optimizers
# ---------------------------------------------------------------------------------------------


@njit(cache=True)
def _update_beta(
    mode: np.ndarray,
    sigma: float,
    records: np.ndarray,
    anisotropic: bool,
    var: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
) -> None:
    """Variances (IB: σ²; AB: w_i σ², Eqs. 13–15) floored, then (a, b) in place."""
    n = mode.size
    s2 = sigma * sigma
    if anisotropic:
        nu_max = 0.0
        for i in range(n):
            acc = 0.0
            for j in range(records.shape[0]):
                acc += records[j, i] * records[j, i]
            var[i] = acc / records.shape[0]
            nu_max = max(nu_max, var[i])
        for i in range(n):
            w = var[i] / nu_max if nu_max > 0.0 else 1.0
            var[i] = w * s2
    else:
        for i in range(n):
            var[i] = s2
    for i in range(n):
        v = min(max(var[i], VARIANCE_FLOOR), VARIANCE_CAP)
        var[i] = v
        m = mode[i]
        s = _concentration(m, v)
        a[i] = 1.0 + m * s
        b[i] = 1.0 + (1.0 - m) * s


class BetaSearch(KeepsBest, Restarts):
    """IB (``anisotropic=False``) or AB (``anisotropic=True``) on the unit cube, one sample a step.

    Parameters
    ----------
    n : int
        Number of parameters.
    rng : numpy.random.Generator
        The only source of randomness.
    anisotropic : bool
        AB when True, IB when False.
    sigma_min : float
        σ_s: stop when σ < sigma_min. Default 1e-12: at σ = 1e-12 the samples still differ from
        the mode by about 1e4 units in the last place of ξ, so the search has resolved ξ to
        ~1e-12 of the box (far beyond any physical parameter) but is not yet sampling
        rounding noise. 0 switches the criterion off.
    f_change_min : float or None
        Δφ_s: stop when φ_m fell by less than this between two successive successful steps.
        None (default) switches it off.
    sigma0 : float or None
        σ before the first step, in (0, SIGMA_CAP]; default (None): ``SIGMA_CAP``, just below
        √(1/12), which is also σ's cap. The first sample is uniform whatever sigma0 (a = b = 1);
        the first (always successful) step then sets σ = min(sigma0·α, SIGMA_CAP).
    stall_window : int or None
        Stop (or restart) when φ_m fell by less than the fraction ``stall_tol`` over the last
        ``stall_window`` evaluations (see :class:`~femupdate.optimize.base.Restarts`). None
        (default) switches it off, as in the paper.
    stall_tol : float
        See ``stall_window``; default 0.01.
    restarts : int
        How many times to start afresh (uniform samples, σ = sigma0, no records) when
        ``sigma_min``, ``f_change_min`` or the stall criterion fires; 0 (default) is the
        paper's algorithm. The result is the best point over all the searches.

    Notes
    -----
    The first step has no mode in force, so it records no increment in AB: the n records start
    at 1 (w_i = 1, isotropic) and the first increment is recorded at the second success.

    Floor: every variance is at least ``VARIANCE_FLOOR`` = 1e-30. In AB w_i becomes 0 when the
    last n increments of ξ_i are all exactly 0, i.e. its standard deviation had fallen below
    the spacing of doubles around the mode, so the draws rounded to the mode itself; without a
    floor that parameter would be frozen for good (and Beta(a, b) undefined). A standard
    deviation of 1e-15 is a few units in the last place of ξ ∈ [0.1, 1]: the draws still move,
    the records can become non-zero again when moving the parameter pays, and nothing
    resolvable is lost. If all n records of all parameters are 0, the weights are taken as 1.
    """

    def __init__(
        self,
        n: int,
        rng: np.random.Generator,
        *,
        anisotropic: bool,
        sigma_min: float = SIGMA_MIN_DEFAULT,
        f_change_min: float | None = None,
        sigma0: float | None = None,
        stall_window: int | None = None,
        stall_tol: float = 0.01,
        restarts: int = 0,
    ) -> None:
        self.n = n
        self.rng = rng
        self.anisotropic = anisotropic
        self.sigma_min = sigma_min
        self.f_change_min = f_change_min
        self.sigma0 = SIGMA_CAP if sigma0 is None else sigma0
        self.restarts = restarts
        self.stall_window = stall_window
        self.stall_tol = stall_tol
        self.alpha = 2.0 ** (1.0 / n)
        self.alpha_fail = self.alpha ** -0.25
        self.best_x = np.full(n, 0.5)  # over all restarts; replaced at the first step
        self._new_search()
        self.steps = 0
        self._trace_mode = np.empty((64, n))
        self._trace_a = np.empty((64, n))
        self._trace_b = np.empty((64, n))
        self._trace_sigma = np.empty(64)
        self._trace_f = np.empty(64)
        self._trace_restarts = np.empty(64)

    def _restart(self) -> None:
        """Step 1: uniform samples (a = b = 1), σ = sigma0, records 1, φ_m = ∞."""
        n = self.n
        self.sigma = self.sigma0
        self.mode = np.full(n, 0.5)
        self.a = np.ones(n)
        self.b = np.ones(n)
        self.var = np.full(n, VARIANCE_CAP)
        self.records = np.ones((n, n))  # AB: the last n increments, one per row
        self.next_record = 0
        self.phi_m = math.inf  # φ at the mode
        self.fresh = True  # the next step is the search's first: it always succeeds
        self.last_change = math.inf  # φ_m decrease at the last success (after the first)

    # -- protocol --------------------------------------------------------------------------

    def ask(self) -> np.ndarray:
        """One sample ξ_i ~ Beta(a_i, b_i), shape (1, n)."""
        return self.rng.beta(self.a, self.b).reshape(1, self.n)

    def tell(self, xs: np.ndarray, fs: np.ndarray,
             rs: np.ndarray | None = None) -> None:  # rs: residuals, unused
        """Update mode, σ, records and (a, b) from one evaluated sample (Steps 3–4)."""
        xs, fs = check_batch(xs, fs, self.n)
        if xs.shape[0] != 1:
            raise ConfigError(f"IB/AB take one sample per step, got {xs.shape[0]}")
        xi = xs[0]
        f = fs[0]
        if self.fresh or f < self.phi_m:
            if not self.fresh:
                if self.anisotropic:
                    self.records[self.next_record] = xi - self.mode
                    self.next_record = (self.next_record + 1) % self.n
                self.last_change = self.phi_m - f
            self.mode = xi.copy()
            self.phi_m = f
            self.fresh = False
            self.sigma = min(self.sigma * self.alpha, SIGMA_CAP)
        else:
            self.sigma *= self.alpha_fail
        self._keep_best(xs, fs)
        _update_beta(self.mode, self.sigma, self.records, self.anisotropic, self.var,
                     self.a, self.b)
        self._record_trace()
        self.steps += 1
        self._track(fs)
        self._restart_if_converged()

    def _criteria(self) -> dict[str, object]:
        """``sigma_min`` (σ), ``f_change_min`` (the last Δφ) and ``stall`` when they fired."""
        fired = self._stall()
        if self.sigma < self.sigma_min:
            fired["sigma_min"] = self.sigma
        if self.f_change_min is not None and self.last_change < self.f_change_min:
            fired["f_change_min"] = self.last_change
        return fired

    def trace(self) -> dict[str, np.ndarray]:
        """Per step, after its update: ``mode``, ``sigma``, ``a``, ``b`` (steps, n), ``f_best``
        (the best φ so far, over all restarts) and ``restarts`` (how many so far)."""
        k = self.steps
        return {
            "mode": self._trace_mode[:k].copy(),
            "sigma": self._trace_sigma[:k].copy(),
            "a": self._trace_a[:k].copy(),
            "b": self._trace_b[:k].copy(),
            "f_best": self._trace_f[:k].copy(),
            "restarts": self._trace_restarts[:k].copy(),
        }

    def close(self) -> None:
        """Nothing to release."""

    # -- internals ---------------------------------------------------------------------------

    def _record_trace(self) -> None:
        k = self.steps
        if k == self._trace_f.shape[0]:  # grow geometrically
            self._trace_mode = _grown(self._trace_mode)
            self._trace_a = _grown(self._trace_a)
            self._trace_b = _grown(self._trace_b)
            self._trace_sigma = _grown(self._trace_sigma)
            self._trace_f = _grown(self._trace_f)
            self._trace_restarts = _grown(self._trace_restarts)
        self._trace_mode[k] = self.mode
        self._trace_a[k] = self.a
        self._trace_b[k] = self.b
        self._trace_sigma[k] = self.sigma
        self._trace_f[k] = self.best_f
        self._trace_restarts[k] = self.restarts_done


def _grown(arr: np.ndarray) -> np.ndarray:
    out = np.empty((2 * arr.shape[0], *arr.shape[1:]), dtype=arr.dtype)
    out[: arr.shape[0]] = arr
    return out


_BETA_OPTIONS = ("sigma_min", "f_change_min", "sigma0", "stall_window", "stall_tol", "restarts")


def _make(method: str, n: int, rng: np.random.Generator, anisotropic: bool,
          options: dict[str, Any]) -> BetaSearch:
    check_option_names(method, options, _BETA_OPTIONS)
    sigma_min = real_option(method, "sigma_min", options.get("sigma_min", SIGMA_MIN_DEFAULT),
                            0.0, SIGMA_CAP, high_open=True)
    f_change_min = real_option(method, "f_change_min", options.get("f_change_min"), 0.0,
                               low_open=True, high_open=True, allow_none=True)
    sigma0 = real_option(method, "sigma0", options.get("sigma0"), 0.0, SIGMA_CAP,
                         low_open=True, allow_none=True)
    return BetaSearch(n, rng, anisotropic=anisotropic, sigma_min=sigma_min,  # type: ignore[arg-type]
                      f_change_min=f_change_min, sigma0=sigma0,
                      **restart_options(method, options))


def make_ib(n: int, rng: np.random.Generator, **options: Any) -> BetaSearch:
    """IB, the isotropic Beta search. Options: ``sigma_min``, ``f_change_min``, ``sigma0``,
    ``stall_window``, ``stall_tol``, ``restarts``."""
    return _make("ib", n, rng, False, options)


def make_ab(n: int, rng: np.random.Generator, **options: Any) -> BetaSearch:
    """AB, the anisotropic Beta search. Options: ``sigma_min``, ``f_change_min``, ``sigma0``,
    ``stall_window``, ``stall_tol``, ``restarts``."""
    return _make("ab", n, rng, True, options)

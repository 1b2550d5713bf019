"""The exact discretisation of :mod:`femupdate.simulate.exact`, prepared and run in compiled code.

Per evaluation: the 2n × 2n state matrix (balanced as the simulator balances it), its
eigendecomposition by the same LAPACK routine as ``scipy.linalg.eig``, the inverse of the
eigenvector matrix through the real inverse of LAPACK's real eigenvector array (a complex pair
``v ± i w`` occupies two real columns; the rows of V⁻¹ of the pair are ``(R_j ∓ i R_{j+1})/2``),
the same condition test, and the first-order-hold coefficients of each kept mode.

The recursion runs on ``w_k = z_k − c1 a_k`` instead of the modal state z:
``w_{k+1} = e w_k + (e c1 + c0) a_k``, one input term per step instead of two, and the outputs
``Re(W z_k) + f a_k = Re(W w_k) + (Re(W c1) + f) a_k``. The same recursion to rounding.

When the eigenvector matrix is ill-conditioned (the simulator then switches to its
matrix-exponential discretisation) or LAPACK fails, the status says so and the caller falls back
to the simulator itself.
"""

from __future__ import annotations

import cmath
import math
from typing import NamedTuple

import numpy as np
from numba import njit

from femupdate.evaluation.lapack import geev_lwork, geev_right
from femupdate.simulate._common import DIVERGENCE_LIMIT
from femupdate.simulate.exact import _SERIES_RADIUS, _SERIES_TERMS, MAX_EIGVEC_CONDITION

__all__ = ["ABSOLUTE_ACCELERATION", "DISPLACEMENT", "MODAL_OK", "NOT_MODAL",
           "RELATIVE_ACCELERATION", "ExactWork", "exact_work", "prepare_modal", "run_modal"]

#: What the kernel outputs at each channel (before the processing).
RELATIVE_ACCELERATION = 0
DISPLACEMENT = 1
ABSOLUTE_ACCELERATION = 2

#: Status of :func:`prepare_modal`.
MODAL_OK = 0
NOT_MODAL = 1  # ill-conditioned eigenvectors or a LAPACK failure: use the simulator


class ExactWork(NamedTuple):
    """Buffers of one exact evaluation (allocated once per evaluator).

    ``coef`` rows: Re e, Im e, Re g, Im g, Re c1, Im c1 of each kept mode (g = e c1 + c0);
    ``wr``/``wi`` the output weights (n_out, 2n) on Re w and −Im w; ``feed`` the weight of
    ``a_k`` per output; ``base`` the table's share subtracted from it (relative accelerations).
    """

    at: np.ndarray  # (2n, 2n) the state matrix, transposed, for dgeev
    eig_re: np.ndarray
    eig_im: np.ndarray
    vrt: np.ndarray  # (2n, 2n) LAPACK's VR, transposed
    work: np.ndarray
    vr: np.ndarray  # (2n, 2n) VR itself, for the inverse
    coef: np.ndarray  # (6, 2n)
    wr: np.ndarray  # (n_out, 2n)
    wi: np.ndarray  # (n_out, 2n)
    feed: np.ndarray  # (n_out,)
    base: np.ndarray  # (n_out,)
    state: np.ndarray  # (2, 2n) Re w, Im w


#: From 8 kept modes on, the modal loops run over a multiple of this many (zero modes fill
#: the rest): with fewer than 16 iterations LLVM's vectorised loop body (8 doubles, twice
#: unrolled) never runs (10 modes: 114 µs, padded to 16: 83 µs on the bridge). Fewer modes
#: run as they are (3 modes padded to 16 would be 5 times the work).
MODE_BLOCK = 16
MIN_PADDED = 8


def exact_work(n: int, n_out: int) -> ExactWork:
    """Fresh buffers for an ``n``-DOF system with ``n_out`` outputs."""
    size = 2 * n
    cap = -(-size // MODE_BLOCK) * MODE_BLOCK
    return ExactWork(
        at=np.empty((size, size)), eig_re=np.empty(size), eig_im=np.empty(size),
        vrt=np.empty((size, size)), work=np.empty(geev_lwork(size)), vr=np.empty((size, size)),
        coef=np.empty((6, cap)), wr=np.empty((n_out, cap)), wi=np.empty((n_out, cap)),
        feed=np.empty(n_out), base=np.empty(n_out), state=np.empty((2, cap)),
    )


@njit(cache=True)
def _typical_frequency(M: np.ndarray, K: np.ndarray) -> float:
    """``exact.typical_frequency``: geometric mean of √(K_ii/M_ii) over K_ii > 0 (else 1)."""
    s = 0.0
    count = 0
    for i in range(M.shape[0]):
        ratio = K[i, i] / M[i, i]
        if ratio > 0.0:
            s += math.log(ratio)
            count += 1
    return math.exp(0.5 * (s / count)) if count else 1.0


@njit(cache=True)
def _phi_series(x: complex, p: int) -> complex:
    """``Σ x^k / (k+p)!`` (``exact.phi_series``)."""
    s = 0j
    term = 1.0 / math.gamma(p + 1) + 0j
    for k in range(_SERIES_TERMS):
        s += term
        term = term * x / (k + p + 1)
    return s


@njit(cache=True)
def _foh(lam: complex, h: float) -> tuple[complex, complex, complex]:
    """``exact.foh_coefficients`` of one eigenvalue: (e, g0, g1)."""
    x = lam * h
    e = cmath.exp(x)
    if abs(x) < _SERIES_RADIUS:
        phi1 = _phi_series(x, 1)
        phi2 = _phi_series(x, 2)
    else:
        phi1 = (e - 1.0) / x
        phi2 = (e - 1.0 - x) / (x * x)
    return e, h * (phi1 - phi2), h * phi2


@njit(cache=True)
def _fill_state_matrix(M: np.ndarray, minv: np.ndarray, K: np.ndarray, C: np.ndarray,
                       w_s: float, at: np.ndarray) -> None:
    """The balanced state matrix ``S A S⁻¹`` (``S = diag(ω_s, …, 1, …)``), transposed."""
    n = M.shape[0]
    at[:, :] = 0.0
    for i in range(n):
        at[n + i, i] = w_s
        for j in range(n):
            sk = 0.0
            sc = 0.0
            for c in range(n):
                sk += minv[i, c] * K[c, j]
                sc += minv[i, c] * C[c, j]
            at[j, n + i] = -sk / w_s
            at[n + j, n + i] = -sc


@njit(cache=True)
def _condition(vrt: np.ndarray, wi: np.ndarray, R: np.ndarray) -> float:
    """1-norm condition of the complex eigenvector matrix V from VR and R = VR⁻¹."""
    size = wi.shape[0]
    norm_v = 0.0
    j = 0
    while j < size:
        s = 0.0
        if wi[j] > 0.0 and j + 1 < size:
            for i in range(size):
                s += math.hypot(vrt[j, i], vrt[j + 1, i])
            j += 2
        else:
            for i in range(size):
                s += abs(vrt[j, i])
            j += 1
        norm_v = max(norm_v, s)
    norm_inv = 0.0
    for c in range(size):
        s = 0.0
        j = 0
        while j < size:
            if wi[j] > 0.0 and j + 1 < size:
                s += math.hypot(R[j, c], R[j + 1, c])  # two rows of modulus |.|/2 each
                j += 2
            else:
                s += abs(R[j, c])
                j += 1
        norm_inv = max(norm_inv, s)
    return norm_v * norm_inv


@njit(cache=True)
def prepare_modal(M: np.ndarray, minv: np.ndarray, K: np.ndarray, C: np.ndarray,
                  load: np.ndarray, r_out: np.ndarray, outputs: np.ndarray, dt: float,
                  quantity: int, work: ExactWork) -> tuple[int, int]:
    """The modal filters of the system at step ``dt`` and its outputs' weights, into ``work``.

    Returns (status, m): ``MODAL_OK`` and the number of modes to run (the kept modes, then
    zero ones up to a multiple of ``MODE_BLOCK`` from ``MIN_PADDED`` on), or ``NOT_MODAL`` when
    the simulator would use its dense discretisation (or LAPACK failed).
    """
    n = M.shape[0]
    size = 2 * n
    w_s = _typical_frequency(M, K)
    _fill_state_matrix(M, minv, K, C, w_s, work.at)
    if geev_right(work.at, work.eig_re, work.eig_im, work.vrt, work.work) != 0:
        return NOT_MODAL, 0
    wr_, wi_ = work.eig_re, work.eig_im
    n_pos = 0
    n_neg = 0
    for j in range(size):
        n_pos += wi_[j] > 0.0
        n_neg += wi_[j] < 0.0
    if n_pos != n_neg:
        return NOT_MODAL, 0
    vrt = work.vrt
    for i in range(size):
        for j in range(size):
            work.vr[i, j] = vrt[j, i]
    try:
        R = np.linalg.inv(work.vr)
    except Exception:  # singular: the simulator's dense fallback
        return NOT_MODAL, 0
    cond = _condition(vrt, wi_, R)
    if not (math.isfinite(cond) and cond <= MAX_EIGVEC_CONDITION):
        return NOT_MODAL, 0
    # b = -M⁻¹ p: the input direction in the velocity half of the state
    b = np.empty(n)
    for i in range(n):
        s = 0.0
        for c in range(n):
            s += minv[i, c] * load[c]
        b[i] = -s
    n_out = outputs.shape[0]
    for o in range(n_out):
        # Relative accelerations as the reference forms them, absolute minus r a_g: the two
        # round alike (when the table's share dominates, its rounding dominates both).
        acceleration = quantity != DISPLACEMENT
        work.feed[o] = r_out[o] + b[outputs[o]] if acceleration else 0.0
        work.base[o] = r_out[o] if quantity == RELATIVE_ACCELERATION else 0.0
    m = 0
    j = 0
    while j < size:
        pair = wi_[j] > 0.0
        lam = complex(wr_[j], wi_[j])
        weight = 2.0 if pair else 1.0
        # participation of the input: row j of V⁻¹ (velocity half) times b
        bj = 0j
        for c in range(n):
            if pair:
                vinv = 0.5 * complex(R[j, n + c], -R[j + 1, n + c])
            else:
                vinv = complex(R[j, n + c], 0.0)
            bj += vinv * b[c]
        e, g0, g1 = _foh(lam, dt)
        c0 = g0 * bj
        c1 = g1 * bj
        g = e * c1 + c0
        work.coef[0, m] = e.real
        work.coef[1, m] = e.imag
        work.coef[2, m] = g.real
        work.coef[3, m] = g.imag
        work.coef[4, m] = c1.real
        work.coef[5, m] = c1.imag
        for o in range(n_out):
            d = outputs[o]
            if quantity == DISPLACEMENT:
                re = vrt[j, d] / w_s
                im = vrt[j + 1, d] / w_s if pair else 0.0
                row = complex(re, im) * weight
            else:
                row = complex(vrt[j, n + d], vrt[j + 1, n + d] if pair else 0.0) * lam * weight
            work.wr[o, m] = row.real
            work.wi[o, m] = row.imag
            work.feed[o] += row.real * c1.real - row.imag * c1.imag
        m += 1
        j += 2 if pair else 1
    padded = -(-m // MODE_BLOCK) * MODE_BLOCK if m >= MIN_PADDED else m
    work.coef[:, m:padded] = 0.0
    work.wr[:, m:padded] = 0.0
    work.wi[:, m:padded] = 0.0
    return MODAL_OK, padded


@njit(cache=True, fastmath={"contract", "reassoc"})
def _recursion(a: np.ndarray, coef: np.ndarray, wr: np.ndarray, wi: np.ndarray,
               feed: np.ndarray, base: np.ndarray, m: int, state: np.ndarray,
               y: np.ndarray) -> bool:
    """Run the modal filters over the input ``a``; ``y[o, k]`` gets output o at sample k.

    Returns whether the solution diverged (the final modal state is not finite or beyond
    ``DIVERGENCE_LIMIT``: the recursion is linear, so an overflow persists to the end).
    """
    ns = a.shape[0]
    n_out = wr.shape[0]
    xr = state[0]
    xi = state[1]
    a0 = a[0]
    for j in range(m):
        xr[j] = -coef[4, j] * a0
        xi[j] = -coef[5, j] * a0
    for k in range(ns):
        ak = a[k]
        for o in range(n_out):
            s = 0.0
            for j in range(m):
                s += wr[o, j] * xr[j] - wi[o, j] * xi[j]
            y[o, k] = (s + feed[o] * ak) - base[o] * ak
        for j in range(m):
            er = coef[0, j]
            ei = coef[1, j]
            r = er * xr[j] - ei * xi[j] + coef[2, j] * ak
            xi[j] = er * xi[j] + ei * xr[j] + coef[3, j] * ak
            xr[j] = r
    s = 0.0
    for j in range(m):
        s += abs(xr[j]) + abs(xi[j])
    return not s < DIVERGENCE_LIMIT


@njit(cache=True)
def run_modal(a: np.ndarray, m: int, work: ExactWork, y: np.ndarray) -> bool:
    """The prepared filters (:func:`prepare_modal`) over input ``a``: the raw outputs into
    ``y`` (n_out, n_samples). Returns whether the solution diverged."""
    return _recursion(a, work.coef, work.wr, work.wi, work.feed, work.base, m, work.state, y)

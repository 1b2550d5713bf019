"""Central differences with friction (:mod:`femupdate.simulate.nonlinear`), prepared and run in
compiled code.

Per evaluation: the stable-step check on the stuck system (the largest eigenvalue by the
LAPACK driver of ``scipy.linalg.eigh(..., subset_by_index=...)``), the undamped modes (the
driver of ``eigh(K, M)``) and the test that they diagonalise C, then the modal recurrence of
``CentralDifferenceSimulator`` with the elasto-slip law, each output sample processed at once
(:mod:`femupdate.evaluation.processing`).

Elements with ``k_r = 0`` never carry force and are left out; the slip limit ``f_u / k_r`` of
the others is computed once per evaluation instead of at every step. The law is written on the
element's elastic deformation ``t = clamp(y − y_r, ±f_u/k_r)`` (force ``k_r t``, new offset
``y − t``): the same law as :func:`femupdate.model.friction.elasto_slip`, which clamps the offset
and then the force, with two clamps fewer per element and step; ``k_r`` is folded into the
coefficients that bring the force into the modes, and the base acceleration is interpolated
once per substep, not mode by mode. Together 1.28 → 1.05 ms for the friction bridge's kernel
as numba code written out for its size (47,680 steps, timed interleaved); the outputs move by
rounding (2e-12 relative). The written-out kernel is now LLVM IR (:mod:`.lanes`).

A damping matrix that the modes do not diagonalise (discrete dashpots) is run by the simulator
in physical coordinates: the status then sends the caller to it.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from femupdate.evaluation.lapack import sygvd_sizes, sygvd_vectors, sygvx_largest, sygvx_lwork
from femupdate.simulate._common import DIVERGENCE_LIMIT

__all__ = ["CENTRAL_OK", "NOT_DIAGONAL", "UNSTABLE", "CentralWork", "central_work",
           "prepare_central", "run_central"]

#: Status of :func:`prepare_central`.
CENTRAL_OK = 0
UNSTABLE = 1  # h ω_max ≥ 2: the simulator refuses the step (φ = inf)
NOT_DIAGONAL = 2  # damping couples the modes, or LAPACK failed: use the simulator

# As the simulator's kernels (central_difference._FASTMATH): no 'nnan'/'ninf', the divergence
# check must see NaN.
_FASTMATH = {"contract", "reassoc"}

#: What the kernel outputs at each channel (as exact.RELATIVE_ACCELERATION, …).
RELATIVE_ACCELERATION = 0
DISPLACEMENT = 1
ABSOLUTE_ACCELERATION = 2


class CentralWork(NamedTuple):
    """Buffers and coefficients of one central-difference evaluation (allocated once).

    ``modal`` rows: a, b, g (the modal recurrence ``η⁺ = a η − b η⁻ + g a_g − Pᵀ t``);
    ``yf`` (n_f, n) element deformations from η, ``pf`` (n_f, n) elastic deformations ``t`` of
    the elements into η⁺ (``k_r`` folded in), ``po`` (n_out, n) output DOFs from η; ``limit``
    the slip limits ``f_u / k_r`` of the elements that carry force (the first ``active``; the
    other rows are zero).
    """

    a: np.ndarray  # (n, n) work copies for LAPACK
    b: np.ndarray
    w: np.ndarray
    work_gvd: np.ndarray
    iwork_gvd: np.ndarray
    work_gvx: np.ndarray
    iwork_gvx: np.ndarray
    modal: np.ndarray  # (3, n)
    yf: np.ndarray  # (n_f, n)
    pf: np.ndarray  # (n_f, n)
    po: np.ndarray  # (n_out, n)
    limit: np.ndarray  # (n_f,)
    eta: np.ndarray  # (3, n): previous, current, next
    eta0: np.ndarray  # (2, n): η_0 and η_-1
    slip: np.ndarray  # (n_f,)


def central_work(n: int, n_friction: int, n_out: int) -> CentralWork:
    """Fresh buffers for an ``n``-DOF system with ``n_friction`` elements and ``n_out`` outputs."""
    lwork, liwork = sygvd_sizes(n)
    return CentralWork(
        a=np.empty((n, n)), b=np.empty((n, n)), w=np.empty(n), work_gvd=np.empty(lwork),
        iwork_gvd=np.empty(liwork, dtype=np.int32), work_gvx=np.empty(sygvx_lwork(n)),
        iwork_gvx=np.empty(6 * n, dtype=np.int32), modal=np.empty((3, n)),
        yf=np.empty((n_friction, n)), pf=np.empty((n_friction, n)), po=np.empty((n_out, n)),
        limit=np.empty(n_friction), eta=np.empty((3, n)), eta0=np.empty((2, n)),
        slip=np.empty(n_friction),
    )


@njit(cache=True)
def _omega_max(M: np.ndarray, K: np.ndarray, kr: np.ndarray, fu: np.ndarray, fi: np.ndarray,
               fj: np.ndarray, work: CentralWork) -> tuple[float, int]:
    """Largest circular frequency of the stuck system ``K + Σ k_r b bᵀ`` (``f_u > 0``)."""
    a = work.a
    a[:, :] = K
    for e in range(kr.shape[0]):
        if fu[e] > 0.0:
            i = fi[e]
            j = fj[e]
            a[i, i] += kr[e]
            if j >= 0:
                a[j, j] += kr[e]
                a[i, j] -= kr[e]
                a[j, i] -= kr[e]
    work.b[:, :] = M
    w2, info = sygvx_largest(a, work.b, work.work_gvx, work.iwork_gvx)
    return math.sqrt(max(w2, 0.0)), info


@njit(cache=True)
def prepare_central(M: np.ndarray, K: np.ndarray, C: np.ndarray, load: np.ndarray,
                    minv: np.ndarray, kr: np.ndarray, fu: np.ndarray, fi: np.ndarray,
                    fj: np.ndarray, outputs: np.ndarray, h: float, a_g0: float,
                    work: CentralWork) -> tuple[int, int]:
    """The modal recurrence at substep ``h`` and the initial state, into ``work``.

    ``a_g0`` is the first input sample (the initial acceleration, from rest). Returns (status,
    number of elements that carry force).
    """
    n = M.shape[0]
    w_max, info = _omega_max(M, K, kr, fu, fi, fj, work)
    if info != 0:
        return NOT_DIAGONAL, 0
    if w_max > 0.0 and h * w_max >= 2.0:
        return UNSTABLE, 0
    work.a[:, :] = K
    work.b[:, :] = M
    if sygvd_vectors(work.a, work.b, work.w, work.work_gvd, work.iwork_gvd) != 0:
        return NOT_DIAGONAL, 0
    phi = work.a  # row j: mode j (Φᵀ M Φ = I)
    c = np.empty(n)
    big = 0.0
    off = 0.0
    for i in range(n):  # Φᵀ C Φ: diagonal?
        for j in range(n):
            s = 0.0
            for r in range(n):
                t = 0.0
                for q in range(n):
                    t += C[r, q] * phi[j, q]
                s += phi[i, r] * t
            big = max(big, abs(s))
            if i == j:
                c[i] = s
            else:
                off = max(off, abs(s))
    if big > 0.0 and off > 1e-12 * big:
        return NOT_DIAGONAL, 0
    h2 = h * h
    for i in range(n):
        gain = 1.0 / (1.0 / h2 + c[i] / (2.0 * h))
        work.modal[0, i] = (2.0 / h2 - work.w[i]) * gain
        work.modal[1, i] = (1.0 / h2 - c[i] / (2.0 * h)) * gain
        s = 0.0
        for r in range(n):
            s += phi[i, r] * -load[r]
        work.modal[2, i] = gain * s
    active = 0
    for e in range(kr.shape[0]):
        if kr[e] <= 0.0:  # never carries force (elasto_slip returns 0)
            continue
        for i in range(n):
            y = phi[i, fi[e]]
            if fj[e] >= 0:
                y -= phi[i, fj[e]]
            work.yf[active, i] = y
            gain = 1.0 / (1.0 / h2 + c[i] / (2.0 * h))
            work.pf[active, i] = y * gain * kr[e]
        work.limit[active] = fu[e] / kr[e]
        active += 1
    # Rows of elements without force stay zero: a kernel that runs every row (the written-out
    # one) then computes a zero force for them.
    work.yf[active:] = 0.0
    work.pf[active:] = 0.0
    work.limit[active:] = 0.0
    for o in range(outputs.shape[0]):
        for i in range(n):
            work.po[o, i] = phi[i, outputs[o]]
    # From rest: u_-1 = h²/2 · M⁻¹(-p a_g0), η_-1 = Φᵀ M u_-1, η_0 = 0
    um1 = np.empty(n)
    for i in range(n):
        s = 0.0
        for r in range(n):
            s += minv[i, r] * -(a_g0 * load[r])
        um1[i] = 0.5 * h * h * s
    for i in range(n):
        s = 0.0
        for r in range(n):
            t = 0.0
            for q in range(n):
                t += M[r, q] * um1[q]
            s += phi[i, r] * t
        work.eta0[0, i] = 0.0
        work.eta0[1, i] = s
    return CENTRAL_OK, active


@njit(cache=True, fastmath=_FASTMATH)
def _kernel(ag: np.ndarray, substeps: int, h: float, quantity: int, r_out: np.ndarray,
            modal: np.ndarray, yf: np.ndarray, pf: np.ndarray, limit: np.ndarray, active: int,
            po: np.ndarray, eta: np.ndarray, slip: np.ndarray, y: np.ndarray) -> bool:
    """The modal central-difference recurrence with elasto-slip elements, the outputs at the
    samples into ``y`` (n_out, n_samples); True if diverged."""
    ns = ag.shape[0]
    n = modal.shape[1]
    n_out = po.shape[0]
    ip, ic, ix = 0, 1, 2  # rows of eta: previous, current, next
    invh2 = 1.0 / (h * h)
    for e in range(active):
        slip[e] = 0.0
    for k in range(ns):
        last = k == ns - 1
        ak = ag[k]
        step = 0.0 if last else (ag[k + 1] - ak) / substeps  # a_g linear within the sample
        for j in range(1 if last else substeps):
            a_j = ak + j * step
            for i in range(n):
                eta[ix, i] = (modal[0, i] * eta[ic, i] - modal[1, i] * eta[ip, i]
                              + modal[2, i] * a_j)
            for e in range(active):
                u = 0.0  # the element's deformation
                for i in range(n):
                    u += yf[e, i] * eta[ic, i]
                t = min(max(u - slip[e], -limit[e]), limit[e])  # its elastic deformation
                slip[e] = u - t
                for i in range(n):
                    eta[ix, i] -= pf[e, i] * t
            if j == 0:
                s = 0.0
                for i in range(n):
                    s += abs(eta[ix, i])
                if not s < DIVERGENCE_LIMIT:
                    return True
                for o in range(n_out):
                    v = 0.0
                    if quantity == DISPLACEMENT:
                        for i in range(n):
                            v += po[o, i] * eta[ic, i]
                    else:
                        for i in range(n):
                            v += po[o, i] * (eta[ix, i] - 2.0 * eta[ic, i] + eta[ip, i])
                        v *= invh2
                        if quantity == ABSOLUTE_ACCELERATION:
                            v += r_out[o] * ak
                    y[o, k] = v
            ip, ic, ix = ic, ix, ip
    return False


@njit(cache=True)
def run_central(ag: np.ndarray, substeps: int, h: float, quantity: int, r_out: np.ndarray,
                active: int, work: CentralWork, y: np.ndarray) -> bool:
    """The prepared recurrence (:func:`prepare_central`) over ``ag``: the raw outputs into
    ``y`` (n_out, n_samples). Returns whether the solution diverged."""
    work.eta[0, :] = work.eta0[1]
    work.eta[1, :] = work.eta0[0]
    return _kernel(ag, substeps, h, quantity, r_out, work.modal, work.yf, work.pf, work.limit,
                   active, work.po, work.eta, work.slip, y)

"""φ of a model with Bouc–Wen elements in compiled code: the generic central-difference path
(:mod:`.central`) with the elements' hysteresis beside the elasto-slip sliders.

Per evaluation: the assembly of M, C, K and the friction values (:func:`.assembly.assemble`),
the Bouc–Wen table from the search point (every value in its range and ``−β < γ ≤ β``, else
the point goes to the reference path, whose ``Structure`` raises the message naming the
element), the modal recurrence (:func:`.central.prepare_central`), the elements' rows in the
modes, and the stable-step check with the elements at their largest tangent stiffness (as
:class:`femupdate.simulate.central_difference.CentralDifferenceSimulator`); then the recurrence
of the simulator's modal kernel, element law and order of operations included, so the two agree
to rounding. When the damping couples the undamped modes (storey dashpots), the simulator's
physical-coordinate recurrence runs instead (``u⁺ = G1 u − G2 u⁻ + g a_g − H f``, the matrices
from ``A_eff = M/h² + C/2h`` by one inversion). The written-out kernels and SIMD lanes of the
friction models are not used here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numba import njit

from femupdate.evaluation import central
from femupdate.evaluation.assembly import (
    ASSEMBLY_OK,
    AssemblyPlan,
    add_link_damping,
    assemble,
    rayleigh_beta,
)
from femupdate.evaluation.central import CentralWork
from femupdate.evaluation.lapack import sygvx_largest
from femupdate.evaluation.processing import Post, process_and_compare
from femupdate.model.friction import elasto_slip
from femupdate.model.hysteresis import (
    BOUC_WEN_PARAMETERS,
    Z_U_RANGE,
    bouc_wen_degrading_update,
    bouc_wen_force,
    bouc_wen_update,
    row_degrades,
)
from femupdate.model.structure import Structure
from femupdate.simulate._common import DIVERGENCE_LIMIT

__all__ = ["BoucWenPlan", "PhysicalWork", "bouc_wen_batch", "bouc_wen_plan", "physical_work"]

_FASTMATH = {"contract", "reassoc"}  # as central._FASTMATH
#: log z_u's range (a compile-time constant of the kernels)
LOG_Z_U_LOW, LOG_Z_U_HIGH = math.log(Z_U_RANGE[0]), math.log(Z_U_RANGE[1])

# Status per point, as the evaluator's: DONE, REFERENCE
_DONE = 0
_REFERENCE = 1


class BoucWenPlan(NamedTuple):
    """The Bouc–Wen elements of a structure for the compiled path, and their buffers.

    ``const`` and ``pidx`` (9, n_h): value per element and column of
    :data:`~femupdate.model.hysteresis.BOUC_WEN_PARAMETERS`, or the element's parameter index
    in the search vector (-1: the constant); ``spec`` (9, 3) each column's (low, high,
    low_open). Written per evaluation: ``table`` (n_h, 9), ``dy_max`` (n_h,), the rows ``yb``
    (deformations from the modes) and ``pb`` (forces into the modes), ``state`` (3, n_h): the
    previous deformation, z and the hysteretic energy (of degrading elements).
    """

    dof_i: np.ndarray
    dof_j: np.ndarray
    const: np.ndarray
    pidx: np.ndarray
    spec: np.ndarray
    table: np.ndarray
    dy_max: np.ndarray
    yb: np.ndarray
    pb: np.ndarray
    state: np.ndarray


class PhysicalWork(NamedTuple):
    """The physical-coordinate recurrence's matrices (transposed: rows contiguous) and state."""

    G1T: np.ndarray  # (n, n)
    G2T: np.ndarray  # (n, n)
    g: np.ndarray  # (n,) A_eff⁻¹ (−p)
    HT: np.ndarray  # (n_f, n) friction forces into u⁺
    HbT: np.ndarray  # (n_h, n) Bouc–Wen forces into u⁺
    u: np.ndarray  # (3, n) previous, current, next
    slip: np.ndarray  # (n_f,)


def physical_work(n: int, n_friction: int, n_bouc_wen: int) -> PhysicalWork:
    """Buffers of :class:`PhysicalWork` for an ``n``-DOF system."""
    return PhysicalWork(G1T=np.zeros((n, n)), G2T=np.zeros((n, n)), g=np.zeros(n),
                        HT=np.zeros((n_friction, n)), HbT=np.zeros((n_bouc_wen, n)),
                        u=np.zeros((3, n)), slip=np.zeros(n_friction))


def bouc_wen_plan(structure: Structure, names: Sequence[str]) -> BoucWenPlan:
    """The plan of ``structure``'s Bouc–Wen elements for search vectors over ``names``."""
    topo = structure._topo()
    params = structure.parameters
    props = topo.bouc_wen_props
    count = int(topo.bouc_wen_i.size)
    width = len(BOUC_WEN_PARAMETERS)
    const = np.zeros((width, count))
    pidx = np.full((width, count), -1, dtype=np.int64)
    spec = np.zeros((width, 3))
    for row, prop in enumerate(props):
        const[row] = prop.const
        for e in prop.where:
            pidx[row, e] = list(names).index(params[prop.pidx[e]])
        spec[row] = (prop.spec.low, prop.spec.high, float(prop.spec.low_open))
    n = int(topo.n)
    return BoucWenPlan(
        dof_i=topo.bouc_wen_i.astype(np.int64), dof_j=topo.bouc_wen_j.astype(np.int64),
        const=const, pidx=pidx, spec=spec, table=np.zeros((count, width)),
        dy_max=np.zeros(count), yb=np.zeros((count, n)), pb=np.zeros((count, n)),
        state=np.zeros((3, count)))


assert BOUC_WEN_PARAMETERS == ("k", "alpha", "A", "beta", "gamma", "n", "delta_a", "delta_nu",
                               "delta_eta")  # the columns below


@njit(cache=True)
def _table(bw: BoucWenPlan, p: np.ndarray) -> bool:
    """The elements' parameters at physical values ``p``; False when one gives no hysteresis
    (a value out of its range, or γ outside (−β, β])."""
    for e in range(bw.table.shape[0]):
        for j in range(bw.table.shape[1]):
            v = bw.const[j, e] if bw.pidx[j, e] < 0 else p[bw.pidx[j, e]]
            low, high, low_open = bw.spec[j, 0], bw.spec[j, 1], bw.spec[j, 2]
            if not (v > low if low_open else v >= low) or not v <= high:
                return False
            bw.table[e, j] = v
        A, beta, gamma, n = bw.table[e, 2], bw.table[e, 3], bw.table[e, 4], bw.table[e, 5]
        if not (-beta < gamma <= beta):
            return False
        # bouc_wen_step_limit: 1 / (2 n (β + |γ|) z_u^(n−1)), from log z_u (a small n under-
        # or overflows z_u itself), z_u within Z_U_RANGE (check_bouc_wen_parameters)
        log_z_u = math.log(A / (beta + gamma)) / n
        if not LOG_Z_U_LOW <= log_z_u <= LOG_Z_U_HIGH:
            return False
        bw.dy_max[e] = 0.5 / (n * (beta + abs(gamma)) * math.exp((n - 1.0) * log_z_u))
    return True


@njit(cache=True, inline="always")
def _advance(bw: BoucWenPlan, e: int, y: float) -> float:
    """Element ``e``'s ``z`` (and with degradation its energy) advanced to the deformation
    ``y`` from ``bw.state``, as the simulator's ``_bouc_wen_step``; its force."""
    t = bw.table
    if not row_degrades(t, e):
        z = bouc_wen_update(bw.state[1, e], y - bw.state[0, e], t[e, 2], t[e, 3], t[e, 4],
                            t[e, 5], bw.dy_max[e])
    else:
        z, energy = bouc_wen_degrading_update(bw.state[1, e], bw.state[2, e], y - bw.state[0, e],
                                              t[e, 2], t[e, 3], t[e, 4], t[e, 5], t[e, 6],
                                              t[e, 7], t[e, 8], (1.0 - t[e, 1]) * t[e, 0],
                                              bw.dy_max[e])
        bw.state[2, e] = energy
    bw.state[0, e] = y
    bw.state[1, e] = z
    return bouc_wen_force(y, z, t[e, 0], t[e, 1])


@njit(cache=True)
def _link_damping(plan: AssemblyPlan, p: np.ndarray, C: np.ndarray, bw: BoucWenPlan) -> None:
    """``C += β K_links``: Rayleigh's β on the Bouc–Wen elements' initial stiffness
    ``k (α + (1 − α) A)``, as ``Structure.assemble`` adds it (friction sliders never)."""
    beta = rayleigh_beta(plan, p)
    if beta == 0.0:
        return
    t = bw.table
    k0 = t[:, 0] * (t[:, 1] + (1.0 - t[:, 1]) * t[:, 2])
    add_link_damping(C, beta, bw.dof_i, bw.dof_j, k0)


@njit(cache=True)
def _stable(M: np.ndarray, K: np.ndarray, kr: np.ndarray, fu: np.ndarray, fi: np.ndarray,
            fj: np.ndarray, bw: BoucWenPlan, h: float, work: CentralWork) -> int:
    """``central.CENTRAL_OK`` if ``h ω_max < 2`` with the sliders stuck and every Bouc–Wen
    element at its largest tangent (``bouc_wen_max_tangent``); else UNSTABLE or NOT_DIAGONAL
    (LAPACK failed). Overwrites ``work.a`` and ``work.b``."""
    a = work.a
    a[:, :] = K
    for e in range(kr.shape[0]):
        if fu[e] > 0.0:
            i, j = fi[e], fj[e]
            a[i, i] += kr[e]
            if j >= 0:
                a[j, j] += kr[e]
                a[i, j] -= kr[e]
                a[j, i] -= kr[e]
    for e in range(bw.table.shape[0]):
        k, alpha, A, beta, gamma = (bw.table[e, 0], bw.table[e, 1], bw.table[e, 2],
                                    bw.table[e, 3], bw.table[e, 4])
        kt = k * (alpha + (1.0 - alpha) * max(A, 2.0 * beta * A / (beta + gamma)))
        i, j = bw.dof_i[e], bw.dof_j[e]
        a[i, i] += kt
        if j >= 0:
            a[j, j] += kt
            a[i, j] -= kt
            a[j, i] -= kt
    work.b[:, :] = M
    w2, info = sygvx_largest(a, work.b, work.work_gvx, work.iwork_gvx)
    if info != 0:
        return central.NOT_DIAGONAL
    w_max = math.sqrt(max(w2, 0.0))
    return central.UNSTABLE if w_max > 0.0 and h * w_max >= 2.0 else central.CENTRAL_OK


@njit(cache=True)
def _rows(bw: BoucWenPlan, h: float, work: CentralWork) -> None:
    """The elements' deformations from the modes (``yb``) and their forces into the next
    modal state (``pb``, the gain ``1 / (1/h² + c/2h)`` of each mode folded in), from the
    modes ``work.a`` (row j: mode j) that :func:`central.prepare_central` left."""
    n = work.modal.shape[1]
    phi = work.a
    for e in range(bw.table.shape[0]):
        i0, j0 = bw.dof_i[e], bw.dof_j[e]
        for i in range(n):
            y = phi[i, i0]
            if j0 >= 0:
                y -= phi[i, j0]
            bw.yb[e, i] = y
            gain = (1.0 + work.modal[1, i]) * h * h / 2.0  # b = 2 gain / h² − 1
            bw.pb[e, i] = y * gain


@njit(cache=True, fastmath=_FASTMATH)
def _kernel(ag: np.ndarray, substeps: int, h: float, quantity: int, r_out: np.ndarray,
            modal: np.ndarray, yf: np.ndarray, pf: np.ndarray, limit: np.ndarray, active: int,
            po: np.ndarray, eta: np.ndarray, slip: np.ndarray, bw: BoucWenPlan,
            y: np.ndarray) -> bool:
    """:func:`central._kernel` with the Bouc–Wen elements after the sliders, as the
    simulator's modal kernel orders them; the outputs into ``y``; True if diverged."""
    ns = ag.shape[0]
    n = modal.shape[1]
    n_out = po.shape[0]
    nh = bw.table.shape[0]
    ip, ic, ix = 0, 1, 2
    invh2 = 1.0 / (h * h)
    for e in range(active):
        slip[e] = 0.0
    for e in range(nh):
        bw.state[0, e] = 0.0  # from rest: no deformation, z = 0
        bw.state[1, e] = 0.0
        bw.state[2, e] = 0.0
    for k in range(ns):
        last = k == ns - 1
        ak = ag[k]
        step = 0.0 if last else (ag[k + 1] - ak) / substeps
        for j in range(1 if last else substeps):
            a_j = ak + j * step
            for i in range(n):
                eta[ix, i] = (modal[0, i] * eta[ic, i] - modal[1, i] * eta[ip, i]
                              + modal[2, i] * a_j)
            for e in range(active):
                u = 0.0
                for i in range(n):
                    u += yf[e, i] * eta[ic, i]
                t = min(max(u - slip[e], -limit[e]), limit[e])
                slip[e] = u - t
                for i in range(n):
                    eta[ix, i] -= pf[e, i] * t
            for e in range(nh):
                u = 0.0
                for i in range(n):
                    u += bw.yb[e, i] * eta[ic, i]
                f = _advance(bw, e, u)
                for i in range(n):
                    eta[ix, i] -= bw.pb[e, i] * f
            if j == 0:
                s = 0.0
                for i in range(n):
                    s += abs(eta[ix, i])
                if not s < DIVERGENCE_LIMIT:
                    return True
                for o in range(n_out):
                    v = 0.0
                    if quantity == central.DISPLACEMENT:
                        for i in range(n):
                            v += po[o, i] * eta[ic, i]
                    else:
                        for i in range(n):
                            v += po[o, i] * (eta[ix, i] - 2.0 * eta[ic, i] + eta[ip, i])
                        v *= invh2
                        if quantity == central.ABSOLUTE_ACCELERATION:
                            v += r_out[o] * ak
                    y[o, k] = v
            ip, ic, ix = ic, ix, ip
    return False


@njit(cache=True)
def _prepare_physical(M: np.ndarray, C: np.ndarray, K: np.ndarray, load: np.ndarray,
                      minv: np.ndarray, fi: np.ndarray, fj: np.ndarray, bw: BoucWenPlan,
                      h: float, a_g0: float, phys: PhysicalWork) -> None:
    """The simulator's ``_prepare_physical`` and its initial state (from rest) into ``phys``."""
    n = M.shape[0]
    h2 = h * h
    a_inv = np.linalg.inv(M / h2 + C / (2.0 * h))
    phys.G1T[:, :] = (a_inv @ (2.0 * M / h2 - K)).T
    phys.G2T[:, :] = (a_inv @ (M / h2 - C / (2.0 * h))).T
    phys.g[:] = a_inv @ -load
    for e in range(fi.shape[0]):  # H = A_eff⁻¹ Bᵀ: column e is A_eff⁻¹ (e_i − e_j)
        for r in range(n):
            phys.HT[e, r] = a_inv[r, fi[e]] - (a_inv[r, fj[e]] if fj[e] >= 0 else 0.0)
    for e in range(bw.dof_i.shape[0]):
        i0, j0 = bw.dof_i[e], bw.dof_j[e]
        for r in range(n):
            phys.HbT[e, r] = a_inv[r, i0] - (a_inv[r, j0] if j0 >= 0 else 0.0)
    um1 = 0.5 * h2 * (minv @ (-a_g0 * load))  # u_-1 from rest, as the simulator's
    phys.u[0, :] = um1
    phys.u[1, :] = 0.0


@njit(cache=True, fastmath=_FASTMATH)
def _physical_kernel(ag: np.ndarray, substeps: int, h: float, quantity: int,
                     r_out: np.ndarray, outputs: np.ndarray, kr: np.ndarray, fu: np.ndarray,
                     fi: np.ndarray, fj: np.ndarray, phys: PhysicalWork, bw: BoucWenPlan,
                     y: np.ndarray) -> bool:
    """The simulator's physical ``_cd_kernel`` (sliders, then Bouc–Wen elements) with the
    outputs into ``y``; True if diverged."""
    ns = ag.shape[0]
    n = phys.g.shape[0]
    nf = kr.shape[0]
    nh = bw.table.shape[0]
    invh2 = 1.0 / (h * h)
    ip, ic, ix = 0, 1, 2
    u = phys.u
    for e in range(nf):
        phys.slip[e] = 0.0
    for e in range(nh):
        bw.state[0, e] = 0.0
        bw.state[1, e] = 0.0
        bw.state[2, e] = 0.0
    for k in range(ns):
        last = k == ns - 1
        for j in range(1 if last else substeps):
            if last:
                for i in range(n):
                    u[ix, i] = phys.g[i] * ag[k]
            else:
                alpha = j / substeps
                for i in range(n):
                    qk = phys.g[i] * ag[k]
                    u[ix, i] = qk + alpha * (phys.g[i] * ag[k + 1] - qk)
            for c in range(n):
                a = u[ic, c]
                b = u[ip, c]
                for i in range(n):
                    u[ix, i] += phys.G1T[c, i] * a - phys.G2T[c, i] * b
            for e in range(nf):
                d = u[ic, fi[e]]
                if fj[e] >= 0:
                    d -= u[ic, fj[e]]
                f, y_r = elasto_slip(d, phys.slip[e], kr[e], fu[e])
                phys.slip[e] = y_r
                for i in range(n):
                    u[ix, i] -= phys.HT[e, i] * f
            for e in range(nh):
                d = u[ic, bw.dof_i[e]]
                if bw.dof_j[e] >= 0:
                    d -= u[ic, bw.dof_j[e]]
                f = _advance(bw, e, d)
                for i in range(n):
                    u[ix, i] -= phys.HbT[e, i] * f
            if j == 0:
                s = 0.0
                for i in range(n):
                    s += abs(u[ix, i])
                if not s < DIVERGENCE_LIMIT:
                    return True
                for o in range(outputs.shape[0]):
                    d = outputs[o]
                    if quantity == central.DISPLACEMENT:
                        y[o, k] = u[ic, d]
                    else:
                        v = (u[ix, d] - 2.0 * u[ic, d] + u[ip, d]) * invh2
                        if quantity == central.ABSOLUTE_ACCELERATION:
                            v += r_out[o] * ag[k]
                        y[o, k] = v
            ip, ic, ix = ic, ix, ip
    return False


@njit(cache=True, nogil=True)
def bouc_wen_batch(X: np.ndarray, plan: AssemblyPlan, p: np.ndarray, M: np.ndarray,
                   minv: np.ndarray, C: np.ndarray, K: np.ndarray, load: np.ndarray,
                   kr: np.ndarray, fu: np.ndarray, fi: np.ndarray, fj: np.ndarray,
                   ag: np.ndarray, r_out: np.ndarray, outputs: np.ndarray, h: float,
                   substeps: int, quantity: int, work: CentralWork, post: Post,
                   y: np.ndarray, per_channel: np.ndarray, zi: np.ndarray, bw: BoucWenPlan,
                   phys: PhysicalWork, raw: bool, phi: np.ndarray,
                   status: np.ndarray) -> None:
    """φ of every row of X (the evaluator's ``_central_batch`` with Bouc–Wen elements);
    status 1 (REFERENCE): not done here; ``raw``: stop at the outputs, φ NaN."""
    for row in range(X.shape[0]):
        phi[row] = np.nan
        status[row] = _REFERENCE
        if assemble(plan, X[row], p, M, minv, C, K, load, kr, fu) != ASSEMBLY_OK:
            continue
        if not _table(bw, p):
            continue
        if plan.rayleigh_links:
            _link_damping(plan, p, C, bw)
        code, active = central.prepare_central(M, K, C, load, minv, kr, fu, fi, fj, outputs,
                                               h, ag[0], work)
        if code == central.UNSTABLE:
            status[row] = _DONE
            phi[row] = np.inf
            continue
        modal = code == central.CENTRAL_OK  # else the damping couples the modes
        if modal:
            _rows(bw, h, work)
        code = _stable(M, K, kr, fu, fi, fj, bw, h, work)
        if code == central.NOT_DIAGONAL:  # LAPACK failed
            continue
        status[row] = _DONE
        if code == central.UNSTABLE:
            phi[row] = np.inf  # the simulator refuses the step: a failed evaluation
            continue
        if modal:
            work.eta[0, :] = work.eta0[1]
            work.eta[1, :] = work.eta0[0]
            diverged = _kernel(ag, substeps, h, quantity, r_out, work.modal, work.yf, work.pf,
                               work.limit, active, work.po, work.eta, work.slip, bw, y)
        else:
            _prepare_physical(M, C, K, load, minv, fi, fj, bw, h, ag[0], phys)
            diverged = _physical_kernel(ag, substeps, h, quantity, r_out, outputs, kr, fu,
                                        fi, fj, phys, bw, y)
        if diverged:
            phi[row] = np.inf
        elif not raw:
            phi[row] = process_and_compare(post, y, per_channel, zi)

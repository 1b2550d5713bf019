"""Central differences, the paper's integrator, with sub-steps and optional friction elements.

With ``h = dt / substeps`` and the input linear between samples,

    (M/h² + C/(2h)) u_{n+1} = p_n - K u_n - B_fᵀ f_D(B_f u_n)
                              + (2M/h²) u_n - (M/h² - C/(2h)) u_{n-1}

is fused once into ``u_{n+1} = G1 u_n - G2 u_{n-1} + q_n - H f_D`` with ``A_eff = M/h² + C/(2h)``,
``G1 = A_eff⁻¹(2M/h² - K)``, ``G2 = A_eff⁻¹(M/h² - C/(2h))``, ``q = A_eff⁻¹ p`` and
``H = A_eff⁻¹ B_fᵀ``. Friction forces follow from the current displacement (explicit), so the
elasto-slip elements touch only their own DOFs. Velocity and acceleration at a sample are the
scheme's own central differences, ``(u_{n+1} - u_{n-1})/(2h)`` and
``(u_{n+1} - 2u_n + u_{n-1})/h²``, which satisfy the equation of motion at the sample exactly.

When the undamped modes diagonalise C (no damping, Rayleigh or modal damping: Φᵀ C Φ diagonal),
the same recurrence runs in modal coordinates ``u = Φ η`` (``Φᵀ M Φ = I``): the linear part is
then a diagonal update ``η_{n+1} = a ⊙ η_n - b ⊙ η_{n-1} + q_n - P f_D`` and only the friction
elements' deformations ``y = (B_f Φ) η`` and forces couple the modes. It is the same scheme (the
results agree to rounding, 1e-12…1e-10) at about half the work per step. Non-proportional damping
(discrete dashpots) keeps the physical form.

Bouc–Wen elements (:mod:`femupdate.model.hysteresis`) enter the same way, ``- H_b f_H`` with
``H_b = A_eff⁻¹ B_hᵀ``: their hysteretic displacement ``z`` (with degradation, with their
hysteretic energy) is advanced over each step's deformation increment (Runge–Kutta in the
deformation) before their force is computed from the current displacement, so the scheme stays
explicit.

The scheme is stable for ``h < 2/ω_max``, of the stuck system and the Bouc–Wen elements at their
largest tangent stiffness; a larger step is refused with the largest stable step and the number
of substeps that works.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.linalg as sla
from numba import njit

from femupdate.errors import SimulationError
from femupdate.model.friction import elasto_slip
from femupdate.model.hysteresis import (
    BOUC_WEN_PARAMETERS,
    bouc_wen_degrading_update,
    bouc_wen_force,
    bouc_wen_max_tangent,
    bouc_wen_step_limit,
    bouc_wen_update,
    row_degrades,
)
from femupdate.model.system import System
from femupdate.simulate._common import (
    Simulator,
    cached,
    check_critical_step,
    element_histories,
    is_diverged,
    omega_max,
    sample_loads,
)

# Fused multiply-adds and reassociated sums (vectorised dot products: ~10 % faster on the
# bridge) but no 'nnan'/'ninf': the divergence check must still see NaN. The order of a sum is
# fixed when a kernel compiles, so a run still repeats bit for bit on one machine.
_FASTMATH = {"contract", "reassoc"}


@njit(cache=True)
def _sample_arrays(ns, no, nf, nb):
    """Displacement, velocity, acceleration (ns, no); friction force and slip (ns, nf);
    Bouc–Wen force and z (ns, nb)."""
    return (np.empty((ns, no)), np.empty((ns, no)), np.empty((ns, no)), np.empty((ns, nf)),
            np.empty((ns, nf)), np.empty((ns, nb)), np.empty((ns, nb)))


@njit(cache=True, inline="always")
def _bouc_wen_step(e, y, yb, zb, eb, bw, dy_max):
    """Advance element ``e``'s ``z`` (and with degradation its energy ``eb[e]``) to the
    deformation ``y`` and return its force."""
    if not row_degrades(bw, e):
        zb[e] = bouc_wen_update(zb[e], y - yb[e], bw[e, 2], bw[e, 3], bw[e, 4], bw[e, 5],
                                dy_max[e])
    else:
        z, energy = bouc_wen_degrading_update(zb[e], eb[e], y - yb[e], bw[e, 2], bw[e, 3],
                                              bw[e, 4], bw[e, 5], bw[e, 6], bw[e, 7],
                                              bw[e, 8], (1.0 - bw[e, 1]) * bw[e, 0],
                                              dy_max[e])
        zb[e] = z
        eb[e] = energy
    yb[e] = y
    return bouc_wen_force(y, zb[e], bw[e, 0], bw[e, 1])


@njit(cache=True, fastmath=_FASTMATH)
def _cd_kernel(G1T, G2T, q, substeps, h, u0, um1, fi, fj, kr, fu, HT, out, bi, bj, bw, dy_max,
               HbT):
    """Central-difference time stepping with elasto-slip elements (none when ``kr`` is empty)
    and Bouc–Wen elements (none when ``bw`` is empty).

    ``G1T, G2T, HT, HbT`` are the transposes of ``G1, G2, H, H_b`` (columns contiguous for the
    updates); ``q`` (ns, n) the loads ``A_eff⁻¹ p`` at the samples, interpolated linearly in
    between; ``bw`` (nb, 9) the Bouc–Wen parameters, ``dy_max`` their Runge–Kutta part limits.
    Returns displacement, velocity and relative acceleration at the output DOFs, friction force
    and slip offset per element, Bouc–Wen force and z per element at the samples, and whether
    the solution diverged.
    """
    ns = q.shape[0]
    n = u0.shape[0]
    nf = kr.shape[0]
    nb = bw.shape[0]
    no = out.shape[0]
    disp, vel, acc, ff, slip, bf, bz = _sample_arrays(ns, no, nf, nb)
    yb = np.empty(nb)  # deformation at the previous step
    zb = np.zeros(nb)
    eb = np.zeros(nb)  # hysteretic energy (degrading elements)
    fb = np.empty(nb)
    for e in range(nb):
        yb[e] = u0[bi[e]] - (u0[bj[e]] if bj[e] >= 0 else 0.0)
    u_prev = um1.copy()
    u = u0.copy()
    u_next = np.empty(n)
    yr = np.zeros(nf)
    fe = np.empty(nf)
    inv2h = 0.5 / h
    invh2 = 1.0 / (h * h)
    for k in range(ns):
        last = k == ns - 1
        for j in range(1 if last else substeps):
            alpha = j / substeps
            if last:
                for i in range(n):
                    u_next[i] = q[k, i]
            else:
                for i in range(n):
                    u_next[i] = q[k, i] + alpha * (q[k + 1, i] - q[k, i])
            for c in range(n):
                a = u[c]
                b = u_prev[c]
                for i in range(n):
                    u_next[i] += G1T[c, i] * a - G2T[c, i] * b
            for e in range(nf):
                y = u[fi[e]]
                if fj[e] >= 0:
                    y -= u[fj[e]]
                f, y_r = elasto_slip(y, yr[e], kr[e], fu[e])
                yr[e] = y_r
                fe[e] = f
                for i in range(n):
                    u_next[i] -= HT[e, i] * f
            for e in range(nb):
                y = u[bi[e]]
                if bj[e] >= 0:
                    y -= u[bj[e]]
                f = _bouc_wen_step(e, y, yb, zb, eb, bw, dy_max)
                fb[e] = f
                for i in range(n):
                    u_next[i] -= HbT[e, i] * f
            if j == 0:
                if is_diverged(u_next):
                    return disp, vel, acc, ff, slip, bf, bz, True
                for o in range(no):
                    d = out[o]
                    disp[k, o] = u[d]
                    vel[k, o] = (u_next[d] - u_prev[d]) * inv2h
                    acc[k, o] = (u_next[d] - 2.0 * u[d] + u_prev[d]) * invh2
                for e in range(nf):
                    ff[k, e] = fe[e]
                    slip[k, e] = yr[e]
                for e in range(nb):
                    bf[k, e] = fb[e]
                    bz[k, e] = zb[e]
            u_prev, u, u_next = u, u_next, u_prev
    return disp, vel, acc, ff, slip, bf, bz, False


@njit(cache=True, fastmath=_FASTMATH)
def _modal_cd_kernel(a, b, q, substeps, h, eta0, eta_m1, Yf, kr, fu, Pf, Po, Yb, bw, dy_max,
                     Pb):
    """Central differences in modal coordinates with elasto-slip elements (none if ``kr`` empty)
    and Bouc–Wen elements (none if ``bw`` is empty).

    ``η_{n+1} = a ⊙ η_n - b ⊙ η_{n-1} + q_n - Pfᵀ f - Pbᵀ f_b`` with the element deformations
    ``y = Yf η`` and ``y_b = Yb η``; ``q`` (ns, n) holds the modal loads at the samples,
    interpolated linearly in between; ``Po`` maps modes to the output DOFs. Returns what
    :func:`_cd_kernel` returns.
    """
    ns = q.shape[0]
    n = eta0.shape[0]
    nf = kr.shape[0]
    nb = bw.shape[0]
    no = Po.shape[0]
    disp, vel, acc, ff, slip, bf, bz = _sample_arrays(ns, no, nf, nb)
    yb = np.empty(nb)
    zb = np.zeros(nb)
    eb = np.zeros(nb)  # hysteretic energy (degrading elements)
    fb = np.empty(nb)
    for e in range(nb):
        y = 0.0
        for i in range(n):
            y += Yb[e, i] * eta0[i]
        yb[e] = y
    eta_prev = eta_m1.copy()
    eta = eta0.copy()
    eta_next = np.empty(n)
    dq = np.zeros(n)
    yr = np.zeros(nf)
    fe = np.empty(nf)
    inv2h = 0.5 / h
    invh2 = 1.0 / (h * h)
    for k in range(ns):
        last = k == ns - 1
        if not last:
            for i in range(n):
                dq[i] = (q[k + 1, i] - q[k, i]) / substeps
        for j in range(1 if last else substeps):
            for i in range(n):
                eta_next[i] = a[i] * eta[i] - b[i] * eta_prev[i] + (q[k, i] + j * dq[i])
            for e in range(nf):
                y = 0.0
                for i in range(n):
                    y += Yf[e, i] * eta[i]
                f, y_r = elasto_slip(y, yr[e], kr[e], fu[e])
                yr[e] = y_r
                fe[e] = f
                for i in range(n):
                    eta_next[i] -= Pf[e, i] * f
            for e in range(nb):
                y = 0.0
                for i in range(n):
                    y += Yb[e, i] * eta[i]
                f = _bouc_wen_step(e, y, yb, zb, eb, bw, dy_max)
                fb[e] = f
                for i in range(n):
                    eta_next[i] -= Pb[e, i] * f
            if j == 0:
                if is_diverged(eta_next):
                    return disp, vel, acc, ff, slip, bf, bz, True
                for o in range(no):
                    d = 0.0
                    v = 0.0
                    w = 0.0
                    for i in range(n):
                        d += Po[o, i] * eta[i]
                        v += Po[o, i] * (eta_next[i] - eta_prev[i])
                        w += Po[o, i] * (eta_next[i] - 2.0 * eta[i] + eta_prev[i])
                    disp[k, o] = d
                    vel[k, o] = v * inv2h
                    acc[k, o] = w * invh2
                for e in range(nf):
                    ff[k, e] = fe[e]
                    slip[k, e] = yr[e]
                for e in range(nb):
                    bf[k, e] = fb[e]
                    bz[k, e] = zb[e]
            eta_prev, eta, eta_next = eta, eta_next, eta_prev
    return disp, vel, acc, ff, slip, bf, bz, False


def modal_damping(
    M: np.ndarray, C: np.ndarray, K: np.ndarray, rtol: float = 1e-12
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Undamped modes that diagonalise ``C``, or None when the damping couples them.

    Returns
    -------
    (ω², Φ, c) or None
        Eigenvalues of ``(K, M)``, mass-normalised modes (``Φᵀ M Φ = I``) and the diagonal of
        ``Φᵀ C Φ``, if its off-diagonal entries are below ``rtol`` times its largest entry.
    """
    w2, phi = sla.eigh(K, M, check_finite=False)
    c_modal = phi.T @ C @ phi
    c = np.diag(c_modal).copy()
    scale = np.abs(c_modal).max()
    if scale > 0.0 and np.abs(c_modal - np.diag(c)).max() > rtol * scale:
        return None
    return w2, phi, c


def stuck_omega_max(w2: np.ndarray, phi: np.ndarray, rows: np.ndarray, k: np.ndarray) -> float:
    """Largest natural circular frequency (rad/s) of ``(K + Bᵀ diag(k) B, M)`` from the modes
    of ``(K, M)``.

    Parameters
    ----------
    w2, phi : ndarray
        Eigenvalues of ``(K, M)`` and their mass-normalised modes (``Φᵀ M Φ = I``).
    rows, k : ndarray
        The elements' connectivity ``B`` (n_el, n) and their stiffnesses (n_el,).

    Returns
    -------
    float
        ``√λ_max`` of ``diag(ω²) + (BΦ)ᵀ diag(k) (BΦ)``: the same eigenvalues as the
        generalised problem, by a standard one (no Cholesky of M, no reduction).
    """
    n = w2.size
    bp = rows @ phi
    a = np.diag(w2) + bp.T @ (k[:, None] * bp)
    top = sla.eigh(a, eigvals_only=True, subset_by_index=[n - 1, n - 1], check_finite=False)
    return float(np.sqrt(max(top[-1], 0.0)))


class CentralDifferenceSimulator(Simulator):
    """Central differences prepared for one system, sample interval and number of substeps.

    Friction elements, if the system has them, are integrated with the elasto-slip law (that is
    the nonlinear integrator, :func:`femupdate.simulate.nonlinear.prepare_nonlinear`);
    :func:`prepare_central_difference` accepts linear systems only. Runs in modal coordinates
    when the modes diagonalise C (:func:`modal_damping`), in physical ones otherwise.
    """

    def __init__(
        self,
        system: System,
        dt: float,
        outputs: Sequence[int] | np.ndarray | None = None,
        substeps: int = 1,
        *,
        method: str = "central_difference",
    ) -> None:
        super().__init__(system, dt, outputs, substeps)
        n = self.n_dof
        fr = system.friction
        nf = 0 if fr is None else fr.count
        # the stuck stiffness Bᵀ diag(k) B of the elements, as its rows B and stiffnesses k
        stuck_rows, stuck_k = [np.zeros((0, n))], [np.zeros(0)]
        if nf:
            bf = fr.connectivity(n)
            active = fr.f_u > 0  # a slider with f_u = 0 never carries force
            stuck_rows.append(bf[active])
            stuck_k.append(np.asarray(fr.k_r, dtype=float)[active])
        else:
            bf = np.zeros((0, n))
        bw = system.bouc_wen
        nb = 0 if bw is None else bw.count
        if nb:
            hb = bw.connectivity(n)
            stuck_rows.append(hb)
            stuck_k.append(bouc_wen_max_tangent(*bw.table[:, :5].T))
            self._bw = np.ascontiguousarray(bw.table, dtype=np.float64)
            self._bi = np.ascontiguousarray(bw.dof_i, dtype=np.int64)
            self._bj = np.ascontiguousarray(bw.dof_j, dtype=np.int64)
            t = self._bw
            self._dy_max = np.ascontiguousarray(bouc_wen_step_limit(t[:, 2], t[:, 3], t[:, 4],
                                                                    t[:, 5]))
        else:
            hb = np.zeros((0, n))
            self._bw = np.zeros((0, len(BOUC_WEN_PARAMETERS)))
            self._bi = np.zeros(0, dtype=np.int64)
            self._bj = np.zeros(0, dtype=np.int64)
            self._dy_max = np.zeros(0)
        self._hb = hb
        self.n_bouc_wen = nb
        M, C, K = system.M, system.C, system.K
        # the modes depend on the linear part alone: a search that changes only the elements
        # computes them once (femupdate.simulate._common.cached)
        modal = cached(modal_damping, M, C, K)
        stuck, k_el = np.vstack(stuck_rows), np.concatenate(stuck_k)
        self.omega_max = (omega_max(M, K + stuck.T @ (k_el[:, None] * stuck)) if modal is None
                          else stuck_omega_max(modal[0], modal[1], stuck, k_el))
        check_critical_step(self.dt, self.substeps, self.omega_max, 2.0, method)
        self.modal = modal is not None
        if modal is None:
            self._prepare_physical(M, C, K, system.seismic_load, bf, method, hb)
        else:
            self._prepare_modal(*modal, M, system.seismic_load, bf, hb)
        self._bf = bf
        if nf:
            self._fi = np.ascontiguousarray(fr.dof_i, dtype=np.int64)
            self._fj = np.ascontiguousarray(fr.dof_j, dtype=np.int64)
            self._kr = np.ascontiguousarray(fr.k_r, dtype=np.float64)
            self._fu = np.ascontiguousarray(fr.f_u, dtype=np.float64)
        else:
            self._fi = np.zeros(0, dtype=np.int64)
            self._fj = np.zeros(0, dtype=np.int64)
            self._kr = np.zeros(0)
            self._fu = np.zeros(0)
        self.n_friction = nf

    def _prepare_physical(self, M: np.ndarray, C: np.ndarray, K: np.ndarray, p: np.ndarray,
                          bf: np.ndarray, method: str, hb: np.ndarray) -> None:
        """The fused recurrence's matrices in physical coordinates (module docstring); ``hb``
        the Bouc–Wen connectivity, coupled as the friction elements' ``bf``."""
        h = self.h
        a_eff = M / h**2 + C / (2.0 * h)
        try:
            lu = sla.lu_factor(a_eff, check_finite=False)
        except (sla.LinAlgError, ValueError):
            raise SimulationError(
                f"{method}: M/h² + C/(2h) is singular at h = {h:.6g} s; check M and C"
            ) from None
        solve = lambda b: sla.lu_solve(lu, b, check_finite=False)  # noqa: E731
        self._G1T = np.ascontiguousarray(solve(2.0 * M / h**2 - K).T)
        self._G2T = np.ascontiguousarray(solve(M / h**2 - C / (2.0 * h)).T)
        self._g = solve(-p)
        self._G3 = solve(np.eye(self.n_dof))
        self._HT = np.ascontiguousarray(solve(bf.T).T) if len(bf) else np.zeros((0, self.n_dof))
        self._HbT = np.ascontiguousarray(solve(hb.T).T) if len(hb) else np.zeros((0, self.n_dof))

    def _prepare_modal(self, w2: np.ndarray, phi: np.ndarray, c: np.ndarray, M: np.ndarray,
                       p: np.ndarray, bf: np.ndarray, hb: np.ndarray) -> None:
        """The same recurrence per mode: ``(1/h² + c/2h) η_{n+1} = …`` divided through."""
        h = self.h
        gain = 1.0 / (1.0 / h**2 + c / (2.0 * h))
        self._a = (2.0 / h**2 - w2) * gain
        self._b = (1.0 / h**2 - c / (2.0 * h)) * gain
        self._g = gain * (phi.T @ -p)
        self._G3 = gain[:, None] * phi.T
        self._Yf = np.ascontiguousarray(bf @ phi)
        self._Pf = np.ascontiguousarray(bf @ phi * gain[None, :])
        self._Po = np.ascontiguousarray(phi[self.outputs])
        self._to_modal = phi.T @ M  # η = Φᵀ M u
        self._Yb = np.ascontiguousarray(hb @ phi)
        self._Pb = np.ascontiguousarray(hb @ phi * gain[None, :])

    def _initial_force(self, x0: np.ndarray) -> np.ndarray:
        """Friction and Bouc–Wen forces on the DOFs at the initial state (slip offsets and
        ``z`` start at zero)."""
        force = np.zeros(self.n_dof)
        if self.n_friction:
            y = self._bf @ x0
            f = np.array([elasto_slip(y[e], 0.0, self._kr[e], self._fu[e])[0]
                          for e in range(self.n_friction)])
            force += self._bf.T @ f
        if self.n_bouc_wen:
            y = self._hb @ x0
            force += self._hb.T @ (self._bw[:, 0] * self._bw[:, 1] * y)  # α k y at z = 0
        return force

    def _integrate(
        self, ag: np.ndarray | None, force: np.ndarray | None, ns: int, x0: np.ndarray,
        v0: np.ndarray,
    ) -> tuple:
        h = self.h
        q = sample_loads(ag, force, self._g, self._G3)
        # u_{-1} from a Taylor step backwards with the acceleration the equations give at t = 0
        a0 = self._initial_acceleration(ag, force, x0, v0, self._initial_force(x0))
        um1 = x0 - h * v0 + 0.5 * h * h * a0
        friction = (self._kr, self._fu)
        if self.modal:
            disp, vel, acc, ff, slip, bf, bz, diverged = _modal_cd_kernel(
                self._a, self._b, q, self.substeps, h, self._to_modal @ x0,
                self._to_modal @ um1, self._Yf, *friction, self._Pf, self._Po,
                self._Yb, self._bw, self._dy_max, self._Pb,
            )
        else:
            disp, vel, acc, ff, slip, bf, bz, diverged = _cd_kernel(
                self._G1T, self._G2T, q, self.substeps, h, x0, um1, self._fi, self._fj,
                *friction, self._HT, self.outputs, self._bi, self._bj, self._bw,
                self._dy_max, self._HbT,
            )
        return (disp, vel, acc, diverged,
                *element_histories(self.n_friction, self.n_bouc_wen, ff, slip, bf, bz))


def prepare_central_difference(
    system: System,
    dt: float,
    outputs: Sequence[int] | np.ndarray | None = None,
    substeps: int = 1,
) -> CentralDifferenceSimulator:
    """Prepare central differences for a linear ``system`` at ``h = dt / substeps``.

    Parameters
    ----------
    system : System
        Linear system (for friction elements use ``method="nonlinear"``).
    dt : float
        Sample interval of the inputs and outputs (s).
    outputs : sequence of int, optional
        DOF indices to output (default: all).
    substeps : int
        Integration steps per sample interval; the input is interpolated linearly.

    Raises
    ------
    SimulationError
        If the system has friction elements, or ``h >= 2/ω_max`` (unstable).
    """
    if not system.is_linear:
        raise SimulationError(
            "method 'central_difference' is for linear systems; this system has "
            f"{system.nonlinear_elements()}: use method='nonlinear'"
        )
    return CentralDifferenceSimulator(system, dt, outputs, substeps)

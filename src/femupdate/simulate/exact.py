"""Exact discretisation of a linear system for a piecewise-linear input (first-order hold).

The equations ``M ÿ + C ẏ + K y = p(t)`` in state space, ``x = [y; ẏ]``,

    ẋ = A x + [0; M⁻¹] p,     A = [[0, I], [-M⁻¹K, -M⁻¹C]],

are diagonalised, ``A = V Λ V⁻¹`` (complex; any damping, proportional or not), into independent
first-order modal filters ``ż = λ z + β·p``. For ``p`` linear between samples each one has the
exact recursion

    z_{k+1} = e^{λh} z_k + γ0 β·p_k + γ1 β·p_{k+1},
    γ1 = h φ2(λh),  γ0 = h (φ1(λh) - φ2(λh)),  φ1(x) = (eˣ - 1)/x,  φ2(x) = (eˣ - 1 - x)/x²,

with a series for small ``|λh|`` (rigid and near-rigid modes). Of a conjugate pair only one mode
is run (the other is its conjugate, so the pair contributes twice the real part). The response
is exact at the samples up to rounding; there is no step-size limit and no sub-stepping.

When ``V`` is ill-conditioned (defective or nearly repeated eigenvalues, e.g. an undamped rigid
mode), the full state is discretised instead with the matrix exponential of an augmented matrix
and run as a dense recursion.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import scipy.linalg as sla
from numba import njit

from femupdate.errors import SimulationError
from femupdate.model.system import System
from femupdate.simulate._common import (
    DIVERGENCE_LIMIT,
    Simulator,
    is_diverged,
)

# Above this 1-norm condition number of the (balanced) eigenvector matrix, rounding in the modal
# transform (about cond·eps) is no longer negligible: use the matrix-exponential discretisation.
# A defective eigenvalue (an undamped rigid mode) perturbed by rounding gives about 1/√eps ~ 1e8.
MAX_EIGVEC_CONDITION = 1e6
_SERIES_RADIUS = 0.5
_SERIES_TERMS = 24  # 0.5**24 / 26! ~ 1e-34: the series is exact to rounding inside the radius


def phi_series(x: np.ndarray, p: int) -> np.ndarray:
    """``Σ_k x^k / (k+p)!``, the entire function ``φ_p`` of exponential integrators, for small x."""
    s = np.zeros_like(x)
    term = np.full_like(x, 1.0 / math.factorial(p))
    for k in range(_SERIES_TERMS):
        s += term
        term = term * x / (k + p + 1)
    return s


def foh_coefficients(lam: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """First-order-hold recursion coefficients of ``ż = λ z + u`` over a step ``h``.

    Parameters
    ----------
    lam : ndarray of complex
        Eigenvalues.
    h : float
        Step (s).

    Returns
    -------
    e, g0, g1 : ndarray of complex
        ``z(t+h) = e z(t) + g0 u(t) + g1 u(t+h)``, exact when ``u`` is linear over the step.
    """
    x = np.asarray(lam, dtype=np.complex128) * h
    small = np.abs(x) < _SERIES_RADIUS
    xs = np.where(small, 1.0, x)  # keeps the closed forms away from 0/0 (series used there)
    with np.errstate(over="ignore", invalid="ignore"):
        e = np.exp(x)
        phi1 = (e - 1.0) / xs
        phi2 = (e - 1.0 - xs) / (xs * xs)
    if small.any():
        phi1[small] = phi_series(x[small], 1)
        phi2[small] = phi_series(x[small], 2)
    return e, h * (phi1 - phi2), h * phi2


def typical_frequency(M: np.ndarray, K: np.ndarray) -> float:
    """A middle circular frequency: the geometric mean of √(K_ii/M_ii) over DOFs with K_ii > 0.

    Only a scale for balancing the state; 1 when no DOF has stiffness.
    """
    ratio = np.diag(K) / np.diag(M)
    ratio = ratio[ratio > 0]
    return float(np.exp(0.5 * np.mean(np.log(ratio)))) if ratio.size else 1.0


def foh_state_matrices(
    A: np.ndarray, B: np.ndarray, h: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact first-order-hold discretisation of ``ẋ = A x + B u`` by one matrix exponential.

    Returns ``Φ, G0, G1`` with ``x_{k+1} = Φ x_k + G0 u_k + G1 u_{k+1}`` for ``u`` linear over
    the step: the exponential of ``h·[[A, B, 0], [0, 0, I], [0, 0, 0]]`` (input and its slope
    appended to the state) holds ``Φ``, ``Γa = ∫Φ B`` and ``Γb``, and ``G0 = Γa - Γb/h``,
    ``G1 = Γb/h``.
    """
    ns, ni = B.shape
    F = np.zeros((ns + 2 * ni, ns + 2 * ni))
    F[:ns, :ns] = A
    F[:ns, ns : ns + ni] = B
    F[ns : ns + ni, ns + ni :] = np.eye(ni)
    E = sla.expm(F * h)
    phi = E[:ns, :ns]
    ga = E[:ns, ns : ns + ni]
    gb = E[:ns, ns + ni :]
    return phi, ga - gb / h, gb / h


@njit(cache=True)
def _modal_recursion(ag, fmod, e, c0, c1, g0, g1, z0):
    """Run the modal filters: the real and imaginary parts of every mode at every sample.

    ``z_{k+1} = e z_k + c0 a_k + c1 a_{k+1} (+ g0 F_k + g1 F_{k+1})``. Returns
    (Z (ns, 2m + 1) with ``Re z`` in the first m columns, ``Im z`` in the next m and the input
    ``a_k`` in the last, for its direct feed-through to the accelerations; diverged).
    """
    ns = ag.shape[0]
    m = e.shape[0]
    has_force = fmod.shape[0] > 0
    Z = np.empty((ns, 2 * m + 1))
    z = z0.copy()
    for j in range(m):
        Z[0, j] = z[j].real
        Z[0, m + j] = z[j].imag
    for k in range(ns):
        Z[k, 2 * m] = ag[k]
    for k in range(1, ns):
        ak0 = ag[k - 1]
        ak1 = ag[k]
        for j in range(m):
            zj = e[j] * z[j] + c0[j] * ak0 + c1[j] * ak1
            if has_force:
                zj += g0[j] * fmod[k - 1, j] + g1[j] * fmod[k, j]
            z[j] = zj
            Z[k, j] = zj.real
            Z[k, m + j] = zj.imag
    # The recursion is linear: a solution that overflowed stays inf or NaN to the end, so the
    # last state tells (one check instead of one per step).
    s = 0.0
    for j in range(m):
        s += abs(z[j].real) + abs(z[j].imag)
    return Z, not s < DIVERGENCE_LIMIT  # NaN fails the comparison too


@njit(cache=True)
def _dense_recursion(phiT, Q0, Q1, x0):
    """``x_{k+1} = Φ x_k + Q0_k + Q1_{k+1}`` (``phiT`` = Φᵀ); returns (X, diverged)."""
    ns = Q0.shape[0]
    n = x0.shape[0]
    X = np.empty((ns, n))
    X[0, :] = x0
    for k in range(1, ns):
        for i in range(n):
            X[k, i] = Q0[k - 1, i] + Q1[k, i]
        for c in range(n):
            xc = X[k - 1, c]
            for i in range(n):
                X[k, i] += phiT[c, i] * xc
        if is_diverged(X[k]):
            return X, True
    return X, False


def _is_diagonal(system: System) -> bool:
    """Whether M, C and K are all diagonal (a system of uncoupled modal coordinates)."""
    return all(np.count_nonzero(a - np.diag(np.diag(a))) == 0
               for a in (system.M, system.C, system.K))


def _decoupled_eigen(system: System, w_s: float
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Eigenvalues, eigenvectors, their inverse and its 1-norm condition number of the scaled
    state matrix of uncoupled DOFs, in closed form (what ``scipy.linalg.eig`` and ``inv`` of the
    2n × 2n matrix give, in O(n) instead of O(n³): the reduced model of a large structure has
    hundreds of modes).

    DOF j's block of the state ``[ω_s y; ẏ]`` is ``[[0, ω_s], [-k/(m ω_s), -c/m]]``, with
    eigenvalues the roots of ``λ² + (c/m) λ + k/m`` and eigenvectors ``[ω_s, λ]`` at (j, n + j),
    scaled to unit length as LAPACK's.
    Ordered as LAPACK does: a complex pair with Im > 0 first; real roots as they are. Equal
    roots (critical damping) have no eigenvector basis: the condition number is then infinite,
    and the caller takes the matrix exponential.
    """
    m, c, k = (np.diag(a).astype(float) for a in (system.M, system.C, system.K))
    n = m.size
    half = -0.5 * c / m
    root = np.sqrt((half * half - k / m).astype(complex))
    root = np.where(root.imag < 0, -root, root)  # the root with Im ≥ 0 first
    lam1, lam2 = half + root, half - root
    V = np.zeros((2 * n, 2 * n), dtype=np.complex128)
    vinv = np.zeros_like(V)
    j = np.arange(n)
    first, second = 2 * j, 2 * j + 1  # each DOF's two eigenvalues side by side, as LAPACK
    s1, s2 = np.hypot(w_s, np.abs(lam1)), np.hypot(w_s, np.abs(lam2))  # unit vectors, as LAPACK
    V[j, first], V[j, second] = w_s / s1, w_s / s2
    V[n + j, first], V[n + j, second] = lam1 / s1, lam2 / s2
    with np.errstate(divide="ignore", invalid="ignore"):
        det = w_s * (lam2 - lam1)
        vinv[first, j], vinv[first, n + j] = s1 * lam2 / det, -s1 * w_s / det
        vinv[second, j], vinv[second, n + j] = -s2 * lam1 / det, s2 * w_s / det
        norm_v = np.max(np.maximum((w_s + np.abs(lam1)) / s1, (w_s + np.abs(lam2)) / s2))
        norm_vinv = np.max(np.maximum(np.abs(vinv[first, j]) + np.abs(vinv[second, j]),
                                      np.abs(vinv[first, n + j]) + np.abs(vinv[second, n + j])))
        cond = float(norm_v * norm_vinv)
    lam = np.empty(2 * n, dtype=np.complex128)
    lam[first], lam[second] = lam1, lam2
    # a real root pair: both real (LAPACK's exact zeros of Im)
    real = root.imag == 0
    lam[first[real]] = lam1[real].real
    lam[second[real]] = lam2[real].real
    return lam, V, vinv, cond if np.isfinite(cond) else math.inf


class ExactSimulator(Simulator):
    """A linear system discretised exactly for first-order-hold inputs at step ``dt``.

    Build it once per system (one 2n × 2n eigendecomposition), then call :meth:`run` for each
    input. Use :func:`prepare_exact` to build one. With ``decoupled=True`` a system whose
    ``M``, ``C`` and ``K`` are all diagonal (uncoupled modal coordinates) takes its
    eigendecomposition in closed form instead (O(n), not O(n³); the reduced path's).

    Attributes
    ----------
    modal : bool
        True when the modal filters are used, False for the matrix-exponential fallback.
    condition : float
        1-norm condition number of the eigenvector matrix that chose between the two.
    """

    # Its outputs come from the state and the input together (absolute accelerations).
    returns_absolute_acceleration = True

    def __init__(
        self, system: System, dt: float, outputs: Sequence[int] | np.ndarray | None = None,
        *, decoupled: bool = False,
    ) -> None:
        super().__init__(system, dt, outputs)
        if not system.is_linear:
            raise SimulationError(
                "method 'exact' is for linear systems; this system has "
                f"{system.nonlinear_elements()}: use method='nonlinear'"
            )
        n = self.n_dof
        minv = self._minv
        self._minv_out = np.ascontiguousarray(minv[self.outputs])
        # The state derivative A x omits the input's direct term: relative acceleration is
        # A-part − (M⁻¹ p) a_g at the outputs.
        self._ag_feed = self._r_out - (minv @ system.seismic_load)[self.outputs]
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        A[n:, :n] = -minv @ system.K
        A[n:, n:] = -minv @ system.C
        # Eigenvectors [φ; λφ] of low and high modes differ in scale by ω_max/ω_min; the state
        # [ω_s y; ẏ] with a middle frequency ω_s balances them (cond(V) 1.5e5 -> 3e2 on the
        # 10-DOF bridge), so a tight condition threshold can single out defective cases.
        self._w_s = typical_frequency(system.M, system.K)
        if decoupled and _is_diagonal(system):
            lam, V, vinv, cond = _decoupled_eigen(system, self._w_s)
        else:
            scale = np.concatenate([np.full(n, self._w_s), np.ones(n)])
            lam, V = sla.eig(scale[:, None] * A / scale[None, :], check_finite=False)
            V = V.astype(np.complex128)  # scipy returns real vectors when all are real
            with np.errstate(all="ignore"):
                try:
                    vinv = np.linalg.inv(V)
                    cond = float(np.linalg.norm(V, 1) * np.linalg.norm(vinv, 1))
                except np.linalg.LinAlgError:
                    cond = np.inf
        # LAPACK returns exactly real eigenvalues for real ones and pairs with Im > 0 first.
        pairs_ok = np.count_nonzero(lam.imag > 0) == np.count_nonzero(lam.imag < 0)
        self.condition = cond
        self.modal = bool(np.isfinite(cond) and cond <= MAX_EIGVEC_CONDITION and pairs_ok)
        if self.modal:
            self._prepare_modal(system, minv, lam, V, vinv)
        else:
            self._prepare_dense(system, minv, A)

    def _prepare_modal(
        self, system: System, minv: np.ndarray, lam: np.ndarray, V: np.ndarray, vinv: np.ndarray
    ) -> None:
        n = self.n_dof
        keep = lam.imag >= 0
        weight = np.where(lam.imag[keep] > 0, 2.0, 1.0)  # a pair counts twice its real part
        lam_k = lam[keep]
        vinv_k = vinv[keep]
        # V, vinv are of the scaled state [ω_s y; ẏ]: y-rows of V and y-columns of V⁻¹ scale
        V = V.copy()
        V[:n] /= self._w_s
        vinv_k = vinv_k.copy()
        vinv_k[:, :n] *= self._w_s
        self._vinv = np.ascontiguousarray(vinv_k)
        b_ag = vinv_k[:, n:] @ (-(minv @ system.seismic_load))  # M⁻¹(-p); = -r if p = M r
        self._b_force = np.ascontiguousarray(vinv_k[:, n:] @ minv)  # (m, n)
        e, g0, g1 = foh_coefficients(lam_k, self.dt)
        self._e, self._g0, self._g1 = e, g0, g1
        self._c0 = g0 * b_ag
        self._c1 = g1 * b_ag
        out = self.outputs
        rows = np.vstack([V[out], V[n + out], (V * lam)[n + out]])[:, keep] * weight
        # Output = Re(rows · z) = rows.real · Re z − rows.imag · Im z: one product with the
        # (samples × 2m) history of the modes gives every output at every sample.
        # The last row multiplies a_g: absolute acceleration = A-part + (r − M⁻¹p) a_g (0 when
        # p = M r), displacement and velocity have no direct term.
        feed = np.concatenate([np.zeros(2 * out.size), self._ag_feed])
        self._W = np.ascontiguousarray(np.vstack([rows.real.T, -rows.imag.T, feed]))
        self._no_force = np.zeros((0, lam_k.size), dtype=np.complex128)

    def _prepare_dense(self, system: System, minv: np.ndarray, A: np.ndarray) -> None:
        n = self.n_dof
        B = np.vstack([np.zeros((n, n)), minv])
        phi, G0, G1 = foh_state_matrices(A, B, self.dt)
        self._phiT = np.ascontiguousarray(phi.T)
        self._G0, self._G1 = G0, G1
        out = self.outputs
        self._rows = np.vstack([np.eye(2 * n)[out], np.eye(2 * n)[n + out], A[n + out]])

    def _integrate(
        self, ag: np.ndarray | None, force: np.ndarray | None, ns: int, x0: np.ndarray,
        v0: np.ndarray,
    ) -> tuple:
        run = self._run_modal if self.modal else self._run_dense
        return run(ag, force, ns, x0, v0)

    def _run_modal(
        self,
        ag: np.ndarray | None,
        force: np.ndarray | None,
        ns: int,
        x0: np.ndarray,
        v0: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
        z0 = self._vinv @ np.concatenate([x0, v0])
        fmod = self._no_force if force is None else np.ascontiguousarray(force @ self._b_force.T)
        a = np.zeros(ns) if ag is None else ag
        Z, diverged = _modal_recursion(
            a, fmod, self._e, self._c0, self._c1, self._g0, self._g1, z0
        )
        if diverged:
            nan = np.full((ns, self.outputs.size), np.nan)
            return nan, nan.copy(), nan.copy(), True
        disp, vel, acc = np.hsplit(Z @ self._W, 3)
        if force is not None:
            acc += force @ self._minv_out.T  # direct feed-through of the nodal forces
        return disp, vel, acc, diverged

    def _run_dense(
        self,
        ag: np.ndarray | None,
        force: np.ndarray | None,
        ns: int,
        x0: np.ndarray,
        v0: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
        n = self.n_dof
        loads = np.zeros((ns, n)) if force is None else force.copy()
        if ag is not None:
            loads -= np.outer(ag, self._p)
        Q0 = np.ascontiguousarray(loads @ self._G0.T)
        Q1 = np.ascontiguousarray(loads @ self._G1.T)
        X, diverged = _dense_recursion(self._phiT, Q0, Q1, np.concatenate([x0, v0]))
        no = self.outputs.size
        Y = X @ self._rows.T
        disp = np.ascontiguousarray(Y[:, :no])
        vel = np.ascontiguousarray(Y[:, no : 2 * no])
        acc = np.ascontiguousarray(Y[:, 2 * no :])
        if force is not None:
            acc += force @ self._minv_out.T
        if ag is not None:
            acc += np.outer(ag, self._ag_feed)
        return disp, vel, acc, diverged


def prepare_exact(
    system: System, dt: float, outputs: Sequence[int] | np.ndarray | None = None
) -> ExactSimulator:
    """Discretise a linear ``system`` exactly for inputs sampled every ``dt`` (first-order hold).

    Parameters
    ----------
    system : System
        Linear system (no friction elements).
    dt : float
        Sample interval (s).
    outputs : sequence of int, optional
        DOF indices to output (default: all).

    Returns
    -------
    ExactSimulator
        Call ``.run(ag, force, x0=..., v0=...)`` for each input.
    """
    return ExactSimulator(system, dt, outputs)

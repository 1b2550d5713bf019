"""Newmark's method for linear systems (average acceleration by default), with sub-steps.

In acceleration form with ``h = dt / substeps`` and the input linear between samples:

    predictor   ũ = u_n + h v_n + h²(½ - β) a_n,   ṽ = v_n + h(1 - γ) a_n
    solve       (M + γh C + βh² K) a_{n+1} = p_{n+1} - C ṽ - K ũ
    corrector   u_{n+1} = ũ + βh² a_{n+1},         v_{n+1} = ṽ + γh a_{n+1}

``S = (M + γhC + βh²K)⁻¹`` is applied once, at preparation, to give the fused update
``a_{n+1} = Au u_n + Av v_n + Aa a_n + S p_{n+1}``. ``β = 0`` (explicit) is allowed. With
``2β >= γ >= ½`` the method is unconditionally stable; otherwise the step must satisfy
``h ω_max < 1/√(γ/2 - β)`` and a larger one is refused.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.linalg as sla
from numba import njit

from femupdate.errors import ConfigError, SimulationError
from femupdate.model.system import System
from femupdate.simulate._common import (
    DIVERGENCE_LIMIT,
    Simulator,
    check_critical_step,
    omega_max,
    sample_loads,
)

GAMMA_RANGE = (0.5, 1.0)
BETA_RANGE = (0.0, 1.0)


def check_newmark_parameters(beta: float, gamma: float) -> tuple[float, float]:
    """Return ``(beta, gamma)`` as floats after checking the allowed ranges.

    ``γ`` in [0.5, 1] (below 0.5 the method amplifies; above, it damps numerically) and ``β`` in
    [0, 1]. Stability of the step is checked separately.
    """
    try:
        beta, gamma = float(beta), float(gamma)
    except (TypeError, ValueError):
        raise ConfigError(
            f"newmark_beta = {beta!r} and newmark_gamma = {gamma!r} must be numbers"
        ) from None
    if not GAMMA_RANGE[0] <= gamma <= GAMMA_RANGE[1]:
        raise ConfigError(
            f"newmark_gamma = {gamma!r} is not allowed; it must lie in [{GAMMA_RANGE[0]}, "
            f"{GAMMA_RANGE[1]}] (0.5 = no numerical damping; average acceleration is 0.5)"
        )
    if not BETA_RANGE[0] <= beta <= BETA_RANGE[1]:
        raise ConfigError(
            f"newmark_beta = {beta!r} is not allowed; it must lie in [{BETA_RANGE[0]}, "
            f"{BETA_RANGE[1]}] (average acceleration is 0.25; >= gamma/2 is unconditionally "
            "stable)"
        )
    return beta, gamma


def newmark_omega_crit(beta: float, gamma: float) -> float:
    """Largest stable ``h·ω`` of undamped Newmark: ``1/√(γ/2 - β)``, inf when ``2β >= γ``."""
    d = 0.5 * gamma - beta
    return np.inf if d <= 0.0 else 1.0 / np.sqrt(d)


@njit(cache=True)
def _newmark_kernel(AuT, AvT, AaT, q, substeps, h, beta, gamma, u0, v0, a0, out):
    """Newmark time stepping; returns displacement, velocity, relative acceleration at the
    output DOFs and the samples, and whether the solution diverged."""
    ns = q.shape[0]
    n = u0.shape[0]
    no = out.shape[0]
    disp = np.empty((ns, no))
    vel = np.empty((ns, no))
    acc = np.empty((ns, no))
    u = u0.copy()
    v = v0.copy()
    a = a0.copy()
    a_next = np.empty(n)
    cu = h * h * (0.5 - beta)
    cb = h * h * beta
    cv = h * (1.0 - gamma)
    cg = h * gamma
    for k in range(ns):
        s = 0.0
        for i in range(n):
            s += abs(u[i]) + abs(v[i])
        if not s < DIVERGENCE_LIMIT:  # NaN fails too
            return disp, vel, acc, True
        for o in range(no):
            d = out[o]
            disp[k, o] = u[d]
            vel[k, o] = v[d]
            acc[k, o] = a[d]
        if k == ns - 1:
            break
        for j in range(substeps):
            alpha = (j + 1) / substeps
            for i in range(n):
                a_next[i] = q[k, i] + alpha * (q[k + 1, i] - q[k, i])
            for c in range(n):
                uc = u[c]
                vc = v[c]
                ac = a[c]
                for i in range(n):
                    a_next[i] += AuT[c, i] * uc + AvT[c, i] * vc + AaT[c, i] * ac
            for i in range(n):
                u[i] += h * v[i] + cu * a[i] + cb * a_next[i]
                v[i] += cv * a[i] + cg * a_next[i]
            a, a_next = a_next, a
    return disp, vel, acc, False


class NewmarkSimulator(Simulator):
    """Newmark's method prepared for one linear system, sample interval, substeps, β and γ."""

    def __init__(
        self,
        system: System,
        dt: float,
        outputs: Sequence[int] | np.ndarray | None = None,
        substeps: int = 1,
        beta: float = 0.25,
        gamma: float = 0.5,
    ) -> None:
        super().__init__(system, dt, outputs, substeps)
        if not system.is_linear:
            raise SimulationError(
                "method 'newmark' is for linear systems; this system has "
                f"{system.nonlinear_elements()}: use method='nonlinear'"
            )
        self.beta, self.gamma = check_newmark_parameters(beta, gamma)
        n, h = self.n_dof, self.h
        w_crit = newmark_omega_crit(self.beta, self.gamma)
        self.omega_max: float | None = None  # only needed (and computed) when conditional
        if np.isfinite(w_crit):
            self.omega_max = omega_max(system.M, system.K)
            check_critical_step(self.dt, self.substeps, self.omega_max, w_crit, "newmark")
        M, C, K = system.M, system.C, system.K
        b, g = self.beta, self.gamma
        lu = sla.lu_factor(M + g * h * C + b * h * h * K, check_finite=False)
        solve = lambda x: sla.lu_solve(lu, x, check_finite=False)  # noqa: E731
        self._AuT = np.ascontiguousarray(solve(-K).T)
        self._AvT = np.ascontiguousarray(solve(-(C + h * K)).T)
        self._AaT = np.ascontiguousarray(solve(-(h * (1 - g) * C + h * h * (0.5 - b) * K)).T)
        self._g = solve(-system.seismic_load)
        self._S = solve(np.eye(n))

    def _integrate(
        self, ag: np.ndarray | None, force: np.ndarray | None, ns: int, x0: np.ndarray,
        v0: np.ndarray,
    ) -> tuple:
        q = sample_loads(ag, force, self._g, self._S)
        a0 = self._initial_acceleration(ag, force, x0, v0)
        disp, vel, acc, diverged = _newmark_kernel(
            self._AuT,
            self._AvT,
            self._AaT,
            q,
            self.substeps,
            self.h,
            self.beta,
            self.gamma,
            x0,
            v0,
            a0,
            self.outputs,
        )
        return disp, vel, acc, diverged


def prepare_newmark(
    system: System,
    dt: float,
    outputs: Sequence[int] | np.ndarray | None = None,
    substeps: int = 1,
    beta: float = 0.25,
    gamma: float = 0.5,
) -> NewmarkSimulator:
    """Prepare Newmark's method for a linear ``system`` at ``h = dt / substeps``.

    Parameters
    ----------
    system : System
        Linear system.
    dt : float
        Sample interval of the inputs and outputs (s).
    outputs : sequence of int, optional
        DOF indices to output (default: all).
    substeps : int
        Integration steps per sample interval; the input is interpolated linearly.
    beta, gamma : float
        Newmark parameters; the default (¼, ½) is the average-acceleration rule.

    Raises
    ------
    ConfigError
        For β or γ out of range.
    SimulationError
        For friction systems, or a conditionally stable (2β < γ) scheme at too large a step.
    """
    return NewmarkSimulator(system, dt, outputs, substeps, beta, gamma)

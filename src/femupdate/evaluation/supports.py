"""φ(x) of a multi-support case (``[[model.support_groups]]``) in compiled code.

A linear model driven by several support records responds with the sum of its responses to
each record. With the pseudo-static split of :mod:`femupdate.simulate.multisupport`
(``u = R d + y``, ``R = −K_ff⁻¹ K_fs E``) the dynamic part ``y`` solves

    M ÿ + C ẏ + K y = −P a(t) − Q v(t),   P = M R + M_fs E,   Q = C R + C_fs E,

a system with 2g inputs (the g groups' accelerations and velocities), each a column of ``P``
or ``Q`` times one record. Each input runs through the exact modal filters of the uniform
case (:func:`femupdate.evaluation.exact.prepare_modal` with that column as the load), and the
outputs add up; the pseudo-static part adds ``R a`` to the accelerations (``R d`` to the
displacements), less the share of a group a channel is recorded relative to
(``relative_to``).

The coupling blocks ``K_fs``, ``M_fs``, ``C_fs`` come from a compiled assembly of the
*released* structure: the case's model with the groups' support DOFs free and a unit mass on
each of them, so that its mass matrix is positive definite. That mass sits on the diagonal of
the support DOFs only: the free block and the free-support blocks are those of
:meth:`femupdate.model.structure.Structure.support_coupling`, which releases the same DOFs.

The step-by-step path (``CaseModel.support_response``) stays the reference: a point whose
assembly or eigenvectors the compiled path leaves (a value out of range, an ill-conditioned
eigenvector matrix, a singular stiffness) is evaluated by it, as are Newmark and central
differences, and a zero-phase filter of the prediction.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any, Protocol

import numpy as np
from numba import njit

from femupdate.evaluation import exact
from femupdate.evaluation.assembly import ASSEMBLY_OK, AssemblyPlan, assemble, plan_assembly
from femupdate.evaluation.evaluator import DONE, REFERENCE, UpdateProblem, _post, scaled_residuals
from femupdate.evaluation.processing import process_and_compare
from femupdate.simulate._common import DIVERGENCE_LIMIT

__all__ = ["SupportEvaluator", "support_outputs"]

#: Status of :func:`support_outputs` besides ``DONE`` and ``REFERENCE``.
DIVERGED = 2


class SupportProblem(UpdateProblem, Protocol):
    """What :class:`SupportEvaluator` reads besides an ``UpdateProblem``'s: the case's model
    (``CaseModel``: its DOF labels, and which channels are recorded relative to a group) and
    the released structure with its released DOFs
    (``released()``: :func:`femupdate.problem.released.released_structure`)."""

    model: Any
    released: Callable[[], tuple[Any, list[tuple[str, str]]]]


@njit(cache=True)
def _blocks(Mt: np.ndarray, Ct: np.ndarray, Kt: np.ndarray, free: np.ndarray,
            sup: np.ndarray, e: np.ndarray, M: np.ndarray, C: np.ndarray, K: np.ndarray,
            mfs: np.ndarray, cfs: np.ndarray, kfs: np.ndarray) -> None:
    """The free blocks of the released matrices into M, C, K, and ``M_fs E`` (n × g) etc."""
    n = free.shape[0]
    for i in range(n):
        for j in range(n):
            M[i, j] = Mt[free[i], free[j]]
            C[i, j] = Ct[free[i], free[j]]
            K[i, j] = Kt[free[i], free[j]]
    mfs[:, :] = 0.0
    cfs[:, :] = 0.0
    kfs[:, :] = 0.0
    for s in range(sup.shape[0]):
        for g in range(e.shape[1]):
            if e[s, g] != 0.0:
                for i in range(n):
                    mfs[i, g] += e[s, g] * Mt[free[i], sup[s]]
                    cfs[i, g] += e[s, g] * Ct[free[i], sup[s]]
                    kfs[i, g] += e[s, g] * Kt[free[i], sup[s]]


@njit(cache=True, nogil=True)  # threads of a process share a batch (runs.executors)
def support_outputs(x: np.ndarray, plan: AssemblyPlan, p: np.ndarray, Mt: np.ndarray,
                    minv_t: np.ndarray, Ct: np.ndarray, Kt: np.ndarray, load_t: np.ndarray,
                    kr: np.ndarray, fu: np.ndarray, free: np.ndarray, sup: np.ndarray,
                    e: np.ndarray, records: np.ndarray, disp: np.ndarray, shift: np.ndarray,
                    outputs: np.ndarray, dt: float, displacement: bool,
                    work: exact.ExactWork, y: np.ndarray) -> int:
    """The outputs at search point ``x`` into ``y`` (n_out, n_samples): absolute
    accelerations (or displacements with ``displacement``) less ``shift`` (n_out × g) times
    the groups' records (accelerations, or displacements ``disp`` (g, n_samples)).

    ``records`` (2g, n_samples) holds the groups' accelerations, then their velocities.
    Returns ``DONE``, ``REFERENCE`` (not evaluated here) or ``DIVERGED``.
    """
    if assemble(plan, x, p, Mt, minv_t, Ct, Kt, load_t, kr, fu) != ASSEMBLY_OK:
        return REFERENCE
    n = free.shape[0]
    g = e.shape[1]
    M = np.empty((n, n))
    C = np.empty((n, n))
    K = np.empty((n, n))
    mfs = np.empty((n, g))
    cfs = np.empty((n, g))
    kfs = np.empty((n, g))
    _blocks(Mt, Ct, Kt, free, sup, e, M, C, K, mfs, cfs, kfs)
    try:
        R = -np.linalg.solve(K, kfs)
        minv = np.linalg.inv(M)
    except Exception:  # singular: the step-by-step path says so
        return REFERENCE
    P = M @ R + mfs
    Q = C @ R + cfs
    n_out = outputs.shape[0]
    loads = np.empty((n, 2 * g))  # the inputs' loads: P then Q
    direct = np.zeros((n_out, 2 * g))  # the pseudo-static R a, less a group recorded relative to
    for col in range(g):
        for i in range(n):
            loads[i, col] = P[i, col]
            loads[i, g + col] = Q[i, col]
        if not displacement:
            for o in range(n_out):
                direct[o, col] = R[outputs[o], col] - shift[o, col]
    code = _modal_inputs(M, minv, K, C, loads, direct, outputs, dt, displacement, records,
                         work, y)
    if code != DONE:
        return code
    if displacement:  # the pseudo-static R d, less a group recorded relative to
        for o in range(n_out):
            for col in range(g):
                w = R[outputs[o], col] - shift[o, col]
                for k in range(y.shape[1]):
                    y[o, k] += w * disp[col, k]
    return DONE


@njit(cache=True)
def _modal_inputs(M: np.ndarray, minv: np.ndarray, K: np.ndarray, C: np.ndarray,
                  loads: np.ndarray, direct: np.ndarray, outputs: np.ndarray, dt: float,
                  displacement: bool, records: np.ndarray, work: exact.ExactWork,
                  y: np.ndarray) -> int:
    """The exact modal filters of ``M ÿ + C ẏ + K y = −Σ_c loads[:, c] records[c](t)`` over
    every input at once; outputs (accelerations, plus ``direct`` times the inputs, or
    displacements) into ``y``. One eigendecomposition (that of the uniform path,
    :func:`~femupdate.evaluation.exact.prepare_modal`, which also checks its conditioning),
    then each mode's input is the sum of the records weighted by their participations."""
    quantity = exact.DISPLACEMENT if displacement else exact.ABSOLUTE_ACCELERATION
    n = M.shape[0]
    n_in = loads.shape[1]
    n_out = outputs.shape[0]
    code, _ = exact.prepare_modal(M, minv, K, C, loads[:, 0].copy(), np.zeros(n_out), outputs,
                                  dt, quantity, work)
    if code != exact.MODAL_OK:
        return REFERENCE
    try:
        vinv = np.linalg.inv(work.vr)
    except Exception:
        return REFERENCE
    b = -(minv @ loads)  # (n, n_in): the inputs' directions in the velocity half of the state
    feed = np.zeros((n_out, n_in))  # the inputs' direct terms: M⁻¹ force and R a
    if not displacement:
        for o in range(n_out):
            for c in range(n_in):
                feed[o, c] = direct[o, c] + b[outputs[o], c]
    size = 2 * n
    beta = np.zeros((size, n_in), dtype=np.complex128)
    e = np.zeros(size, dtype=np.complex128)
    g0 = np.zeros(size, dtype=np.complex128)
    g1 = np.zeros(size, dtype=np.complex128)
    m = 0
    j = 0
    while j < size:  # the modes in prepare_modal's order (its output weights wr, wi)
        pair = work.eig_im[j] > 0.0
        for c in range(n_in):
            s = 0j
            for q in range(n):
                if pair:
                    row = 0.5 * complex(vinv[j, n + q], -vinv[j + 1, n + q])
                else:
                    row = complex(vinv[j, n + q], 0.0)
                s += row * b[q, c]
            beta[m, c] = s
        e[m], g0[m], g1[m] = exact._foh(complex(work.eig_re[j], work.eig_im[j]), dt)
        m += 1
        j += 2 if pair else 1
    # each mode's input, u_i(t) = Σ_c β_ic s_c(t), sample-major for the recursion
    ur = np.ascontiguousarray((np.ascontiguousarray(beta[:m].real) @ records).T)  # (ns, m)
    ui = np.ascontiguousarray((np.ascontiguousarray(beta[:m].imag) @ records).T)
    diverged = _recursion(e[:m], g0[:m], g1[:m], ur, ui)  # the modes' histories, in place
    y[:, :] = (ur @ np.ascontiguousarray(work.wr[:, :m].T)).T
    y -= (ui @ np.ascontiguousarray(work.wi[:, :m].T)).T
    y += feed @ records
    return DIVERGED if diverged else DONE


@njit(cache=True, fastmath={"contract", "reassoc"})
def _recursion(e: np.ndarray, g0: np.ndarray, g1: np.ndarray, ur: np.ndarray,
               ui: np.ndarray) -> bool:
    """``z_{k+1} = e z_k + g0 u_k + g1 u_{k+1}`` from rest for every mode, the inputs
    ``u = ur + i ui`` (n_samples, m) overwritten by the states ``z`` (the modes side by side
    in the inner loop: independent, vectorised). Returns whether the final state is beyond
    ``DIVERGENCE_LIMIT`` or not finite (the recursion is linear: an overflow persists)."""
    m = e.shape[0]
    er, ei = e.real.copy(), e.imag.copy()
    ar, ai = g0.real.copy(), g0.imag.copy()
    br, bi = g1.real.copy(), g1.imag.copy()
    xr = np.zeros(m)
    xi = np.zeros(m)
    pr = ur[0].copy()  # u_k of the step
    pi = ui[0].copy()
    ur[0, :] = 0.0
    ui[0, :] = 0.0
    for k in range(1, ur.shape[0]):
        for i in range(m):
            u1r = ur[k, i]
            u1i = ui[k, i]
            nr = er[i] * xr[i] - ei[i] * xi[i] + ar[i] * pr[i] - ai[i] * pi[i] \
                + br[i] * u1r - bi[i] * u1i
            ni = er[i] * xi[i] + ei[i] * xr[i] + ar[i] * pi[i] + ai[i] * pr[i] \
                + br[i] * u1i + bi[i] * u1r
            xr[i] = nr
            xi[i] = ni
            pr[i] = u1r
            pi[i] = u1i
            ur[k, i] = nr
            ui[k, i] = ni
    s = 0.0
    for i in range(m):
        s += abs(xr[i]) + abs(xi[i])
    return not s < DIVERGENCE_LIMIT


class SupportEvaluator:
    """φ of a multi-support trial, compiled (see the module docstring), with the interface of
    :class:`femupdate.evaluation.Evaluator` that :class:`~femupdate.problem.update.TrialProblem`
    and :mod:`femupdate.evaluation.shared` use. Not thread-safe; each thread builds its own.

    Parameters
    ----------
    problem : SupportProblem
        A trial of a case with ``[[model.support_groups]]``
        (:class:`~femupdate.problem.update.TrialProblem`).
    """

    def __init__(self, problem: SupportProblem) -> None:
        from femupdate.simulate.multisupport import integrate_record

        case = problem.case
        exp = problem.experiment
        model = problem.model
        self._reference: Callable[[np.ndarray], float] = problem.phi_reference
        twin, supports = problem.released()
        self.plan = plan_assembly(twin, case.parameter_names,
                                  [p.scale == "log" for p in case.parameters],
                                  problem.direction, case.nominal())
        index = {label: i for i, label in enumerate(twin.dof_labels)}
        self.free = np.array([index[label] for label in model.structure.dof_labels],
                             dtype=np.int64)
        self.sup = np.array([index[f"{node}.{dof}"] for node, dof in supports], dtype=np.int64)
        groups = [[f"{node}.{case.model.group_dof(g)}" for node in g.nodes]
                  for g in case.model.support_groups]
        labels = [f"{node}.{dof}" for node, dof in supports]
        self.e = np.zeros((len(supports), len(groups)))
        for col, members in enumerate(groups):
            for label in members:
                self.e[labels.index(label), col] = 1.0
        self.dt = float(exp.dt)
        ag = np.asarray(problem._ag, dtype=float)
        velocity, disp = integrate_record(ag, self.dt, "exact")  # as support_response
        self.records = np.ascontiguousarray(np.vstack([ag.T, velocity.T]))
        self.disp = np.ascontiguousarray(disp.T)
        self.shift = np.ascontiguousarray(model.reference, dtype=float)
        self.outputs = np.ascontiguousarray(problem.outputs, dtype=np.int64)
        self.displacement = bool(not problem.integrate and exp.quantity == "displacement")
        n_t, n_out, ns = self.plan.n, self.outputs.size, ag.shape[0]
        n_params = len(case.parameter_names)
        self._mats = (np.empty(n_params), np.empty((n_t, n_t)), np.empty((n_t, n_t)),
                      np.empty((n_t, n_t)), np.empty((n_t, n_t)), np.empty(n_t),
                      np.empty(0), np.empty(0))
        self.work = exact.exact_work(self.free.size, n_out)
        self.y = np.empty((n_out, ns))
        self.per_channel = np.empty(n_out)
        pre = case.preprocess
        sos = np.zeros((0, 6))
        if problem.filter:
            from femupdate.data import signal

            sos = signal.band_sos(1.0 / self.dt, float(pre.highpass_hz), pre.highpass_order,
                                  pre.lowpass_hz, pre.lowpass_order)
        self.zero_phase = bool(problem.filter and pre.zero_phase)
        self.supported = problem.method == "exact" and not self.zero_phase
        self.zi = np.empty(2 * sos.shape[0])
        self.post = _post(problem.objective, sos, problem.integrate, self.dt, exp.score, ns)

    # -- evaluation ------------------------------------------------------------------------

    def _simulate(self, x: np.ndarray) -> int:
        """The raw outputs at ``x`` into ``self.y``: DONE, REFERENCE or DIVERGED."""
        if not self.supported:
            return REFERENCE
        p, Mt, minv_t, Ct, Kt, load_t, kr, fu = self._mats
        return support_outputs(np.ascontiguousarray(x, dtype=float), self.plan, p, Mt, minv_t,
                               Ct, Kt, load_t, kr, fu, self.free, self.sup, self.e,
                               self.records, self.disp, self.shift, self.outputs, self.dt,
                               self.displacement, self.work, self.y)

    def __call__(self, x: np.ndarray) -> float:
        """φ(x), as ``TrialProblem.phi_reference`` to rounding."""
        status = self._simulate(x)
        if status == REFERENCE:
            return self._reference(np.asarray(x, dtype=float).copy())
        if status == DIVERGED:
            return np.inf
        return float(process_and_compare(self.post, self.y, self.per_channel, self.zi))

    def batch(self, X: np.ndarray) -> np.ndarray:
        """φ of every row of ``X`` (k, n_params), each its single call's."""
        X = np.ascontiguousarray(X, dtype=float)
        if X.ndim != 2:
            raise ValueError(f"X must have shape (k, n_params), got {X.shape}")
        return np.array([self(x) for x in X])

    def residuals(self, x: np.ndarray) -> np.ndarray | None:
        """The residual vector r(x) (φ = ‖r‖² to rounding), or None where the compiled path
        does not reach or the evaluation failed (the caller's step-by-step path then says
        why)."""
        if self._simulate(x) != DONE:
            return None
        phi = process_and_compare(self.post, self.y, self.per_channel, self.zi)
        return scaled_residuals(self.post, self.y) if np.isfinite(phi) else None

    def residuals_batch(self, X: np.ndarray) -> Iterator[np.ndarray | None]:
        """:meth:`residuals` of every row of ``X``, one after another."""
        for x in np.ascontiguousarray(X, dtype=float):
            yield self.residuals(x)

    def simulated(self, x: np.ndarray) -> tuple[np.ndarray | None, float]:
        """The raw outputs at ``x`` (this evaluator's buffer, overwritten by the next call):
        ``(y, nan)``; ``(None, inf)`` for a failed evaluation, ``(None, nan)`` where the
        compiled path does not reach."""
        status = self._simulate(x)
        if status == REFERENCE:
            return None, np.nan
        if status == DIVERGED:
            return None, np.inf
        return self.y, np.nan

    def simulated_rows(self, X: np.ndarray) -> Iterator[tuple[np.ndarray | None, float]]:
        """:meth:`simulated` of every row of ``X``, one after another."""
        for x in np.ascontiguousarray(X, dtype=float):
            yield self.simulated(x)

    def compare_with(self, y: np.ndarray, residuals: bool = False
                     ) -> float | np.ndarray | None:
        """φ of outputs from :meth:`simulated` (a trial's of the same records), as this
        evaluator compares them; with ``residuals`` its residual vector (None if φ is not
        finite). ``y`` is copied, not changed."""
        np.copyto(self.y, y)
        phi = float(process_and_compare(self.post, self.y, self.per_channel, self.zi))
        if not residuals:
            return phi
        return scaled_residuals(self.post, self.y) if np.isfinite(phi) else None

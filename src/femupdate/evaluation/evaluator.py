"""φ(x) of an update problem in one compiled call, with preallocated buffers: :class:`Evaluator`.

One evaluation is: search point → physical values → M, C, K (:mod:`.assembly`) → the
integrator's preparation (:mod:`.exact`, :mod:`.central`; LAPACK from :mod:`.lapack`) → its time
loop, the raw outputs into a preallocated buffer (or a kernel written out for the size,
:mod:`.codegen`) → the prediction's processing and the comparison, φ
(:func:`.processing.process_and_compare`). A batch of k points is one compiled loop over them
(:meth:`Evaluator.batch`, which releases the GIL: threads, each with its own evaluator, can
share a batch); a single point is a batch of one, so the two give the same bits.

What the compiled path does not cover is evaluated by the reference (``UpdateProblem``'s
simulator path), point by point: Newmark, a damping matrix the undamped
modes do not diagonalise under central differences, an ill-conditioned eigenvector matrix in the
exact discretisation (the simulator's dense fallback), parameter values out of range or a mass
matrix that is not positive definite (the reference raises the ModelError that says which element).
Models with Bouc–Wen elements run their own batch (:mod:`.hysteresis`): the generic
central-difference kernels (modal, or physical for non-proportional damping) with the elements'
hysteresis, no written-out kernel or SIMD lanes.
A zero-phase high-pass of the prediction is applied by scipy between the compiled simulation
and the compiled comparison.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numba import njit

from femupdate.data import signal
from femupdate.evaluation import central, exact
from femupdate.evaluation.assembly import ASSEMBLY_OK, AssemblyPlan, assemble, plan_assembly
from femupdate.evaluation.lanes import LANES, LaneWork, lane_work
from femupdate.evaluation.processing import Post, process_and_compare


class UpdateProblem(Protocol):
    """What the evaluator reads of a trial's problem
    (:class:`femupdate.problem.update.TrialProblem`):
    the case, the experiment, the structure and integrator, the processing flags, the error
    function, and its reference path for the points the compiled one leaves."""

    case: Any
    experiment: Any
    structure: Any
    method: str
    direction: str
    substeps: int
    outputs: np.ndarray
    integrate: bool
    filter: bool
    objective: Any
    _r_out: np.ndarray
    _ag: np.ndarray
    derived_fields: tuple[str, ...]

    def phi_reference(self, x: np.ndarray) -> float: ...

    def compiled_rows(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...

__all__ = ["Evaluator", "Matrices", "evaluator_for"]

#: Status per evaluated point (besides a value of φ).
DONE = 0
REFERENCE = 1  # evaluate this point with the reference path

_QUANTITIES = {"relative_acceleration": exact.RELATIVE_ACCELERATION,
               "displacement": exact.DISPLACEMENT,
               "absolute_acceleration": exact.ABSOLUTE_ACCELERATION}


@dataclass(frozen=True)
class Matrices:
    """Buffers of the assembled system (written at every evaluation)."""

    p: np.ndarray
    M: np.ndarray
    minv: np.ndarray
    C: np.ndarray
    K: np.ndarray
    load: np.ndarray
    kr: np.ndarray
    fu: np.ndarray

    @classmethod
    def empty(cls, n_params: int, n: int, n_friction: int) -> Matrices:
        return cls(np.empty(n_params), np.empty((n, n)), np.empty((n, n)), np.empty((n, n)),
                   np.empty((n, n)), np.empty(n), np.empty(n_friction), np.empty(n_friction))


# ------------------------------------------------------------------------ compiled batches


#: What :func:`exact_setup` and :func:`central_setup` leave to do: run the prepared kernel.
RUN = 2


@njit(cache=True)
def exact_setup(x: np.ndarray, plan: AssemblyPlan, p: np.ndarray, M: np.ndarray,
                minv: np.ndarray, C: np.ndarray, K: np.ndarray, load: np.ndarray,
                kr: np.ndarray, fu: np.ndarray, r_out: np.ndarray, outputs: np.ndarray,
                dt: float, quantity: int, work: exact.ExactWork) -> tuple[int, int]:
    """Assembly and modal preparation of one point: (status, modes to run).

    Status ``RUN``: the filters are prepared in ``work``; ``REFERENCE``: not compiled.
    """
    if assemble(plan, x, p, M, minv, C, K, load, kr, fu) != ASSEMBLY_OK:
        return REFERENCE, 0
    code, m = exact.prepare_modal(M, minv, K, C, load, r_out, outputs, dt, quantity, work)
    if code != exact.MODAL_OK:
        return REFERENCE, 0
    return RUN, m


@njit(cache=True)
def compare(diverged: bool, raw: bool, post: Post, y: np.ndarray, per_channel: np.ndarray,
            zi: np.ndarray) -> float:
    """φ after a simulation: inf if it diverged, NaN for ``raw`` (outputs left in y)."""
    if diverged:
        return np.inf
    if raw:
        return np.nan
    return process_and_compare(post, y, per_channel, zi)


@njit(cache=True, nogil=True)
def _exact_batch(X: np.ndarray, plan: AssemblyPlan, p: np.ndarray, M: np.ndarray,
                 minv: np.ndarray, C: np.ndarray, K: np.ndarray, load: np.ndarray,
                 kr: np.ndarray, fu: np.ndarray, ag: np.ndarray, r_out: np.ndarray,
                 outputs: np.ndarray, dt: float, quantity: int, work: exact.ExactWork,
                 post: Post, y: np.ndarray, per_channel: np.ndarray, zi: np.ndarray,
                 raw: bool, phi: np.ndarray, status: np.ndarray) -> None:
    """φ of every row of X with the exact discretisation (status REFERENCE: not done here;
    ``raw``: stop at the outputs, left in ``y`` for one row, φ NaN)."""
    for row in range(X.shape[0]):
        phi[row] = np.nan
        status[row], m = exact_setup(X[row], plan, p, M, minv, C, K, load, kr, fu, r_out,
                                     outputs, dt, quantity, work)
        if status[row] == RUN:
            phi[row] = compare(exact.run_modal(ag, m, work, y), raw, post, y, per_channel, zi)
            status[row] = DONE


@njit(cache=True)
def central_setup(x: np.ndarray, plan: AssemblyPlan, p: np.ndarray, M: np.ndarray,
                  minv: np.ndarray, C: np.ndarray, K: np.ndarray, load: np.ndarray,
                  kr: np.ndarray, fu: np.ndarray, fi: np.ndarray, fj: np.ndarray,
                  ag: np.ndarray, outputs: np.ndarray, h: float,
                  work: central.CentralWork) -> tuple[float, int, int]:
    """Assembly and preparation of one point for central differences: (φ, status, active).

    Status ``RUN``: the recurrence is prepared in ``work`` (``active`` elements carry force);
    ``DONE``: φ is known already (inf: an unstable step); ``REFERENCE``: not compiled.
    """
    if assemble(plan, x, p, M, minv, C, K, load, kr, fu) != ASSEMBLY_OK:
        return np.nan, REFERENCE, 0
    code, active = central.prepare_central(M, K, C, load, minv, kr, fu, fi, fj, outputs, h,
                                           ag[0], work)
    if code == central.NOT_DIAGONAL:
        return np.nan, REFERENCE, 0
    if code == central.UNSTABLE:
        return np.inf, DONE, 0  # the simulator refuses the step: a failed evaluation
    return np.nan, RUN, active


@njit(cache=True, nogil=True)
def _central_batch(X: np.ndarray, plan: AssemblyPlan, p: np.ndarray, M: np.ndarray,
                   minv: np.ndarray, C: np.ndarray, K: np.ndarray, load: np.ndarray,
                   kr: np.ndarray, fu: np.ndarray, fi: np.ndarray, fj: np.ndarray,
                   ag: np.ndarray, r_out: np.ndarray, outputs: np.ndarray, h: float,
                   substeps: int, quantity: int, work: central.CentralWork, post: Post,
                   y: np.ndarray, per_channel: np.ndarray, zi: np.ndarray, raw: bool,
                   phi: np.ndarray, status: np.ndarray) -> None:
    """φ of every row of X with central differences (status REFERENCE: not done here)."""
    for row in range(X.shape[0]):
        phi[row], status[row], active = central_setup(X[row], plan, p, M, minv, C, K, load,
                                                      kr, fu, fi, fj, ag, outputs, h, work)
        if status[row] == RUN:
            diverged = central.run_central(ag, substeps, h, quantity, r_out, active, work, y)
            phi[row] = compare(diverged, raw, post, y, per_channel, zi)
            status[row] = DONE


# ------------------------------------------------------------------------ the evaluator


class Evaluator:
    """φ of an :class:`~femupdate.problem.update.UpdateProblem`, compiled, with its own buffers.

    Build it with :func:`evaluator_for`; call it like the problem (``ev(x)``) or on a batch
    (``ev.batch(X)``). Not thread-safe (the buffers are shared by the calls); each process
    builds its own.

    Parameters
    ----------
    problem : UpdateProblem
        The problem; its reference path evaluates the points the compiled path leaves.
    """

    def __init__(self, problem: UpdateProblem) -> None:
        case = problem.case
        exp = problem.experiment
        structure = problem.structure
        # Fields that are expressions of parameters: their values follow the search point's
        # (problem.compiled_rows appends them; the reference path takes the point alone).
        derived = tuple(problem.derived_fields)
        n_search = len(case.parameters)
        self._reference: Callable[[np.ndarray], float] = (
            (lambda x: problem.phi_reference(x[:n_search])) if derived
            else problem.phi_reference)
        self.method = problem.method
        names = (*case.parameter_names, *derived)
        self.plan = plan_assembly(structure, names, [p.scale == "log" for p in case.parameters]
                                  + [False] * len(derived), problem.direction, case.nominal())
        n = self.plan.n
        nominal_system = structure.assemble(case.nominal(), problem.direction)
        fr = nominal_system.friction
        self.n_friction = 0 if fr is None else fr.count
        self.fi = (np.zeros(0, dtype=np.int64) if fr is None
                   else np.ascontiguousarray(fr.dof_i, dtype=np.int64))
        self.fj = (np.zeros(0, dtype=np.int64) if fr is None
                   else np.ascontiguousarray(fr.dof_j, dtype=np.int64))
        self.mats = Matrices.empty(len(names), n, self.n_friction)
        self.outputs = np.ascontiguousarray(problem.outputs, dtype=np.int64)
        self.r_out = np.ascontiguousarray(problem._r_out, dtype=float)
        self.ag = np.ascontiguousarray(problem._ag, dtype=float)
        self.dt = float(exp.dt)
        self.substeps = int(problem.substeps)
        if problem.integrate:
            what = "relative_acceleration"
        elif exp.quantity == "displacement":
            what = "displacement"
        else:
            what = "absolute_acceleration"
        self.quantity = _QUANTITIES[what]
        pre = case.preprocess
        sos = np.zeros((0, 6))
        if problem.filter:
            sos = signal.band_sos(float(1.0 / exp.dt), float(pre.highpass_hz),
                                  pre.highpass_order, pre.lowpass_hz, pre.lowpass_order)
        self._sos = np.ascontiguousarray(sos, dtype=float)
        # A zero-phase filter needs the whole record: scipy filters between the simulation
        # and the comparison, which then has no filter of its own.
        self.zero_phase = bool(problem.filter and pre.zero_phase)
        self.post = _post(problem.objective, self._sos[:0] if self.zero_phase else self._sos,
                          problem.integrate, self.dt, exp.score, self.ag.size)
        self.supported = self.method in ("exact", "nonlinear", "central_difference")
        self.bouc_wen: Any = None  # (BoucWenPlan, PhysicalWork) of a Bouc–Wen model
        n_out = self.outputs.size
        self._central_batch: Callable[..., None] = _central_batch
        self._exact_batch: Callable[..., None] = _exact_batch
        self._written: Any = None  # the written-out kernel's module (codegen), if used
        self.lanes: LaneWork | None = None  # the friction kernel's SIMD lanes, if written
        self._written_modes = -1
        if self.method == "exact":
            self.work: Any = exact.exact_work(n, n_out)
            self._write_exact_kernel(case.nominal(), problem)
        else:
            self.work = central.central_work(n, self.n_friction, n_out)
            if nominal_system.n_bouc_wen:  # the generic kernels with the hysteresis
                from femupdate.evaluation import hysteresis

                self.bouc_wen = (hysteresis.bouc_wen_plan(structure, names),
                                 hysteresis.physical_work(n, self.n_friction,
                                                          nominal_system.n_bouc_wen))
                self._central_batch = hysteresis.bouc_wen_batch
            elif self.n_friction and self.supported:
                from femupdate.evaluation.codegen import friction_kernel

                written = friction_kernel(n, self.n_friction, n_out, self.substeps)
                if written is not None:
                    self._central_batch = written.batch
                    self._written = written
                    self.lanes = lane_work(n, self.n_friction, n_out, self.ag.size)
        self.y = np.empty((n_out, self.ag.size))
        self.per_channel = np.empty(n_out)
        self.zi = np.empty(2 * self._sos.shape[0])
        self._bind()

    def _write_exact_kernel(self, nominal: dict[str, float], problem: UpdateProblem) -> None:
        """Use the written-out modal filters when the nominal model has few modes."""
        if not self.supported:
            return
        from femupdate.evaluation.codegen import MAX_EXACT_MODES, exact_kernel

        m = self.mats
        x = problem.compiled_rows(problem.case.to_search(nominal))[0][0]
        status, modes = exact_setup(x, self.plan, m.p, m.M, m.minv, m.C, m.K, m.load, m.kr,
                                    m.fu, self.r_out, self.outputs, self.dt, self.quantity,
                                    self.work)
        if status == RUN and modes < MAX_EXACT_MODES:
            written = exact_kernel(modes, self.outputs.size)
            if written is not None:
                self._exact_batch = written.batch
                self._written, self._written_modes = written, modes

    def _bind(self) -> None:
        """The batch kernel's arguments that never change, and buffers of a single call."""
        m = self.mats
        head = (self.plan, m.p, m.M, m.minv, m.C, m.K, m.load, m.kr, m.fu)
        tail = (self.work, self.post, self.y, self.per_channel, self.zi)
        if self.method == "exact":
            self._batch = self._exact_batch
            self._static = (*head, self.ag, self.r_out, self.outputs, self.dt, self.quantity,
                            *tail)
        else:
            self._batch = self._central_batch
            self._static = (*head, self.fi, self.fj, self.ag, self.r_out, self.outputs,
                            self.dt / self.substeps, self.substeps, self.quantity, *tail)
            if self.lanes is not None:  # the written batch runs rows in SIMD lanes
                self._static += (self.lanes,)
            if self.bouc_wen is not None:
                self._static += self.bouc_wen
        self._entry: dict[bool, Callable[..., None]] = {}
        self._single = (np.empty((1, self.plan.log_scale.size)), np.empty(1),
                        np.empty(1, dtype=np.int64))

    # -- evaluation ------------------------------------------------------------------------

    def __call__(self, x: np.ndarray) -> float:
        """φ(x), as ``UpdateProblem.phi_reference`` (to rounding: see the module docstring)."""
        if not self.supported or self.zero_phase:
            return float(self.batch(np.asarray(x, dtype=float)[None, :])[0])
        one, phi, status = self._single
        one[0] = x
        self._run(one, False, phi, status)
        if status[0] == REFERENCE:
            return self._reference(one[0].copy())
        return float(phi[0])

    def batch(self, X: np.ndarray) -> np.ndarray:
        """φ of every row of ``X`` (k, n_params) in one compiled loop; the same values, bit
        for bit, as k single calls."""
        X = np.ascontiguousarray(X, dtype=float)
        if X.ndim != 2:
            raise ValueError(f"X must have shape (k, n_params), got {X.shape}")
        phi = np.empty(X.shape[0])
        status = np.full(X.shape[0], REFERENCE, dtype=np.int64)
        if self.supported and self.zero_phase:
            for row in range(X.shape[0]):
                phi[row], status[row] = self._zero_phase(X[row])
        elif self.supported:
            self._run(X, False, phi, status)
        for row in np.flatnonzero(status == REFERENCE):
            phi[row] = self._reference(X[row])
        return phi

    def residuals(self, x: np.ndarray) -> np.ndarray | None:
        """The residual vector r(x), as ``ErrorFunction.residuals`` orders and scales it
        (φ = ‖r‖² to rounding), from the compiled simulation and processing; None where the
        compiled path does not reach (a zero-phase filter, an assembly or a simulation it
        leaves to the reference, a failed evaluation): the caller's step-by-step path then
        gives them, and says why a failure failed."""
        if not self.supported or self.zero_phase:
            return None
        one, phi, status = self._single
        one[0] = x
        self._run(one, False, phi, status)
        if status[0] == REFERENCE or not np.isfinite(phi[0]):
            return None
        return scaled_residuals(self.post, self.y)

    def residuals_batch(self, X: np.ndarray) -> Iterator[np.ndarray | None]:
        """:meth:`residuals` of every row of ``X`` (k, n_params), each bit for bit its single
        call, one after another as the caller takes them (so that they can be written where
        they go, with no list of k vectors held); with the friction kernel in SIMD lanes,
        ``LANES`` rows per compiled call (each lane's differences read out before the next
        group overwrites them)."""
        X = np.ascontiguousarray(X, dtype=float)
        lanes = self.lanes
        if lanes is None or not self.supported or self.zero_phase:
            for x in X:
                yield self.residuals(x)
            return
        for start in range(0, X.shape[0], LANES):
            group = X[start:start + LANES]
            if group.shape[0] == 1:
                yield self.residuals(group[0])
                continue
            phi = np.empty(group.shape[0])
            status = np.full(group.shape[0], REFERENCE, dtype=np.int64)
            self._run(group, False, phi, status)
            lane_of = {int(row): q for q, row in enumerate(lanes.rows) if row >= 0}
            for i in range(group.shape[0]):
                ok = status[i] == DONE and np.isfinite(phi[i]) and i in lane_of
                yield scaled_residuals(self.post, lanes.y[lane_of[i]]) if ok else None

    def simulated(self, x: np.ndarray) -> tuple[np.ndarray | None, float]:
        """The outputs at ``x`` as the comparison takes them, before it: ``(y, nan)``, with
        ``y`` (n_channels, n_samples) this evaluator's buffer (after a zero-phase filter, a
        new array), overwritten by the next call; ``(None, inf)`` for a failed evaluation,
        ``(None, nan)`` where the compiled path does not reach. Trials that share the record
        (:mod:`femupdate.evaluation.shared`) compare their windows with it
        (:meth:`compare_with`)."""
        if not self.supported:
            return None, np.nan
        one, phi, status = self._single
        one[0] = x
        self._run(one, True, phi, status)
        if status[0] == REFERENCE:
            return None, np.nan
        if not np.isnan(phi[0]):  # diverged or an unstable step: inf
            return None, float(phi[0])
        if self.zero_phase:
            import scipy.signal

            return np.ascontiguousarray(scipy.signal.sosfiltfilt(self._sos, self.y, axis=1)), \
                np.nan
        return self.y, np.nan

    def simulated_rows(self, X: np.ndarray) -> Iterator[tuple[np.ndarray | None, float]]:
        """:meth:`simulated` of every row of ``X`` (k, n_params), one after another as the
        caller takes them, each bit for bit its single call; with the friction kernel in SIMD
        lanes ``LANES`` rows per compiled call, each row's outputs read from its lane (valid
        until the caller takes the row after the group's last)."""
        X = np.ascontiguousarray(X, dtype=float)
        lanes = self.lanes
        if lanes is None or not self.supported or self.zero_phase:
            for x in X:
                yield self.simulated(x)
            return
        for start in range(0, X.shape[0], LANES):
            group = X[start:start + LANES]
            if group.shape[0] == 1:
                yield self.simulated(group[0])
                continue
            phi = np.empty(group.shape[0])
            status = np.full(group.shape[0], REFERENCE, dtype=np.int64)
            self._run(group, True, phi, status)  # raw: each lane's outputs left in place
            lane_of = {int(row): q for q, row in enumerate(lanes.rows) if row >= 0}
            for i in range(group.shape[0]):
                if status[i] != DONE or i not in lane_of:
                    yield None, np.nan
                elif not np.isnan(phi[i]):  # diverged: inf
                    yield None, float(phi[i])
                else:
                    yield lanes.y[lane_of[i]], np.nan

    def compare_with(self, y: np.ndarray, residuals: bool = False
                     ) -> float | np.ndarray | None:
        """φ of outputs from :meth:`simulated` (this trial's or another's of the same record
        and processing), as this evaluator compares them; with ``residuals``, its residual
        vector (None for a non-finite φ). ``y`` is copied, not changed."""
        np.copyto(self.y, y)
        phi = float(process_and_compare(self.post, self.y, self.per_channel, self.zi))
        if not residuals:
            return phi
        return scaled_residuals(self.post, self.y) if np.isfinite(phi) else None

    def _run(self, X: np.ndarray, raw: bool, phi: np.ndarray, status: np.ndarray) -> None:
        """The compiled batch over the rows of X (C-contiguous float64)."""
        args = (X, *self._static, raw, phi, status)
        entry = self._entry.get(raw)
        if entry is None:
            entry = self._entry[raw] = _entry_point(self._batch, args)
        entry(*args)

    def stages(self, x: np.ndarray) -> dict[str, Callable[[], object]]:
        """The compiled stages of φ(x) as separate calls, for timing them one by one.

        ``assembly``, ``prepare`` (the eigenproblem and the kernel's coefficients, after an
        assembly), ``simulation`` (the kernel φ uses, on the prepared point) and ``compare``
        (processing and objective, on the simulated outputs); each call carries its own
        dispatch overhead. The point must be one the compiled path evaluates.
        """
        if self.bouc_wen is not None:
            raise ValueError("stages: not available for a model with Bouc–Wen elements")
        m = self.mats
        x = np.ascontiguousarray(x, dtype=float)
        head = (x, self.plan, m.p, m.M, m.minv, m.C, m.K, m.load, m.kr, m.fu)
        if self.method == "exact":
            def setup() -> tuple[int, int]:
                return exact_setup(*head, self.r_out, self.outputs, self.dt, self.quantity,
                                   self.work)

            status, size = setup()

            def simulate() -> bool:
                if size == self._written_modes:
                    w = self.work
                    return self._written.kernel(self.ag, w.coef, w.wr, w.wi, w.feed, w.base,
                                                self.y)
                return exact.run_modal(self.ag, size, self.work, self.y)
        else:
            h = self.dt / self.substeps

            def setup() -> tuple[float, int, int]:
                return central_setup(*head, self.fi, self.fj, self.ag, self.outputs, h,
                                     self.work)

            _, status, size = setup()

            def simulate() -> bool:
                if self._written is not None:
                    w = self.work
                    return self._written.kernel(self.ag, self.substeps, h, self.quantity,
                                                self.r_out, w.modal, w.yf, w.pf, w.limit, w.po,
                                                w.eta0, self.y)
                return central.run_central(self.ag, self.substeps, h, self.quantity,
                                           self.r_out, size, self.work, self.y)
        if status != RUN:
            raise ValueError("this point is not evaluated by the compiled path")
        simulate()
        raw = self.y.copy()

        def compare_() -> float:
            np.copyto(self.y, raw)  # the comparison overwrites the outputs
            return process_and_compare(self.post, self.y, self.per_channel, self.zi)

        return {"assembly": lambda: assemble(self.plan, *head[:1], *head[2:]),
                "prepare": setup, "simulation": simulate,
                "compare": compare_, "copy": lambda: np.copyto(self.y, raw)}

    def _zero_phase(self, x: np.ndarray) -> tuple[float, int]:
        """(φ, status) when the prediction is filtered forward and backward (``sosfiltfilt``)."""
        phi = np.empty(1)
        status = np.empty(1, dtype=np.int64)
        self._run(x[None, :], True, phi, status)
        if status[0] != DONE or not np.isnan(phi[0]):  # to the reference, or inf
            return float(phi[0]), int(status[0])
        import scipy.signal

        y = np.ascontiguousarray(scipy.signal.sosfiltfilt(self._sos, self.y, axis=1))
        return float(process_and_compare(self.post, y, self.per_channel, self.zi)), DONE


def scaled_residuals(post: Post, d: np.ndarray) -> np.ndarray:
    """r from the differences ``d`` = ŷ − y (n_channels, n_samples) that
    :func:`process_and_compare` leaves: with experimental parameters the part of each channel
    the constants cannot explain, each channel scaled by √(w_c / (Σw · E_c)); channel after
    channel, as ``ErrorFunction.residuals``. Only the scored samples are read: the first
    ``stop - start`` of each row."""
    d = d[:, :post.stop - post.start]
    energy = post.energy
    if post.projected:
        c = d @ post.q.T  # (n_channels, 2): Qᵀd of each channel
        d = d - c @ post.q
        energy = energy + np.sum((c + post.qty.T) ** 2, axis=1)
    scale = np.sqrt(post.weights / (post.weights.sum() * energy))
    return (d * scale[:, None]).ravel()


def _entry_point(dispatcher: Any, args: tuple) -> Callable[..., None]:
    """The compiled function for these arguments' types, called without the dispatcher's
    type resolution (about 6 of the 10 µs a call through it costs with this many arguments);
    the dispatcher itself when it has no such entry."""
    from numba import typeof

    types = tuple(typeof(a) for a in args)
    entry = dispatcher.compile(types)  # loads it from numba's cache, or compiles it
    return dispatcher if entry is None else entry


def _post(obj: Any, sos: np.ndarray, integrate: bool, dt: float, score: slice,
          n_samples: int) -> Post:
    """The processing and comparison of an ``Objective``'s target, as the kernels use them:
    the target holds the samples ``score`` of a record of ``n_samples``."""
    projected = bool(obj.with_experimental_parameters)
    n, nc = obj.target.shape
    start, stop, step = score.indices(n_samples)
    if step != 1 or stop - start != n:
        raise ValueError(f"the target's {n} samples are not the scored samples {score} of "
                         f"a record of {n_samples}")
    return Post(
        sos=np.ascontiguousarray(sos, dtype=float), integrate=bool(integrate), dt=float(dt),
        target=np.ascontiguousarray(obj.target.T, dtype=float),
        q=np.ascontiguousarray(obj._q.T if projected else np.zeros((2, n)), dtype=float),
        qty=np.ascontiguousarray(obj._qty if projected else np.zeros((2, nc)), dtype=float),
        energy=np.ascontiguousarray(obj._perp_energy if projected else obj._energy,
                                    dtype=float),
        weights=np.ascontiguousarray(obj.weights, dtype=float), projected=projected,
        start=int(start), stop=int(stop),
    )


def evaluator_for(problem: UpdateProblem) -> Evaluator:
    """The compiled evaluator of ``problem`` (see :class:`Evaluator`)."""
    return Evaluator(problem)

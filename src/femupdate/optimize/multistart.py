"""``multistart-lm``: space-filling starts, a bounded Levenberg–Marquardt local phase, restarts.

A sum of squares φ = ‖r‖² (the NMSE of Eq. 1 is one: :meth:`UpdateProblem.residuals`) has a
Gauss–Newton model that is nearly exact close to a zero-residual solution, so a trust-region
least-squares step converges in a few iterations where sampling methods crawl along the
correlated valleys of the bridge (E–kp4, c1–c4). What it lacks is globality: from a random
start in the box a local search often ends in an *improper* minimum (a parameter at a bound,
the gradient pointing out) or in a spurious valley. Hence three phases, all in ask/tell on
the unit cube:

1. **Pool** (global): a Latin hypercube of ``pool`` points, evaluated in batches of at most
   POOL_BATCH (with residuals, a batch's vectors are held at once: 20 n of them for the whole
   pool would make the memory grow with the parameters; the values are the same). Local
   searches start from its best points, best first, skipping points within ``min_distance``
   of an earlier start or end point (they would fall into a basin already searched); when
   none is left, a new pool is drawn.
2. **Local** (a bounded Levenberg–Marquardt): the Jacobian by forward differences, its n
   points (n + 1 with the base point) asked as one batch, with steps chosen for the noise of
   the simulation (estimated once per run from a difference table, ECnoise), and between two
   of them up to ``broyden`` Broyden rank-1 updates from the accepted steps; the step
   minimises the damped Gauss–Newton model within the box [0, 1]^n − x (Cholesky, or
   bounded-variable least squares when the box binds); the damping follows Nielsen's rule. A
   step the model predicted well that still cut φ by less than half is extended (2p, 4p, …)
   while φ falls: the floor of a flat valley keeps descending beyond the model's minimum.
3. **Stages and restarts**: a stage ends when its steps no longer decrease the model
   (``ftol``, ``xtol``, λ > 1e16) or it stalls (φ fell by less than ``stall_tol`` over its
   last ``stall_iters`` accepted steps). The fine stage is then followed by a coarse one —
   central differences with the step ``coarse_step`` — which sees through ripples of φ finer
   than that step (on the bridge, a stiff abutment mode whose phase over the record turns
   with kp1 leaves minima 1e-3 apart along the kp1 valley, where a fine-step search stops at
   φ ≈ 2e-6); stages alternate while each cuts φ by at least ``stage_gain``. Then the search
   ends — at a proper minimum, an improper one or a stall — and the next starts from the
   pool. The run ends when ``patience`` searches have ended at the best φ (with residuals: the
   best has been found again and again, as on noisy or real data, where no target says when
   to stop; off by default when an ``f_target`` is given), or at ``minimize``'s budget or
   target. A search that ends at the lowest φ of the search ends, inside the box, is
   followed by a few valley hops (HOPS).

The result is the best point over all searches. Without residuals (``minimize(...,
residuals=False)``) the local phase is a bounded quasi-Newton method on φ itself: the same
trust-region machinery with a damped-BFGS Hessian and forward-difference gradients, each
search ending with a stage of central differences (``polish``).

Every simulation is an evaluation, and all state is plain arrays, floats and the Generator:
a pickled optimizer resumes bit for bit.

Why this file is long (about 830 lines): it is one state machine. Its phases (pool, noise
table, Jacobian, trial step, extension, stage end) read and write the same search state; the
pure numerics they call (steps, stencils, the bounded step, BFGS) already live in ``trust``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from femupdate.errors import ConfigError
from femupdate.optimize.base import (
    KeepsBest,
    StepTrace,
    check_batch,
    check_option_names,
    int_option,
    real_option,
)
from femupdate.optimize.trust import (
    H_MIN,
    bfgs_update,
    bounded_step,
    broyden_update,
    central_steps,
    damping_update,
    forward_columns,
    forward_steps,
    gain_ratio,
    gram_factor,
    latin_hypercube,
    model_decrease,
    noise_level,
    second_order_columns,
    second_order_stencils,
    step_signs,
)

#: Points of the difference table that estimates the noise (ECnoise: 6 or 7 suffice).
NOISE_POINTS = 7
#: Spacing of that table (unit cube): far below any curvature scale of a smooth simulation,
#: far above rounding of x itself.
NOISE_SPACING = 1e-8
#: A step is accepted when the actual decrease is at least this fraction of the predicted one.
ACCEPT = 1e-4
#: Above this damping the step is nil to rounding: the stage has converged.
LAMBDA_MAX = 1e16
#: An accepted step that the model predicted well (gain ratio above EXTEND_RHO) but that cut
#: φ by less than the factor EXTEND_SLOW is extended: 2p, 4p, … while φ keeps falling.
EXTEND_RHO = 0.75
EXTEND_SLOW = 0.5

#: Pool points asked per batch: the residual vectors of one batch are held at once (64 rows
#: of 15,000 residuals: 7.7 MB), so the memory does not grow with the pool (20 n points).
POOL_BATCH = 64

#: With residuals, a run ends when this many searches have ended at the best φ, within the
#: fraction PATIENCE_TOL (option ``patience``; None: only the budget or the target end it).
#: On the bridge with 2 % noise, searches end 0.1–0.3 % apart along the kp1 valley, at the
#: same E–kp4 to 1e-4: at 0.1 % a run took 9,000–13,000 evaluations to see five of them. Three
#: are enough where runs must also agree with each other (``[search] agree``, 2 by default:
#: the second run is the independent check): on issue 36's bridge record the two runs took
#: 4,643 evaluations with patience 3 against 27,978 with 5, ending 0.2 % higher in φ (0.01 of
#: a nat under the error model ``neff``); on the 1-storey Jenkins fit
#: (benchmarks/jenkins_reliability.py, 10 runs of 3,000) every run ended at the best with 3 as
#: with 5 (24,593 evaluations against 29,759).
PATIENCE = 3
PATIENCE_TOL = 5e-3
#: ... and only once at least PATIENCE_SEARCHES × patience searches from the pool have ended:
#: a spurious basin that draws most starts can hold the first five (the 1-storey Jenkins fit
#: to El Centro 1 and Northridge 1: one run of ten ended "found five times" at φ = 0.339 after
#: 678 evaluations, the nine others at 0.187).
PATIENCE_SEARCHES = 2
#: ... and within an absolute floor: φ of residuals that differ from the best by this many
#: times the rounding noise of one component (measured, or ε times the residuals' RMS at the
#: first start, whichever is larger). At φ = 0 a relative tolerance is zero: on an exactly
#: solvable problem searches end at 1e-31, 1e-30, … around a best of 0 and never "equal" it.
PATIENCE_FLOOR_NOISE = 10.0
#: ... or, if larger, the φ that a search ending with steps below ``xtol`` cannot resolve:
#: n·xtol²·‖J‖²_F (J of the run's first Jacobian, unit cube). A floor from the measured
#: rounding noise alone depends on a processor's last ulps (3.9e-31 on one machine while its
#: searches of r = (x₀ − 0.3, 2(x₁ − 0.7), x₀x₁ − 0.21) ended at 5e-30 … 6e-28, and the
#: run spent its whole budget); this one scales with the residuals (×1e3 → φ ×1e6).

#: Valley hops (residual mode): a search that ends inside the box at the lowest φ any search
#: ended at (within PATIENCE_TOL) is followed by up to HOPS short searches from its end point
#: moved along the valley, the softest direction of the coarse stage's Gauss–Newton Hessian
#: H, by s uniform in ±√(2φ/λ_min(H)) (where the valley's trend would at most double φ), at
#: most HOP_MAX; HOPS more after each new best. Where the
#: data hardly determine a parameter its valley floor is a plateau of local minima (on the
#: noise-free broad-band bridge, a stiff abutment mode's phase turns with kp1: φ ripples
#: between 7e-7 and 2e-6 along a valley whose global minimum, 0, has a basin 100 times
#: narrower than the valley); a hop reaches the next of them in a few steps where a search
#: from the pool takes hundreds of evaluations to get back into the valley. Hops do not count
#: for ``patience``: they are not independent searches.
HOPS = 4
HOP_MAX = 0.1

#: Residual mode: in a fine stage, after an accepted step, the Jacobian is updated by Broyden's
#: rank-1 formula from the step's change of r (no evaluation) up to BROYDEN times in a row
#: before a new difference Jacobian (n evaluations); a step the updated model fails (rejected)
#: or a convergence it claims is checked with a difference Jacobian first. Coarse stages keep
#: their differences: their Jacobian is to see through ripples that a secant from a short step
#: would follow. On the noise-free broad-band bridge (accelerogram seeds 0, 3, 5; 25 runs):
#: 1 update: 733, 896, 1,958 evaluations per success; 2: 828, 877, 1,480; 3: 826, 890, 1,192;
#: 5: 814, 962, 1,127; 9: 815, 896, 1,175; none: 1,775, 2,480, 2,820 (narrow band, seed 0:
#: 445, 408, 442, 383 for 1, 2, 3, 5 updates, 424 without). Option ``broyden = "auto"`` (the
#: default) is BROYDEN with an ``f_target`` and 0 without: on real records, where no target
#: is given and ``patience`` ends a run, the updates cost more than they save near a minimum
#: of large residuals (the one-storey quickstart, 3 × 4 runs: 12,537 evaluations against
#: 9,779, more trial steps, extensions and coarse stages; the 1-storey Jenkins fit, 10 runs:
#: 93,618 against 69,832); gating the updates on the last step's gain ratio (> 0.25, > 0.75)
#: or on its cut of φ (≥ 10 %, ≥ 50 %) did not change that and lost much of the gain on the
#: bridge.
BROYDEN = 5

#: The scalar mode's polish steps are at most this share of the last accepted step (chosen
#: with benchmarks/coco_bbob.py: 0.001, 0.01, 0.1, 0.3 hit 24, 24, 22, 22 of 48 targets;
#: with 0.01, seeds 2 and 3 hit 20 and 20, against 18 and 17 without the bound).
POLISH_SHARE = 0.01

#: Trace codes of the phases.
PHASES = ("pool", "noise", "jacobian", "trial", "extend")


class MultistartLM(KeepsBest):
    """Multistart bounded Levenberg–Marquardt (quasi-Newton without residuals). Picklable.

    Parameters
    ----------
    n : int
        Number of parameters.
    rng : numpy.random.Generator
        The only source of randomness (the pools and the noise table's direction).
    pool : int or None
        Points of each space-filling pool (default 20·n).
    min_distance : float
        A pool point closer than this (RMS over coordinates, unit cube) to an earlier start or
        end point is skipped (default 0.05).
    stall_iters, stall_tol : int, float or None
        A stage has stalled when φ fell by less than the fraction ``stall_tol`` over its last
        ``stall_iters`` accepted steps (default 5; ``stall_tol`` None: 0.01 with residuals, 0
        — off — without).
    lambda0 : float
        Initial damping of a stage, relative to Marquardt's scaling (default 1e-3).
    ftol, xtol : float
        A stage has converged when the model predicts a decrease below ``ftol``·φ, or the
        step is below ``xtol`` in every coordinate (defaults 1e-14 and 1e-13).
    fd_step : float or None
        Forward-difference step (unit cube) of the fine stages for every coordinate; None
        (default) chooses them from the estimated noise
        (:func:`~femupdate.optimize.trust.forward_steps`).
    coarse_step : float, None or "auto"
        Step of the coarse stages' central differences; None: fine stages only. "auto"
        (default): 0.01 with residuals, None without.
    stage_gain : float
        Stages alternate while each cuts φ by at least this fraction (default 0.1).
    extend : bool
        Extend slow, well-predicted steps (default True).
    polish : bool
        Scalar mode: end each search with a stage of central differences (steps
        (3ε/μ)^(1/3) for the noise ε carried to φ's size there), keeping the quasi-Newton
        Hessian (default True).
    patience : int, None or "auto"
        End the run when this many searches have ended at the best φ (within 0.5 %): the best
        has been found again and again. None: only ``minimize``'s budget or target end it.
        "auto" (default): 5 with residuals and no ``f_target``, None otherwise.
    x0 : ndarray or None
        Start of the first local search (unit cube; e.g. the nominal model), before any pool;
        None (default): the best point of the first pool.
    broyden : int or "auto"
        Residual mode: Broyden rank-1 updates of the fine stages' Jacobian allowed between two
        difference Jacobians (0: a difference Jacobian at every step). "auto" (default):
        BROYDEN = 5 with an ``f_target``, 0 without.

    Notes
    -----
    The scalar mode's defaults were chosen on COCO's bbob (d = 5, 48 problems, 5,000
    evaluations, ``benchmarks/coco_bbob.py``): with the residual mode's stall criterion and
    coarse stages its quasi-Newton searches stop short of 1e-8 on the ill-conditioned
    functions (7/48 targets); without them, 16/48; with the central-difference polish, 18/48,
    and 24/48 with its steps kept below POLISH_SHARE of the last step (seeds 2 and 3: 20 and
    20, against 15 and 15 without a polish). A Newton polish with a finite-difference
    Hessian did worse (15/48).
    """

    #: Takes residual vectors when ``minimize`` has them, works on φ alone otherwise.
    needs_residuals = False
    #: Defaults for a checkpoint pickled before these existed (it resumes under these rules).
    best_end = math.inf
    broyden = 0
    updates = 0
    jac: np.ndarray | None = None
    r_prev: np.ndarray | None = None
    jac_norm2 = 0.0  # ‖J‖²_F of the run's first Jacobian (residual mode; see phi_floor)

    def __init__(self, n: int, rng: np.random.Generator, *, pool: int | None = None,
                 min_distance: float = 0.05, stall_iters: int = 5,
                 stall_tol: float | None = None,
                 lambda0: float = 1e-3, ftol: float = 1e-14, xtol: float = 1e-13,
                 fd_step: float | None = None, coarse_step: float | str | None = "auto",
                 stage_gain: float = 0.1, extend: bool = True, polish: bool = True,
                 patience: int | str | None = "auto", x0: np.ndarray | None = None,
                 broyden: int | str = "auto") -> None:
        self.n = n
        self.rng = rng
        self.pool_size = 20 * n if pool is None else pool
        self.min_distance = min_distance
        self.stall_iters = stall_iters
        self.stall_tol_option = stall_tol
        self.stall_tol = 0.0  # resolved with the mode at the first tell
        self.lambda0 = lambda0
        self.ftol = ftol
        self.xtol = xtol
        self.fd_step = fd_step
        self.coarse_step_option = coarse_step
        self.coarse_step: float | None = None  # resolved with the mode at the first tell
        self.stage_gain = stage_gain
        self.extend = extend
        self.polish = polish
        self.patience_option = patience
        self.patience: int | None = None  # resolved with the mode at the first tell
        self.broyden_option = broyden
        self.broyden = 0 if broyden == "auto" else int(broyden)  # "auto": set by target_given
        self.search_ends: list[float] = []  # φ where each search ended
        self.mode: str | None = None  # "residuals" or "scalar", fixed by the first tell
        self.best_x = np.full(n, 0.5)
        self.restarts_done = 0  # local searches started after the first
        self.searches = 0
        self.steps = 0
        self.noise = math.nan  # of one residual component (or of φ), from the table
        self.scale = 0.0  # RMS of a residual component (or |φ|) at the first start
        self.h = np.full(n, math.nan if fd_step is None else fd_step)  # fine steps
        self.visited = np.empty((0, n))  # starts and end points of the searches
        self.valley: np.ndarray | None = None  # H of the search's last coarse stage
        self.hop_x = np.full(n, math.nan)  # the point hops start from, its φ and H
        self.hop_phi = math.inf
        self.best_end = math.inf  # the lowest φ a search (or hop) ended at
        self.hop_hess: np.ndarray | None = None
        self.hops_left = 0
        self.hopping = False  # the current search is a hop
        self._clear_search()
        if x0 is None:
            self._new_pool()
        else:  # the first search starts there; the pool comes when it ends
            self.pool_x = np.empty((0, n))
            self.pool_f = np.empty(0)
            self.searches = 1
            self._start_search(np.asarray(x0, dtype=float))
        self.trace = StepTrace()

    # -- protocol --------------------------------------------------------------------------

    def ask(self) -> np.ndarray:
        """The batch the current phase needs: the pool, the noise table, the Jacobian's points
        (the base point first when its value is unknown), or one trial or extended step."""
        return self.pending.copy()

    def tell(self, xs: np.ndarray, fs: np.ndarray, rs: np.ndarray | None = None) -> None:
        """Values (and residual vectors ``rs`` (k, m), or None) of the batch last asked."""
        xs, fs = check_batch(xs, fs, self.n)
        if xs.shape[0] != self.pending.shape[0]:
            raise ConfigError(f"tell() expects the {self.pending.shape[0]} points last asked, "
                              f"got {xs.shape[0]}")
        mode = "scalar" if rs is None else "residuals"
        if self.mode is None:
            self._set_mode(mode)
        elif mode != self.mode:
            raise ConfigError(f"tell() got {'no ' if rs is None else ''}residuals in a run "
                              f"that started in {self.mode} mode")
        if rs is not None:
            rs = np.asarray(rs, dtype=float).reshape(xs.shape[0], -1)
        self._keep_best(xs, fs)
        phase = self.phase
        if phase == "pool":
            done = getattr(self, "pool_done", 0)  # 0 in a checkpoint made before batches
            self.pool_f[done:done + fs.size] = fs
            self.pool_done = done + fs.size
            if self.pool_done < self.pool_size:
                self.pending = self.pool_x[self.pool_done:self.pool_done + POOL_BATCH].copy()
            else:
                self._next_start()
        elif phase == "noise":
            self._tell_noise(fs, rs)
        elif phase == "jacobian":
            self._tell_jacobian(fs, rs)
        elif phase == "trial":
            self._tell_trial(fs, rs)
        else:
            self._tell_extension(fs, rs)
        self.steps += 1
        self.trace.append(f_best=self.best_f, **{"lambda": self.lam},
                          phase=float(PHASES.index(phase)),
                          restarts=float(self.restarts_done))

    def stop(self) -> dict[str, object]:
        """``{"patience": k}`` once k searches have ended at the best φ (within the fraction
        ``PATIENCE_TOL``) and at least PATIENCE_SEARCHES·k searches have ended: the best has
        been found again and again; otherwise searches go on until ``minimize``'s budget or
        target."""
        if (self.patience is not None and self.confirmations() >= self.patience
                and len(self.search_ends) >= PATIENCE_SEARCHES * self.patience):
            return {"patience": self.patience}
        return {}

    def target_given(self) -> None:
        """``minimize`` has an ``f_target``: it says when to stop, so ``patience = "auto"`` is
        off. (A spurious minimum whose basin draws most starts — φ = 3.4e-2 on the broad-band
        bridge — would otherwise end a run found five times before the target.) And
        ``broyden = "auto"`` is BROYDEN: a target is what a fit that can come close to the
        data has (see BROYDEN)."""
        if self.patience_option == "auto":
            self.patience_option = None
        if self.broyden_option == "auto":
            self.broyden = BROYDEN

    def confirmations(self) -> int:
        """How many searches have ended at the best φ found so far (within PATIENCE_TOL)."""
        if not math.isfinite(self.best_f):
            return 0
        level = self.best_f + max(PATIENCE_TOL * abs(self.best_f), self.phi_floor())
        return sum(phi <= level for phi in self.search_ends)

    def phi_floor(self) -> float:
        """The absolute floor of "the same φ": m·(PATIENCE_FLOOR_NOISE·δ)² with δ the larger of
        the measured noise of a residual component and ε times their RMS at the first start
        (m = 1 and δ the noise of φ itself in scalar mode), with residuals at least
        n·xtol²·‖J‖²_F (see PATIENCE_FLOOR_NOISE). 0 before the noise table."""
        if math.isnan(self.noise):
            return 0.0
        delta = PATIENCE_FLOOR_NOISE * max(self.noise, np.finfo(float).eps * self.scale)
        if self.mode == "residuals":
            unresolved = self.n * self.xtol ** 2 * self.jac_norm2
            return max(getattr(self, "components", 1) * delta * delta, unresolved)
        return delta

    def trace_since(self, step: int) -> dict[str, np.ndarray]:
        """Per step from ``step`` on (rows held): ``f_best``, the damping ``lambda``, the
        ``phase`` (index in PHASES) and ``restarts`` (local searches started so far − 1)."""
        return self.trace.since(step)

    def close(self) -> None:
        """Nothing to release."""

    def _set_mode(self, mode: str) -> None:
        """The defaults that depend on the mode (measured: see the class docstring)."""
        self.mode = mode
        residuals = mode == "residuals"
        tol = self.stall_tol_option
        self.stall_tol = (0.01 if residuals else 0.0) if tol is None else tol
        step = self.coarse_step_option
        self.coarse_step = (1e-2 if residuals else None) if step == "auto" else step
        patience = self.patience_option
        self.patience = (PATIENCE if residuals else None) if patience == "auto" else patience

    # -- global phase ----------------------------------------------------------------------

    def _new_pool(self) -> None:
        self.phase = "pool"
        self.pool_x = latin_hypercube(self.rng, self.pool_size, self.n)
        self.pool_f = np.full(self.pool_size, math.inf)
        self.pool_done = 0  # points of the pool evaluated
        self.pending = self.pool_x[:POOL_BATCH].copy()

    def _next_start(self) -> None:
        """The best pool point away from every start and end so far, or a new pool."""
        self.hopping = False
        for i in np.argsort(self.pool_f, kind="stable"):
            if not math.isfinite(self.pool_f[i]):
                break
            x = self.pool_x[i]
            self.pool_f[i] = math.inf  # used (or too close): never again
            if self.visited.shape[0]:
                dist = np.sqrt(np.mean((self.visited - x) ** 2, axis=1))
                if float(dist.min()) < self.min_distance:
                    continue
            if self.searches:
                self.restarts_done += 1
            self.searches += 1
            self._start_search(x)
            return
        self._new_pool()

    def _start_search(self, x: np.ndarray) -> None:
        """A local search from x (evaluated again: with the Jacobian, or as the first point of
        the noise table on the run's first search)."""
        self._clear_search()
        self.valley = None
        self.x = x.copy()
        self.visited = np.vstack([self.visited, x])
        if math.isnan(self.noise):
            self.phase = "noise"
            direction = self._table_direction(x)
            offsets = np.arange(NOISE_POINTS)[:, None] * NOISE_SPACING
            self.pending = x + offsets * direction
        else:
            self._ask_jacobian(with_base=True)

    def _table_direction(self, x: np.ndarray) -> np.ndarray:
        """A random unit direction whose table stays in the cube (components flipped inward)."""
        d = self.rng.standard_normal(self.n)
        d /= np.linalg.norm(d)
        reach = (NOISE_POINTS - 1) * NOISE_SPACING
        d = np.where(x + reach * d > 1.0, -np.abs(d), d)
        return np.where(x + reach * d < 0.0, np.abs(d), d)

    def _tell_noise(self, fs: np.ndarray, rs: np.ndarray | None) -> None:
        table = fs[:, None] if rs is None else rs
        if not np.all(np.isfinite(table)):
            self._end_stage("failed")  # the start itself (or next to it) fails: next start
            return
        self.noise = noise_level(table)
        slope = float(np.sqrt(np.mean((table[1] - table[0]) ** 2))) / NOISE_SPACING
        self.scale = float(np.sqrt(np.mean(table[0] ** 2)))
        self.components = table.shape[1]  # m: residual components (1 in scalar mode)
        if self.fd_step is None:
            self.h = forward_steps(self.noise, np.full(self.n, slope), self.scale)
        self.phi = self.stage_phi = self.history[0] = float(fs[0])
        self.r = None if rs is None else rs[0].copy()
        self._ask_jacobian(with_base=False)

    # -- local phase -----------------------------------------------------------------------

    def _ask_jacobian(self, with_base: bool) -> None:
        """Forward differences (fine stage) or second-order ones (coarse stage), one batch."""
        self.phase = "jacobian"
        if self.coarse:
            self.offsets, self.weights = second_order_stencils(self.x, self.stage_h)
            eye = np.eye(self.n) * self.stage_h
            rows = np.vstack([self.x + eye * self.offsets[:, :1],
                              self.x + eye * self.offsets[:, 1:]])
        else:
            self.hs = step_signs(self.x, self.h)
            rows = self.x + np.diag(self.hs)
            self.jac = None  # replaced by the differences: not held while they are evaluated
        self.with_base = with_base
        self.pending = np.vstack([self.x, rows]) if with_base else rows

    def _differences(self, base: np.ndarray, values: np.ndarray) -> np.ndarray:
        """The Jacobian (m, n) from the values (k, m) at the points asked after the base."""
        if self.coarse:
            return second_order_columns(base, values, self.weights, self.stage_h)
        return forward_columns(base, values, self.hs)

    def _tell_jacobian(self, fs: np.ndarray, rs: np.ndarray | None) -> None:
        if self.with_base:
            self.phi = self.stage_phi = self.history[0] = float(fs[0])
            self.r = None if rs is None else rs[0].copy()
            if not math.isfinite(self.phi):
                self._end_stage("failed")
                return
            fs = fs[1:]
            rs = None if rs is None else rs[1:]
        if self.mode == "residuals":
            assert rs is not None and self.r is not None
            jac = self._differences(self.r, rs)
            self.updates = 0
            if self.broyden and not self.coarse:
                self.jac = jac
            col2 = self._gauss_newton(jac)
            slopes = np.sqrt(col2 / self.r.size)
        else:
            grad = self._differences(np.array([self.phi]), fs[:, None])[0]
            self._quasi_newton(grad)
            slopes = np.maximum(np.diag(self.hess), np.abs(grad))
            self.d2 = np.maximum(self.d2, np.diag(self.hess))
            self.slopes = slopes
        if self.fd_step is None and not self.coarse and (self.mode == "residuals"
                                                          or self.iters > 0):
            self.h = forward_steps(self.noise, slopes, max(self.scale, abs(self.phi)))
        self._next_step()

    def _gauss_newton(self, jac: np.ndarray) -> np.ndarray:
        """The Gauss–Newton model at x (H, g, Marquardt's scaling) from the Jacobian (residual
        mode); returns J's squared column norms."""
        assert self.r is not None
        self.hess, self.grad, col2 = gram_factor(jac, self.r)
        if not self.jac_norm2 and np.all(np.isfinite(col2)):
            self.jac_norm2 = float(np.sum(col2))
        if self.coarse:
            self.valley = self.hess.copy()
        self.d2 = np.maximum(self.d2, 2.0 * col2)
        return col2

    def _after_step(self) -> None:
        """After an accepted step (and its extensions): in a fine stage with ``broyden``, the
        Jacobian by Broyden's rank-1 update from the step's change of r (no evaluation) up to
        ``broyden`` times in a row; else a new difference Jacobian."""
        if (not self.broyden or self.coarse or self.mode != "residuals"
                or self.updates >= self.broyden or getattr(self, "jac", None) is None):
            self._ask_jacobian(with_base=False)
            return
        assert self.x_prev is not None and self.r is not None
        step = self.x - self.x_prev
        self.jac = broyden_update(self.jac, step, self.r - self.r_prev)
        self.updates += 1
        self._gauss_newton(self.jac)
        self._next_step()

    def _next_step(self) -> None:
        """With the model at x: the end of the search or stage, or the next trial step."""
        if self._stalled():
            self._end_stage("stall")
            return
        self._propose()

    def _quasi_newton(self, grad: np.ndarray) -> None:
        """The scalar mode's Hessian: a scaled identity at a stage's start, then damped BFGS."""
        if self.reuse_hessian:
            self.reuse_hessian = False
        elif self.x_prev is None:
            self.hess = np.eye(self.n) * max(float(np.linalg.norm(grad)) / 0.1, 1e-300)
        else:
            s = self.x - self.x_prev
            y = grad - self.grad
            if self.iters == 1 and float(s @ y) > 0.0:  # Nocedal & Wright's first scaling
                self.hess = np.eye(self.n) * (float(y @ y) / float(s @ y))
            self.hess = bfgs_update(self.hess, s, y)
        self.grad = grad

    def _propose(self) -> None:
        """The damped bounded step at x, or the end of the stage when it is nil."""
        p = bounded_step(self.hess, self.grad, self.lam, self.d2, -self.x, 1.0 - self.x)
        self.pred = model_decrease(self.hess, self.grad, p)
        trial = np.clip(self.x + p, 0.0, 1.0)
        if (not self.pred > self.ftol * abs(self.phi) or float(np.max(np.abs(p))) < self.xtol
                or np.array_equal(trial, self.x)):
            if self.updates:  # converged by an updated Jacobian: see with a difference one
                self._ask_jacobian(with_base=False)
                return
            self._end_stage("converged")
            return
        self.phase = "trial"
        self.pending = trial[None, :]

    def _tell_trial(self, fs: np.ndarray, rs: np.ndarray | None) -> None:
        phi_new = float(fs[0])
        rho = gain_ratio(self.phi, phi_new, self.pred)
        self.lam, self.nu = damping_update(self.lam, self.nu, rho, ACCEPT)
        if rho > ACCEPT:
            step = self.pending[0] - self.x
            slow = rho > EXTEND_RHO and phi_new > EXTEND_SLOW * self.phi
            self.x_prev = self.x
            self.r_prev = self.r
            self._move(self.pending[0], phi_new, rs, new_step=True)
            if slow and self.extend:
                self._ask_extension(step, 2.0)
            else:
                self._after_step()
        elif self.updates:  # a model from updates failed: a new difference Jacobian first
            self._ask_jacobian(with_base=False)
        elif self.lam > LAMBDA_MAX:
            self._end_stage("lambda")
        else:
            self._propose()

    def _move(self, x: np.ndarray, phi: float, rs: np.ndarray | None, new_step: bool) -> None:
        """Go to x. A new step of the model counts for the stall criterion; an extension of
        the same step only lowers that step's φ."""
        self.x = x.copy()
        self.phi = phi
        if rs is not None:
            self.r = rs[0].copy()
        if new_step:
            self.iters += 1
        self.history[self.iters % self.history.size] = phi

    def _ask_extension(self, step: np.ndarray, factor: float) -> None:
        """Try x_prev + factor·step (clipped to the box)."""
        trial = np.clip(self.x_prev + factor * step, 0.0, 1.0)
        if np.array_equal(trial, self.x):
            self._after_step()
            return
        self.phase = "extend"
        self.ext_step = step
        self.ext_factor = factor
        self.pending = trial[None, :]

    def _tell_extension(self, fs: np.ndarray, rs: np.ndarray | None) -> None:
        phi_new = float(fs[0])
        if phi_new < self.phi:
            self._move(self.pending[0], phi_new, rs, new_step=False)
            self._ask_extension(self.ext_step, 2.0 * self.ext_factor)
        else:
            self._after_step()

    def _stalled(self) -> bool:
        k = self.stall_iters
        if self.iters < k:
            return False
        before = self.history[(self.iters - k) % self.history.size]
        return bool(self.phi > (1.0 - self.stall_tol) * before)

    def _end_stage(self, reason: str) -> None:
        """The other stage while the last one paid (the first always does), else the next
        start."""
        # Strictly lower: at φ = 0 (an exact fit) "0 ≤ 0.9·0" held forever, and the stages
        # alternated until the budget ran out.
        gained = self.stages == 0 or (self.phi < self.stage_phi
                                      and self.phi <= (1.0 - self.stage_gain) * self.stage_phi)
        if reason != "failed" and self.coarse_step is not None and gained:
            x, r, phi, stages, coarse = self.x, self.r, self.phi, self.stages, self.coarse
            self._clear_search()
            self.x, self.r, self.phi = x, r, phi
            self.stage_phi = self.history[0] = phi
            self.stages, self.coarse = stages + 1, not coarse
            self.stage_h = np.full(self.n, float(self.coarse_step))
            self._ask_jacobian(with_base=False)
            return
        if (reason != "failed" and self.mode == "scalar" and self.polish and self.stages == 0
                and self.slopes is not None):
            self._polish()
            return
        self._end_search(reason)

    def _end_search(self, reason: str) -> None:
        """Keep the search's end, then a valley hop or the next start."""
        self.visited = np.vstack([self.visited, self.x])
        if not self.hopping:
            self.search_ends.append(self.phi)
        at_best = self._at_best_end()
        self.best_end = min(self.best_end, self.phi)
        if reason != "failed" and self._hop(at_best):
            return
        self._next_start()

    def _hop(self, at_best: bool) -> bool:
        """Start a valley hop (see HOPS) if the search ended at the lowest φ of the search
        ends, inside the box, or hops are left from one; False otherwise.

        The best search end, not the best point evaluated: a point the search evaluated on
        its way (a difference stencil's, along a rippled valley) can lie below the point it
        ends at, and then no hop started (bridge, accelerogram seed 5: a search ended at
        φ = 3.62e-6 in the valley, one of its points at 3.56e-6; no hop, and the run took 23
        more searches, 5,800 evaluations). Inside the box: at an improper minimum (a
        parameter held by a bound) the fit is that of the bound, not a valley floor of ripple
        minima (hops there ended where they started, 4 × 95–195 evaluations)."""
        if self.mode != "residuals" or self.coarse_step is None:
            return False
        if self.valley is not None and at_best and self._inside():
            # a new best (beyond patience's tolerance and floor: at φ ≈ 0, ends that differ
            # by rounding each gave four more hops, and the searches that count waited)
            better = (not math.isfinite(self.hop_phi) or self.phi < self.hop_phi - max(
                PATIENCE_TOL * abs(self.hop_phi), self.phi_floor()))
            if better:
                self.hops_left = HOPS  # a new best: its valley gets its own hops
            self.hop_x, self.hop_phi, self.hop_hess = self.x.copy(), self.phi, self.valley
        if self.hops_left <= 0 or self.hop_hess is None:
            return False
        self.hops_left -= 1
        values, vectors = np.linalg.eigh(self.hop_hess)
        reach = min(math.sqrt(2.0 * self.hop_phi / max(float(values[0]), 1e-300)), HOP_MAX)
        start = np.clip(self.hop_x + self.rng.uniform(-reach, reach) * vectors[:, 0], 0.0, 1.0)
        self.restarts_done += 1
        self.searches += 1
        self._start_search(start)
        self.hopping = True
        return True

    def _at_best_end(self) -> bool:
        """Whether the search ended at the lowest φ of the search ends so far (within
        patience's tolerance and floor)."""
        return self.phi <= self.best_end + max(PATIENCE_TOL * abs(self.best_end),
                                               self.phi_floor())

    def _inside(self) -> bool:
        """Whether no coordinate stands at a bound of the box."""
        return bool(np.all((self.x > 0.0) & (self.x < 1.0)))

    def _polish(self) -> None:
        """The scalar mode's last stage of a search: central differences from where forward
        ones stopped (their gradient error, ~√ε against ~ε^(2/3), stops an ill-conditioned
        search early), with the quasi-Newton Hessian learnt so far (a fresh one would cost
        the stage its first steps). The noise measured at the first start, relative to φ
        there, is carried to φ here: rounding noise scales with the size of φ. The steps are
        also kept below POLISH_SHARE of the last accepted step, about the distance left to the
        minimum: a difference that straddles the minimum is biased wherever φ's curvature
        varies at that scale (on bbob's ill-conditioned f10, f11, f14 such steps stopped the
        searches 1e-7 … 3e-6 above the optimum)."""
        relative = self.noise / max(self.scale, 1e-300)
        self.stage_h = central_steps(relative * abs(self.phi), self.slopes, abs(self.phi))
        if self.x_prev is not None:
            last = float(np.max(np.abs(self.x - self.x_prev)))
            self.stage_h = np.minimum(self.stage_h, max(POLISH_SHARE * last, H_MIN))
        self.stages += 1
        self.coarse = True
        self.stage_phi = self.phi
        self.lam, self.nu = self.lambda0, 2.0
        self.reuse_hessian = True
        self._ask_jacobian(with_base=False)

    def _clear_search(self) -> None:
        """The local search's state before its first step (a fine stage)."""
        self.phase = "pool"
        self.x = np.full(self.n, 0.5)
        self.x_prev: np.ndarray | None = None
        self.r: np.ndarray | None = None
        self.phi = math.inf
        self.grad: np.ndarray | None = None
        self.hess = np.zeros((self.n, self.n))
        self.d2 = np.zeros(self.n)
        self.lam = self.lambda0
        self.nu = 2.0
        self.pred = 0.0
        self.iters = 0
        self.history = np.full(self.stall_iters + 1, math.inf)  # φ after each accepted step
        self.stages = 0  # stages finished in this search
        self.coarse = False  # the stage's differences: fine forward, or coarse second-order
        self.stage_h = np.zeros(self.n)  # steps of a second-order stage
        self.slopes: np.ndarray | None = None  # sizes of φ's slopes (scalar mode)
        self.reuse_hessian = False  # the next gradient replaces the last, the Hessian stays
        self.stage_phi = math.inf  # φ when the stage began
        self.hs = self.h.copy()
        self.with_base = False  # the Jacobian's batch begins with x itself
        self.offsets = np.zeros((self.n, 2))
        self.weights = np.zeros((self.n, 3))
        self.ext_step = np.zeros(self.n)
        self.ext_factor = 0.0
        self.jac = None  # the fine stage's Jacobian (with ``broyden``)
        self.r_prev = None  # r before the last accepted step
        self.updates = 0  # Broyden updates since the last difference Jacobian


_OPTIONS = ("pool", "min_distance", "stall_iters", "stall_tol", "lambda0", "ftol", "xtol",
            "fd_step", "coarse_step", "stage_gain", "extend", "polish", "patience", "x0",
            "broyden")


def bool_option(method: str, name: str, value: Any) -> bool:
    """A boolean option; ConfigError otherwise."""
    if not isinstance(value, bool):
        raise ConfigError(f"option {name!r} of method {method!r} must be true or false, "
                          f"got {value!r}")
    return value


def make_multistart_lm(n: int, rng: np.random.Generator, **options: Any) -> MultistartLM:
    """Multistart bounded Levenberg–Marquardt. Options: ``pool`` (int ≥ 1, default 20·n),
    ``min_distance`` ([0, 1], 0.05), ``stall_iters`` (int ≥ 1, 5), ``stall_tol`` ([0, 1) or
    None: 0.01 with residuals, 0 without), ``lambda0`` (> 0, 1e-3), ``ftol`` (≥ 0, 1e-14),
    ``xtol`` (≥ 0, 1e-13), ``fd_step`` ((0, 0.1] or None: from the noise), ``coarse_step``
    ((0, 0.25], None: no coarse stages, or "auto": 0.01 with residuals, None without),
    ``stage_gain`` ([0, 1), 0.1), ``extend`` (bool, true), ``polish`` (bool, true),
    ``patience`` (int ≥ 1, None or "auto": 5 with residuals and no f_target, None
    otherwise), ``x0``
    (n numbers in [0, 1] or None), ``broyden`` (int ≥ 0 or "auto": 5 with an f_target, 0
    otherwise); see :class:`MultistartLM`."""
    m = "multistart-lm"
    check_option_names(m, options, _OPTIONS)
    pool = options.get("pool")
    return MultistartLM(
        n, rng,
        pool=None if pool is None else int_option(m, "pool", pool, 1),
        min_distance=real_option(m, "min_distance", options.get("min_distance", 0.05), 0.0,
                                 1.0),  # type: ignore[arg-type]
        stall_iters=int_option(m, "stall_iters", options.get("stall_iters", 5), 1),
        stall_tol=real_option(m, "stall_tol", options.get("stall_tol"), 0.0, 1.0,
                              high_open=True, allow_none=True),
        lambda0=real_option(m, "lambda0", options.get("lambda0", 1e-3), 0.0, low_open=True,
                            high_open=True),  # type: ignore[arg-type]
        ftol=real_option(m, "ftol", options.get("ftol", 1e-14), 0.0,
                         high_open=True),  # type: ignore[arg-type]
        xtol=real_option(m, "xtol", options.get("xtol", 1e-13), 0.0,
                         high_open=True),  # type: ignore[arg-type]
        fd_step=real_option(m, "fd_step", options.get("fd_step"), 0.0, 0.1, low_open=True,
                            allow_none=True),
        coarse_step=_coarse_option(m, options.get("coarse_step", "auto")),
        stage_gain=real_option(m, "stage_gain", options.get("stage_gain", 0.1), 0.0, 1.0,
                               high_open=True),  # type: ignore[arg-type]
        extend=bool_option(m, "extend", options.get("extend", True)),
        polish=bool_option(m, "polish", options.get("polish", True)),
        patience=_patience_option(m, options.get("patience", "auto")),
        x0=_start_option(m, n, options.get("x0")),
        broyden=_broyden_option(m, options.get("broyden", "auto")),
    )


def _patience_option(method: str, value: Any) -> int | str | None:
    """``patience``: "auto", None or an integer ≥ 1."""
    if value is None or value == "auto":
        return value
    return int_option(method, "patience", value, 1)


def _broyden_option(method: str, value: Any) -> int | str:
    """``broyden``: "auto" or an integer ≥ 0."""
    if value == "auto":
        return value
    return int_option(method, "broyden", value, 0)


def _coarse_option(method: str, value: Any) -> float | str | None:
    """``coarse_step``: "auto", None or a step in (0, 0.25]."""
    if value == "auto":
        return "auto"
    return real_option(method, "coarse_step", value, 0.0, 0.25, low_open=True,
                       allow_none=True)


def _start_option(method: str, n: int, value: Any) -> np.ndarray | None:
    """``x0``: None or n numbers in [0, 1] (the unit cube of the bounds)."""
    if value is None:
        return None
    try:
        x0 = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        x0 = np.full(0, np.nan)
    if x0.shape != (n,) or not np.all((x0 >= 0.0) & (x0 <= 1.0)):
        raise ConfigError(f"option 'x0' of method {method!r} must be None or {n} numbers in "
                          f"[0, 1] (the start in the unit cube of the bounds), got {value!r}")
    return x0

"""The error function of a model-updating case: parameters → model → simulation → φ.

``UpdateProblem(case, experiments)`` is a picklable callable ``φ(x)`` on the search space of
the case (log10 values for log-scale parameters), ready for :func:`femupdate.minimize` and for
repeated runs in worker processes. A case of several trials shares the model and parameters:
φ is the mean of the fitted trials' φ, weighted by their ``weight`` (Eq. 1 per trial); its
residual vector :meth:`UpdateProblem.residuals` holds every trial's residuals, scaled so that
φ = ‖r‖².

Why this file is long (about 650 lines): a trial's φ and residuals on both paths (compiled and
step by step, with the checks of a point before it is simulated) and the case's combination of
its trials over batches and threads are one contract, tested as one.
"""

from __future__ import annotations

import itertools
import math
import os
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np

from femupdate._parallel import thread_pool
from femupdate.case import Case
from femupdate.case.derived import constraints_of
from femupdate.case.expressions import first_violation
from femupdate.data import signal
from femupdate.errors import ConfigError, ModelError, SimulationError
from femupdate.external.protocol import Evaluation
from femupdate.external.runner import ExternalRunner
from femupdate.model.modes import natural_frequencies
from femupdate.model.system import System
from femupdate.problem.case_model import CaseModel
from femupdate.problem.objective import ErrorFunction
from femupdate.problem.released import released_structure
from femupdate.simulate.response import Response
from femupdate.trials.experiment import Experiment

if TYPE_CHECKING:
    from femupdate.evaluation import Evaluator

Point = np.ndarray | Mapping[str, float]

#: Environment variable: ``reference`` makes every problem built without ``compiled`` evaluate
#: φ step by step (simulator, prediction, error function), to time or check the compiled
#: evaluator against it.
EVALUATOR_ENV = "FEMUPDATE_EVALUATOR"


class TrialProblem:
    """φ of one trial: the case's model driven by the trial's table record, against its
    processed measurement (over its scored samples).

    Parameters
    ----------
    case : Case
        The validated case.
    experiment : Experiment
        The trial's processed data (:func:`femupdate.trials.experiment.load_experiment`).
    compiled : bool or None
        Evaluate φ at search points with the compiled evaluator (:mod:`femupdate.evaluation`:
        equal to the step-by-step path to rounding, several times faster) or step by step;
        None: compiled unless ``FEMUPDATE_EVALUATOR=reference``. The compiled path covers
        femupdate's own planar models, scored over the whole trial or its ``score_window`` (the
        prediction processed from the record's start, as step by step); an external model, a
        3-D frame and the reduced path are evaluated step by step.
    """

    def __init__(self, case: Case, experiment: Experiment, *,
                 compiled: bool | None = None) -> None:
        self.case = case
        self.experiment = experiment
        specs = case.trial_specs()
        spec = next((s for s in specs if s.name == experiment.name),
                    specs[0] if len(specs) == 1 else None)
        channels = spec.data.outputs if spec is not None else None
        # dt: a nonlinear model without [simulation] method gets its integrator here, at the
        # nominal point, held for the whole search (CaseModel.method_for)
        self.model = CaseModel(case, channels, dt=experiment.dt)
        self.released = partial(released_structure, case.model)  # evaluation.supports builds it
        external = self.model.external
        gives_acceleration = external is None or external.quantity == "acceleration"
        if external is not None:
            _check_external(case, experiment, external.quantity)
        self.integrate = (experiment.quantity == "displacement" and gives_acceleration
                          and case.objective.integrate_prediction)
        # A nonlinear model is driven by the record as measured and its prediction filtered as
        # the data were: the high-pass does not commute with it (Case.filters_prediction).
        self.filter = case.filters_prediction and experiment.ag_unfiltered is not None
        self._ag = experiment.ag_unfiltered if self.filter else experiment.ag
        self._runner = None
        if external is not None:
            section = case.model.external
            self._runner = ExternalRunner(external, self._ag, experiment.dt,
                                          timeout=section.timeout, isolate=section.isolate)
        #: Why the last evaluation failed (None when it did not).
        self.last_failure: str | None = None
        if compiled is None:
            compiled = os.environ.get(EVALUATOR_ENV, "compiled") != "reference"
        # The compiled evaluator covers femupdate's planar models on the full path (a score
        # window, support groups too); a 3-D frame (6 DOFs per node: its assembly would be
        # planar), the reduced path (sparse, few modes), several base-motion components and
        # the implicit integrator are evaluated step by step. [[constraints]]: a point where
        # one fails is a failed evaluation.
        self.constraints = constraints_of(case)
        derive = self.model.structure.derive if self._runner is None else None
        #: The model's fields that are expressions, appended (as physical values) to the
        #: points the compiled evaluator takes (:meth:`compiled_rows`).
        self.derived_fields = tuple(derive.expressions) if derive is not None else ()
        self.compiled = (bool(compiled) and self._runner is None
                         and self.model.structure.dofs_per_node != 6
                         and self.model.reduced is None
                         and not self.model.components and self.model.method != "implicit"
                         # the support groups' evaluator takes no derived fields
                         and not (self.model.groups and self.derived_fields))
        self._evaluators: dict[int, Evaluator] = {}
        score = experiment.score
        self.objective = ErrorFunction(
            experiment.target[score],
            t=experiment.t[score],
            weights=experiment.weights,
            experimental_parameters=(
                experiment.quantity == "displacement" and case.objective.experimental_parameters
            ),
        )

    @property
    def name(self) -> str:
        return self.experiment.name

    # What the compiled evaluator reads of its problem (femupdate.evaluation.Evaluator).

    @property
    def structure(self) -> Any:
        return self.model.structure

    @property
    def method(self) -> str:
        return self.model.method

    @property
    def direction(self) -> str:
        return self.model.direction

    @property
    def substeps(self) -> int:
        return self.model.substeps

    @property
    def outputs(self) -> np.ndarray:
        return self.model.outputs

    @property
    def _r_out(self) -> np.ndarray:
        return self.model.influence

    @property
    def evaluator(self) -> Evaluator:
        """The compiled evaluator, built at first use in each process and thread (it owns its
        buffers: threads of one process, e.g. a Dask worker's, each get their own)."""
        key = threading.get_ident()
        evaluator = self._evaluators.get(key)
        if evaluator is None:
            from femupdate.evaluation import evaluator_for

            evaluator = self._evaluators[key] = evaluator_for(self)
        return evaluator

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_evaluators": {}}  # buffers: rebuilt where unpickled

    def compiled_rows(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The search points ``X`` (k, n) as the compiled evaluator takes them, with the
        derived fields' values appended, and which of them satisfy the constraints (the
        others are failed evaluations, said step by step)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        inside = np.ones(X.shape[0], dtype=bool)
        if not (self.derived_fields or self.constraints):
            return X, inside
        # physical values as Case.to_physical computes them (the step-by-step path's bits),
        # a column per parameter
        env: dict[str, Any] = {p.name: np.array([p.to_physical(float(v)) for v in X[:, i]])
                               for i, p in enumerate(self.case.parameters)}
        for constraint in self.constraints:
            inside &= constraint.holds(env)
        out = np.empty((X.shape[0], X.shape[1] + len(self.derived_fields)))
        out[:, :X.shape[1]] = X
        for j, key in enumerate(self.derived_fields, start=X.shape[1]):
            out[:, j] = self.model.structure.derive.expressions[key](env)
        return out, inside

    def phi_at(self, x: np.ndarray) -> float:
        """φ at search point ``x``: compiled when it can be; a failed evaluation is then
        repeated step by step, which says why (``last_failure``)."""
        if not self.compiled:
            return self.phi_reference(x)
        if self.derived_fields or self.constraints:
            rows, inside = self.compiled_rows(x)
            phi = self.evaluator(rows[0]) if inside[0] else math.inf
        else:
            phi = self.evaluator(x)
        if not math.isfinite(phi):
            return self.phi_reference(x)
        self.last_failure = None
        return phi

    def phi_batch(self, X: np.ndarray) -> np.ndarray:
        """φ at every row of ``X``: one compiled loop, bit for bit the single calls."""
        if not self.compiled:
            return np.array([self.phi_reference(x) for x in X])
        if self.derived_fields or self.constraints:
            rows, inside = self.compiled_rows(X)
            out = np.full(rows.shape[0], math.inf)
            out[inside] = self.evaluator.batch(rows[inside])
        else:
            out = self.evaluator.batch(X)
        for i in np.flatnonzero(~np.isfinite(out)):  # why they failed, step by step
            out[i] = self.phi_reference(X[i])
        return out

    def residuals_at(self, x: np.ndarray) -> np.ndarray:
        """The residual vector at search point ``x``: compiled when it can be, else (and for
        a failed evaluation, which then says why) step by step."""
        return self.residuals_rows(np.asarray(x, dtype=float)[None, :])[0]

    def residuals_rows(self, X: np.ndarray, out: np.ndarray | None = None
                       ) -> list[np.ndarray]:
        """:meth:`residuals_at` of every row of ``X``, in order, each bit for bit its single
        call (the compiled evaluator runs several rows per call where it can). With ``out``
        (k, m), each vector is written into its row as it comes (the list then holds the rows
        of ``out``: no k vectors held besides)."""
        rows: Any = [None] * X.shape[0]
        if self.compiled and (self.derived_fields or self.constraints):
            ext, inside = self.compiled_rows(X)
            computed = iter(self.evaluator.residuals_batch(ext[inside]))
            rows = (next(computed) if ok else None for ok in inside)
        elif self.compiled:
            rows = self.evaluator.residuals_batch(X)
        result = []
        for i, (x, r) in enumerate(zip(X, rows, strict=True)):
            if r is None:  # step by step, which also says why a failed evaluation failed
                r = self.residuals(self.case.to_physical(x))
            else:
                self.last_failure = None
            if out is not None:
                out[i] = r
                r = out[i]
            result.append(r)
        return result

    def phi_reference(self, x: np.ndarray) -> float:
        """φ at search point ``x`` through the simulator, the prediction and the error
        function, step by step (what the compiled evaluator is tested against)."""
        return self.phi(self.case.to_physical(np.asarray(x, dtype=float)))

    def simulate(self, values: Mapping[str, float]) -> Response:
        """Response of the model at ``values`` to the trial's base motion, at its outputs.

        An external model's response holds what it gives (absolute accelerations or relative
        displacements; NaN in the other fields); its failure raises ``EvaluationError``.
        """
        if self._runner is None:
            return self.model.simulate(values, self._ag, self.experiment.dt)
        out = self._runner.predict(values)
        nan = np.full_like(out, np.nan)
        t = np.arange(out.shape[0]) * self.experiment.dt
        if self._runner.model.quantity == "acceleration":
            return Response(t, nan, nan, out)
        return Response(t, out, nan, nan.copy())

    def frequencies(self, values: Mapping[str, float]) -> np.ndarray:
        """Undamped natural frequencies (Hz) of the model at ``values`` (friction elements
        stuck); an external model's own, or none."""
        if self._runner is None and self.model.reduced is not None:  # no dense eigenproblem
            return self.model.reduced.frequencies(values, self.experiment.dt)
        if self._runner is None:
            return natural_frequencies(self.model.system(values)).freqs_hz
        freqs = self._runner.frequencies(values)
        return np.empty(0) if freqs is None else freqs

    def close(self) -> None:
        """Stop the external model's processes in this process (nothing for femupdate's)."""
        if self._runner is not None:
            self._runner.close()

    def _filtered(self, x: np.ndarray) -> np.ndarray:
        """The measured data's filters (high-pass, low-pass), applied to a prediction when
        ``self.filter``."""
        if not self.filter:
            return x
        pre = self.case.preprocess
        return signal.band(x, 1.0 / self.experiment.dt, pre.highpass_hz, pre.lowpass_hz,
                           highpass_order=pre.highpass_order, lowpass_order=pre.lowpass_order,
                           zero_phase=pre.zero_phase)

    def prediction(self, response: Response, ag: np.ndarray | None = None) -> np.ndarray:
        """What the error function compares, from a response, over the whole trial.

        Displacements relative to the base: by default the model's relative accelerations
        integrated twice by the trapezoidal rule, exactly as the measured ones were
        (``[objective] integrate_prediction``), else the model's displacements; or absolute
        accelerations. Filtered first when the model's input was not (``self.filter``).
        ``ag``: the base record that drove ``response``, when not the trial's.
        """
        base = self._ag if ag is None else ag
        if self.integrate:
            relative = response.acceleration - self.base_share(base)
            return signal.integrate_twice(self._filtered(relative), self.experiment.dt)
        if self.experiment.quantity == "displacement":
            return self._filtered(response.displacement
                                  - self.model.recorded_share(base, self.experiment.dt))
        return self._filtered(response.acceleration - self.model.recorded_share(base))

    def base_share(self, ag: np.ndarray) -> np.ndarray:
        """The base motion's share of each channel's acceleration as recorded: the table's
        (influence vector), or a support group's (:meth:`CaseModel.recorded_share`)."""
        return self.model.base_share(ag)

    def prediction_driven_by(self, values: Mapping[str, float], ag: np.ndarray
                             ) -> np.ndarray:
        """The prediction (every sample, as :meth:`prediction`) of femupdate's own model at
        ``values`` driven by the base record ``ag`` instead of the trial's, ``ag`` as the
        model takes it (unfiltered when ``self.filter``): how a change of the table's record
        reaches the prediction (the errors-in-variables error model of the benchmarks)."""
        if self._runner is not None:
            raise ConfigError(f"trial {self.name!r}: an external model runs the trial's own "
                              "record only (allowed: femupdate's own models)")
        ag = np.asarray(ag, dtype=float)
        return self.prediction(self.model.simulate(values, ag, self.experiment.dt), ag)

    def scored(self, prediction: np.ndarray) -> np.ndarray:
        """The samples of a prediction the error function scores."""
        return prediction[self.experiment.score]

    def phi_against(self, prediction: np.ndarray, reference: np.ndarray) -> float:
        """φ of a scored ``prediction`` with another scored prediction, ``reference``, as the
        measured target: this trial's error function otherwise (its weights and, for
        displacements, the fitted offset and drift)."""
        own = self.objective
        return float(ErrorFunction(reference, t=own.t, weights=own.weights, kind=own.kind,
                                   experimental_parameters=own.with_experimental_parameters)(
                                       prediction))

    def _scored_prediction(self, values: Mapping[str, float]) -> np.ndarray | None:
        """The scored prediction, or None for a failed simulation (``last_failure`` says why:
        an unstable step, a divergence, an external model's error, a failed constraint)."""
        why, response = first_violation(self.constraints, values), None
        try:
            response = None if why else self.simulate(values)
        except SimulationError as exc:
            why = str(exc)
        except ModelError as exc:  # with derived fields: a value out of its range here
            if not (self.derived_fields or self.constraints):
                raise
            why = str(exc)
        if response is not None and response.diverged:
            why = "the simulation diverged"
        self.last_failure = None if why is None else f"trial {self.name!r}: {why}"
        return None if why else self.scored(self.prediction(response))

    def phi(self, values: Mapping[str, float]) -> float:
        """φ of the trial at physical parameter values (inf for a failed simulation)."""
        prediction = self._scored_prediction(values)
        if prediction is None:
            return math.inf
        phi = self.objective(prediction)
        if not math.isfinite(phi):
            self.last_failure = f"trial {self.name!r}: the processed prediction is not finite"
        return phi

    def per_channel(self, values: Mapping[str, float]) -> np.ndarray:
        """Each channel's error at physical parameter values (inf for a failed simulation)."""
        prediction = self._scored_prediction(values)
        if prediction is None:
            return np.full(self.objective.n_channels, np.inf)
        return self.objective.per_channel(prediction)

    def residuals(self, values: Mapping[str, float]) -> np.ndarray:
        """The trial's residual vector (φ = ‖r‖²); all inf for a failed simulation."""
        prediction = self._scored_prediction(values)
        if prediction is None:
            return np.full(self.objective.target.size, np.inf)
        return self.objective.residuals(prediction)


class UpdateProblem:
    """φ(x) of a case against its processed measurements.

    Parameters
    ----------
    case : Case
        The validated case.
    experiments : Experiment or sequence of Experiment
        The processed data of its trials (:func:`femupdate.trials.experiment.load_experiments`);
        trials with ``role = "validate"`` are kept in ``trials`` and never fitted.
    compiled : bool or None
        As :class:`TrialProblem`'s, for every trial.
    """

    def __init__(self, case: Case, experiments: Experiment | Sequence[Experiment], *,
                 compiled: bool | None = None) -> None:
        if isinstance(experiments, Experiment):
            experiments = [experiments]
        self.case = case
        self.trials = [TrialProblem(case, e, compiled=compiled) for e in experiments]
        self.fitted = [t for t in self.trials if t.experiment.role == "fit"]
        if not self.fitted:
            raise ConfigError(f"{case.label}: no trial to fit (every trial has role = "
                              "\"validate\") (allowed: at least one trial with role = \"fit\")")
        total = sum(t.experiment.weight for t in self.fitted)
        self._shares = [t.experiment.weight / total for t in self.fitted]
        #: Fitted trials (indices into ``fitted``) simulated once per point: windows of one
        #: record (:mod:`femupdate.evaluation.shared`); each other trial a group of its own.
        self.shared_records = [[i] for i in range(len(self.fitted))]
        first = self.fitted[0]  # derived fields and constraints: each trial on its own
        if sum(t.compiled for t in self.fitted) > 1 and not (first.derived_fields
                                                            or first.constraints):
            from femupdate.evaluation import shared

            self.shared_records = shared.shared_groups(self.fitted)

    @property
    def names(self) -> tuple[str, ...]:
        return self.case.parameter_names

    @property
    def bounds(self) -> list[tuple[float, float]]:
        return self.case.bounds

    # The first fitted trial, for the callers of a one-trial case.

    @property
    def experiment(self) -> Experiment:
        return self.fitted[0].experiment

    @property
    def objective(self) -> ErrorFunction:
        return self.fitted[0].objective

    @property
    def model(self) -> CaseModel:
        return self.fitted[0].model

    def values(self, x: np.ndarray) -> dict[str, float]:
        """Physical parameter values of search-space point ``x``."""
        return self.case.to_physical(x)

    def _physical(self, x: Point) -> Mapping[str, float]:
        return x if isinstance(x, Mapping) else self.values(np.asarray(x, dtype=float))

    def system(self, x: Point) -> System:
        """The assembled model at search point ``x`` (or at physical values, a mapping)."""
        return self.fitted[0].model.system(self._physical(x))

    def simulate(self, x: Point) -> Response:
        """Response of the model at ``x`` to the first fitted trial's base motion."""
        return self.fitted[0].simulate(self._physical(x))

    def prediction(self, response: Response) -> np.ndarray:
        """What the first fitted trial's error function compares, from its response."""
        return self.fitted[0].prediction(response)

    def __call__(self, x: np.ndarray) -> float:
        if isinstance(x, Mapping):
            values = self._physical(x)
            return self._combined([t.phi(values) for t in self.fitted])
        x = np.asarray(x, dtype=float)
        if len(self.shared_records) < len(self.fitted):
            return self._combined(list(self._trial_phis(x[None, :])[:, 0]))
        return self._combined([t.phi_at(x) for t in self.fitted])

    def _combined(self, phis: Sequence[float]) -> float:
        """φ of the case from its fitted trials' (their weighted mean)."""
        if len(phis) == 1:
            return phis[0]
        return math.fsum(share * phi for share, phi in zip(self._shares, phis, strict=True))

    def evaluate_batch(self, X: np.ndarray, *, threads: int = 1) -> np.ndarray:
        """φ of every row of ``X`` (k, n), each trial's in one compiled loop: bit for bit k
        single calls. ``threads`` > 1 splits the rows over the threads of a pool kept for the
        process (:func:`femupdate._parallel.thread_pool`), each thread with its own
        evaluators (the compiled loop releases the GIL); the values are the same."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        return _over_threads(self._phi_rows, X, threads)

    def _phi_rows(self, X: np.ndarray) -> np.ndarray:
        """φ of the rows of X in this thread (what a pool thread runs: never the pool again)."""
        phis = self._trial_phis(X)
        return np.array([self._combined(phis[:, i]) for i in range(X.shape[0])])

    def _trial_phis(self, X: np.ndarray) -> np.ndarray:
        """φ of each fitted trial at the rows of X (n_fitted, k): a shared record simulated
        once per row (:mod:`femupdate.evaluation.shared`)."""
        out = np.empty((len(self.fitted), X.shape[0]))
        for group in self.shared_records:
            trials = [self.fitted[i] for i in group]
            if len(trials) == 1:
                out[group[0]] = trials[0].phi_batch(X)
            else:
                from femupdate.evaluation import shared

                out[group] = shared.phi_rows(trials, X)
        return out

    def _trial_residual_rows(self, X: np.ndarray, blocks: Sequence[np.ndarray] | None = None
                             ) -> list[list[np.ndarray]]:
        """Each fitted trial's residual vectors at the rows of X (``out[t][i]``), a shared
        record simulated once per row; with ``blocks`` (one (k, m_t) array per trial), written
        into their rows as they come."""
        out: list[list[np.ndarray]] = [[] for _ in self.fitted]
        for group in self.shared_records:
            trials = [self.fitted[i] for i in group]
            into = None if blocks is None else [blocks[i] for i in group]
            if len(trials) == 1:
                rows = [trials[0].residuals_rows(X, None if into is None else into[0])]
            else:
                from femupdate.evaluation import shared

                rows = shared.residual_rows(trials, X, into)
            for i, trial_rows in zip(group, rows, strict=True):
                out[i] = trial_rows
        return out

    def residuals_batch(self, X: np.ndarray, *, threads: int = 1) -> np.ndarray:
        """The residual vectors of every row of ``X`` (k, n) as the rows of a (k, m) array,
        each the single call's bit for bit: one compiled evaluation per row, or per group of
        rows with the friction kernel in SIMD lanes (each point's differences read out before
        the next overwrite them). ``threads`` as in :meth:`evaluate_batch`: the columns of a
        finite-difference Jacobian on several cores of one process."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        rows = np.empty((X.shape[0], sum(t.objective.target.size for t in self.fitted)))
        if threads <= 1 or X.shape[0] <= 1:
            self._residual_rows(X, rows)
        else:  # each thread writes its rows' slice (no stacking of the parts)
            parts = np.array_split(np.arange(X.shape[0]), min(threads, X.shape[0]))
            list(thread_pool(threads).map(
                lambda i: self._residual_rows(X[i[0]:i[-1] + 1], rows[i[0]:i[-1] + 1]), parts))
        failed = np.flatnonzero(~np.all(np.isfinite(rows), axis=1))
        if failed.size and (failed[-1] != len(X) - 1 or threads > 1):
            self.residuals(X[failed[-1]])  # so that last_failure says why (a later row cleared it)
        return rows

    def _residual_rows(self, X: np.ndarray, out: np.ndarray) -> None:
        """The residual vectors of the rows of X into the rows of ``out``, in this thread (a
        pool thread's task): each trial's written straight into its columns, then scaled in
        place as :meth:`_joined` scales them (no per-row concatenation, no stacking copy)."""
        blocks = _column_blocks(out, [t.objective.target.size for t in self.fitted])
        self._trial_residual_rows(X, blocks)
        if len(blocks) > 1:
            _scale_blocks(blocks, self._shares)

    def phi_reference(self, x: np.ndarray) -> float:
        """φ at search point ``x``, step by step (the compiled evaluator's reference)."""
        x = np.asarray(x, dtype=float)
        return self._combined([t.phi_reference(x) for t in self.fitted])

    @property
    def compiled(self) -> bool:
        """Whether every fitted trial is evaluated by the compiled evaluator."""
        return all(t.compiled for t in self.fitted)

    @property
    def parallel_batches(self) -> bool:
        """Whether ``threads`` > 1 runs the rows of :meth:`evaluate_batch` and
        :meth:`residuals_batch` in parallel: every fitted trial compiled (its loops release
        the GIL; the step-by-step path and an external model's exchanges hold it)."""
        return self.compiled

    @property
    def evaluator(self) -> Evaluator:
        """The first fitted trial's compiled evaluator (in this thread)."""
        return self.fitted[0].evaluator

    @property
    def last_failure(self) -> str | None:
        """Why the last evaluation was inf (the first failed trial's reason), or None."""
        return next((t.last_failure for t in self.fitted if t.last_failure), None)

    def evaluate(self, x: np.ndarray) -> Evaluation:
        """φ at ``x``, and why it is inf when the evaluation failed, and how long it took."""
        start = time.perf_counter()
        phi = self(x)
        seconds = time.perf_counter() - start
        if math.isfinite(phi):
            return Evaluation(phi, None, seconds)
        return Evaluation(math.inf, self.last_failure or "φ is not finite", seconds)

    def frequencies(self, x: Point) -> np.ndarray:
        """Natural frequencies (Hz) of the model at ``x``."""
        return self.fitted[0].frequencies(self._physical(x))

    def close(self) -> None:
        """Stop the external model's processes, if any, in this process."""
        for trial in self.trials:
            trial.close()

    def residuals(self, x: Point) -> np.ndarray:
        """The residual vector r(x) of every fitted trial, with φ(x) = ‖r‖² to rounding: at a
        search point compiled when it can be, at physical values (a mapping) step by step."""
        if isinstance(x, Mapping):
            parts = [t.residuals(x) for t in self.fitted]
        else:
            x = np.asarray(x, dtype=float)
            parts = [rows[0] for rows in self._trial_residual_rows(x[None, :])]
        return self._joined(parts)

    def _joined(self, parts: Sequence[np.ndarray]) -> np.ndarray:
        """r of the case from its fitted trials' (each scaled by the square root of its
        share of φ)."""
        if len(parts) == 1:
            return parts[0]
        return np.concatenate([math.sqrt(share) * r
                               for share, r in zip(self._shares, parts, strict=True)])


def _column_blocks(out: np.ndarray, widths: Sequence[int]) -> list[np.ndarray]:
    """Views of consecutive column blocks of ``out`` (k, Σ widths), one per trial."""
    edges = np.cumsum([0, *widths])
    if edges[-1] != out.shape[1]:
        raise ValueError(f"{out.shape[1]} columns for trials of {list(widths)} residuals")
    return [out[:, a:b] for a, b in itertools.pairwise(edges)]


def _scale_blocks(blocks: Sequence[np.ndarray], shares: Sequence[float]) -> None:
    """Each trial's rows times the square root of its share of φ, in place: the bits of
    :meth:`UpdateProblem._joined`'s ``sqrt(share) * r``."""
    for block, share in zip(blocks, shares, strict=True):
        np.multiply(block, math.sqrt(share), out=block)


def _over_threads(rows_of: Callable[[np.ndarray], np.ndarray], X: np.ndarray,
                  threads: int) -> np.ndarray:
    """``rows_of(X)``, its rows split over ``threads`` threads of the process's kept pool
    when there are several (the results stacked in order)."""
    if threads <= 1 or X.shape[0] <= 1:
        return rows_of(X)
    parts = np.array_split(X, min(threads, X.shape[0]))
    return np.concatenate(list(thread_pool(threads).map(rows_of, parts)))


def _check_external(case: Case, experiment: Experiment, quantity: str) -> None:
    """What an external model gives must give what the error function compares."""
    where = "model.python" if case.model.python is not None else "model.opensees"
    if experiment.quantity == "acceleration" and quantity != "acceleration":
        raise ConfigError(f"{case.label}: {where}.quantity: got 'displacement' but the "
                          "objective compares accelerations (allowed: 'acceleration', or "
                          "objective.quantity = 'displacement')")
    if (experiment.quantity == "displacement" and quantity == "acceleration"
            and not case.objective.integrate_prediction):
        raise ConfigError(f"{case.label}: objective.integrate_prediction: got false with a "
                          "model giving accelerations: its displacements can only be "
                          "integrated (allowed: true, or a model with quantity = "
                          "'displacement')")

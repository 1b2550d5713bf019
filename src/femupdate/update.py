"""The error function of a model-updating case: parameters → model → simulation → φ.

``UpdateProblem(case, experiment)`` is a picklable callable ``φ(x)`` on the search space of the
case (log10 values for log-scale parameters), ready for :func:`femupdate.minimize` and for
repeated runs in worker processes.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np

from femupdate.case import Case, build_structure
from femupdate.data import signal
from femupdate.errors import SimulationError
from femupdate.experiment import Experiment
from femupdate.model.system import System
from femupdate.objective import Objective
from femupdate.simulate import prepare
from femupdate.simulate.response import Response

if TYPE_CHECKING:
    from concurrent.futures import ThreadPoolExecutor

    from femupdate.evaluation import Evaluator


#: Environment variable: ``reference`` makes every UpdateProblem built without ``compiled``
#: evaluate φ step by step (simulator, prediction, objective), to time or check the compiled
#: evaluator against it.
EVALUATOR_ENV = "FEMUPDATE_EVALUATOR"


class UpdateProblem:
    """φ(x) of a case against its processed measurement.

    Parameters
    ----------
    case : Case
        The validated case.
    experiment : Experiment
        The processed measured data (:func:`femupdate.experiment.load_experiment`).
    compiled : bool or None
        Evaluate φ with the compiled evaluator (:mod:`femupdate.evaluation`) or step by step
        (`phi_reference`); None: compiled unless ``FEMUPDATE_EVALUATOR=reference``.
    """

    def __init__(self, case: Case, experiment: Experiment, *,
                 compiled: bool | None = None) -> None:
        if compiled is None:
            compiled = os.environ.get(EVALUATOR_ENV, "compiled") != "reference"
        self.compiled = bool(compiled)
        self.case = case
        self.experiment = experiment
        self.structure = build_structure(case.model)
        self.direction = case.model.excitation_direction
        self.method = case.simulation_method
        self.substeps = 1 if self.method == "exact" else case.preprocess.substeps
        self.integrate = (experiment.quantity == "displacement"
                          and case.objective.integrate_prediction)
        # A nonlinear model is driven by the record as measured and its prediction filtered as
        # the data were: the high-pass does not commute with it (Case.filters_prediction).
        self.filter = case.filters_prediction and experiment.ag_unfiltered is not None
        self._ag = experiment.ag_unfiltered if self.filter else experiment.ag
        assert case.data is not None  # an Experiment exists only for cases with data
        self.outputs = np.array(
            [self.structure.dof_index(c.node, c.dof) for c in case.data.outputs], dtype=np.int64
        )
        self._r_out = self.structure.influence_vector(self.direction)[self.outputs]
        self._evaluators: dict[int, Evaluator] = {}
        self._pool: ThreadPoolExecutor | None = None  # evaluate_batch's threads, when asked
        self.objective = Objective(
            experiment.target,
            t=experiment.t,
            weights=experiment.weights,
            experimental_parameters=(
                experiment.quantity == "displacement" and case.objective.experimental_parameters
            ),
        )

    @property
    def names(self) -> tuple[str, ...]:
        return self.case.parameter_names

    @property
    def bounds(self) -> list[tuple[float, float]]:
        return self.case.bounds

    def values(self, x: np.ndarray) -> dict[str, float]:
        """Physical parameter values of search-space point ``x``."""
        return self.case.to_physical(x)

    def system(self, x: np.ndarray | Mapping[str, float]) -> System:
        """The assembled model at search point ``x`` (or at physical values, a mapping)."""
        values = x if isinstance(x, Mapping) else self.values(np.asarray(x, dtype=float))
        return self.structure.assemble(values, direction=self.direction)

    def simulate(self, x: np.ndarray | Mapping[str, float]) -> Response:
        """Response of the model at ``x`` to the measured base motion, at the output DOFs."""
        sim = prepare(self.system(x), self.experiment.dt, method=self.method,
                      outputs=self.outputs, substeps=self.substeps)
        return sim.run(self._ag)

    def _highpass(self, x: np.ndarray) -> np.ndarray:
        """The measured data's high-pass, applied to a prediction when ``self.filter``."""
        if not self.filter:
            return x
        pre = self.case.preprocess
        return signal.highpass(x, 1.0 / self.experiment.dt, pre.highpass_hz,
                               order=pre.highpass_order, zero_phase=pre.zero_phase)

    def prediction(self, response: Response) -> np.ndarray:
        """What the objective compares, from a response.

        Displacements relative to the base: by default the model's relative accelerations
        integrated twice by the trapezoidal rule, exactly as the measured ones were
        (``[objective] integrate_prediction``), else the model's displacements; or absolute
        accelerations. High-passed first when the model's input was not (``self.filter``).
        """
        if self.integrate:
            relative = response.acceleration - np.outer(self._ag, self._r_out)
            return signal.integrate_twice(self._highpass(relative), self.experiment.dt)
        if self.experiment.quantity == "displacement":
            return self._highpass(response.displacement)
        return self._highpass(response.acceleration)

    # -- φ: compiled (femupdate.evaluation), and the reference it is tested against ----------

    def __call__(self, x: np.ndarray) -> float:
        """φ(x), by the compiled evaluator (equal to `phi_reference` to rounding)."""
        if not self.compiled:
            return self.phi_reference(x)
        return self.evaluator(x)

    def evaluate_batch(self, X: np.ndarray, *, threads: int = 1) -> np.ndarray:
        """φ of every row of ``X`` (k, n) in one compiled loop: bit for bit k single calls.

        ``threads`` > 1 splits the rows over that many threads, each with its own evaluator
        (the compiled loop releases the GIL); the values are the same.
        """
        X = np.asarray(X, dtype=float)
        if not self.compiled:
            return np.array([self.phi_reference(x) for x in X])
        if threads <= 1 or X.shape[0] < 2:
            return self.evaluator.batch(X)
        parts = np.array_split(X, min(threads, X.shape[0]))
        if self._pool is None or self._pool._max_workers < len(parts):
            from concurrent.futures import ThreadPoolExecutor

            self._pool = ThreadPoolExecutor(len(parts), thread_name_prefix="femupdate-phi")
        return np.concatenate(list(self._pool.map(lambda part: self.evaluator.batch(part),
                                                  parts)))

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

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_evaluators"] = {}  # buffers, rebuilt where the problem is unpickled
        state["_pool"] = None
        return state

    def phi_reference(self, x: np.ndarray) -> float:
        """φ(x) through the simulator, the prediction and the objective, step by step."""
        try:
            response = self.simulate(x)
        except SimulationError:
            # An unstable integration step for these parameter values: a failed step.
            return float("inf")
        if response.diverged:
            return float("inf")
        return self.objective(self.prediction(response))

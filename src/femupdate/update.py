"""The error function of a model-updating case: parameters → model → simulation → φ.

``UpdateProblem(case, experiment)`` is a picklable callable ``φ(x)`` on the search space of the
case (log10 values for log-scale parameters), ready for :func:`femupdate.minimize` and for
repeated runs in worker processes.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from femupdate.case import Case, build_structure
from femupdate.data import signal
from femupdate.errors import SimulationError
from femupdate.experiment import Experiment
from femupdate.model.system import System
from femupdate.objective import Objective
from femupdate.simulate import prepare
from femupdate.simulate.response import Response


class UpdateProblem:
    """φ(x) of a case against its processed measurement.

    Parameters
    ----------
    case : Case
        The validated case.
    experiment : Experiment
        The processed measured data (:func:`femupdate.experiment.load_experiment`).
    """

    def __init__(self, case: Case, experiment: Experiment) -> None:
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

    def _response(self, x: np.ndarray | Mapping[str, float]) -> Response | None:
        """The response at ``x``, or None when the simulation failed or diverged."""
        try:
            response = self.simulate(x)
        except SimulationError:
            # An unstable integration step for these parameter values: a failed step.
            return None
        return None if response.diverged else response

    def __call__(self, x: np.ndarray) -> float:
        response = self._response(x)
        if response is None:
            return float("inf")
        return self.objective(self.prediction(response))

    def residuals(self, x: np.ndarray | Mapping[str, float]) -> np.ndarray:
        """Residuals r with φ(x) = ‖r‖² to rounding (``Objective.residuals``), at search point
        ``x`` or at physical values (a mapping); all inf when the simulation failed."""
        response = self._response(x)
        if response is None:
            return np.full(self.objective.target.size, np.inf)
        return self.objective.residuals(self.prediction(response))

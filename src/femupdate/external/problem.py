"""φ(x) of an external model against a processed measurement.

:class:`ExternalProblem` is :class:`femupdate.update.UpdateProblem` with the simulation replaced
by an :class:`~femupdate.external.protocol.ExternalModel`: the same measured data, the same
processing of the prediction (relative accelerations integrated twice by the trapezoidal rule,
high-pass when the model's input was not filtered) and the same objective. It is a picklable
callable for :func:`femupdate.minimize` and the runner; :meth:`~ExternalProblem.evaluate`
also says why an evaluation failed.
"""

from __future__ import annotations

import time
import uuid
from collections.abc import Mapping, Sequence
from typing import Any, Protocol

import numpy as np

from femupdate.data import signal
from femupdate.errors import ConfigError
from femupdate.experiment import Experiment
from femupdate.external.isolation import START_TIMEOUT_S, IsolatedModel, checkout, close_all
from femupdate.external.protocol import (
    Evaluation,
    EvaluationError,
    ExternalModel,
    check_prediction,
)
from femupdate.objective import Objective

__all__ = ["ExternalProblem", "SearchSpace", "residuals_of"]


class SearchSpace(Protocol):
    """The parameters: names, search bounds and the map to physical values (a ``Case``)."""

    @property
    def parameter_names(self) -> tuple[str, ...]: ...

    @property
    def bounds(self) -> list[tuple[float, float]]: ...

    def to_physical(self, x: Sequence[float] | np.ndarray) -> dict[str, float]: ...


class ExternalProblem:
    """φ of an external model on the search space of ``space``.

    Parameters
    ----------
    model : ExternalModel
        The adapter.
    experiment : Experiment
        The processed measured data; its output channels are the model's outputs, in order.
    space : SearchSpace
        Parameter names, bounds and ``to_physical`` (a validated ``Case`` is one).
    timeout : float or None
        Seconds one prediction may take (needs ``isolate``); None: no limit.
    isolate : bool
        Evaluate in a child process (one per calling process, reused; killable). False: in
        this process, for quick trusted functions (no time-out then).
    integrate : bool
        With displacements and a model giving accelerations: integrate its relative
        accelerations twice as the measured ones were (``integrate_prediction``; the only way
        to get displacements from it).
    experimental_parameters : bool
        Fit the integration constants of each displacement channel.
    filter_prediction : bool
        Drive the model with the unfiltered base record and high-pass the prediction as the
        data were (a nonlinear model); needs the experiment's ``ag_unfiltered``.
    highpass : (float, int, bool) or None
        (cut-off Hz, order, zero phase) of the data's high-pass, for ``filter_prediction``.
    start_timeout : float
        Seconds a child process may take to load the model.

    Raises
    ------
    ConfigError
        Outputs that do not match the channels, a quantity that cannot give the one compared,
        a time-out without isolation.
    """

    def __init__(self, model: ExternalModel, experiment: Experiment, space: SearchSpace, *,
                 timeout: float | None = None, isolate: bool = True, integrate: bool = True,
                 experimental_parameters: bool = True, filter_prediction: bool = False,
                 highpass: tuple[float, int, bool] | None = None,
                 start_timeout: float = START_TIMEOUT_S) -> None:
        n_out = len(model.outputs)
        if n_out != len(experiment.channels):
            raise ConfigError(f"model.outputs: the model gives {n_out} outputs "
                              f"{list(model.outputs)}, the data {len(experiment.channels)} "
                              f"channels {list(experiment.channels)} (allowed: one output per "
                              "[[data.outputs]] channel, in the same order)")
        if experiment.quantity == "acceleration" and model.quantity != "acceleration":
            raise ConfigError("model.quantity: got 'displacement' but the objective compares "
                              "accelerations (allowed: 'acceleration', or objective.quantity = "
                              "'displacement')")
        if (experiment.quantity == "displacement" and model.quantity == "acceleration"
                and not integrate):
            raise ConfigError("objective.integrate_prediction: got false with a model giving "
                              "accelerations: its displacements can only be integrated "
                              "(allowed: true, or a model with quantity = 'displacement')")
        if timeout is not None and not isolate:
            raise ConfigError("model.timeout: a time-out needs the model in its own process "
                              "(allowed: isolate = true, or no time-out)")
        if filter_prediction and (experiment.ag_unfiltered is None or highpass is None):
            raise ConfigError("preprocess.filter_prediction: the data were not high-passed "
                              "(allowed: false, or preprocess.highpass_hz > 0)")
        self.model = model
        self.experiment = experiment
        self.space = space
        self.timeout = timeout
        self.isolate = bool(isolate)
        self.start_timeout = float(start_timeout)
        self.filter = bool(filter_prediction)
        self.highpass = highpass
        self.ag = experiment.ag_unfiltered if self.filter else experiment.ag
        assert self.ag is not None
        self.integrate = experiment.quantity == "displacement" and model.quantity == "acceleration"
        self._influence = np.asarray(model.influence, dtype=float)
        self.objective = Objective(
            experiment.target, t=experiment.t, weights=experiment.weights,
            experimental_parameters=(experiment.quantity == "displacement"
                                     and experimental_parameters))
        # Names this problem's child processes in every process it is pickled to.
        self.key = uuid.uuid4().hex
        self._prepared = False

    @classmethod
    def from_case(cls, case: Any, experiment: Experiment, model: ExternalModel,
                  **options: Any) -> ExternalProblem:
        """The problem of a validated case whose model is ``model`` (the case gives the
        objective and preprocessing settings; ``options`` as the constructor)."""
        pre = case.preprocess
        options.setdefault("integrate", case.objective.integrate_prediction)
        options.setdefault("experimental_parameters", case.objective.experimental_parameters)
        options.setdefault("filter_prediction", bool(
            case.preprocess.filter_prediction and experiment.ag_unfiltered is not None))
        options.setdefault("highpass", (pre.highpass_hz, pre.highpass_order, pre.zero_phase))
        return cls(model, experiment, case, **options)

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_prepared": False}

    # ------------------------------------------------------------------ search space

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.space.parameter_names)

    @property
    def bounds(self) -> list[tuple[float, float]]:
        return list(self.space.bounds)

    def values(self, x: np.ndarray | Mapping[str, float]) -> dict[str, float]:
        """Physical parameter values of search point ``x`` (a mapping is taken as values)."""
        if isinstance(x, Mapping):
            return {str(k): float(v) for k, v in x.items()}
        return self.space.to_physical(np.asarray(x, dtype=float))

    # ------------------------------------------------------------------ the model

    def _isolated(self) -> IsolatedModel:
        return IsolatedModel(self.model, self.ag, self.experiment.dt, timeout=self.timeout,
                             start_timeout=self.start_timeout)

    def _call(self, kind: str, values: dict[str, float]) -> np.ndarray | None:
        if self.isolate:
            with checkout(self.key, self._isolated) as worker:
                return worker.request(kind, values)
        if not self._prepared:
            self.model.prepare()  # ConfigError: raised, not a failed evaluation
            self._prepared = True
        try:
            if kind == "predict":
                return self.model.predict(values, self.ag.copy(), self.experiment.dt)
            return self.model.frequencies(values)
        except (ConfigError, EvaluationError):
            raise
        except Exception as exc:
            raise EvaluationError(f"{type(exc).__name__}: {exc}") from exc

    def predict(self, x: np.ndarray | Mapping[str, float]) -> np.ndarray:
        """The model's checked output at ``x`` (n_samples, n_outputs); EvaluationError if
        it failed."""
        raw = self._call("predict", self.values(x))
        return check_prediction(raw, self.ag.size, len(self.model.outputs),
                                where=f"model {self.model!r}")

    def frequencies(self, x: np.ndarray | Mapping[str, float]) -> np.ndarray | None:
        """The model's natural frequencies (Hz) at ``x``, or None if it gives none."""
        out = self._call("frequencies", self.values(x))
        return None if out is None else np.asarray(out, dtype=float)

    def close(self) -> None:
        """Stop this problem's child processes in this process."""
        close_all(self.key)

    # ------------------------------------------------------------------ φ

    def _highpass(self, y: np.ndarray) -> np.ndarray:
        if not self.filter or self.highpass is None:
            return y
        hz, order, zero_phase = self.highpass
        return signal.highpass(y, 1.0 / self.experiment.dt, hz, order=order,
                               zero_phase=zero_phase)

    def prediction(self, output: np.ndarray) -> np.ndarray:
        """What the objective compares, from the model's output (as UpdateProblem does)."""
        if self.integrate:
            relative = output - np.outer(self.ag, self._influence)
            return signal.integrate_twice(self._highpass(relative), self.experiment.dt)
        return self._highpass(output)

    def evaluate(self, x: np.ndarray | Mapping[str, float]) -> Evaluation:
        """φ at ``x`` and, when the evaluation failed (φ = inf), why.

        Raises only ConfigError (and MissingDependencyError): the model cannot be loaded.
        """
        t0 = time.perf_counter()
        try:
            phi = self.objective(self.prediction(self.predict(x)))
        except EvaluationError as exc:
            return Evaluation(float("inf"), str(exc), time.perf_counter() - t0)
        seconds = time.perf_counter() - t0
        if not np.isfinite(phi):
            return Evaluation(float("inf"), "the processed prediction is not finite", seconds)
        return Evaluation(phi, None, seconds)

    def __call__(self, x: np.ndarray) -> float:
        return self.evaluate(x).phi

    def residuals(self, x: np.ndarray | Mapping[str, float]) -> np.ndarray:
        """Residuals whose sum of squares is φ (:func:`residuals_of`), for least-squares
        solvers; EvaluationError if the model failed."""
        return residuals_of(self.objective, self.prediction(self.predict(x)))


def residuals_of(objective: Objective, prediction: np.ndarray) -> np.ndarray:
    """Residuals of ``prediction`` whose sum of squares is ``objective(prediction)``.

    Per channel ``√(w/Σw) (ŷ − ỹ) / ‖ỹ‖``, with ỹ the target corrected by its fitted
    integration constants (the target itself without them), channels one after the other.
    """
    target = objective.corrected_target(prediction)
    target = target[:, None] if target.ndim == 1 else target
    pred = prediction[:, None] if prediction.ndim == 1 else prediction
    w = objective.weights
    scale = np.sqrt(w / w.sum() / np.sum(target**2, axis=0))
    return ((pred - target) * scale).ravel(order="F")

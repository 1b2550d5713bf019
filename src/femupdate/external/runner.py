"""Predictions of an external model for one base motion: in its own process, or in this one.

:class:`ExternalRunner` is what a trial of a case with ``[model.python]`` or
``[model.opensees]`` calls instead of femupdate's integrators: the adapter's prediction,
checked (shape, finite values), from a child process that holds the loaded model (killable on
a time-out, isolated from its global state and crashes: :mod:`femupdate.external.isolation`)
or, for a quick trusted function, in this process. A failure of the model raises
:class:`~femupdate.external.protocol.EvaluationError` with its message: one failed evaluation.
"""

from __future__ import annotations

import uuid
from collections.abc import Mapping
from typing import Any

import numpy as np

from femupdate.errors import ConfigError
from femupdate.external.isolation import START_TIMEOUT_S, IsolatedModel, checkout, close_all
from femupdate.external.protocol import EvaluationError, ExternalModel, check_prediction

__all__ = ["ExternalRunner"]


class ExternalRunner:
    """An external model driven by one base motion (picklable; children stay behind).

    Parameters
    ----------
    model : ExternalModel
        The adapter.
    ag : ndarray (n,)
        Base acceleration, m/s², sampled every ``dt`` s.
    dt : float
        Sample interval, s.
    timeout : float or None
        Seconds one prediction may take (needs ``isolate``); None: no limit.
    isolate : bool
        Predict in a child process (one per calling process, reused; killable). False: in this
        process, for quick trusted functions.
    start_timeout : float
        Seconds a child may take to load the model.
    """

    def __init__(self, model: ExternalModel, ag: np.ndarray, dt: float, *,
                 timeout: float | None = None, isolate: bool = True,
                 start_timeout: float = START_TIMEOUT_S) -> None:
        if timeout is not None and not isolate:
            raise ConfigError("model.timeout: a time-out needs the model in its own process "
                              "(allowed: isolate = true, or no time-out)")
        self.model = model
        self.ag = np.asarray(ag, dtype=float)
        self.dt = float(dt)
        self.timeout = timeout
        self.isolate = bool(isolate)
        self.start_timeout = float(start_timeout)
        # Names this runner's child processes in every process it is pickled to.
        self.key = uuid.uuid4().hex
        self._prepared = False

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_prepared": False}

    def _isolated(self) -> IsolatedModel:
        return IsolatedModel(self.model, self.ag, self.dt, timeout=self.timeout,
                             start_timeout=self.start_timeout)

    def _call(self, kind: str, values: Mapping[str, float]) -> np.ndarray | None:
        if self.isolate:
            with checkout(self.key, self._isolated) as worker:
                return worker.request(kind, values)
        if not self._prepared:
            self.model.prepare()  # ConfigError: raised, not a failed evaluation
            self._prepared = True
        try:
            if kind == "predict":
                return self.model.predict(values, self.ag.copy(), self.dt)
            return self.model.frequencies(values)
        except (ConfigError, EvaluationError):
            raise
        except Exception as exc:
            raise EvaluationError(f"{type(exc).__name__}: {exc}") from exc

    def predict(self, values: Mapping[str, float]) -> np.ndarray:
        """The model's checked output (n_samples, n_outputs); EvaluationError if it failed."""
        raw = self._call("predict", dict(values))
        return check_prediction(raw, self.ag.size, len(self.model.outputs),
                                where=f"model {self.model!r}")

    def frequencies(self, values: Mapping[str, float]) -> np.ndarray | None:
        """The model's natural frequencies (Hz), or None if it gives none."""
        out = self._call("frequencies", dict(values))
        return None if out is None else np.asarray(out, dtype=float)

    def close(self) -> None:
        """Stop this runner's child processes in this process."""
        close_all(self.key)

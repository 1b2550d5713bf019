"""The adapter interface: what femupdate asks of a model it did not build.

An external model is anything that, given parameter values, the base acceleration and its time
step, returns the predicted channels. Everything after the prediction (processing, objective,
runs, store, report) is femupdate's as for the built-in model.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal, Protocol, runtime_checkable

import numpy as np

from femupdate.errors import SimulationError

__all__ = [
    "QUANTITIES",
    "Evaluation",
    "EvaluationError",
    "ExternalModel",
    "Quantity",
    "check_prediction",
]

Quantity = Literal["acceleration", "displacement"]
#: What a model may return: absolute accelerations, or displacements relative to the base.
QUANTITIES: tuple[str, ...] = ("acceleration", "displacement")


class EvaluationError(SimulationError):
    """One evaluation of a model failed; φ is then inf and the message says why."""


@runtime_checkable
class ExternalModel(Protocol):
    """A structural model femupdate drives through its predictions.

    Implementations hold only a description (module paths, file names, settings), so that
    they pickle cheaply to worker processes; whatever they load lives in the process that
    called :meth:`prepare` and is not pickled.

    Attributes
    ----------
    outputs : tuple of str
        Label of each predicted channel, as the model knows it (``"3.uy"``, ``"P1"``).
    quantity : {"acceleration", "displacement"}
        ``"acceleration"``: absolute accelerations (m/s²); ``"displacement"``: displacements
        relative to the base (m).
    influence : ndarray (n_outputs,)
        Displacement of each output for a unit rigid base displacement (1 for a translation
        along the base motion, 0 across it or for a rotation): turns absolute accelerations
        into relative ones.
    """

    outputs: tuple[str, ...]
    quantity: Quantity

    @property
    def influence(self) -> np.ndarray: ...

    def prepare(self) -> None:
        """Load what the model needs in this process (import the user's code).

        Raises ConfigError naming the field and value when it cannot. Called once per process
        before the first prediction; calling it again does nothing.
        """

    def predict(self, values: Mapping[str, float], ag: np.ndarray, dt: float) -> np.ndarray:
        """The predicted channels, shape (len(ag), n_outputs), under base acceleration ``ag``.

        ``ag`` (m/s²) is sampled every ``dt`` seconds and linear in between; the structure
        starts from rest. Any exception is one failed evaluation.
        """

    def frequencies(self, values: Mapping[str, float]) -> np.ndarray | None:
        """Undamped natural frequencies (Hz), lowest first, or None if the model has none."""


@dataclass(frozen=True)
class Evaluation:
    """φ at one candidate, and why it is inf when the evaluation failed.

    Attributes
    ----------
    phi : float
        The error function (inf for a failed evaluation).
    error : str or None
        What went wrong (None for a successful evaluation): the exception, the time-out,
        the bad shape or the first non-finite sample.
    seconds : float
        Wall time of the evaluation.
    """

    phi: float
    error: str | None = None
    seconds: float = 0.0

    @property
    def failed(self) -> bool:
        return self.error is not None


def check_prediction(prediction: object, n_samples: int, n_outputs: int, *,
                     where: str = "the model") -> np.ndarray:
    """The prediction as a finite float array (n_samples, n_outputs), or EvaluationError.

    A 1-D array is accepted for a single output.

    Parameters
    ----------
    prediction : array_like
        What the model returned.
    n_samples, n_outputs : int
        The expected shape.
    where : str
        Names the model in messages.
    """
    if np.iscomplexobj(prediction):  # a float conversion would drop the imaginary part
        raise EvaluationError(f"{where} returned complex values (allowed: real numbers, e.g. "
                              "the real part taken on purpose)")
    try:
        arr = np.asarray(prediction, dtype=float)
    except (TypeError, ValueError) as exc:
        raise EvaluationError(f"{where} returned {type(prediction).__name__}, not an array of "
                              f"numbers ({exc})") from None
    if arr.ndim == 1 and n_outputs == 1:
        arr = arr[:, None]
    if arr.shape != (n_samples, n_outputs):
        raise EvaluationError(f"{where} returned an array of shape {arr.shape}; expected "
                              f"(n_samples, n_outputs) = ({n_samples}, {n_outputs})")
    finite = np.isfinite(arr)
    if not finite.all():
        row, col = np.argwhere(~finite)[0]
        raise EvaluationError(f"{where} returned {arr[row, col]} at sample {row} of output "
                              f"{col} ({int((~finite).sum())} non-finite values)")
    return arr

"""Models femupdate did not build: the user's Python function, or an OpenSeesPy model.

An adapter (:class:`ExternalModel`) turns parameter values, the base acceleration and its time
step into the predicted channels; :class:`ExternalRunner` runs it for one base motion in a
child process (killable on a time-out, isolated from the model's global state and crashes).
A case names its model in ``[model.python]`` or ``[model.opensees]``; everything after the
prediction (processing, error function, runs, store, report) is femupdate's
(:class:`femupdate.problem.update.UpdateProblem`). A failed evaluation is φ = inf with its message.

Names are imported on first use: the worker process that holds a model imports only what the
model needs (a child starts faster).
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

_LAZY = {
    "Evaluation": "femupdate.external.protocol",
    "EvaluationError": "femupdate.external.protocol",
    "ExternalModel": "femupdate.external.protocol",
    "check_prediction": "femupdate.external.protocol",
    "load_function": "femupdate.external.loader",
    "parse_ref": "femupdate.external.loader",
    "PythonModel": "femupdate.external.python_model",
    "OpenSeesModel": "femupdate.external.opensees_model",
    "IsolatedModel": "femupdate.external.isolation",
    "ExternalRunner": "femupdate.external.runner",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'femupdate.external' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))

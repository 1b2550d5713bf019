"""A small synthetic problem and a user module that fails in every way on demand.

A module of its own (not conftest.py, of which the suite has several): pickled objects name it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from femupdate.case import Case, parse_case
from femupdate.problem.update import UpdateProblem
from femupdate.trials.experiment import Experiment

N_SAMPLES = 200
DT = 0.01

#: What ``model`` does for each value of the parameter "mode".
USER_CODE = '''
import os
import time

import numpy as np


def model(values, ag, dt):
    mode = round(values["mode"])
    if mode == 1:
        raise ValueError("negative stiffness in storey 2")
    if mode == 2:
        out = np.zeros((ag.size, 1))
        out[17, 0] = np.nan
        return out
    if mode == 3:
        return np.zeros((ag.size, 2))
    if mode == 4:
        time.sleep(120)
    if mode == 5:
        os._exit(7)
    if mode == 6:
        print("step 41: no convergence", flush=True)
        raise RuntimeError("diverged")
    return (values["a"] * ag)[:, None]


def fragile(values, ag, dt):
    if values["a"] > 3.5:
        raise ValueError("unstable above a = 3.5")
    return (values["a"] * ag)[:, None]


def frequencies(values):
    return [values["a"], 2 * values["a"]]


def helper_not_for_users():
    pass
'''


@dataclass(frozen=True)
class Space:
    """Named parameters, physical values searched directly; by default a gain ``a`` and the
    ``mode`` of failure of the user module (0: none)."""

    parameter_names: tuple[str, ...] = ("a", "mode")
    limits: tuple[tuple[float, float], ...] = ((0.0, 5.0), (0.0, 10.0))

    @property
    def bounds(self) -> list[tuple[float, float]]:
        return list(self.limits)

    def to_physical(self, x: Sequence[float] | np.ndarray) -> dict[str, float]:
        return dict(zip(self.parameter_names, map(float, x), strict=True))


def case_for(model: dict[str, Any], *, quantity: str = "acceleration", space: Space = Space(),
             channels: Sequence[str] = ("roof",), source: Path | None = None) -> Case:
    """A case whose ``[model]`` is ``model`` (``{"python": {...}}`` or ``{"opensees": ...}``);
    its ``[data]`` names the channels only: the experiments here are made in memory."""
    return parse_case({
        "case": {"name": "user"},
        "model": model,
        "parameters": [{"name": n, "lower": lo, "upper": hi}
                       for n, (lo, hi) in zip(space.parameter_names, space.limits, strict=True)],
        "data": {"format": "csv", "rate": 1 / DT, "input": {"file": "x.csv", "column": 0},
                 "outputs": [{"file": "x.csv", "column": i + 1, "name": c}
                             for i, c in enumerate(channels)]},
        "objective": {"quantity": quantity},
    }, source=source)


def problem_for(model: dict[str, Any], exp: Experiment | None = None, *,
                space: Space = Space(), source: Path | None = None) -> UpdateProblem:
    """φ of the case of ``model`` on the experiment ``exp`` (default :func:`experiment`)."""
    exp = exp or experiment()
    case = case_for(model, quantity=exp.quantity, space=space, channels=exp.channels,
                    source=source)
    return UpdateProblem(case, replace(exp, name=case.case.name))


def experiment(quantity: str = "acceleration") -> Experiment:
    """Base motion and a target: 2 × ag (accelerations), or ag integrated twice."""
    t = np.arange(N_SAMPLES) * DT
    ag = np.sin(2 * np.pi * 3.0 * t) * np.exp(-t)
    if quantity == "acceleration":
        target = (2.0 * ag)[:, None]
    else:  # relative displacement of a = 3 under ag, integrated as the data are
        from femupdate.data import signal

        target = signal.integrate_twice(((3.0 - 1.0) * ag)[:, None], DT) + 0.01 + 0.002 * t[:, None]
    return Experiment(t=t, ag=ag, accelerations=(2.0 * ag)[:, None], target=target,
                      quantity=quantity, channels=("roof",), weights=np.ones(1))



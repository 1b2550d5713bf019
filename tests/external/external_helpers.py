"""A small synthetic problem and a user module that fails in every way on demand.

A module of its own (not conftest.py, of which the suite has several): pickled objects name it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from femupdate.experiment import Experiment

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



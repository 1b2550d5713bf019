"""Bounded optimizers on the unit cube behind one loop, :func:`minimize`.

Methods by name (``METHODS``): ``"multistart-lm"`` (the default: multistart bounded
Levenberg–Marquardt), ``"ab"`` and ``"ib"`` (the paper's adaptive Beta sampling), ``"cmaes"``
(pycma, truncated Gaussian by resampling); others plug in with :func:`register_method`.
"""

from femupdate.optimize.base import Optimizer
from femupdate.optimize.beta import BetaSearch, beta_mode_variance, beta_parameters
from femupdate.optimize.minimize import (
    METHODS,
    MinimizeState,
    minimize,
    parse_bounds,
    register_method,
    start,
)
from femupdate.optimize.termination import Status

__all__ = [
    "METHODS",
    "BetaSearch",
    "MinimizeState",
    "Optimizer",
    "Status",
    "beta_mode_variance",
    "beta_parameters",
    "minimize",
    "parse_bounds",
    "register_method",
    "start",
]

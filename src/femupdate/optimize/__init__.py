"""Bounded optimizers on the unit cube behind one loop, :func:`minimize`.

Methods by name (``METHODS``): ``"ab"`` and ``"ib"`` (the paper's adaptive Beta sampling),
``"cmaes"`` (pycma, truncated Gaussian by resampling), ``"de"`` (scipy), ``"ga"`` (pymoo).
"""

from femupdate.optimize.base import Optimizer
from femupdate.optimize.beta import BetaSearch, beta_mode_variance, beta_parameters
from femupdate.optimize.minimize import METHODS, MinimizeState, minimize, parse_bounds, start
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
    "start",
]

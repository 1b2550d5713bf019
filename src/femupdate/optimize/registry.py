"""The optimizers by name: the product's four, and the plug-ins registered explicitly."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from femupdate.errors import ConfigError
from femupdate.optimize.base import Factory
from femupdate.optimize.beta import make_ab, make_ib
from femupdate.optimize.cmaes import make_cmaes
from femupdate.optimize.multistart import make_multistart_lm

__all__ = ["METHODS", "POPULATION_METHODS", "RESIDUAL_METHODS", "objective_for",
           "register_method"]

#: The optimizers by name: factories ``(n, rng, **options) -> Optimizer``. The product's four
#: are here; variants kept for comparison (benchmarks/plugins: DE, a GA, multistart scipy
#: ``least_squares``) add themselves with :func:`register_method`, called explicitly.
METHODS: dict[str, Factory] = {
    "ib": make_ib,
    "ab": make_ab,
    "cmaes": make_cmaes,
    "multistart-lm": make_multistart_lm,
}

#: Methods given ``problem.residuals`` with ``residuals=True`` when the problem has them.
RESIDUAL_METHODS: set[str] = {"multistart-lm"}
#: Methods whose steps evaluate a population (several candidates; multistart-lm: its pools
#: and Jacobians): with fewer runs than workers their populations are spread over the workers.
POPULATION_METHODS: set[str] = {"cmaes", "multistart-lm"}


def register_method(name: str, factory: Factory, *, residuals: bool = False,
                    population: bool = False) -> None:
    """Add an optimizer to :data:`METHODS` under ``name`` (a plug-in: the core registers none).

    Parameters
    ----------
    name : str
        The method's name in ``minimize(method=...)`` and ``[search] method``; a name taken
        by another factory is a ConfigError.
    factory : callable
        ``factory(n, rng, **options) -> Optimizer`` on the unit cube.
    residuals : bool
        The method minimizes a residual vector (``minimize(..., residuals=True)``).
    population : bool
        Its steps ask several candidates (spread over workers when runs are fewer).

    Notes
    -----
    Worker processes inherit the registry when they are forked (Linux's default); elsewhere
    register in the worker too.
    """
    if METHODS.get(name, factory) is not factory:
        raise ConfigError(f"method {name!r} is registered already (methods: "
                          f"{', '.join(METHODS)})")
    METHODS[name] = factory
    if residuals:
        RESIDUAL_METHODS.add(name)
    if population:
        POPULATION_METHODS.add(name)


def objective_for(problem: Any, method: str) -> tuple[Callable[[np.ndarray], Any], bool]:
    """What ``method`` minimizes of a problem that has both φ (``problem(x)``) and
    ``problem.residuals(x)``: ``(problem.residuals, True)`` for RESIDUAL_METHODS, else
    ``(problem, False)``; the pair is ``minimize``'s ``fun`` and ``residuals``."""
    if method in RESIDUAL_METHODS:
        return problem.residuals, True
    return problem, False

"""Variants kept to compare with, outside the product: optimizers femupdate does not ship.

``register_optimizers()`` adds them to :data:`femupdate.optimize.minimize.METHODS` by name
(``de``: scipy's differential evolution; ``ga``: pymoo's genetic algorithm; ``scipy-lsq``:
multistart scipy ``least_squares``, the peer baseline of the residual methods). Benchmark
scripts call it before they run; ``python benchmarks/with_plugins.py ARGS`` runs the
``femupdate`` command line with them registered.
"""

from __future__ import annotations

from femupdate.optimize.registry import METHODS, register_method


def register_optimizers() -> None:
    """Register ``de``, ``ga`` and ``scipy-lsq`` (again: a no-op)."""
    from plugins.evolutionary import make_de, make_ga
    from plugins.scipy_lsq import make_scipy_lsq

    for name, factory, residuals in (("de", make_de, False), ("ga", make_ga, False),
                                     ("scipy-lsq", make_scipy_lsq, True)):
        if name not in METHODS:
            register_method(name, factory, residuals=residuals, population=not residuals)

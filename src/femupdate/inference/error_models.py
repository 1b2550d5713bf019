"""The product's error models by name, and the functions that build one at a best fit.

:data:`ERROR_MODELS` registers, explicitly, the kinds a user chooses on purpose:
``"neff"`` (:mod:`femupdate.inference.neff`, the default of the Laplace record and of the
sampled posterior), ``"eiv"`` (:mod:`femupdate.inference.eiv`, errors in the variables: a
noisy table record, linear models) and ``"known"`` (:mod:`femupdate.inference.known`, a given
noise level).
Other kinds register in a :meth:`~femupdate.inference.likelihood.Registry.copy` of it
(``benchmarks/posterior.py`` does, for the kinds measured and set aside) and pass it as
``registry``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from femupdate.inference.eiv import EIV
from femupdate.inference.known import Known
from femupdate.inference.likelihood import ErrorModel, Registry, fit_residuals, residual_blocks
from femupdate.inference.neff import NEff

#: The product's kinds (the default first).
ERROR_MODELS = Registry(NEff(), EIV(), Known())
#: The error model of the Laplace record and of the sampled posterior when the case names
#: none (docs/posterior.md, "Calibration").
DEFAULT_KIND = "neff"


def case_kinds(registry: Registry = ERROR_MODELS) -> tuple[str, ...]:
    """The kinds a case file (``[posterior] error_model``) and ``--error-model`` may name."""
    return tuple(n for n in registry.names if registry[n].in_case)


def error_model(blocks: tuple[slice, ...] | list[slice], kind: str = DEFAULT_KIND, *,
                best_residuals: np.ndarray | None = None,
                dof_removed: tuple[int, ...] | list[int] | None = None,
                sigma: float | np.ndarray | None = None,
                jacobian: np.ndarray | None = None,
                registry: Registry = ERROR_MODELS, **options: Any) -> ErrorModel:
    """Build an error model of kind ``kind`` over the residual ``blocks``.

    Parameters
    ----------
    blocks : sequence of slice
        Contiguous blocks covering r from 0, in order (:func:`residual_blocks`).
    kind : str
        A name in ``registry`` (ConfigError naming the allowed ones otherwise).
    best_residuals : ndarray (m,), optional
        r at the best fit (every kind but ``"known"`` measures on it, once).
    dof_removed : sequence of int, optional
        Degrees of freedom each block lost to fitted constants (subtracted from N_c).
    sigma : float or ndarray (c,), optional
        The known error standard deviation (kind ``"known"`` only), in units of r.
    jacobian : ndarray (m, n), optional
        ∂r/∂θ at the best fit, for kinds that use it.
    registry : Registry
        Where ``kind`` is looked up.
    **options
        Options of the kind (the product's take none).
    """
    builder = registry[kind]
    fit = fit_residuals(blocks, best_residuals=best_residuals, dof_removed=dof_removed,
                        sigma=sigma, jacobian=jacobian, options=options)
    return builder.build(fit)


def problem_error_model(problem: Any, best_residuals: np.ndarray, kind: str = DEFAULT_KIND,
                        jacobian: np.ndarray | None = None, *,
                        point: np.ndarray | None = None, registry: Registry = ERROR_MODELS,
                        **options: Any) -> ErrorModel:
    """The error model of an UpdateProblem, fixed at its best fit's residuals (and, for the
    kinds that use them, its Jacobian there and the search ``point``)."""
    blocks, removed = residual_blocks(problem)
    fit = fit_residuals(blocks, best_residuals=best_residuals, dof_removed=removed,
                        jacobian=jacobian, problem=problem, point=point, options=options)
    return registry[kind].build(fit)

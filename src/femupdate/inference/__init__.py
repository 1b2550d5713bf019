"""The posterior of a case's parameters: error model, priors, Laplace, TMCMC.

- :mod:`~femupdate.inference.likelihood`: the error model's interface and registry
  (:class:`ErrorModel`, :class:`Registry`, :func:`residual_blocks`);
- :mod:`~femupdate.inference.error_models`: the product's kinds by name
  (:data:`ERROR_MODELS`: ``"neff"``, the default, and ``"known"``), :func:`error_model`;
- :mod:`~femupdate.inference.priors`: :class:`Prior` (uniform, log-uniform, truncated normal
  and lognormal) on the unit cube and in physical units;
- :mod:`~femupdate.inference.laplace`: the Gaussian at the best fit (:func:`laplace`);
- :mod:`~femupdate.inference.tmcmc`: transitional MCMC on the ask/tell loop (:class:`TMCMC`).
"""

from femupdate.inference.error_models import (
    DEFAULT_KIND,
    ERROR_MODELS,
    error_model,
    problem_error_model,
)
from femupdate.inference.laplace import (
    LaplaceResult,
    interval_spread,
    jacobian_unit,
    laplace,
    sentences,
    summarize_gaussian,
)
from femupdate.inference.likelihood import ErrorModel, Registry, residual_blocks
from femupdate.inference.priors import Prior
from femupdate.inference.tmcmc import TMCMC, TMCMCPosterior, make_tmcmc, run_tmcmc

__all__ = [
    "DEFAULT_KIND",
    "ERROR_MODELS",
    "TMCMC",
    "ErrorModel",
    "LaplaceResult",
    "Prior",
    "Registry",
    "TMCMCPosterior",
    "error_model",
    "interval_spread",
    "jacobian_unit",
    "laplace",
    "make_tmcmc",
    "problem_error_model",
    "residual_blocks",
    "run_tmcmc",
    "sentences",
    "summarize_gaussian",
]

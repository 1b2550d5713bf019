"""The posterior of a case's parameters: error model, priors, Laplace, TMCMC.

- :mod:`~femupdate.posterior.likelihood`: the error model's interface and registry
  (:class:`ErrorModel`, :class:`Registry`, :func:`residual_blocks`);
- :mod:`~femupdate.posterior.error_models`: the product's kinds by name
  (:data:`ERROR_MODELS`: ``"neff"``, the default, and ``"known"``), :func:`error_model`;
- :mod:`~femupdate.posterior.priors`: :class:`Prior` (uniform, log-uniform, truncated normal
  and lognormal) on the unit cube and in physical units;
- :mod:`~femupdate.posterior.laplace`: the Gaussian at the best fit (:func:`laplace`);
- :mod:`~femupdate.posterior.tmcmc`: transitional MCMC on the ask/tell loop (:class:`TMCMC`).
"""

from femupdate.posterior.error_models import (
    DEFAULT_KIND,
    ERROR_MODELS,
    error_model,
    problem_error_model,
)
from femupdate.posterior.laplace import (
    LaplaceResult,
    interval_spread,
    jacobian_unit,
    laplace,
    sentences,
    summarize_gaussian,
)
from femupdate.posterior.likelihood import ErrorModel, Registry, residual_blocks
from femupdate.posterior.priors import Prior
from femupdate.posterior.tmcmc import TMCMC, TMCMCPosterior, make_tmcmc, run_tmcmc

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

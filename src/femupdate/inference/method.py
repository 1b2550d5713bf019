"""TMCMC as a method of the run machinery (``run_all``): store, resume, workers, Dask.

``run_all`` keeps a run's settings, options included, as JSON in its store (a resume is
refused when they change) and rebuilds the optimizer from them in the worker that advances
the run. So the method registered here, ``"tmcmc"``, takes its error model, prior and
reference Gaussian as plain data (:func:`sampler_options`) and builds the core's
:class:`~femupdate.inference.tmcmc.TMCMC` from them; its :meth:`CaseTMCMC.extras` hands the
final samples back through the run's stored result.

The registry of methods lives in a lower layer (:mod:`femupdate.optimize.minimize`);
:func:`register` adds the method to it, explicitly: ``femupdate posterior`` calls it before
its runs, and the problem a posterior run evaluates, :class:`SampledProblem`, calls it when a
worker process (local or Dask) unpickles it. Importing this module registers nothing.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from femupdate.errors import ConfigError
from femupdate.inference.error_models import ERROR_MODELS
from femupdate.inference.likelihood import ErrorModel, Registry
from femupdate.inference.priors import Prior
from femupdate.inference.tmcmc import TMCMC
from femupdate.optimize.registry import METHODS, register_method
from femupdate.problem.update import UpdateProblem

METHOD = "tmcmc"


class CaseTMCMC(TMCMC):
    """The core's TMCMC, built from JSON-ready options, handing its samples back."""

    def extras(self) -> dict[str, Any]:
        """What the run's result keeps (JSON-ready): reached or not, β, the equally weighted
        samples in the unit cube and their log-likelihoods, log-evidence, ESS, the stages."""
        post = self.posterior()
        return {
            "reached": post.reached, "beta": post.beta,
            "samples_unit": None if post.samples is None else post.samples.tolist(),
            "loglike": None if post.loglike is None else post.loglike.tolist(),
            "log_evidence": None if not post.reached else post.log_evidence,
            "ess": None if not post.reached else post.ess,
            "ess_params": None if post.ess_params is None else post.ess_params.tolist(),
            "stages": post.stages, "evaluations": post.evaluations, "failures": post.failures,
        }


def error_model_data(model: ErrorModel) -> dict[str, Any]:
    """An error model as plain data (:func:`error_model_from` rebuilds it bit for bit)."""
    return model.data()


def error_model_from(data: Mapping[str, Any], registry: Registry = ERROR_MODELS
                     ) -> ErrorModel:
    """The error model of :func:`error_model_data`'s data, by its kind in ``registry``."""
    return registry.from_data(data)


def prior_data(prior: Prior, specs: Mapping[str, Mapping[str, Any]]) -> dict[str, Any]:
    """A prior as plain data: its parameters' bounds and scales and the specs it was given."""
    return {"names": list(prior.names), "lower": prior.lower.tolist(),
            "upper": prior.upper.tolist(), "scales": list(prior.scales),
            "specs": {k: dict(v) for k, v in specs.items()}, "source": prior.source}


def prior_from(data: Mapping[str, Any]) -> Prior:
    return Prior(data["names"], data["lower"], data["upper"], data["scales"], data["specs"],
                 source=str(data.get("source", "priors")))


def sampler_options(model: ErrorModel, prior: Prior, specs: Mapping[str, Mapping[str, Any]],
                    population: int, reference: tuple[np.ndarray, np.ndarray] | None = None,
                    **options: Any) -> dict[str, Any]:
    """The options of method ``"tmcmc"`` as ``run_all`` stores them (JSON-ready)."""
    out = {"error_model": error_model_data(model), "prior": prior_data(prior, specs),
           "population": int(population), **options}
    if reference is not None:
        out["reference"] = [np.asarray(reference[0]).tolist(),
                            np.asarray(reference[1]).tolist()]
    return out


def make_case_tmcmc(n: int, rng: np.random.Generator, **options: Any) -> CaseTMCMC:
    """The registry's factory: :func:`sampler_options`' data → :class:`CaseTMCMC`."""
    for required in ("error_model", "prior"):
        if not isinstance(options.get(required), Mapping):
            raise ConfigError(f"method {METHOD!r} needs the option {required!r} as data "
                              "(femupdate.inference.method.sampler_options builds them)")
    options = dict(options)
    model = error_model_from(options.pop("error_model"))
    prior = prior_from(options.pop("prior"))
    reference = options.pop("reference", None)
    if reference is not None:
        reference = (np.asarray(reference[0], float), np.asarray(reference[1], float))
    return CaseTMCMC(n, rng, error_model=model, prior=prior, reference=reference, **options)


def register() -> None:
    """Add method ``"tmcmc"`` to :data:`femupdate.optimize.registry.METHODS` (idempotent):
    a population method, its stages spread over the workers when runs are fewer."""
    if METHOD not in METHODS:
        register_method(METHOD, make_case_tmcmc, population=True)


class SampledProblem(UpdateProblem):
    """An update problem whose posterior is sampled: the same residuals (and batches); its
    class lives here so that a worker that unpickles it has method ``"tmcmc"`` registered."""

    @classmethod
    def of(cls, problem: UpdateProblem) -> SampledProblem:
        """The same problem (its trials and evaluators shared), as a SampledProblem."""
        new = cls.__new__(cls)
        new.__dict__.update(problem.__dict__)
        return new

    def __setstate__(self, state: dict[str, Any]) -> None:
        # a worker process (local or Dask) that unpickles it advances "tmcmc" runs
        self.__dict__.update(state)
        register()

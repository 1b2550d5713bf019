"""The Laplace approximation at the best fit of an update, as ``summary.json`` records it.

Every update ends with it (``Summary.laplace``): the residuals' Jacobian at the best point by
one batch of 2n evaluations (:func:`~femupdate.posterior.jacobian.residual_jacobian`), the
case's error model fixed at the best residuals and its priors, then the Gaussian of
:func:`~femupdate.posterior.laplace.laplace`. It is cheap and local: the sampled posterior
(``femupdate posterior``) is what to trust when a parameter is not determined or the model is
far from linear over its interval.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from femupdate.errors import FemupdateError
from femupdate.posterior.jacobian import residual_jacobian
from femupdate.posterior.laplace import LaplaceResult, laplace, summarize_gaussian
from femupdate.posterior.likelihood import DEFAULT_KIND, problem_error_model
from femupdate.posterior.priors import Prior
from femupdate.posterior.records import LaplaceRecord, Marginal, correlation_rows
from femupdate.update import UpdateProblem

LN10 = math.log(10.0)


def case_priors(case: Any) -> Prior:
    """The prior of a case's parameters: uniform on each search interval (log-uniform where
    ``scale = "log"``) unless ``[posterior.priors]`` gives another."""
    section = getattr(case, "posterior", None)
    specs = {} if section is None else {n: p.spec() for n, p in section.priors.items()}
    return Prior.from_case(case, specs)


def case_error_kind(case: Any) -> str:
    """``[posterior] error_model``, or the default error model."""
    section = getattr(case, "posterior", None)
    return DEFAULT_KIND if section is None else section.error_model


def laplace_record(problem: UpdateProblem, x: np.ndarray, *,
                   kind: str | None = None) -> LaplaceRecord:
    """The Laplace approximation at search point ``x`` (a best fit) of ``problem``.

    A failure (the model fails beside ``x``, a residual block is zero) is recorded as the
    record's ``note``, not raised: the update's results stand without it.
    """
    case = problem.case
    kind = kind or case_error_kind(case)
    n = len(problem.names)
    try:
        prior = case_priors(case)
        r, jac = residual_jacobian(problem.residuals_batch, problem.bounds, x)
        model = problem_error_model(problem, r, kind)
        best_unit = prior.to_unit(np.asarray(x, dtype=float))
        result = centred(laplace(jac, r, best_unit, model, prior), best_unit, prior)
    except FemupdateError as exc:
        return LaplaceRecord(error_model=kind, names=list(problem.names), nfev=2 * n + 1,
                             note=f"no Laplace approximation: {exc}")
    return record_of(result, prior, kind, nfev=2 * n + 1)


def centred(result: LaplaceResult, best_unit: np.ndarray, prior: Prior) -> LaplaceResult:
    """The Gaussian of ``result`` moved to the best fit, pulled only by the prior.

    The likelihood's gradient vanishes at a least-squares minimum; the Newton step of
    :func:`laplace` takes it from the Jacobian, which here is a secant over 1 % of each range
    (:data:`~femupdate.posterior.jacobian.UNIT_STEP`), so on a nonlinear model its step would
    move the mean by the secant's error (on the real 1-storey trial it put k1's 90 % interval
    beside the best fit, not around it). The prior's pull, Σ·∇log p, is kept.
    """
    prior_grad, _ = prior.curvature_unit(best_unit)
    return summarize_gaussian(best_unit + result.cov_unit @ prior_grad, result.cov_unit, prior)


def record_of(result: LaplaceResult, prior: Prior, kind: str, nfev: int) -> LaplaceRecord:
    """The summary's record of a :class:`LaplaceResult`: physical marginals (lognormal on a
    log scale), correlations, the undetermined parameters and the sentences."""
    names = list(result.names)
    params = {name: physical_marginal(float(result.mean[i]), float(result.std[i]),
                                      prior.is_log[i], result.quantiles[:, i])
              for i, name in enumerate(names)}
    return LaplaceRecord(
        error_model=kind, names=names, params=params,
        correlations=correlation_rows(result.correlations),
        undetermined=[n for n, u in zip(names, result.undetermined, strict=True) if u],
        sentences=list(result.sentences), nfev=nfev)


def physical_marginal(mean: float, sd: float, log_scale: bool,
                      quantiles: np.ndarray) -> Marginal:
    """A Gaussian marginal of the search space in physical units: itself on a linear scale,
    the lognormal of 10**x on a log scale; ``quantiles`` (5/50/95 %, physical) as given."""
    if log_scale:
        s = LN10 * sd
        median = 10.0 ** mean
        with np.errstate(over="ignore"):
            phys_mean = float(median * np.exp(0.5 * s * s))
            phys_sd = float(phys_mean * np.sqrt(np.expm1(s * s)))
        mean, sd = phys_mean, phys_sd
    q05, q50, q95 = (float(q) for q in quantiles)
    return Marginal(mean=mean, sd=sd, q05=q05, q50=q50, q95=q95)


def laplace_dict(record: LaplaceRecord | None) -> Mapping[str, Any] | None:
    return None if record is None else record.model_dump()

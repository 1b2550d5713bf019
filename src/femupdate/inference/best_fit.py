"""The Laplace approximation at the best fit of an update, as ``summary.json`` records it, and
the Gaussian ``femupdate posterior`` starts from (:func:`best_fit_gaussian`).

Every update ends with it (``Summary.laplace``): the residuals' Jacobian at the best point by
one batch of 2n evaluations (:func:`~femupdate.inference.jacobian.residual_jacobian`), the
case's error model fixed at the best residuals and its priors, then the Gaussian of
:func:`~femupdate.inference.laplace.laplace`. It is cheap and local: the sampled posterior
(``femupdate posterior``) is what to trust when a parameter is not determined or the model is
far from linear over its interval.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from femupdate.errors import ConfigError, FemupdateError
from femupdate.inference.error_models import DEFAULT_KIND, problem_error_model
from femupdate.inference.jacobian import LOCAL_STEP, UNIT_STEP, residual_jacobian
from femupdate.inference.laplace import LaplaceResult, laplace, summarize_gaussian
from femupdate.inference.likelihood import ErrorModel
from femupdate.inference.priors import Prior
from femupdate.inference.records import LaplaceRecord, Marginal, correlation_rows
from femupdate.problem.update import UpdateProblem

LN10 = math.log(10.0)
#: The coarse (1 %) interval this many times the local one's: the Gaussian does not hold.
NOT_QUADRATIC_RATIO = 3.0


def case_priors(case: Any) -> Prior:
    """The prior of a case's parameters: uniform on each search interval (log-uniform where
    ``scale = "log"``) unless ``[posterior.priors]`` gives another."""
    section = getattr(case, "posterior", None)
    specs = {} if section is None else {n: p.spec() for n, p in section.priors.items()}
    return Prior.from_case(case, specs)


def case_error_kind(case: Any) -> str:
    """``[posterior] error_model``, or the default error model."""
    section = getattr(case, "posterior", None)
    return DEFAULT_KIND if section is None or section.error_model is None \
        else section.error_model


def laplace_record(problem: UpdateProblem, x: np.ndarray, *,
                   kind: str | None = None) -> LaplaceRecord:
    """The Laplace approximation at search point ``x`` (a best fit) of ``problem``, at two
    scales (:func:`two_scale_record`; 4n + 1 evaluations).

    A failure (the model fails beside ``x``, a residual block is zero) is recorded as the
    record's ``note``, not raised: the update's results stand without it.
    """
    case = problem.case
    kind = kind or case_error_kind(case)
    n = len(problem.names)
    nfev = 4 * n + 1
    try:
        prior = case_priors(case)
        x = np.asarray(x, dtype=float)
        r = np.asarray(problem.residuals_batch(x[None, :])[0], dtype=float)
        best_unit = prior.to_unit(x)
        jacobians = [residual_jacobian(problem.residuals_batch, problem.bounds, x, step=step)
                     for step in (LOCAL_STEP, UNIT_STEP)]
        model = problem_error_model(problem, r, kind, jacobians[1][1], point=x)
        results = [fit_gaussian(laplace(jac, r_x, best_unit, model, prior), best_unit, prior,
                                model) for r_x, jac in jacobians]
    except FemupdateError as exc:
        return LaplaceRecord(error_model=kind, names=list(problem.names), nfev=nfev,
                             note=f"no Laplace approximation: {exc}")
    return two_scale_record(results[0], results[1], prior, kind, nfev)


def best_fit_gaussian(problem: UpdateProblem, x: np.ndarray, kind: str,
                      counts_from: ErrorModel | None = None
                      ) -> tuple[ErrorModel, Prior, LaplaceResult | None, str | None]:
    """The error model fixed at the best fit ``x`` (or with the counts of ``counts_from``)
    and the Laplace Gaussian there, from the Jacobian over 1 % steps (None, with why, when
    it cannot be had: TMCMC then starts from the prior); the kinds that use the Jacobian
    (``"eiv"``'s magnitude adjustment) are given it."""
    prior = case_priors(problem.case)
    x = np.asarray(x, dtype=float)
    r = np.asarray(problem.residuals_batch(x[None, :])[0], dtype=float)
    try:  # the Laplace step takes r from the Jacobian's own batch
        r_jac, jac = residual_jacobian(problem.residuals_batch, problem.bounds, x)
        why = None
    except FemupdateError as exc:
        r_jac, jac, why = None, None, str(exc)
    model = problem_error_model(problem, r, kind, jac, point=x)
    if counts_from is not None:
        if model.whitens:
            raise ConfigError(f"{problem.case.label}: error model {model.kind!r} whitens the "
                              "residuals by each model class's own response, so the classes' "
                              "evidences would not be of one likelihood (allowed: "
                              f"error_model = {DEFAULT_KIND!r} for a comparison of classes)")
        if (model.kind != counts_from.kind or model.starts.tolist() != counts_from.starts.tolist()
                or model.stops.tolist() != counts_from.stops.tolist()):
            raise ConfigError(f"{problem.case.label}: the error model to share ({counts_from.kind}"
                              f", {counts_from.starts.size} blocks) is not of this case's data "
                              f"({model.kind}, {model.starts.size} blocks) (allowed: model "
                              "classes of the same trials, channels and error model)")
        model = dataclasses.replace(model, counts=counts_from.counts, rho=counts_from.rho)
    if jac is None or r_jac is None:
        return model, prior, None, why
    best_unit = prior.to_unit(x)
    try:
        return model, prior, fit_gaussian(laplace(jac, r_jac, best_unit, model, prior),
                                          best_unit, prior, model), None
    except FemupdateError as exc:
        return model, prior, None, str(exc)


def coarse_choices(local: LaplaceResult, coarse: LaplaceResult
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which parameters take the 1 % secant's marginal (:func:`two_scale_record`):
    ``(undetermined, not_quadratic, widening)``, the first two boolean per parameter (the
    coarse one says undetermined where the local one does not; determined at both scales and
    NOT_QUADRATIC_RATIO times wider or more), the last the coarse interval over the local."""
    with np.errstate(divide="ignore", invalid="ignore"):
        widening = coarse.spread / local.spread
    undetermined = coarse.undetermined & ~local.undetermined
    not_quadratic = ~coarse.undetermined & (widening >= NOT_QUADRATIC_RATIO)
    return undetermined, not_quadratic, widening


def two_scale_record(local: LaplaceResult, coarse: LaplaceResult, prior: Prior, kind: str,
                     nfev: int) -> LaplaceRecord:
    """The record of the local Laplace approximation, but for the parameters that the one
    over 1 % of each range says the data do not determine: those take the coarse one's
    marginal and sentence.

    Why two: φ has ripples finer than 1 % along weakly seen directions (on the viscous bridge,
    minima about 1e-3 apart along the kp1 valley, where a stiff abutment mode's phase turns
    over the record). The local curvature (step 1e-4) is that of one ripple: it gave kp1 a
    ±9 % interval around 1.7e8 when the truth is 1e8 and TMCMC's samples fill 86 % of its
    range. The secant over 1 % sees the valley (kp1 not determined), but it overstates the
    precision of the well-determined parameters by 2–3× where the local one is within 10–50 %
    of TMCMC's (E ±0.43 % against ±0.92 % locally and ±1.2 % sampled). Correlations: the
    local ones.

    A parameter whose interval the 1 % secant makes :data:`NOT_QUADRATIC_RATIO` times or more
    wider than the local one, and that is determined at both scales, is ``not_quadratic``: φ
    is far from quadratic over its interval, so no Gaussian at the best fit describes it. It
    takes the coarse marginal (the wider) and a sentence that says to sample the posterior. On
    the friction bridge (2 % noise) that is kp1: 0.46 % of its range locally, 9.1 % over 1 %
    steps, 19 % over 3 %, against ±41 % sampled by TMCMC; every other parameter's ratio is
    0.8–1.3 there and at most 1.0 on the viscous bridge.
    """
    record = record_of(local, prior, kind, nfev)
    coarse_record = record_of(coarse, prior, kind, nfev)
    undetermined, not_quadratic, widening = coarse_choices(local, coarse)
    for i, name in enumerate(record.names):
        if undetermined[i]:
            record.params[name] = coarse_record.params[name]
            record.sentences[i] = coarse_record.sentences[i]
        elif not_quadratic[i]:
            record.params[name] = coarse_record.params[name]
            record.sentences[i] = (
                f"{name}: the Gaussian at the best fit does not describe it (its 90 % interval "
                f"is {widening[i]:.0f}× wider over 1 % steps than locally: φ is far from "
                "quadratic there); sample the posterior (femupdate posterior) for its "
                "uncertainty")
            record.not_quadratic.append(name)
    record.undetermined = [n for i, n in enumerate(record.names)
                           if local.undetermined[i] or coarse.undetermined[i]]
    return record


def fit_gaussian(result: LaplaceResult, best_unit: np.ndarray, prior: Prior,
                 model: ErrorModel) -> LaplaceResult:
    """The Laplace Gaussian ``result`` of ``model`` at a least-squares fit: :func:`centred`
    there, but for an error model that whitens the residuals (``"eiv"``), whose own mode is
    not the least-squares fit (it weighs the frequencies by their noise): its Newton step
    toward that mode is kept."""
    if model.whitens:
        return result
    return centred(result, best_unit, prior)


def centred(result: LaplaceResult, best_unit: np.ndarray, prior: Prior) -> LaplaceResult:
    """The Gaussian of ``result`` moved to the best fit, pulled only by the prior.

    The likelihood's gradient vanishes at a least-squares minimum; the Newton step of
    :func:`laplace` takes it from the Jacobian, a secant over 1e-4 or 1 % of each range
    (:mod:`femupdate.inference.jacobian`), so on a nonlinear model its step would
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

"""The analytic check: a model linear in its parameters, Gaussian noise of known variance, a
Gaussian posterior in closed form. TMCMC (from the prior, and from the Laplace Gaussian) and
Laplace: means within 0.1 posterior sd, sds within 5 %, correlations within 0.05; TMCMC's
log-evidence against the closed form."""

from __future__ import annotations

import numpy as np
import pytest

from femupdate.inference.analytic import Residuals, exact_log_evidence, linear_gaussian
from femupdate.inference.laplace import jacobian_unit, laplace
from femupdate.inference.tmcmc import run_tmcmc

CASE = linear_gaussian()


def _laplace():
    best_theta = np.linalg.lstsq(CASE.design, CASE.data, rcond=None)[0]
    best = CASE.prior.to_unit(best_theta)
    jac = jacobian_unit(CASE.residuals_batch, best, CASE.prior)
    return laplace(jac, CASE.residuals_batch(best_theta)[0], best, CASE.model, CASE.prior)


def _check(mean: np.ndarray, cov: np.ndarray) -> None:
    sd = np.sqrt(np.diag(CASE.cov))
    assert np.all(np.abs(mean - CASE.mean) <= 0.1 * sd)
    assert np.all(np.abs(np.sqrt(np.diag(cov)) / sd - 1) <= 0.05)
    corr = cov / np.outer(np.sqrt(np.diag(cov)), np.sqrt(np.diag(cov)))
    assert np.all(np.abs(corr - CASE.cov / np.outer(sd, sd)) <= 0.05)


def test_laplace_meets_the_analytic_check() -> None:
    result = _laplace()
    _check(result.mean, result.cov)


@pytest.mark.slow
@pytest.mark.parametrize("start", ["prior", "laplace"])
def test_tmcmc_meets_the_analytic_check(start: str) -> None:
    options = {}
    if start == "laplace":
        result = _laplace()
        options["reference"] = (result.mean_unit, result.cov_unit)
    post, _ = run_tmcmc(Residuals(CASE).residuals, CASE.prior, CASE.model, seed=11,
                        population=4000, **options)
    assert post.reached
    x = CASE.prior.to_search(post.samples)
    _check(x.mean(axis=0), np.cov(x.T))
    # log-evidence: within 0.15 (the prior start's stages add their noise) of the closed form
    assert post.log_evidence == pytest.approx(exact_log_evidence(CASE), abs=0.15)
    assert post.stages[-1]["beta"] == 1.0
    assert (len(post.stages) == 1) == (start == "laplace")  # a good reference: one stage

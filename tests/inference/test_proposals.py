"""TMCMC's mixture proposal: its density against the closed form and its own draws, the
k-means fit's clusters; the single Gaussian it replaced as the default still meets the
analytic check."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy import stats

from femupdate.inference.analytic import Residuals, linear_gaussian
from femupdate.inference.proposals import (
    MEMBERS_PER_PARAMETER,
    GaussianMixture,
    fit_mixture,
)
from femupdate.inference.tmcmc import run_tmcmc, safe_cholesky

CASE = linear_gaussian()


def _two_gaussians() -> GaussianMixture:
    means = np.array([[0.0, 0.0], [3.0, -1.0]])
    covs = np.array([[[1.0, 0.3], [0.3, 0.5]], [[0.2, 0.0], [0.0, 2.0]]])
    return GaussianMixture(np.log([0.3, 0.7]), means, np.linalg.cholesky(covs))


def test_mixture_density_is_the_weighted_sum_of_its_gaussians() -> None:
    mix = _two_gaussians()
    x = np.random.default_rng(0).normal(size=(50, 2)) * 2
    covs = mix.chols @ np.transpose(mix.chols, (0, 2, 1))
    expected = sum(w * stats.multivariate_normal(m, c).pdf(x) for w, m, c in
                   zip(np.exp(mix.log_weights), mix.means, covs, strict=True))
    assert np.allclose(np.exp(mix.logpdf(x)), expected, rtol=1e-10)


def test_mixture_draws_follow_its_density() -> None:
    mix = _two_gaussians()
    draws = mix.sample(np.random.default_rng(1), 200_000)
    # the share of draws in a box against the density integrated over it (midpoint grid)
    edges = np.linspace(-1.0, 1.0, 201)
    mid = 0.5 * (edges[1:] + edges[:-1])
    grid = np.stack(np.meshgrid(mid, mid), axis=-1).reshape(-1, 2)
    mass = float(np.exp(mix.logpdf(grid)).sum() * (edges[1] - edges[0]) ** 2)
    share = np.mean(np.all(np.abs(draws) <= 1.0, axis=1))
    assert share == pytest.approx(mass, abs=4e-3)  # 4 binomial sd at this share


def test_fit_mixture_finds_separate_clusters_and_merges_small_ones() -> None:
    rng = np.random.default_rng(2)
    x = np.vstack([rng.normal([0.2, 0.2], 0.02, (600, 2)),
                   rng.normal([0.8, 0.7], 0.03, (400, 2))])
    mix = fit_mixture(x, 12, 1.0, np.random.default_rng(3), safe_cholesky)
    members = np.exp(mix.log_weights) * x.shape[0]
    assert np.all(members >= MEMBERS_PER_PARAMETER * 2 - 1e-9)
    assert np.exp(mix.log_weights).sum() == pytest.approx(1.0)
    # every component lies in one of the two clusters, with its share of them
    near_first = np.linalg.norm(mix.means - [0.2, 0.2], axis=1) < 0.1
    near_second = np.linalg.norm(mix.means - [0.8, 0.7], axis=1) < 0.1
    assert np.all(near_first | near_second)
    assert np.exp(mix.log_weights[near_first]).sum() == pytest.approx(0.6)
    # same generator, same mixture; too few rows for two clusters: one Gaussian
    again = fit_mixture(x, 12, 1.0, np.random.default_rng(3), safe_cholesky)
    assert again.means.tobytes() == mix.means.tobytes()
    one = fit_mixture(x[:15], 12, 1.5, np.random.default_rng(3), safe_cholesky)
    assert one.means.shape == (1, 2)
    assert np.allclose(one.chols[0] @ one.chols[0].T, 1.5 ** 2 * np.cov(x[:15].T))


def test_fit_mixture_of_a_population_of_few_distinct_particles() -> None:
    """A resampled population that repeats a few particles: no more clusters than distinct
    rows, and no component of zero width (those take the population's covariance)."""
    rng = np.random.default_rng(7)
    x = np.repeat(rng.random((10, 3)), 40, axis=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mix = fit_mixture(x, 16, 1.5, np.random.default_rng(8), safe_cholesky)
    assert mix.means.shape[0] <= 10
    whole = 1.5 * np.linalg.cholesky(np.cov(x.T))
    assert all(np.allclose(chol, whole) for chol in mix.chols)
    assert np.all(np.isfinite(mix.logpdf(x)))


def test_tmcmc_with_the_single_gaussian_still_meets_the_analytic_check() -> None:
    """The mixture is the default (tests/inference/test_analytic.py checks it); the single
    Gaussian it replaced stays an option: from the prior (several stages of its moves),
    population 4000, means within 0.1 posterior sd, sds within 5 %, correlations within 0.05
    of the closed form."""
    post, _ = run_tmcmc(Residuals(CASE).residuals, CASE.prior, CASE.model, seed=11,
                        population=4000, proposal="independent")
    assert post.reached and len(post.stages) > 1
    x = CASE.prior.to_search(post.samples)
    sd = np.sqrt(np.diag(CASE.cov))
    assert np.all(np.abs(x.mean(axis=0) - CASE.mean) <= 0.1 * sd)
    cov = np.cov(x.T)
    s = np.sqrt(np.diag(cov))
    assert np.all(np.abs(s / sd - 1) <= 0.05)
    assert np.all(np.abs(cov / np.outer(s, s) - CASE.cov / np.outer(sd, sd)) <= 0.05)

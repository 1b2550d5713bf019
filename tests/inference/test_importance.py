"""Importance sampling at β = 1: the t mixture is a density, the per-parameter ESS
predicts the scatter of the estimate, and TMCMC with ``final = "importance"`` meets the
analytic check, repeatable and resumable bit for bit."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from scipy.stats import norm

from femupdate.errors import ConfigError
from femupdate.inference.analytic import Residuals, exact_log_evidence, linear_gaussian
from femupdate.inference.importance import (
    TMixture,
    defensive_mixture,
    importance_ess,
    kish_ess,
    resampled_ess,
)
from femupdate.inference.tmcmc import make_tmcmc, run_tmcmc, safe_cholesky
from femupdate.optimize.minimize import MinimizeState

CASE = linear_gaussian()


def test_the_t_mixture_is_a_density_its_draws_follow() -> None:
    mix = TMixture(np.log([0.3, 0.5, 0.2]), np.array([[-1.0], [2.0], [0.5]]),
                   np.array([[[0.5]], [[0.8]], [[1.5]]]), 3.0)
    grid = np.linspace(-2000, 2000, 2_000_001)[:, None]
    density = np.exp(mix.logpdf(grid))
    assert np.trapezoid(density, grid[:, 0]) == pytest.approx(1.0, abs=2e-3)
    draws = mix.sample(np.random.default_rng(0), 200_000)[:, 0]
    edges = np.array([-3.0, -1.0, 0.0, 1.0, 2.0, 4.0])
    cdf = np.array([np.trapezoid(density[grid[:, 0] <= e], grid[grid[:, 0] <= e, 0])
                    for e in edges])
    assert np.allclose(np.mean(draws[:, None] <= edges, axis=0), cdf, atol=5e-3)


def test_defensive_mixture_of_a_population_keeps_its_centre_and_widens_it() -> None:
    rng = np.random.default_rng(1)
    x = rng.multivariate_normal([0.4, 0.6], [[0.01, 0.004], [0.004, 0.02]], size=2000)
    mix = defensive_mixture(x, 4, 1.2, np.random.default_rng(2), safe_cholesky)
    assert np.allclose(mix.means[-1], x.mean(axis=0))  # the whole population's t, last
    assert np.allclose(mix.chols[-1] @ mix.chols[-1].T, 1.5 ** 2 * np.cov(x.T))
    assert np.exp(mix.log_weights[-1]) == pytest.approx(0.3)
    assert np.all(np.isfinite(mix.logpdf(x)))


def test_equal_weights_count_every_draw_and_one_weight_counts_one() -> None:
    x = np.random.default_rng(3).standard_normal((500, 2))
    assert np.allclose(importance_ess(x, np.zeros(500)), 500)
    assert kish_ess(np.zeros(500)) == pytest.approx(500)
    log_w = np.full(500, -np.inf)
    log_w[7] = 0.0
    assert kish_ess(log_w) == pytest.approx(1.0)
    assert np.allclose(importance_ess(x, np.full(500, -np.inf)), 0.0)
    assert np.allclose(resampled_ess(np.array([500.0, 250.0]), 500), [250.0, 500 / 3])


def test_the_ess_predicts_the_scatter_of_the_weighted_mean() -> None:
    """Draws from N(0, 2²) weighted to N(1, 1): over 400 seeds the variance of the
    self-normalised mean is σ²/ESS within 15 %."""
    means, predicted = [], []
    for seed in range(400):
        x = 2.0 * np.random.default_rng(seed).standard_normal((400, 1))
        log_w = norm.logpdf(x[:, 0], 1.0, 1.0) - norm.logpdf(x[:, 0], 0.0, 2.0)
        w = np.exp(log_w - log_w.max())
        means.append(float(w @ x[:, 0] / w.sum()))
        predicted.append(1.0 / importance_ess(x, log_w)[0])
    assert np.var(means) == pytest.approx(np.mean(predicted), rel=0.15)


def _importance(seed: int, **options: object):
    return run_tmcmc(Residuals(CASE).residuals, CASE.prior, CASE.model, seed=seed,
                     population=1000, final="importance", **options)


def test_importance_at_beta_one_meets_the_analytic_check() -> None:
    post, _ = _importance(11, ess=1500)
    assert post.reached and post.stages[-1]["draws"] >= 1000
    assert np.all(post.ess_params >= 1500 * 1500 / (1500 + post.samples.shape[0]) - 1e-9)
    x = CASE.prior.to_search(post.samples)
    sd = np.sqrt(np.diag(CASE.cov))
    assert np.all(np.abs(x.mean(axis=0) - CASE.mean) <= 0.1 * sd)
    cov = np.cov(x.T)
    s = np.sqrt(np.diag(cov))
    assert np.all(np.abs(s / sd - 1) <= 0.05)
    assert np.all(np.abs(cov / np.outer(s, s) - CASE.cov / np.outer(sd, sd)) <= 0.05)


def test_importance_is_repeatable_and_resumes_to_identical_samples() -> None:
    one, _ = _importance(5)
    two, _ = _importance(5)
    assert one.samples.tobytes() == two.samples.tobytes()
    fun = Residuals(CASE).residuals
    sampler = make_tmcmc(3, np.random.default_rng(5), error_model=CASE.model,
                         prior=CASE.prior, population=1000, final="importance")
    state = MinimizeState(sampler, "tmcmc", CASE.prior.search_low, CASE.prior.search_high,
                          1_000_000, None, residuals=True)
    while sampler.phase != "importance":
        state.step(fun)
    state.step(fun)  # one adapting batch
    state = pickle.loads(pickle.dumps(state))
    while not state.done:
        state.step(fun)
    assert state.optimizer.posterior().samples.tobytes() == one.samples.tobytes()


def test_a_bad_final_option_is_refused() -> None:
    with pytest.raises(ConfigError, match="option 'final'"):
        run_tmcmc(Residuals(CASE).residuals, CASE.prior, CASE.model, population=100,
                  final="is")


def test_importance_from_a_tempered_population_meets_the_analytic_check() -> None:
    """``importance_from``: from the prior, the first stage at β ≥ 0.3 goes to β = 1 by
    importance sampling (fewer stages than tempering all the way), and the posterior and its
    evidence (then the importance draws' own estimate) pass the analytic check."""
    tempered, _ = _importance(3, ess=1500)
    post, _ = _importance(3, ess=1500, importance_from=0.3)
    assert post.reached and len(post.stages) < len(tempered.stages)
    assert post.stages[-1]["beta"] == 1.0
    x = CASE.prior.to_search(post.samples)
    sd = np.sqrt(np.diag(CASE.cov))
    assert np.all(np.abs(x.mean(axis=0) - CASE.mean) <= 0.1 * sd)
    s = np.sqrt(np.diag(np.cov(x.T)))
    assert np.all(np.abs(s / sd - 1) <= 0.05)
    assert post.log_evidence == pytest.approx(exact_log_evidence(CASE), abs=0.15)
    with pytest.raises(ConfigError, match="importance_from"):
        _importance(3, importance_from=1.5)

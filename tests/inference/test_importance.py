"""Importance sampling at β = 1: the t mixture is a density, the per-parameter ESS
predicts the scatter of the estimate, and TMCMC with ``final = "importance"`` meets the
analytic check, repeatable and resumable bit for bit."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
from scipy.stats import norm

from femupdate.errors import ConfigError
from femupdate.inference.analytic import Residuals, exact_log_evidence, linear_gaussian
from femupdate.inference.error_models import error_model
from femupdate.inference.importance import (
    TMixture,
    defensive_mixture,
    importance_ess,
    kish_ess,
    resampled_ess,
)
from femupdate.inference.priors import Prior
from femupdate.inference.tmcmc import importance_degenerate, make_tmcmc, run_tmcmc, safe_cholesky
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


def test_weights_too_uneven_are_called_degenerate() -> None:
    x = np.random.default_rng(4).standard_normal((1000, 2))
    even = np.zeros(1000)
    assert not importance_degenerate(importance_ess(x, even), even, 1000)
    # every draw weighs alike but most fell outside the cube: 1,000 of 30,000 draws
    assert importance_degenerate(importance_ess(x, even), even, 30_000)
    one = np.zeros(1000)
    one[3] = np.log(150.0)  # a fifth of the weight on one draw, Kish's ESS still 40 %
    assert kish_ess(one) > 0.05 * 1000
    assert importance_degenerate(importance_ess(x, one), one, 1000)
    assert not importance_degenerate(importance_ess(x, one), one, 1000, weight=0.5)


def _banana(width: float, n: int = 2):
    """θ_0 ~ N(0, 1) and θ_k ~ N(θ_0², width²), k ≥ 1, under uniform priors (their bounds
    leave out less than 1e-4 of it): the residuals, the prior, the error model (known σ = 1;
    a third residual row is zero) and log Z in closed form."""
    prior = Prior([f"p{k}" for k in range(n)], [-4.0] + [-2.0] * (n - 1),
                  [4.0] + [16.0] * (n - 1))
    model = error_model([slice(0, n + 1)], "known", sigma=1.0)

    def residuals(theta: np.ndarray) -> np.ndarray:
        return np.concatenate([[theta[0]], (theta[1:] - theta[0] ** 2) / width, [0.0]])

    log_z = (n - 1) * math.log(width / 18.0) - math.log(8.0) - 0.5 * math.log(2 * math.pi)
    return residuals, prior, model, log_z


def test_a_forced_fallback_keeps_the_analytic_check() -> None:
    """``fallback = 1``: importance sampling is dropped after its first batch that counts;
    the tempering goes on by moves from the β it had reached, and the posterior and log Z
    still pass the analytic check."""
    post, _ = _importance(3, ess=1500, importance_from=0.3, fallback=1.0)
    fell = [s for s in post.stages if s.get("fallback")]
    assert post.reached and len(fell) == 1 and fell[0]["beta"] < 1.0
    assert fell[0]["draws"] == 1000 and fell[0]["evaluations"] > 1000
    assert post.stages[-1]["beta"] == 1.0 and "draws" not in post.stages[-1]
    x = CASE.prior.to_search(post.samples)
    sd = np.sqrt(np.diag(CASE.cov))
    assert np.all(np.abs(x.mean(axis=0) - CASE.mean) <= 0.1 * sd)
    s = np.sqrt(np.diag(np.cov(x.T)))
    assert np.all(np.abs(s / sd - 1) <= 0.08)  # three standard errors at its ESS (≈ 860)
    assert post.log_evidence == pytest.approx(exact_log_evidence(CASE), abs=0.15)
    # by default the Gaussian's weights are even enough: no fallback, fewer evaluations
    kept, _ = _importance(3, ess=1500, importance_from=0.3)
    assert not any(s.get("fallback") for s in kept.stages)
    assert kept.evaluations < post.evaluations


def test_a_forced_fallback_on_a_banana_keeps_its_moments_and_evidence() -> None:
    residuals, prior, model, log_z = _banana(0.05)
    post, _ = run_tmcmc(residuals, prior, model, seed=2, population=1000, final="importance",
                        importance_from=0.3, fallback=1.0)
    assert post.reached and any(s.get("fallback") for s in post.stages)
    x = prior.to_search(post.samples)
    assert abs(x[:, 0].mean()) <= 0.1 and abs(x[:, 0].std() - 1.0) <= 0.08
    assert abs(x[:, 1].mean() - 1.0) <= 0.15  # E θ_1 = E θ_0² = 1 (sd 1.4)
    assert post.log_evidence == pytest.approx(log_z, abs=0.2)


def test_a_curved_banana_falls_back_by_default_and_costs_less() -> None:
    """In three dimensions the banana's importance weights are degenerate (a few % of the
    draws count): the run falls back after its first batch that counts, where importance
    sampling alone draws batches to its cap; both reach β = 1."""
    residuals, prior, model, _ = _banana(0.02, 3)
    options = dict(seed=0, population=1000, final="importance", importance_from=0.3, ess=500)
    post, _ = run_tmcmc(residuals, prior, model, **options)
    kept, _ = run_tmcmc(residuals, prior, model, fallback=0.0, **options)
    fell = [s for s in post.stages if s.get("fallback")]
    assert post.reached and kept.reached and len(fell) == 1
    assert fell[0]["efficiency"] < 0.05 and fell[0]["draws"] == 1000
    assert not any(s.get("fallback") for s in kept.stages)
    assert post.evaluations < kept.evaluations
    again, _ = run_tmcmc(residuals, prior, model, **options)
    assert again.samples.tobytes() == post.samples.tobytes()
    assert again.log_evidence == post.log_evidence
    # pickled just after it fell back (a checkpoint) and continued: the same samples
    options.pop("seed")
    sampler = make_tmcmc(3, np.random.default_rng(0), error_model=model, prior=prior, **options)
    state = MinimizeState(sampler, "tmcmc", prior.search_low, prior.search_high, 1_000_000,
                          None, residuals=True)
    while sampler.phase != "mcmc" or not sampler._fell_back:
        state.step(residuals)
    state = pickle.loads(pickle.dumps(state))
    while not state.done:
        state.step(residuals)
    assert state.optimizer.posterior().samples.tobytes() == post.samples.tobytes()

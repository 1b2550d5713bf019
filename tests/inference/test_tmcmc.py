"""TMCMC on the loop: repeatable bit for bit, resumable from a pickle, failures not fatal, a
budget too small gives no posterior, the stages' rules."""

from __future__ import annotations

import builtins
import dataclasses
import pickle

import numpy as np
import pytest

from femupdate.errors import ConfigError
from femupdate.inference.analytic import Residuals, linear_gaussian
from femupdate.inference.tmcmc import (
    TMCMC,
    ess_by_ancestry,
    ess_of_population,
    make_tmcmc,
    next_beta,
    run_tmcmc,
    systematic_resample,
)
from femupdate.optimize.minimize import MinimizeState

CASE = linear_gaussian()


def _state(seed: int, **options: object) -> tuple[MinimizeState, TMCMC]:
    sampler = make_tmcmc(3, np.random.default_rng(seed), error_model=CASE.model,
                         prior=CASE.prior, population=200, **options)
    state = MinimizeState(sampler, "tmcmc", CASE.prior.search_low, CASE.prior.search_high,
                          1_000_000, None, residuals=True)
    return state, sampler


def test_same_seed_same_samples_bit_for_bit() -> None:
    one, _ = run_tmcmc(Residuals(CASE).residuals, CASE.prior, CASE.model, seed=5,
                       population=300)
    two, _ = run_tmcmc(Residuals(CASE).residuals, CASE.prior, CASE.model, seed=5,
                       population=300)
    other, _ = run_tmcmc(Residuals(CASE).residuals, CASE.prior, CASE.model, seed=6,
                         population=300)
    assert one.samples.tobytes() == two.samples.tobytes()
    assert one.log_evidence == two.log_evidence and one.stages == two.stages
    assert not np.array_equal(one.samples, other.samples)


def test_pickled_mid_run_and_continued_gives_identical_samples() -> None:
    fun = Residuals(CASE).residuals
    state, sampler = _state(3)
    while not state.done:
        state.step(fun)
    reference = sampler.posterior()
    state, sampler = _state(3)
    for _ in range(7):  # into the second stage
        state.step(fun)
    assert len(sampler.stages) >= 2 and not state.done
    state = pickle.loads(pickle.dumps(state))
    while not state.done:
        state.step(fun)
    resumed = state.optimizer.posterior()
    assert resumed.samples.tobytes() == reference.samples.tobytes()
    assert resumed.log_evidence == reference.log_evidence


def test_a_checkpoint_without_ancestry_resumes() -> None:
    """A state pickled before the ancestry was kept (no ``_eve``) resumes to a posterior."""
    fun = Residuals(CASE).residuals
    state, sampler = _state(3)
    for _ in range(7):
        state.step(fun)
    del sampler._eve
    state = pickle.loads(pickle.dumps(state))
    while not state.done:
        state.step(fun)
    post = state.optimizer.posterior()
    assert post.reached and 0 < post.ess <= 200


def test_a_failed_evaluation_in_a_stage_is_recorded_and_not_fatal() -> None:
    fun = Residuals(CASE, fail_at=450)  # in the second stage's moves
    post, state = run_tmcmc(fun.residuals, CASE.prior, CASE.model, seed=2, population=200)
    assert post.reached and post.failures == 1 and state.nfail == 1
    failed = [s for s in post.stages if s["failures"]]
    assert len(failed) == 1 and failed[0]["failures"] == 1
    assert np.all(np.isfinite(post.loglike))  # never accepted


def test_failures_at_the_start_weigh_nothing() -> None:
    fun = Residuals(CASE, fail_at=0)
    post, _ = run_tmcmc(fun.residuals, CASE.prior, CASE.model, seed=2, population=200,
                        map=builtins.map)
    assert post.reached and post.failures == 1 and np.all(np.isfinite(post.loglike))


def test_a_budget_too_small_gives_no_posterior() -> None:
    post, state = run_tmcmc(Residuals(CASE).residuals, CASE.prior, CASE.model, seed=2,
                            population=200, max_evals=700)
    assert "max_evals" in state.stopped
    assert not post.reached and post.samples is None and np.isnan(post.log_evidence)
    assert 0.0 < post.beta < 1.0


def test_next_beta_meets_the_cov_target() -> None:
    g = np.random.default_rng(0).normal(0, 50, 1000)
    beta = next_beta(g, 0.2, 1.0)
    w = np.exp((beta - 0.2) * (g - g.max()))
    assert w.std() / w.mean() == pytest.approx(1.0, rel=1e-6)
    assert next_beta(np.zeros(10), 0.3, 1.0) == 1.0


def test_systematic_resampling_keeps_the_expected_counts() -> None:
    w = np.random.default_rng(0).dirichlet(np.ones(50))
    for seed in range(20):  # each count is floor or ceil of N·w
        idx = systematic_resample(w, np.random.default_rng(seed))
        assert np.all(np.abs(np.bincount(idx, minlength=50) - 50 * w) < 1)


def test_ess_of_a_population() -> None:
    rng = np.random.default_rng(0)
    start = rng.standard_normal((100, 2))
    assert np.all(ess_of_population(start, rng.standard_normal((100, 2)), np.ones(100))
                  == 100.0)
    copies = np.zeros(100)
    copies[:10] = 10.0
    # unmoved copies of 10 parents: 10 independent values (ρ = 1)
    assert ess_of_population(start, start, copies) == pytest.approx(10.0)


def test_ess_by_ancestry_of_known_families() -> None:
    rng = np.random.default_rng(1)
    values = rng.standard_normal((4000, 2))
    # every particle its own family: the variance of the mean is s²/N exactly
    assert np.allclose(ess_by_ancestry(values, np.arange(4000)), 4000.0)
    # 1000 independent values, each copied 4 times: 1000 effective samples (the estimator's
    # own noise, about 1/sqrt(1000), well inside 10 %)
    copies = np.repeat(values[:1000], 4, axis=0)
    ancestors = np.repeat(rng.permutation(1000) * 7, 4)  # any labels
    assert np.allclose(ess_by_ancestry(copies, ancestors), 1000.0, rtol=0.1)


@pytest.mark.slow
def test_reported_ess_matches_the_variance_of_the_mean_across_seeds() -> None:
    """σ²/ESS ≈ the variance of the posterior mean across independent runs, on the analytic
    case from the prior (several stages). Measured with the mixture moves: reported ESS (mean
    over seeds) 450 against 389 measured across 40 seeds (worst parameter); with the single
    Gaussian 420 against 559; the random-walk's old estimate (420 against 163) would fail the
    lower bound of the ratio."""
    means, variances, ess = [], [], []
    for child in np.random.SeedSequence(5).spawn(40):
        post, _ = run_tmcmc(Residuals(CASE).residuals, CASE.prior, CASE.model, seed=child,
                            population=500)
        means.append(post.samples.mean(axis=0))
        variances.append(post.samples.var(axis=0))
        ess.append(post.ess)
    across = np.mean(variances, axis=0) / np.var(means, axis=0, ddof=1)
    ratio = float(np.min(across) / np.mean(ess))  # < 1: the reported ESS overstates
    assert 0.6 <= ratio <= 4.0


@pytest.mark.parametrize("options, match", [
    ({"population": 5}, r"'population' of method 'tmcmc' must be in \[20, inf\]"),
    ({"cov_target": 0.0}, r"'cov_target' of method 'tmcmc' must be in \(0, 10\]"),
    ({"proposal": "hmc"}, r"'proposal' of method 'tmcmc' must be one of rw, independent, mixture"),
    ({"speed": 2}, r"unknown option\(s\) 'speed' for method 'tmcmc'"),
    ({"components": 0}, r"'components' of method 'tmcmc' must be in \[1, 1000\], got 0"),
    ({"fallback": 1.5}, r"'fallback' of method 'tmcmc' must be in \[0, 1\], got 1.5"),
    ({"reference": (np.full(3, 0.5), 1e2 * np.eye(3))}, r"less than 1 % of the Gaussian"),
])
def test_bad_options(options: dict, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        make_tmcmc(3, np.random.default_rng(0), error_model=CASE.model, prior=CASE.prior,
                   **options)


@pytest.mark.parametrize("proposal", ["mixture", "independent"])
def test_a_last_step_with_every_proposal_outside_ends_the_run(proposal: str) -> None:
    state, sampler = _state(4, steps=1, proposal=proposal)
    fun = Residuals(CASE).residuals
    while sampler.beta < 1.0:
        state.step(fun)
    # the final stage's only step: every proposal outside the cube
    if proposal == "mixture":
        sampler._move = dataclasses.replace(sampler._move, chols=sampler._move.chols * 1e6)
    else:
        sampler._move = (sampler._move[0], sampler._move[1] * 1e6)
    while not state.done:
        state.step(fun)
    post = sampler.posterior()
    assert post.reached and post.stages[-1]["acceptance"] < 0.01

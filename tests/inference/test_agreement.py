"""The sampled posterior's verdict: whether independent runs agree, per parameter, checked on
runs whose true effective sample sizes are known (independent draws, shifted means)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from femupdate.pipeline.posterior.agreement import MIN_ESS, runs_agreement

NAMES = ["a", "b"]


def _runs(rng: np.random.Generator, size: int, shifts: np.ndarray) -> list[np.ndarray]:
    """Runs of ``size`` independent N(shift, 1) draws per parameter."""
    return [shift + rng.standard_normal((size, len(NAMES))) for shift in shifts]


def test_runs_of_one_posterior_agree_and_keep_their_own_count() -> None:
    rng = np.random.default_rng(1)
    runs = _runs(rng, 1000, np.zeros((4, 2)))
    got = runs_agreement(runs, [np.full(2, 1000.0)] * 4, NAMES)
    assert got.unsettled == [] and got.words.startswith("the 4 independent runs agree")
    assert np.all(got.ess <= 4000.0) and np.all(got.ess > MIN_ESS)
    assert np.all(np.abs(got.rhat - 1.0) < 0.01)


def test_the_scatter_of_the_means_measures_the_runs_true_count() -> None:
    # runs of N independent draws: each run's mean is worth N samples, and B/W estimates 1/N
    # without bias (W/B itself is biased high with 3 degrees of freedom)
    rng = np.random.default_rng(2)
    inverse = [1.0 / runs_agreement(_runs(rng, 250, np.zeros((4, 2))), [np.full(2, 250.0)] * 4,
                                    NAMES).ess_across for _ in range(400)]
    assert np.mean(inverse) * 250 == pytest.approx(1.0, abs=0.08)


def test_runs_that_claim_a_hundred_times_their_worth_are_called_unsettled() -> None:
    # each run's mean scatters as if it held 10 samples, while each claims 1,000
    rng = np.random.default_rng(3)
    caught = 0
    for _ in range(200):
        shifts = np.column_stack([rng.normal(0.0, math.sqrt(0.1), 4), np.zeros(4)])
        got = runs_agreement(_runs(rng, 1000, shifts), [np.full(2, 1000.0)] * 4, NAMES)
        caught += got.unsettled == ["a"]
    assert caught >= 190  # 98 % in theory (χ² of 3 degrees of freedom)
    assert "UNSETTLED" in got.words and "a (the runs disagree: their means scatter" in got.words


def test_too_few_samples_are_unsettled_even_when_the_runs_agree() -> None:
    rng = np.random.default_rng(4)
    got = runs_agreement(_runs(rng, 50, np.zeros((4, 2))), [np.full(2, 50.0)] * 4, NAMES)
    assert got.unsettled == NAMES and np.all(got.ess <= 200.0)
    assert "disagree" not in got.words and "effective samples)" in got.words


def test_one_run_cannot_check_itself_and_says_so() -> None:
    rng = np.random.default_rng(5)
    got = runs_agreement(_runs(rng, 1000, np.zeros((1, 2))), [np.array([900.0, 300.0])], NAMES)
    assert np.all(np.isnan(got.rhat)) and np.all(np.isnan(got.ess_across))
    assert got.ess.tolist() == [900.0, 300.0] and got.unsettled == ["b"]
    assert got.words.startswith("one run: whether independent runs agree was not checked")

"""Pairs of strongly correlated parameter estimates (the bench's diagonal valleys)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from femupdate.problem.identifiability import estimate_correlations, strong_correlations


def test_strong_correlations_lists_each_pair_once_by_decreasing_magnitude() -> None:
    corr = np.array([[1.0, -0.95, 0.2, 0.0],
                     [-0.95, 1.0, 0.1, 0.5],
                     [0.2, 0.1, 1.0, 0.99],
                     [0.0, 0.5, 0.99, 1.0]])
    pairs = strong_correlations(["E", "kp1", "c1", "c4"], corr)
    assert pairs == [("c1", "c4", 0.99), ("E", "kp1", -0.95)]
    assert strong_correlations(["E", "kp1", "c1", "c4"], corr, threshold=0.99) == []


def test_correlations_of_a_parameter_without_information_are_nan_not_an_overflow() -> None:
    rng = np.random.default_rng(0)
    jac = rng.standard_normal((50, 3))
    jac[:, 1] = 0.0  # the data do not see the second parameter
    jac[:, 2] = jac[:, 0] + 1e-3 * rng.standard_normal(50)  # a diagonal valley
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        corr = estimate_correlations(jac)
    assert np.all(np.isnan(corr[1])) and np.all(np.isnan(corr[:, 1]))
    assert corr[0, 0] == pytest.approx(1.0) and corr[0, 2] == pytest.approx(corr[2, 0])
    assert corr[0, 2] < -0.99
    assert strong_correlations(["a", "b", "c"], corr) == [("a", "c", corr[0, 2])]

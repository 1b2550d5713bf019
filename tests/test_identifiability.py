"""Pairs of strongly correlated parameter estimates (the bench's diagonal valleys)."""

from __future__ import annotations

import numpy as np

from femupdate.identifiability import strong_correlations


def test_strong_correlations_lists_each_pair_once_by_decreasing_magnitude() -> None:
    corr = np.array([[1.0, -0.95, 0.2, 0.0],
                     [-0.95, 1.0, 0.1, 0.5],
                     [0.2, 0.1, 1.0, 0.99],
                     [0.0, 0.5, 0.99, 1.0]])
    pairs = strong_correlations(["E", "kp1", "c1", "c4"], corr)
    assert pairs == [("c1", "c4", 0.99), ("E", "kp1", -0.95)]
    assert strong_correlations(["E", "kp1", "c1", "c4"], corr, threshold=0.99) == []

"""Residual rows of several trials written into one preallocated array (update._rows_into)."""

from __future__ import annotations

import math

import numpy as np

from femupdate.update import _rows_into


def test_rows_of_several_trials_equal_the_joined_vectors_bit_for_bit():
    rng = np.random.default_rng(7)
    parts = [[rng.standard_normal(5) for _ in range(4)], [rng.standard_normal(3) for _ in range(4)]]
    shares = [0.3, 0.7]
    out = _rows_into(parts, shares)
    expected = np.vstack([
        np.concatenate([math.sqrt(s) * p[i] for s, p in zip(shares, parts, strict=True)])
        for i in range(4)
    ])
    assert out.shape == (4, 8)
    np.testing.assert_array_equal(out, expected)


def test_rows_of_one_trial_are_its_vectors_unscaled():
    rows = [np.arange(3.0) + i for i in range(2)]
    np.testing.assert_array_equal(_rows_into([rows], None), np.vstack(rows))

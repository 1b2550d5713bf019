"""Residual rows of several trials written into one preallocated array: each trial's vectors
into its column block, then scaled in place (update._column_blocks, update._scale_blocks)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from femupdate.problem.update import _column_blocks, _scale_blocks


def test_rows_of_several_trials_equal_the_joined_vectors_bit_for_bit():
    rng = np.random.default_rng(7)
    parts = [[rng.standard_normal(5) for _ in range(4)], [rng.standard_normal(3) for _ in range(4)]]
    shares = [0.3, 0.7]
    out = np.empty((4, 8))
    blocks = _column_blocks(out, [5, 3])
    for block, rows in zip(blocks, parts, strict=True):
        for i, r in enumerate(rows):
            block[i] = r
    _scale_blocks(blocks, shares)
    expected = np.vstack([  # UpdateProblem._joined, row by row
        np.concatenate([math.sqrt(s) * p[i] for s, p in zip(shares, parts, strict=True)])
        for i in range(4)
    ])
    np.testing.assert_array_equal(out, expected)


def test_blocks_are_views_of_the_output():
    out = np.zeros((2, 5))
    _, second = _column_blocks(out, [2, 3])
    second[1] = [1.0, 2.0, 3.0]
    np.testing.assert_array_equal(out[1], [0.0, 0.0, 1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="5 columns"):
        _column_blocks(out, [2, 2])

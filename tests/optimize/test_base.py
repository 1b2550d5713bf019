"""The rows of a residual batch handed to an optimizer (optimize.base.stack_rows)."""

from __future__ import annotations

import numpy as np

from femupdate.optimize.base import stack_rows


def _batch() -> np.ndarray:
    out = np.empty((3, 4))
    out[:] = np.arange(12.0).reshape(3, 4)
    return out


def test_the_rows_of_one_batch_are_that_batch_not_a_copy() -> None:
    batch = _batch()
    rows = [np.asarray(r, dtype=float).reshape(-1) for r in batch]  # as minimize takes them
    assert stack_rows(rows) is batch


def test_other_rows_are_stacked() -> None:
    batch = _batch()
    failed = [batch[0], np.full(4, np.inf), batch[2]]  # a failed row replaced by inf
    for rows in (failed, list(batch[:2]), [batch[1], batch[0], batch[2]],
                 [np.ones(4), np.zeros(4)]):
        out = stack_rows(rows)
        assert out is not batch
        np.testing.assert_array_equal(out, np.vstack(rows))

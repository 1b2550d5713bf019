"""The Jacobian at a best fit: exact on residuals linear and quadratic in the parameters."""

from __future__ import annotations

import numpy as np
import pytest

from femupdate.errors import FemupdateError
from femupdate.inference.jacobian import residual_jacobian

BOUNDS = [(0.0, 2.0), (-1.0, 1.0), (10.0, 20.0)]


def _quadratic(X: np.ndarray) -> np.ndarray:
    """r_k(θ) = A θ + 0.5 θ₀² (second-order differences are exact on it)."""
    A = np.arange(12.0).reshape(4, 3) - 5.0
    return X @ A.T + 0.5 * X[:, :1] ** 2


def test_jacobian_is_exact_inside_and_at_a_bound() -> None:
    A = np.arange(12.0).reshape(4, 3) - 5.0
    for x in (np.array([0.7, 0.2, 13.0]), np.array([2.0, -1.0, 20.0])):  # inside; at bounds
        r, jac = residual_jacobian(_quadratic, BOUNDS, x)
        expected = A.copy()
        expected[:, 0] += x[0]
        np.testing.assert_allclose(r, _quadratic(x[None])[0])
        span = np.array([high - low for low, high in BOUNDS])
        np.testing.assert_allclose(jac, expected * span, rtol=1e-7, atol=1e-7)  # unit cube


def test_a_failed_neighbour_is_an_error_not_a_guess() -> None:
    def fails_right_of_one(X: np.ndarray) -> np.ndarray:
        out = _quadratic(X)
        out[X[:, 0] > 1.0] = np.inf
        return out

    with pytest.raises(FemupdateError, match=r"parameter\(s\) \[0\]"):
        residual_jacobian(fails_right_of_one, BOUNDS, np.array([1.0, 0.0, 15.0]))

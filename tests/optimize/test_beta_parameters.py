"""(mode, variance) -> (a, b) of the Beta distribution (Eq. 11), against Eqs. 5-7."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from femupdate.errors import ConfigError
from femupdate.optimize import beta_mode_variance, beta_parameters
from femupdate.optimize.beta import VARIANCE_CAP

EPS = np.finfo(float).eps
modes = st.one_of(st.floats(0.0, 1.0), st.sampled_from([0.0, 1.0, 0.5, 1e-300, 1.0 - EPS]))
# log-uniform variances from 1e-30 up to the cap 1/12
log_variances = st.floats(-30.0, math.log10(VARIANCE_CAP))


def _check_recovered(m: np.ndarray, v: np.ndarray, a: np.ndarray, b: np.ndarray) -> None:
    assert np.all(np.isfinite(a)) and np.all(np.isfinite(b))
    assert np.all(a >= 1.0) and np.all(b >= 1.0)
    m_rec, v_rec = beta_mode_variance(a, b)
    np.testing.assert_allclose(v_rec, v, rtol=1e-9, atol=0.0)
    s = (a - 1.0) + (b - 1.0)
    proper = s > 0.0  # s = 0: the uniform distribution (at the cap), no mode
    assert np.all(proper | (v >= VARIANCE_CAP * (1.0 - 1e-12)))
    # 1e-9 relative, plus the rounding of a = 1 + m*s and b (a few ulps of a + b, over s)
    tol = 1e-9 * m + 4.0 * EPS * (a + b) / np.where(proper, s, 1.0)
    assert np.all(~proper | (np.abs(m_rec - m) <= tol))


@settings(max_examples=400, deadline=None)
@given(modes, log_variances)
@example(0.0, -30.0)
@example(1.0, -30.0)
@example(0.5, -30.0)
@example(0.0, math.log10(VARIANCE_CAP))
@example(0.3, math.log10(VARIANCE_CAP * (1 - 1e-12)))
def test_mode_and_variance_recovered(mode: float, log_variance: float) -> None:
    variance = min(10.0**log_variance, VARIANCE_CAP)
    a, b = beta_parameters(mode, variance)
    _check_recovered(np.array(mode), np.array(variance), a, b)


@settings(max_examples=100, deadline=None)
@given(arrays(float, st.integers(1, 12), elements=st.floats(0.0, 1.0)),
       arrays(float, st.integers(1, 12), elements=log_variances))
def test_vectorised(modes_: np.ndarray, log_vars: np.ndarray) -> None:
    k = min(modes_.size, log_vars.size)
    m = modes_[:k]
    v = np.minimum(10.0 ** log_vars[:k], VARIANCE_CAP)
    a, b = beta_parameters(m, v)
    assert a.shape == b.shape == (k,)
    _check_recovered(m, v, a, b)


def test_closed_form_cases() -> None:
    # Beta(2, 2): mode 1/2, variance 4 / (16 * 5) = 1/20
    a, b = beta_parameters(0.5, 0.05)
    np.testing.assert_allclose([a, b], [2.0, 2.0], rtol=1e-13)
    # Beta(1, 3): mode 0, variance 3 / (16 * 5) = 3/80
    a, b = beta_parameters(0.0, 3.0 / 80.0)
    np.testing.assert_allclose([a, b], [1.0, 3.0], rtol=1e-13)
    # Beta(5, 1): mode 1, variance 5 / (36 * 7)
    a, b = beta_parameters(1.0, 5.0 / 252.0)
    np.testing.assert_allclose([a, b], [5.0, 1.0], rtol=1e-13)
    # the cap is the uniform distribution
    a, b = beta_parameters([0.0, 0.2, 1.0], VARIANCE_CAP)
    np.testing.assert_array_equal(a, 1.0)
    np.testing.assert_array_equal(b, 1.0)


def test_broadcast_shape() -> None:
    a, b = beta_parameters(np.full((2, 3), 0.25), 1e-4)
    assert a.shape == b.shape == (2, 3)


@pytest.mark.parametrize(
    ("mode", "variance", "match"),
    [(-0.1, 0.01, "mode"), (1.5, 0.01, "mode"), (math.nan, 0.01, "mode"),
     (0.5, 0.0, "variance"), (0.5, 0.1, "variance"), (0.5, math.nan, "variance")],
)
def test_invalid(mode: float, variance: float, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        beta_parameters(mode, variance)

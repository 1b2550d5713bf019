"""Tests of femupdate.problem.objective: Eq. 1 and the experimental parameters (the paper's
Eq. 1 and
§5.2; docs/method.md)."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from femupdate.errors import ConfigError, DataError
from femupdate.problem.objective import ErrorFunction, nmse
from femupdate.simulate.response import Response

T = np.linspace(0.0, 4.6, 461)


def target(n_channels: int = 3) -> np.ndarray:
    k = np.arange(1, n_channels + 1)
    return np.sin(2 * np.pi * 1.3 * k * T[:, None]) * np.exp(-0.2 * k * T[:, None])


# --------------------------------------------------------------------------- nmse


def test_nmse_perfect_and_zero_prediction() -> None:
    y = target()
    assert nmse(y, y) == 0.0
    assert nmse(np.zeros_like(y), y) == pytest.approx(1.0, rel=1e-15)
    assert nmse(np.zeros(T.size), y[:, 0]) == pytest.approx(1.0, rel=1e-15)


def test_nmse_per_channel_scaling_and_weights() -> None:
    y = target(2)
    # ŷ = (1 + e_i) y_i gives error e_i² on channel i
    pred = y * np.array([1.1, 0.7])
    assert nmse(pred, y) == pytest.approx((0.01 + 0.09) / 2, rel=1e-12)
    assert nmse(pred, y, weights=[1.0, 3.0]) == pytest.approx((0.01 + 3 * 0.09) / 4,
                                                              rel=1e-12)
    assert nmse(pred, y, weights=[1.0, 0.0]) == pytest.approx(0.01, rel=1e-12)


def test_nmse_nonfinite_prediction_is_inf() -> None:
    y = target()
    for bad in (np.nan, np.inf, -np.inf):
        pred = y.copy()
        pred[10, 1] = bad
        assert nmse(pred, y) == np.inf


def test_nmse_rejects_bad_input() -> None:
    y = target()
    with pytest.raises(DataError, match=r"prediction has shape \(461, 2\), target \(461, 3\)"):
        nmse(y[:, :2], y)
    with pytest.raises(DataError, match=r"target channels \[1\] are all zero"):
        nmse(y, y * np.array([1.0, 0.0, 1.0]))
    with pytest.raises(ConfigError, match="one value per channel"):
        nmse(y, y, weights=[1.0, 2.0])
    with pytest.raises(ConfigError, match=">= 0 and not all 0"):
        nmse(y, y, weights=[1.0, -2.0, 1.0])


# --------------------------------------------------------------------------- ErrorFunction


def test_objective_without_constants_is_nmse() -> None:
    y = target()
    pred = y * 0.9 + 0.01
    obj = ErrorFunction(y, T, weights=[1.0, 2.0, 3.0])
    assert obj(pred) == pytest.approx(nmse(pred, y, weights=[1.0, 2.0, 3.0]), rel=1e-14)
    assert obj(y) == 0.0
    np.testing.assert_array_equal(obj.experimental_parameters(pred), np.zeros((3, 2)))


def test_constants_recovered_exactly() -> None:
    y = target()
    c0 = np.array([0.3, -1.2, 5.0])
    c1 = np.array([-0.05, 0.4, 2.0])
    measured = y - c0 - c1 * T[:, None]  # integration lost c0 + c1 t
    obj = ErrorFunction(measured, T, experimental_parameters=True)
    np.testing.assert_allclose(obj.experimental_parameters(y), np.column_stack([c0, c1]),
                               rtol=1e-11, atol=1e-13)
    assert obj(y) < 1e-25
    np.testing.assert_allclose(obj.corrected_target(y), y, atol=1e-12)


def test_constants_in_sample_units_without_t() -> None:
    y = target(1)[:, 0]
    measured = y - 2.0 - 0.01 * np.arange(T.size)
    obj = ErrorFunction(measured, experimental_parameters=True)
    np.testing.assert_allclose(obj.experimental_parameters(y), [[2.0, 0.01]], rtol=1e-11)


def test_constants_are_the_least_squares_fit() -> None:
    rng = np.random.default_rng(11)
    y = target()
    pred = y + 0.05 * rng.standard_normal(y.shape)
    obj = ErrorFunction(y, T, experimental_parameters=True)
    basis = np.column_stack([np.ones(T.size), T])
    expected = np.linalg.lstsq(basis, pred - y, rcond=None)[0].T
    np.testing.assert_allclose(obj.experimental_parameters(pred), expected, rtol=1e-10)
    # φ from its definition: residual after the fit over the corrected measurement
    resid = pred - y - basis @ expected.T
    corrected = y + basis @ expected.T
    direct = np.mean(np.sum(resid**2, axis=0) / np.sum(corrected**2, axis=0))
    assert obj(pred) == pytest.approx(direct, rel=1e-12)


@settings(max_examples=40, deadline=None)
@given(a=st.floats(-1e3, 1e3), b=st.floats(-1e2, 1e2), scale=st.floats(0.5, 1.5),
       channel=st.integers(0, 2))
def test_phi_invariant_to_a_line_added_to_the_measurement(a: float, b: float, scale: float,
                                                           channel: int) -> None:
    y = target()
    pred = y * scale + 0.02 * np.cos(7 * T)[:, None]
    shifted = y.copy()
    shifted[:, channel] += a + b * T
    phi = ErrorFunction(y, T, experimental_parameters=True)(pred)
    phi_shifted = ErrorFunction(shifted, T, experimental_parameters=True)(pred)
    assert phi_shifted == pytest.approx(phi, rel=1e-7, abs=1e-14)


def test_zero_prediction_gives_one_with_constants() -> None:
    obj = ErrorFunction(target(), T, experimental_parameters=True)
    assert obj(np.zeros((T.size, 3))) == pytest.approx(1.0, rel=1e-13)


def test_objective_nonfinite_prediction_is_inf() -> None:
    y = target()
    obj = ErrorFunction(y, T, experimental_parameters=True)
    pred = y.copy()
    pred[3, 0] = np.nan
    assert obj(pred) == np.inf
    assert np.isnan(obj.experimental_parameters(pred)).all()
    pred[3, 0] = np.inf
    assert obj(pred) == np.inf


def test_objective_accepts_a_response() -> None:
    y = target(2)
    zeros = np.zeros_like(y)
    resp = Response(T, displacement=y, velocity=zeros, acceleration=2 * y)
    assert ErrorFunction(y, T, experimental_parameters=True)(resp) < 1e-25
    assert ErrorFunction(2 * y, T, kind="acceleration")(resp) == 0.0
    diverged = Response(T, displacement=y, velocity=zeros, acceleration=y, diverged=True)
    assert ErrorFunction(y, T)(diverged) == np.inf


def test_objective_is_picklable() -> None:
    y = target()
    obj = ErrorFunction(y, T, weights=[1, 2, 3], experimental_parameters=True)
    pred = 0.8 * y + 0.1
    assert pickle.loads(pickle.dumps(obj))(pred) == obj(pred)


def test_objective_rejects_bad_configuration() -> None:
    y = target()
    with pytest.raises(ConfigError, match="use kind='displacement'"):
        ErrorFunction(y, T, kind="acceleration", experimental_parameters=True)
    with pytest.raises(ConfigError, match="kind must be"):
        ErrorFunction(y, T, kind="velocity")  # type: ignore[arg-type]
    with pytest.raises(DataError, match=r"target channels \[1\] are straight lines"):
        ErrorFunction(np.column_stack([y[:, 0], 1 + 2 * T]), T, experimental_parameters=True)
    with pytest.raises(DataError, match="NaN or inf"):
        ErrorFunction(np.full((5, 1), np.nan))
    with pytest.raises(DataError, match=r"t must be finite with shape \(461,\)"):
        ErrorFunction(y, T[:-1])
    with pytest.raises(DataError, match=r"prediction has shape \(461, 2\)"):
        ErrorFunction(y, T)(y[:, :2])

"""The elasto-slip (Jenkins) law, driven directly with prescribed deformation histories."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from femupdate.errors import ModelError
from femupdate.model.friction import check_friction_parameters, elasto_slip


def drive(y: np.ndarray, k_r: float, f_u: float) -> tuple[np.ndarray, np.ndarray]:
    """Force and slip offset along a deformation history, from zero slip."""
    f = np.empty_like(y)
    yr = np.empty_like(y)
    y_r = 0.0
    for i, yi in enumerate(y):
        f[i], y_r = elasto_slip(float(yi), y_r, k_r, f_u)
        yr[i] = y_r
    return f, yr


def triangle_cycles(u_max: float, du: float, cycles: int) -> np.ndarray:
    """0 → u_max, then `cycles` symmetric cycles u_max → -u_max → u_max, in steps du."""
    up = np.arange(0.0, u_max + du / 2, du)
    down = np.arange(u_max, -u_max - du / 2, -du)
    cycle = np.concatenate([down[1:], down[::-1][1:]])
    return np.concatenate([up, *([cycle] * cycles)])


def test_sticks_with_stiffness_k_r():
    y = np.linspace(-0.4, 0.4, 81)  # within f_u/k_r = 0.5
    f, yr = drive(y, 2.0, 1.0)
    np.testing.assert_allclose(f, 2.0 * y, rtol=0, atol=1e-15)
    assert np.all(yr == 0.0)


def test_slips_at_f_u_and_keeps_the_spring_at_its_limit():
    y = np.linspace(0.0, 3.0, 301)
    f, yr = drive(y, 2.0, 1.0)
    slipping = y > 0.5
    np.testing.assert_allclose(f[slipping], 1.0, rtol=0, atol=1e-15)
    np.testing.assert_allclose(y[slipping] - yr[slipping], 0.5, rtol=0, atol=1e-15)
    # unloading from y = 3 sticks again with k_r, around the new offset 2.5
    f_back, _ = elasto_slip(2.9, yr[-1], 2.0, 1.0)
    assert f_back == pytest.approx(2.0 * (2.9 - 2.5), abs=1e-14)


@pytest.mark.parametrize(("k_r", "f_u", "u_max"), [(2.0, 1.0, 2.0), (8.0, 0.5, 0.75)])
def test_dissipates_the_loop_area_per_cycle(k_r, f_u, u_max):
    """∮ f du over one symmetric cycle = 4 f_u (u_max - f_u/k_r). The steps du = 1/256 put
    every kink of the loop on a sample, so the trapezoidal rule is exact."""
    du = 1.0 / 256.0
    y = triangle_cycles(u_max, du, 3)
    f, _ = drive(y, k_r, f_u)
    n_first = round(u_max / du) + 1
    n_cycle = (y.size - n_first) // 3
    expected = 4.0 * f_u * (u_max - f_u / k_r)
    for c in range(3):
        sl = slice(n_first - 1 + c * n_cycle, n_first + (c + 1) * n_cycle)
        work = np.sum(0.5 * (f[sl][1:] + f[sl][:-1]) * np.diff(y[sl]))
        assert work == pytest.approx(expected, rel=1e-12)


def test_dissipation_under_a_smooth_cycle():
    """A sinusoidal history (kinks between samples): the area converges to the same value."""
    k_r, f_u, u_max = 3.0, 1.2, 1.5
    t = np.linspace(0.0, 2.0 * np.pi, 200_001)
    y = np.concatenate([u_max * np.sin(t[:50_001]), u_max * np.cos(t)])
    f, _ = drive(y, k_r, f_u)
    yc, fc = y[50_000:], f[50_000:]
    work = np.sum(0.5 * (fc[1:] + fc[:-1]) * np.diff(yc))
    assert work == pytest.approx(4.0 * f_u * (u_max - f_u / k_r), rel=1e-6)


def test_zero_slip_force_gives_no_force_and_infinite_gives_a_spring():
    y = np.sin(np.linspace(0.0, 20.0, 500)) * 3.0
    f0, _ = drive(y, 5.0, 0.0)
    assert np.all(f0 == 0.0)
    finf, yr = drive(y, 5.0, np.inf)
    np.testing.assert_array_equal(finf, 5.0 * y)
    assert np.all(yr == 0.0)
    fk0, _ = drive(y, 0.0, 1.0)
    assert np.all(fk0 == 0.0)


@settings(max_examples=60, deadline=None)
@given(
    steps=st.lists(st.floats(-1.0, 1.0, allow_nan=False), min_size=1, max_size=200),
    k_r=st.floats(1e-3, 1e6),
    f_u=st.floats(0.0, 1e3),
)
def test_force_bounded_and_consistent_with_the_spring(steps, k_r, f_u):
    y = np.cumsum(steps)
    f, yr = drive(y, k_r, f_u)
    assert np.all(np.abs(f) <= f_u * (1 + 1e-12))
    # the force is always the spring's, f = k_r (y - y_r), stuck or slipping, up to the rounding
    # of y - y_r (a few ulps of |y|, |y_r|) and of f_u/k_r
    tol = 1e-12 * (k_r * (np.abs(y) + np.abs(yr)) + f_u)
    assert np.all(np.abs(f - k_r * (y - yr)) <= tol)


def test_invalid_parameters_name_the_element():
    with pytest.raises(ModelError, match="element 1: k_r"):
        check_friction_parameters(np.array([1.0, -2.0]), np.array([1.0, 1.0]))
    with pytest.raises(ModelError, match="element 0: f_u"):
        check_friction_parameters(np.array([1.0]), np.array([np.nan]))

"""``minimize(..., timeout=T)``: evaluations in a child process, killed when they overrun."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from femupdate import minimize
from femupdate.errors import ConfigError
from femupdate.optimize.timed import FAILED, TimedFunction

BOUNDS = [(0.0, 1.0), (0.0, 1.0)]


def sphere(x: np.ndarray) -> float:
    return float(np.sum((x - 0.3) ** 2))


def slow_right_half(x: np.ndarray) -> float:
    if x[0] > 0.5:
        time.sleep(60)
    return sphere(x)


@pytest.mark.parametrize("method", ["ab", "cmaes"])
def test_a_timeout_that_never_fires_changes_nothing(method: str) -> None:
    plain = minimize(sphere, BOUNDS, method, max_evals=60, seed=4)
    timed = minimize(sphere, BOUNDS, method, max_evals=60, seed=4, timeout=30.0)
    assert timed.nfev == plain.nfev and timed.fun == plain.fun
    assert np.array_equal(timed.x, plain.x)
    assert np.array_equal(timed.history["fun"], plain.history["fun"])
    assert timed.nfail == 0 and timed.failure is None


def test_timed_out_evaluations_fail_and_the_search_goes_on() -> None:
    res = minimize(slow_right_half, BOUNDS, "ab", max_evals=24, seed=0, timeout=0.2)
    failed = ~np.isfinite(res.history["fun"])
    right = res.history["x"][:, 0] > 0.5
    assert np.array_equal(failed, right)  # exactly the points that sleep
    assert res.nfail == int(right.sum()) > 0
    assert math.isfinite(res.fun) and res.x[0] <= 0.5
    assert res.failure.startswith("timed out: fun(x) took longer than 0.2 s")


def test_the_child_is_replaced_after_a_time_out() -> None:
    timed = TimedFunction(slow_right_half, 0.2)
    try:
        assert timed(np.array([0.9, 0.1])) is FAILED and "timed out" in timed.last_failure
        assert timed(np.array([0.3, 0.3])) == 0.0 and timed.last_failure is None
    finally:
        timed.close()


def test_residual_functions_under_a_timeout() -> None:
    res = minimize(lambda x: x - 0.3, BOUNDS, "multistart-lm", residuals=True, max_evals=200,
                   seed=1, timeout=10.0)
    assert res.fun < 1e-20 and res.residuals.shape == (2,)


@pytest.mark.parametrize("timeout", [0, -1.0, math.inf, math.nan, "1", True])
def test_timeout_values_are_checked(timeout: object) -> None:
    with pytest.raises(ConfigError, match="timeout: got"):
        minimize(sphere, BOUNDS, "ab", timeout=timeout)

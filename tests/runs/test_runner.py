"""Repeated runs: independent child seeds, order, parallel equals serial."""

from __future__ import annotations

import numpy as np
import pytest

from femupdate.errors import ConfigError
from femupdate.optimize import minimize
from femupdate.paper.problems.dynamic import DynamicProblem
from femupdate.runs import RunOutcome, repeat, run_seeds
from femupdate.runs.stats import BOUND_TOL, at_bounds, evaluation_stats, spread


def sphere(x: np.ndarray) -> float:
    return float(np.sum((x - 0.3) ** 2))


BOUNDS = [(-1.0, 1.0)] * 3


def test_runs_use_spawned_children_and_repeat_alone() -> None:
    outcomes = repeat(sphere, BOUNDS, "ab", runs=3, seed=7, max_evals=300)
    assert [o.index for o in outcomes] == [0, 1, 2]
    assert [o.seed["spawn_key"] for o in outcomes] == [[0], [1], [2]]
    # Run 2 repeated on its own, from its child seed, is the same run bit for bit.
    alone = minimize(sphere, BOUNDS, "ab", seed=np.random.default_rng(run_seeds(7, 3)[2]),
                     max_evals=300)
    np.testing.assert_array_equal(alone.x, outcomes[2].x)
    assert alone.fun == outcomes[2].fun
    # Different children give different runs.
    assert outcomes[0].fun != outcomes[1].fun


def test_parallel_equals_serial() -> None:
    problem = DynamicProblem()
    kw = dict(runs=4, seed=3, max_evals=400, f_target=1e-10)
    serial = repeat(problem, problem.bounds, "ab", workers=1, **kw)
    parallel = repeat(problem, problem.bounds, "ab", workers=2, **kw)
    for a, b in zip(serial, parallel, strict=True):
        np.testing.assert_array_equal(a.x, b.x)
        assert (a.fun, a.nfev, a.stop) == (b.fun, b.nfev, b.stop)


def test_outcome_records_restarts() -> None:
    outcomes = repeat(sphere, BOUNDS, "ab", runs=2, seed=1, max_evals=2_000, sigma_min=1e-2,
                      restarts=3)
    for o in outcomes:
        ref = minimize(sphere, BOUNDS, "ab", seed=np.random.default_rng(run_seeds(1, 2)[o.index]),
                       max_evals=2_000, sigma_min=1e-2, restarts=3)
        assert o.restarts == ref.restarts == 3
        assert RunOutcome.from_dict(o.to_dict()).restarts == 3


def test_bad_runs_and_workers() -> None:
    with pytest.raises(ConfigError, match="runs must be at least 1"):
        repeat(sphere, BOUNDS, runs=0)
    with pytest.raises(ConfigError, match="workers must be at least 1"):
        repeat(sphere, BOUNDS, runs=1, workers=0)


def test_evaluation_stats_counts_only_successes() -> None:
    stats = evaluation_stats([100, 300, 50_000, 200], [True, True, False, True])
    assert stats["runs"] == 4 and stats["successes"] == 3
    assert stats["success_ratio"] == 0.75
    assert (stats["evals_min"], stats["evals_max"]) == (100, 300)
    assert stats["evals_mean"] == pytest.approx(200.0)
    assert stats["evals_median"] == 200.0
    assert stats["evals_per_success"] == pytest.approx(50_600 / 3)
    none = evaluation_stats([10, 20], [False, False])
    assert none["successes"] == 0 and none["evals_mean"] is None
    assert none["evals_per_success"] is None


def test_at_bounds_names_the_parameters_at_a_bound_and_the_side() -> None:
    bounds = [(0.0, 10.0), (2.0, 3.0), (-1.0, 1.0), (5.0, 6.0)]
    x = np.array([10.0 * (1 - 0.5 * BOUND_TOL), 2.0, 0.0, 5.0 + 2 * BOUND_TOL])
    assert at_bounds(x, bounds, ["a", "b", "c", "d"]) == {"a": "upper", "b": "lower"}
    assert at_bounds(np.array([5.0, 2.5, 0.3, 5.5]), bounds, ["a", "b", "c", "d"]) == {}


def test_spread() -> None:
    out = spread(np.array([[1.0, 10.0], [3.0, 30.0]]), ["a", "b"])
    assert out["a"] == {"mean": 2.0, "std": pytest.approx(np.sqrt(2.0)), "min": 1.0, "max": 3.0}
    assert out["b"]["max"] == 30.0

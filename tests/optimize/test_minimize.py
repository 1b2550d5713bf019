"""minimize(): validation, the loop's contract, repeatability and quality on small problems."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import Bounds

from femupdate.benchmarks.dynamic import DynamicProblem
from femupdate.errors import ConfigError
from femupdate.optimize import METHODS, Status, minimize

ALL = sorted(METHODS)
BOX = [(-1.0, 2.0), (0.0, 1.0), (10.0, 20.0), (-5.0, -4.0)]
CENTRE = np.array([0.3, 0.7, 12.0, -4.6])
SCALE = np.array([3.0, 1.0, 10.0, 1.0])


def sphere(x: np.ndarray) -> float:
    d = (x - CENTRE) / SCALE
    return float(d @ d)


SMALL = {"ib": {}, "ab": {}, "cmaes": {}, "de": {"popsize": 10}, "ga": {"popsize": 10}}


# --- validation: one test per bad input -------------------------------------------------------

@pytest.mark.parametrize("bounds", [[(0.0, 1.0), (2.0, 2.0)], [(0.0, 1.0), (3.0, 2.0)]])
def test_lower_not_below_upper(bounds: list) -> None:
    with pytest.raises(ConfigError, match=r"bounds\[1\].*low must be < high"):
        minimize(sphere, bounds)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_bounds(bad: float) -> None:
    with pytest.raises(ConfigError, match=r"bounds\[0\].*finite"):
        minimize(sphere, [(bad, 1.0), (0.0, 1.0)])
    with pytest.raises(ConfigError, match=r"bounds\[1\].*finite"):
        minimize(sphere, Bounds([0.0, 0.0], [1.0, bad]))


def test_malformed_bounds() -> None:
    with pytest.raises(ConfigError, match="pairs"):
        minimize(sphere, [(0.0, 1.0, 2.0)])
    with pytest.raises(ConfigError, match="pairs"):
        minimize(sphere, [("a", 1.0)])
    with pytest.raises(ConfigError, match="at least one"):
        minimize(sphere, [])


@pytest.mark.parametrize("max_evals", [0, -3, 2.5, True])
def test_bad_max_evals(max_evals: object) -> None:
    with pytest.raises(ConfigError, match="max_evals"):
        minimize(sphere, BOX, max_evals=max_evals)  # type: ignore[arg-type]


@pytest.mark.parametrize("f_target", [math.nan, math.inf, "1e-3"])
def test_bad_f_target(f_target: object) -> None:
    with pytest.raises(ConfigError, match="f_target"):
        minimize(sphere, BOX, f_target=f_target)  # type: ignore[arg-type]


def test_unknown_method() -> None:
    allowed = "allowed methods: ib, ab, cmaes, de, ga"
    with pytest.raises(ConfigError, match=f"unknown method 'nelder'; {allowed}"):
        minimize(sphere, BOX, "nelder")


@pytest.mark.parametrize("method", ALL)
def test_unknown_option(method: str) -> None:
    with pytest.raises(ConfigError, match=f"unknown option.*'tolerance'.*{method!r}.*allowed"):
        minimize(sphere, BOX, method, tolerance=1e-3)


@pytest.mark.parametrize(
    ("method", "option", "value"),
    [("ab", "sigma_min", -1.0), ("ib", "sigma0", 0.5), ("ab", "f_change_min", 0.0),
     ("cmaes", "popsize", 1), ("cmaes", "sigma0", 0.0), ("cmaes", "tolfun", -1e-11),
     ("cmaes", "tolx", math.inf), ("de", "popsize", 4),
     ("de", "recombination", 1.5), ("de", "mutation", (1.0, 0.5)), ("ga", "popsize", 1.5)],
)
def test_option_out_of_range(method: str, option: str, value: object) -> None:
    with pytest.raises(ConfigError, match=f"option {option!r} of method {method!r}"):
        minimize(sphere, BOX, method, **{option: value})


def test_bad_seed() -> None:
    with pytest.raises(ConfigError, match="seed"):
        minimize(sphere, BOX, seed="abc")


def test_fun_returning_nan_is_a_counted_failure() -> None:
    calls = []

    def flaky(x: np.ndarray) -> float:
        calls.append(1)
        return math.nan if len(calls) % 3 == 0 else sphere(x)

    res = minimize(flaky, BOX, "ab", seed=0, max_evals=300)
    assert res.nfev == len(calls) == 300
    assert np.all(np.isinf(res.history["fun"][2::3]))
    assert np.isfinite(res.fun)
    res = minimize(lambda x: math.nan, BOX, "ab", seed=0, max_evals=20)
    assert res.nfev == 20 and res.fun == math.inf and not res.success


def test_fun_raising_propagates_with_x() -> None:
    calls = []

    class Boom(RuntimeError):
        pass

    def explodes(x: np.ndarray) -> float:
        calls.append(x.copy())
        if len(calls) == 7:
            raise Boom("simulation diverged")
        return sphere(x)

    with pytest.raises(Boom, match="simulation diverged") as info:
        minimize(explodes, BOX, "cmaes", seed=1)
    notes = "\n".join(getattr(info.value, "__notes__", []))
    assert str(calls[-1].tolist()) in notes


# --- the loop's contract ----------------------------------------------------------------------

@pytest.mark.parametrize("method", ALL)
def test_history_and_result_consistent(method: str) -> None:
    seen = []
    res = minimize(sphere, BOX, method, seed=3, max_evals=137,
                   callback=lambda x, f: seen.append((x.copy(), f)), **SMALL[method])
    h = res.history
    assert res.nfev == 137 and h["x"].shape == (137, 4) and h["fun"].shape == (137,)
    assert res.status == Status.MAX_EVALS and not res.success
    assert res.stop["max_evals"] == 137 and res.method == method
    low, high = np.array(BOX).T
    assert np.all((h["x"] >= low) & (h["x"] <= high))
    np.testing.assert_array_equal(h["fun"], [sphere(x) for x in h["x"]])
    np.testing.assert_array_equal(h["x"], [x for x, _ in seen])
    np.testing.assert_array_equal(h["fun"], [f for _, f in seen])
    best = int(np.argmin(h["fun"]))
    assert res.fun == h["fun"][best]
    np.testing.assert_array_equal(res.x, h["x"][best])


def test_cmaes_tolerances_reach_pycma() -> None:
    def offset_sphere(x: np.ndarray) -> float:  # pycma's tolerances are absolute
        return sphere(x) + 1.0

    default = minimize(offset_sphere, BOX, "cmaes", seed=0, max_evals=20_000)
    assert "tolfun" in default.stop
    off = minimize(offset_sphere, BOX, "cmaes", seed=0, max_evals=20_000, tolfun=0.0,
                   tolfunhist=0.0)
    assert not {"tolfun", "tolfunhist"} & set(off.stop)
    assert off.nfev > default.nfev


def test_partial_batch_is_not_told() -> None:
    res = minimize(sphere, BOX, "cmaes", seed=0, max_evals=12, popsize=5)
    assert res.nfev == 12 and res.nit == 2  # the third population was cut after 2
    assert res.history["sigma"].shape == (2,)


def test_f_target_stops_at_once() -> None:
    res = minimize(sphere, BOX, "ab", seed=0, f_target=1e-4)
    f = res.history["fun"]
    assert res.success and res.status == Status.F_TARGET
    assert f[-1] <= 1e-4 and np.all(f[:-1] > 1e-4)
    assert res.stop == {"f_target": f[-1]} and res.fun == f[-1]
    assert res.history["f_best"][-1] == f[-1]  # the last sample was told


def test_optimizer_criterion_stops() -> None:
    res = minimize(sphere, BOX, "ab", seed=0, sigma_min=1e-4)
    assert res.status == Status.OPTIMIZER and not res.success
    assert res.stop["sigma_min"] < 1e-4
    assert "sigma_min" in res.message


def test_bounds_object_same_as_pairs() -> None:
    low, high = np.array(BOX).T
    a = minimize(sphere, BOX, "ab", seed=5, max_evals=200)
    b = minimize(sphere, Bounds(low, high), "ab", seed=5, max_evals=200)
    np.testing.assert_array_equal(a.history["x"], b.history["x"])


@pytest.mark.parametrize("method", ["ab", "de"])
def test_custom_map(method: str) -> None:
    batches = []

    def my_map(fun, rows):  # an eager map, as an executor's would be
        rows = list(rows)
        batches.append(len(rows))
        return [fun(r) for r in rows]

    a = minimize(sphere, BOX, method, seed=2, max_evals=100, **SMALL[method])
    b = minimize(sphere, BOX, method, seed=2, max_evals=100, map=my_map, **SMALL[method])
    np.testing.assert_array_equal(a.history["x"], b.history["x"])
    assert batches[0] == (1 if method == "ab" else 10)


def test_seed_forms() -> None:
    ss = np.random.SeedSequence(11)
    a = minimize(sphere, BOX, seed=ss, max_evals=50)
    b = minimize(sphere, BOX, seed=np.random.default_rng(np.random.SeedSequence(11)),
                 max_evals=50)
    np.testing.assert_array_equal(a.history["x"], b.history["x"])


# --- repeatability and quality ------------------------------------------------------------------

@pytest.mark.parametrize("method", ALL)
def test_repeatable_bit_for_bit(method: str) -> None:
    runs = [minimize(sphere, BOX, method, seed=42, max_evals=400, **SMALL[method])
            for _ in range(2)]
    a, b = runs
    assert a.nfev == b.nfev and a.nit == b.nit and a.fun == b.fun
    np.testing.assert_array_equal(a.x, b.x)
    assert a.history.keys() == b.history.keys()
    for key in a.history:
        np.testing.assert_array_equal(a.history[key], b.history[key])
    c = minimize(sphere, BOX, method, seed=43, max_evals=400, **SMALL[method])
    assert not np.array_equal(a.history["x"], c.history["x"])


@pytest.mark.parametrize(("method", "target"),
                         [("ib", 1e-6), ("cmaes", 1e-6), ("de", 1e-4), ("ga", 1e-2)])
def test_reduces_phi_on_sphere(method: str, target: float) -> None:
    res = minimize(sphere, BOX, method, seed=0, max_evals=3000, **SMALL[method])
    assert res.fun < target < res.history["fun"][0]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ab_solves_dynamic_benchmark(seed: int) -> None:
    problem = DynamicProblem()
    res = minimize(problem, problem.bounds, "ab", seed=seed, max_evals=10_000, f_target=1e-10)
    assert res.success and res.fun <= 1e-10
    np.testing.assert_allclose(res.x, problem.truth, rtol=1e-3)


def test_executor_map() -> None:
    from concurrent.futures import ThreadPoolExecutor

    a = minimize(sphere, BOX, "cmaes", seed=4, max_evals=53, popsize=6)
    with ThreadPoolExecutor(2) as pool:
        b = minimize(sphere, BOX, "cmaes", seed=4, max_evals=53, popsize=6, map=pool.map)
    assert b.nfev == 53
    for key in a.history:
        np.testing.assert_array_equal(a.history[key], b.history[key])

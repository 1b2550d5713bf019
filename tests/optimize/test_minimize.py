"""minimize(): validation, the loop's contract, repeatability and quality on small problems."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from plugins import register_optimizers
from scipy.optimize import Bounds

from femupdate.errors import ConfigError
from femupdate.optimize import METHODS, Status, minimize
from femupdate.paper.problems.dynamic import DynamicProblem

register_optimizers()  # the comparison optimizers (benchmarks/plugins) are tested here too

# scipy-lsq needs residual vectors: its contract is tested in test_multistart.py.
ALL = sorted(set(METHODS) - {"scipy-lsq"})
BOX = [(-1.0, 2.0), (0.0, 1.0), (10.0, 20.0), (-5.0, -4.0)]
CENTRE = np.array([0.3, 0.7, 12.0, -4.6])
SCALE = np.array([3.0, 1.0, 10.0, 1.0])


def sphere(x: np.ndarray) -> float:
    d = (x - CENTRE) / SCALE
    return float(d @ d)


SMALL = {"ib": {}, "ab": {}, "cmaes": {}, "de": {"popsize": 10}, "ga": {"popsize": 10},
         "multistart-lm": {"pool": 10}}


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
    allowed = "allowed methods: ib, ab, cmaes, multistart-lm, de, ga, scipy-lsq"
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
     ("cmaes", "tolx", math.inf), ("ab", "restarts", -1), ("cmaes", "restarts", 1.5),
     ("ib", "stall_window", 0), ("cmaes", "stall_tol", 1.0),
     ("de", "popsize", 4),
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
                   callback=lambda intermediate_result: seen.append(intermediate_result),
                   **SMALL[method])
    h = res.history
    assert res.nfev == 137 and h["x"].shape == (137, 4) and h["fun"].shape == (137,)
    assert res.status == Status.MAX_EVALS and not res.success
    assert res.stop["max_evals"] == 137 and res.method == method
    low, high = np.array(BOX).T
    assert np.all((h["x"] >= low) & (h["x"] <= high))
    np.testing.assert_array_equal(h["fun"], [sphere(x) for x in h["x"]])
    # scipy's callback: once per completed step, with the best so far.
    assert [r.nit for r in seen] == list(range(1, res.nit + 1))
    for r in seen:
        assert r.fun == h["fun"][: r.nfev].min()
        np.testing.assert_array_equal(r.x, h["x"][: r.nfev][np.argmin(h["fun"][: r.nfev])])
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


def test_cmaes_resampling_is_capped_then_projects() -> None:
    # The mean at a corner of a 40-dimensional box: a draw lands inside with probability
    # 2^-40, so resampling without a cap would not end; with it, each candidate takes at most
    # MAX_RESAMPLES redraws and is then clipped into the box (and told to pycma as such).
    from femupdate.optimize import cmaes

    opt = cmaes.CMAES(40, np.random.default_rng(0), sigma0=0.3)
    opt.es.mean[:] = 0.0
    xs = opt.ask()
    assert xs.shape == (5, 40) and np.all((xs >= 0.0) & (xs <= 1.0))
    assert opt.projected == 5 and opt.resamples == 5 * cmaes.MAX_RESAMPLES
    assert np.any(xs == 0.0, axis=1).all()  # projected onto the box's faces
    opt.tell(xs, np.sum(xs, axis=1))  # pycma takes the projected points


def test_cmaes_resamples_inside_when_cheap() -> None:
    # Well inside the box the truncated Gaussian is drawn exactly: no candidate projected.
    from femupdate.optimize import cmaes

    opt = cmaes.CMAES(4, np.random.default_rng(1))
    for _ in range(40):
        xs = opt.ask()
        opt.tell(xs, np.sum((xs - 0.1) ** 2, axis=1))
    assert opt.resamples > 0 and opt.projected == 0


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
    # scipy's meaning of success: without an f_target, converging by the optimizer's own
    # criterion is a success; running out of budget is not.
    res = minimize(sphere, BOX, "ab", seed=0, sigma_min=1e-4)
    assert res.status == Status.OPTIMIZER and res.success
    assert res.stop["sigma_min"] < 1e-4
    assert "sigma_min" in res.message


def trap(x: np.ndarray) -> float:
    """An improper minimum at the lower bound (φ = 0.5, a quarter of the box drains into it) and
    the global one, φ = 0, at 0.7: a converged search in the trap can only restart."""
    u = float(x[0])
    return 0.5 + u if u < 0.25 else min(1.0, 20.0 * (u - 0.7) ** 2)


@pytest.mark.parametrize(("method", "options"),
                         [("ab", {"sigma_min": 1e-3}), ("ib", {"f_change_min": 1e-3}),
                          ("cmaes", {"tolx": 1e-3})])
def test_restarts_leave_a_converged_search(method: str, options: dict) -> None:
    res = minimize(trap, [(0.0, 1.0)], method, seed=1, max_evals=5_000, restarts=3, **options)
    h = res.history
    assert res.restarts == 3 and h["restarts"][-1] == 3
    assert np.all(np.diff(h["restarts"]) >= 0) and set(np.unique(h["restarts"])) == {0, 1, 2, 3}
    assert res.status == Status.OPTIMIZER and res.nfev < 5_000  # the last search converged
    assert res.fun == h["fun"].min()  # the best over all searches
    per_step = 5 if method == "cmaes" else 1  # λ = 5; IB/AB one sample a step
    last_of_step = np.arange(1, res.nit + 1) * per_step - 1
    np.testing.assert_array_equal(h["f_best"], np.minimum.accumulate(h["fun"])[last_of_step])
    again = minimize(trap, [(0.0, 1.0)], method, seed=1, max_evals=5_000, restarts=3, **options)
    np.testing.assert_array_equal(again.history["fun"], h["fun"])


def test_restarts_escape_improper_minima() -> None:
    def successes(restarts: int) -> int:
        return sum(minimize(trap, [(0.0, 1.0)], "ab", seed=seed, max_evals=3_000, f_target=1e-8,
                            sigma_min=1e-4, restarts=restarts).success for seed in range(20))

    without, with_restarts = successes(0), successes(20)
    assert without < 20 and with_restarts == 20


@pytest.mark.parametrize("method", ["ab", "cmaes"])
def test_stall_fires_when_the_best_falls_by_less_than_stall_tol_over_the_window(
        method: str) -> None:
    opt = METHODS[method](2, np.random.default_rng(0), stall_window=3, stall_tol=0.1)
    values = [8.0, 4.0, 2.0, 1.0, 0.95, 0.95, 0.95]  # told one at a time
    fired = []
    for f in values:
        opt._track(np.array([f]))
        fired.append(opt._stall())
    assert fired[:6] == [{}] * 6  # 6 evaluations: 0.95 against 2.0 three evaluations earlier
    assert fired[6] == {"stall": pytest.approx(0.05)}  # 0.95 against 1.0: less than 10 % less


def test_stall_is_relative_to_the_magnitude_of_phi() -> None:
    opt = METHODS["ab"](1, np.random.default_rng(0), stall_window=2, stall_tol=0.1)
    opt._track(np.array([-10.0, -10.5, -10.6]))  # negative φ: a fall of 6 % of |φ|
    assert opt._stall() == {"stall": pytest.approx(0.06)}
    opt._track(np.array([-20.0]))
    assert opt._stall() == {}
    fresh = METHODS["ab"](1, np.random.default_rng(0), stall_window=2)
    fresh._track(np.array([np.inf, np.inf, np.inf]))  # all failed: nothing to compare
    assert fresh._stall() == {}


def test_stall_restarts_a_search_creeping_into_an_improper_minimum() -> None:
    # σ_s off: a search in the trap creeps towards the bound with ever smaller successes and
    # never converges; only the stall criterion ends it.
    def runs(**options: object) -> list:
        return [minimize(trap, [(0.0, 1.0)], "ab", seed=seed, max_evals=2_000, f_target=1e-8,
                         sigma_min=0.0, **options) for seed in range(20)]

    creeping = runs(restarts=5)
    trapped = [r for r in creeping if not r.success]
    assert trapped and all(r.nfev == 2_000 and r.restarts == 0 for r in trapped)
    assert all(r.x[0] < 1e-3 for r in trapped)
    restarted = runs(restarts=5, stall_window=100)
    assert all(r.success for r in restarted)
    assert {r.restarts for r in restarted} > {0}
    alone = runs(stall_window=100)  # no restart left: stall stops the run
    stopped = [r for r in alone if not r.success]
    assert stopped and all("stall" in r.stop and r.nfev < 200 for r in stopped)


def test_no_restart_is_the_paper_algorithm() -> None:
    """restarts=0 stops at the first convergence; more restarts change nothing before it."""
    one = minimize(trap, [(0.0, 1.0)], "ab", seed=2, max_evals=5_000, sigma_min=1e-3)
    more = minimize(trap, [(0.0, 1.0)], "ab", seed=2, max_evals=5_000, sigma_min=1e-3,
                    restarts=2)
    assert one.restarts == 0 and "sigma_min" in one.stop
    np.testing.assert_array_equal(more.history["fun"][: one.nfev], one.history["fun"])
    assert more.nfev > one.nfev


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
    b = minimize(sphere, BOX, method, seed=2, max_evals=100, workers=my_map, **SMALL[method])
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
        b = minimize(sphere, BOX, "cmaes", seed=4, max_evals=53, popsize=6, workers=pool.map)
    assert b.nfev == 53
    for key in a.history:
        np.testing.assert_array_equal(a.history[key], b.history[key])


def test_workers_as_processes_give_the_same_run() -> None:
    a = minimize(sphere, BOX, "cmaes", seed=4, max_evals=60, popsize=6)
    b = minimize(sphere, BOX, "cmaes", seed=4, max_evals=60, popsize=6, workers=2)
    for key in a.history:
        np.testing.assert_array_equal(a.history[key], b.history[key])
    with pytest.raises(ConfigError, match="workers must be"):
        minimize(sphere, BOX, workers=0)


def test_deprecated_map_and_two_argument_callback_still_work() -> None:
    seen = []
    with pytest.warns(DeprecationWarning, match="map"):
        a = minimize(sphere, BOX, "ab", seed=1, max_evals=30, map=map)
    with pytest.warns(DeprecationWarning, match=r"callback\(x, f\)"):
        b = minimize(sphere, BOX, "ab", seed=1, max_evals=30,
                     callback=lambda x, f: seen.append(f))
    np.testing.assert_array_equal(a.history["fun"], b.history["fun"])
    np.testing.assert_array_equal(seen, b.history["fun"])  # once per evaluation


def test_callback_stop_iteration_ends_the_run() -> None:
    def stop_at_20(intermediate_result):
        if intermediate_result.nfev >= 20:
            raise StopIteration

    res = minimize(sphere, BOX, "ab", seed=1, max_evals=1000, callback=stop_at_20)
    assert res.nfev == 20 and res.status == Status.CALLBACK and not res.success
    assert res.stop == {"callback": True} and "StopIteration" in res.message


@pytest.mark.parametrize("value", ["1.0", True, None, [1.0, 2.0]])
def test_a_function_value_that_is_not_a_number_is_an_error(value: object) -> None:
    with pytest.raises(ConfigError, match="fun\\(x\\) must return a real number"):
        minimize(lambda x: value, BOX, seed=0, max_evals=5)


def test_a_one_element_array_is_a_number() -> None:
    res = minimize(lambda x: np.array([sphere(x)]), BOX, seed=0, max_evals=5)
    assert res.nfev == 5 and np.isfinite(res.fun)


def test_a_scalar_function_may_have_a_negative_target() -> None:
    # bbob's optima are negative; only a sum of squares (residuals=True) never goes below 0.
    res = minimize(lambda x: float(x @ x) - 5.0, [(-1.0, 1.0)] * 2, "ab", seed=0,
                   max_evals=5000, f_target=-4.9)
    assert "f_target" in res.stop and res.fun <= -4.9
    with pytest.raises(ConfigError, match="f_target"):
        minimize(lambda x: x, [(-1.0, 1.0)] * 2, "multistart-lm", residuals=True, f_target=-1)


@pytest.mark.parametrize("method", ["multistart-lm", "de", "ab", "ga"])
def test_memory_follows_the_budget_in_many_dimensions(method: str) -> None:
    # Issue 33: 4,000 parameters and max_evals = 10 took 5.1 GB and 206 s (a pool of 20·n
    # points, a population of 15·n held whole before the first evaluation).
    import tracemalloc

    tracemalloc.start()
    try:
        res = minimize(lambda x: float(np.sum((x - 0.3) ** 2)), [(0.0, 1.0)] * 4000, method,
                       seed=1, max_evals=10)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert res.nfev == 10 and peak < 400e6, peak


@pytest.mark.parametrize(("method", "n", "words"), [
    ("multistart-lm", 4000, "cannot serve 4,000 parameters: it would hold about 2.1 GB"),
    ("cmaes", 2001, "decompose an n × n covariance (allowed: up to 2,000 parameters)"),
])
def test_a_dimension_the_method_cannot_serve_is_refused_up_front(method: str, n: int,
                                                                 words: str) -> None:
    with pytest.raises(ConfigError, match=re.escape(words)):
        minimize(lambda x: 0.0, [(0.0, 1.0)] * n, method, max_evals=50_000)

"""Checkpointing (pickle) and isolation: threads and numpy's global random state."""

from __future__ import annotations

import pickle
import threading

import numpy as np
import pytest
from plugins import register_optimizers

from femupdate.optimize import METHODS, minimize, start

register_optimizers()  # the comparison optimizers (benchmarks/plugins) are tested here too


def sphere(x: np.ndarray) -> float:
    d = x - 0.3
    return float(d @ d)


def _steps(opt, k: int) -> list[np.ndarray]:
    asked = []
    for _ in range(k):
        xs = opt.ask()
        asked.append(xs)
        opt.tell(xs, np.array([sphere(x) for x in xs]))
    return asked


@pytest.mark.parametrize("method", ["ib", "ab", "cmaes"])
def test_pickled_optimizer_resumes_bit_identically(method: str) -> None:
    opt = METHODS[method](5, np.random.default_rng(7))
    _steps(opt, 60)
    clone = pickle.loads(pickle.dumps(opt))
    # A checkpoint leaves the trace out (the store keeps it) but keeps counting the steps.
    assert clone.trace.steps == opt.trace.steps == 60 and clone.trace_since(0) == {}
    a, b = _steps(opt, 60), _steps(clone, 60)
    for xa, xb in zip(a, b, strict=True):
        np.testing.assert_array_equal(xa, xb)
    assert opt.best_f == clone.best_f
    np.testing.assert_array_equal(opt.best_x, clone.best_x)
    after = clone.trace_since(60)
    assert after and all(v.shape[0] == 60 for v in after.values())
    for key, value in opt.trace_since(60).items():
        np.testing.assert_array_equal(value, after[key])


@pytest.mark.parametrize("method", ["ab", "cmaes"])
def test_pickled_loop_state_resumes_bit_identically(method: str) -> None:
    state = start(sphere, [(0.0, 1.0)] * 3 + [(-2.0, 5.0)], method, seed=3, max_evals=500)
    for _ in range(40):
        state.step(sphere)
    nfev0, nit0 = state.nfev, state.nit
    clone = pickle.loads(pickle.dumps(state))
    assert clone.evaluations_since(0)[0].shape[0] == 0  # the history stays out of a checkpoint
    for s in (state, clone):
        while not s.done:
            s.step(sphere)
    a, b = state.result(), clone.result()
    assert a.nfev == b.nfev == 500 and a.fun == b.fun
    for ea, eb in zip(state.evaluations_since(nfev0), clone.evaluations_since(nfev0),
                      strict=True):
        np.testing.assert_array_equal(ea, eb)
    for key, value in state.trace_since(nit0).items():
        np.testing.assert_array_equal(value, clone.trace_since(nit0)[key])


@pytest.mark.parametrize("method", ["de", "ga"])
def test_de_ga_refuse_pickling(method: str) -> None:
    opt = METHODS[method](3, np.random.default_rng(0), popsize=6)
    try:
        with pytest.raises(TypeError, match="restart"):
            pickle.dumps(opt)
    finally:
        opt.close()


def test_de_leaves_no_thread() -> None:
    before = threading.active_count()
    minimize(sphere, [(0.0, 1.0)] * 3, "de", seed=0, max_evals=95, popsize=10)  # mid-population
    assert threading.active_count() == before
    minimize(sphere, [(0.0, 1.0)] * 3, "de", seed=0, f_target=1e-2, popsize=10)
    assert threading.active_count() == before
    with pytest.raises(ZeroDivisionError):
        minimize(lambda x: 1 / 0, [(0.0, 1.0)] * 3, "de", seed=0, popsize=10)
    assert threading.active_count() == before
    opt = METHODS["de"](3, np.random.default_rng(0), popsize=6)
    opt.ask()
    del opt  # never closed: the finalizer stops the thread
    import gc

    gc.collect()
    assert threading.active_count() == before


def test_de_own_tolerance_fires() -> None:
    before = threading.active_count()
    res = minimize(sphere, [(0.0, 1.0)] * 2, "de", seed=0, popsize=8, tol=0.5)
    assert res.stop == {"de_tol": 0.5} and res.status == 2
    assert threading.active_count() == before


@pytest.mark.parametrize("method", ["cmaes", "ga", "de", "ab"])
def test_numpy_global_random_state_neither_used_nor_changed(method: str) -> None:
    options = {"popsize": 6} if method in ("ga", "de") else {}
    np.random.seed(1)  # noqa: NPY002
    before = np.random.get_state()  # noqa: NPY002
    a = minimize(sphere, [(0.0, 1.0)] * 3, method, seed=9, max_evals=200, **options)
    after = np.random.get_state()  # noqa: NPY002
    assert np.array_equal(before[1], after[1]) and before[2] == after[2]  # not touched
    np.random.seed(12345)  # noqa: NPY002 (perturb the global state between the runs)
    np.random.rand(17)  # noqa: NPY002
    b = minimize(sphere, [(0.0, 1.0)] * 3, method, seed=9, max_evals=200, **options)
    np.testing.assert_array_equal(a.history["x"], b.history["x"])

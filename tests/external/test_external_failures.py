"""A user function that raises, returns NaN or the wrong shape, hangs or kills its process:
each is one failed evaluation (φ = inf) with a clear message, and the batch goes on."""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
import pytest
from external_helpers import Space, experiment, problem_for

from femupdate.errors import ConfigError
from femupdate.external import Evaluation, EvaluationError, check_prediction
from femupdate.problem.update import UpdateProblem
from femupdate.runs import run_all
from femupdate.runs.batch import evaluate_batch
from femupdate.runs.executors import open_executor

#: mode → a fragment of the message of its failure.
EXPECTED = {
    1: "ValueError: negative stiffness in storey 2 (user_model.py:",
    2: "returned nan at sample 17 of output 0 (1 non-finite values)",
    3: "returned an array of shape (200, 2); expected (n_samples, n_outputs) = (200, 1)",
    4: "timed out: predicting took longer than 1.5 s; the model's process was killed",
    5: "the model's process died (exit code 7) while predicting",
    6: "RuntimeError: diverged (user_model.py:",
}


def _x(mode: int, a: float = 2.0) -> np.ndarray:
    return np.array([a, float(mode)])


def test_a_good_candidate_is_fitted(problem: UpdateProblem) -> None:
    ev = problem.evaluate(_x(0))
    assert ev == Evaluation(0.0, None, ev.seconds) and not ev.failed
    assert problem(_x(0, a=1.0)) == pytest.approx(0.25)  # (1 − 2)² / 2²
    assert problem.frequencies(_x(0, a=1.5)).tolist() == [1.5, 3.0]


def _key(problem: UpdateProblem) -> str:
    """Names the problem's model processes (one trial, one external model)."""
    return problem.trials[0]._runner.key


@pytest.mark.slow
def test_every_failure_is_inf_with_its_message_and_the_batch_finishes(
        problem: UpdateProblem) -> None:
    modes = [0, 1, 2, 3, 4, 5, 6, 0]
    start = time.perf_counter()
    results = evaluate_batch(problem, [_x(m) for m in modes])
    assert len(results) == len(modes)
    assert time.perf_counter() - start < 30
    for mode, ev in zip(modes, results, strict=True):
        if mode == 0:
            assert ev.phi == 0.0 and ev.error is None
            continue
        assert ev.phi == np.inf and ev.failed, mode
        assert EXPECTED[mode] in ev.error, (mode, ev.error)
    # What the model printed before failing is quoted.
    assert "model output: step 41: no convergence" in results[6].error


@pytest.mark.slow
def test_a_hung_model_is_killed_and_replaced(problem: UpdateProblem) -> None:
    from femupdate.external.isolation import _all

    assert problem(_x(0)) == 0.0
    (worker,) = _all[_key(problem)]
    old_pid = worker.pid
    ev = problem.evaluate(_x(4))
    assert ev.phi == np.inf and 1.5 <= ev.seconds < 10
    with pytest.raises(ProcessLookupError):
        os.kill(old_pid, 0)  # gone
    assert problem(_x(0)) == 0.0 and worker.pid != old_pid


@pytest.mark.slow
def test_batches_over_two_local_processes_keep_order(problem: UpdateProblem) -> None:
    from femupdate.external.isolation import _all

    rows = [_x(0, 1.0), _x(1), _x(0, 2.0), _x(3), _x(0, 3.0)]
    assert problem(_x(0)) == 0.0
    (mine,) = _all[_key(problem)]
    pid = mine.pid
    with open_executor(2) as ex:  # forked workers: they must start their own model processes
        remote = evaluate_batch(problem, rows, ex)
    assert mine.pid == pid and mine.alive  # this process's, untouched by the forks
    local = evaluate_batch(problem, rows)
    assert [e.phi for e in remote] == [e.phi for e in local]
    assert [e.error for e in remote] == [e.error for e in local]


def test_in_process_evaluation_catches_exceptions_too(user_module: Path) -> None:
    prob = problem_for({"python": {"function": f"{user_module}:model", "isolate": False}})
    assert prob(_x(0)) == 0.0
    ev = prob.evaluate(_x(1))
    assert ev.phi == np.inf
    assert ev.error == "trial 'user': ValueError: negative stiffness in storey 2"
    assert "shape (200, 2)" in prob.evaluate(_x(3)).error


def test_a_time_out_needs_a_process(user_module: Path) -> None:
    with pytest.raises(ConfigError, match=r"model\.timeout: a time-out needs the model in its "
                                          r"own process"):
        problem_for({"python": {"function": f"{user_module}:model", "isolate": False,
                                "timeout": 1.0}})


def test_check_prediction_accepts_one_column_as_a_vector() -> None:
    assert check_prediction(np.arange(4.0), 4, 1).shape == (4, 1)
    with pytest.raises(EvaluationError, match="returned str, not an array of numbers"):
        check_prediction("abc", 4, 1)


def test_residuals_square_to_phi(user_module: Path) -> None:
    exp = experiment("displacement")
    prob = problem_for({"python": {"function": f"{user_module}:model", "isolate": False}}, exp)
    for a in (2.0, 2.9, 3.0, 4.5):
        r = prob.residuals(_x(0, a))
        assert r.shape == (exp.t.size,)
        assert float(r @ r) == pytest.approx(prob(_x(0, a)), rel=1e-12, abs=1e-30)
    assert prob(_x(0, 3.0)) < 1e-20  # the integration constants fitted away


@pytest.mark.slow
def test_failures_on_a_dask_cluster_are_the_same(problem: UpdateProblem) -> None:
    distributed = pytest.importorskip("dask.distributed", reason="needs the 'dask' extra")
    rows = [_x(0, 1.0), _x(1), _x(5), _x(0, 3.0)]
    # Worker threads in this process: quick to start; each thread gets its own model process.
    # (Daemonic worker processes, which may not have multiprocessing children, are exercised by
    # benchmarks/external_parallel.py.)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, \
            open_executor(scheduler=cluster.scheduler_address) as ex:
        remote = evaluate_batch(problem, rows, ex)
    assert [e.phi for e in remote] == [e.phi for e in evaluate_batch(problem, rows)]
    assert remote[0].phi == pytest.approx(0.25) and remote[2].phi == np.inf
    assert EXPECTED[1] in remote[1].error and EXPECTED[5] in remote[2].error


def test_a_search_through_the_runner_survives_failures(user_module: Path, tmp_path: Path
                                                       ) -> None:
    from femupdate.runs.store import ResultsStore

    prob = problem_for({"python": {"function": f"{user_module}:fragile"}},
                       space=Space(("a",), ((0.0, 5.0),)))
    try:
        outcomes = run_all(prob, prob.bounds, "ab", runs=2, seed=3, max_evals=150,
                           store_dir=tmp_path)
    finally:
        prob.close()
    for outcome in outcomes:
        assert outcome.nfev == 150 and abs(outcome.x[0] - 2.0) < 1e-3
        assert outcome.nfail > 0 and "unstable above a = 3.5" in outcome.failure
    with ResultsStore.open(tmp_path) as store:
        phi = np.concatenate([store.history(i)["fun"] for i in range(2)])
        failures = store.failures(0)
    assert np.isinf(phi).any() and np.isfinite(phi).any()  # failures stored as inf, runs done
    # every failed evaluation's message is in the store, at its evaluation
    inf_at = np.flatnonzero(np.isinf(store_phi := phi[:150]))
    assert [i for i, _ in failures] == inf_at.tolist() and store_phi.size == 150
    assert all("ValueError: unstable above a = 3.5" in why for _, why in failures)

"""run_all: chunked runs through a store equal uninterrupted minimize runs, bit for bit."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from grouped import run_all
from plugins import register_optimizers

from femupdate.errors import ConfigError
from femupdate.optimize import minimize
from femupdate.paper.problems.dynamic import PARAMETER_NAMES, DynamicProblem
from femupdate.runs import run_seeds
from femupdate.runs.store import FILENAME, ResultsStore, StoreError

register_optimizers()  # the comparison optimizers (benchmarks/plugins) are tested here too

PROBLEM = DynamicProblem()
BOUNDS = PROBLEM.bounds
OPTIONS = {"ab": {}, "ib": {}, "cmaes": {"popsize": 5}, "de": {"popsize": 5}, "ga": {"popsize": 20}}


def stored_evaluations(directory: Path) -> dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per run: eval indices, x and φ as stored."""
    with ResultsStore.open(directory) as store:
        return {r.run: store.evaluations(r.run)[:3] for r in store.runs()}


def assert_same_outcomes(a: list, b: list) -> None:
    assert len(a) == len(b)
    for oa, ob in zip(a, b, strict=True):
        assert oa.index == ob.index and oa.seed == ob.seed
        np.testing.assert_array_equal(oa.x, ob.x)
        assert (oa.fun, oa.nfev, oa.nit, oa.success, oa.status) == (
            ob.fun, ob.nfev, ob.nit, ob.success, ob.status)


def assert_same_store(dir_a: Path, dir_b: Path) -> None:
    ea, eb = stored_evaluations(dir_a), stored_evaluations(dir_b)
    assert ea.keys() == eb.keys()
    for run in ea:
        (ia, xa, fa), (ib, xb, fb) = ea[run], eb[run]
        np.testing.assert_array_equal(ia, np.arange(ia.size))  # 0 … nfev − 1, none twice
        np.testing.assert_array_equal(ia, ib)
        assert xa.tobytes() == xb.tobytes() and fa.tobytes() == fb.tobytes()


RESTARTING = {"ab": {"sigma_min": 0.02, "restarts": 5}, "cmaes": {"tolx": 0.05, "restarts": 5}}


@pytest.mark.parametrize(
    ("method", "options"),
    [(m, OPTIONS[m]) for m in ("ab", "ib", "cmaes")] + list(RESTARTING.items()),
)
def test_each_run_is_minimize_with_its_child_seed(method: str, options: dict) -> None:
    # Tiny, odd chunks: every run is pickled, stripped and resumed dozens of times.
    kw = dict(runs=2, seed=4, max_evals=700, f_target=1e-10)
    outcomes = run_all(PROBLEM, BOUNDS, method, options=options, chunk_evals=37,
                       keep_history=True, **kw)
    if "restarts" in options:  # restarts made between chunks survive the pickling
        assert all(o.restarts > 0 for o in outcomes)
    for i, outcome in enumerate(outcomes):
        ref = minimize(PROBLEM, BOUNDS, method, seed=np.random.default_rng(run_seeds(4, 2)[i]),
                       max_evals=700, f_target=1e-10, **options)
        np.testing.assert_array_equal(outcome.x, ref.x)
        assert (outcome.fun, outcome.nfev, outcome.nit, outcome.stop, outcome.restarts) == (
            ref.fun, ref.nfev, ref.nit, ref.stop, ref.restarts)
        assert outcome.history.keys() == ref.history.keys()
        for key, value in ref.history.items():  # evaluations and the optimizer's trace
            assert outcome.history[key].tobytes() == value.tobytes(), key


class Crashing:
    """φ that raises at its ``crash_at``-th call in this process: a crash mid-set."""

    def __init__(self, crash_at: int) -> None:
        self.calls = 0
        self.crash_at = crash_at

    def __call__(self, x: np.ndarray) -> float:
        self.calls += 1
        if self.calls == self.crash_at:
            raise RuntimeError("simulated crash")
        return PROBLEM(x)


@pytest.mark.parametrize("method", ["ab", "cmaes", "de"])
def test_resume_after_a_crash_equals_an_uninterrupted_set(tmp_path: Path, method: str) -> None:
    kw = dict(runs=3, seed=8, max_evals=600, options=OPTIONS[method], chunk_evals=50,
              names=PARAMETER_NAMES)
    reference = run_all(PROBLEM, BOUNDS, method, store_dir=tmp_path / "ref", **kw)
    # Crash halfway through the last run (runs go one after the other in this process).
    crash_at = reference[0].nfev + reference[1].nfev + reference[2].nfev // 2
    with pytest.raises(RuntimeError, match="simulated crash"):
        run_all(Crashing(crash_at), BOUNDS, method, store_dir=tmp_path / "cut", **kw)
    with ResultsStore.open(tmp_path / "cut") as store:
        status = [r.status for r in store.runs()]
        assert status == ["done", "done", "running"]  # the crash came in run 2
        has_checkpoint = store.checkpoint(2) is not None
    assert has_checkpoint == (method != "de")  # de cannot be checkpointed: it restarts
    resumed = run_all(PROBLEM, BOUNDS, method, store_dir=tmp_path / "cut", resume=True, **kw)
    assert_same_outcomes(resumed, reference)
    assert_same_store(tmp_path / "cut", tmp_path / "ref")


def test_local_processes_equal_this_process(tmp_path: Path) -> None:
    kw = dict(runs=3, seed=2, max_evals=2000, f_target=1e-10, chunk_evals=300)
    inline = run_all(PROBLEM, BOUNDS, "ab", store_dir=tmp_path / "one", **kw)
    pool = run_all(PROBLEM, BOUNDS, "ab", store_dir=tmp_path / "two", workers=2, **kw)
    assert_same_outcomes(inline, pool)
    assert_same_store(tmp_path / "one", tmp_path / "two")


@pytest.mark.parametrize("method", ["de", "ga"])
def test_a_population_spread_over_workers_gives_the_same_run(method: str) -> None:
    # One run, two workers: the run stays here and each population is split between them.
    kw = dict(runs=1, seed=6, max_evals=400, options=OPTIONS[method], keep_history=True)
    inline = run_all(PROBLEM, BOUNDS, method, **kw)
    spread = run_all(PROBLEM, BOUNDS, method, workers=2, **kw)
    assert_same_outcomes(inline, spread)
    assert spread[0].history["fun"].tobytes() == inline[0].history["fun"].tobytes()


@pytest.mark.parametrize("compiled", [True, False])
def test_a_least_squares_run_spread_over_workers_gives_the_same_bits(
        compiled: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    # multistart-lm on the bridge (14,304 residuals): its pools and Jacobians go to two
    # threads of this process when the problem is evaluated compiled, else to the worker
    # processes; its optimizer and φ = r·r stay here, with one BLAS thread as in a worker (a
    # threaded dot product of that length rounds differently, and the search follows).
    from femupdate.paper.problems.bridge import viscous_problem
    from femupdate.problem.update import UpdateProblem

    problem = viscous_problem()
    threads_asked: list[int] = []
    batch = UpdateProblem.residuals_batch

    def counted(self: UpdateProblem, X: np.ndarray, *, threads: int = 1) -> np.ndarray:
        threads_asked.append(threads)
        return batch(self, X, threads=threads)

    monkeypatch.setattr(UpdateProblem, "residuals_batch", counted)
    if not compiled:
        monkeypatch.setattr(UpdateProblem, "parallel_batches", False)
    kw = dict(runs=1, seed=4, max_evals=260, keep_history=True, residuals=True)
    inline = run_all(problem.residuals, problem.bounds, "multistart-lm", **kw)
    assert threads_asked and set(threads_asked) == {1}
    threads_asked.clear()
    spread = run_all(problem.residuals, problem.bounds, "multistart-lm", workers=2, **kw)
    assert set(threads_asked) == ({2} if compiled else set())  # workers: their own copies
    assert_same_outcomes(inline, spread)
    assert spread[0].history["fun"].tobytes() == inline[0].history["fun"].tobytes()


def test_a_finished_set_resumes_to_the_same_outcomes(tmp_path: Path) -> None:
    kw = dict(runs=2, seed=1, max_evals=300, store_dir=tmp_path)
    first = run_all(PROBLEM, BOUNDS, "ab", **kw)
    again = run_all(PROBLEM, BOUNDS, "ab", resume=True, **kw)
    assert_same_outcomes(first, again)
    assert [o.stop for o in first] == [o.stop for o in again]


def test_resume_without_a_seed_continues_the_recorded_entropy(tmp_path: Path) -> None:
    kw = dict(runs=2, seed=None, max_evals=400, chunk_evals=40, store_dir=tmp_path)
    with pytest.raises(RuntimeError, match="simulated crash"):
        run_all(Crashing(600), BOUNDS, "ab", **kw)
    resumed = run_all(PROBLEM, BOUNDS, "ab", resume=True, **kw)
    entropy = resumed[0].seed["entropy"]
    assert resumed[1].seed == {"entropy": entropy, "spawn_key": [1]}
    ref = minimize(PROBLEM, BOUNDS, "ab", max_evals=400,
                   seed=np.random.default_rng(run_seeds(entropy, 2)[1]))
    np.testing.assert_array_equal(resumed[1].x, ref.x)
    assert resumed[1].nfev == ref.nfev


def test_resume_is_refused_for_other_settings_or_another_case(tmp_path: Path) -> None:
    kw = dict(runs=1, seed=0, max_evals=100, store_dir=tmp_path, case_dict={"case": "a"})
    run_all(PROBLEM, BOUNDS, "ab", **kw)
    before = (tmp_path / FILENAME).read_bytes()
    with pytest.raises(StoreError, match=r"the case changed since its runs started: case: "
                                          r"'a' → 'b'.*--restart"):
        run_all(PROBLEM, BOUNDS, "ab", resume=True, **{**kw, "case_dict": {"case": "b"}})
    with pytest.raises(StoreError, match=r"written with method = 'ab'.*'ib'"):
        run_all(PROBLEM, BOUNDS, "ib", resume=True, **kw)
    with pytest.raises(StoreError, match=r"written with the root seed = 0, this run asks for "
                                          r"the root seed = 1"):
        run_all(PROBLEM, BOUNDS, "ab", resume=True, **{**kw, "seed": 1})
    with pytest.raises(StoreError, match="already holds a results store"):
        run_all(PROBLEM, BOUNDS, "ab", **kw)  # no resume: never overwritten
    assert (tmp_path / FILENAME).read_bytes() == before


def test_progress_log_has_one_line_per_event(tmp_path: Path) -> None:
    log = tmp_path / "log.jsonl"
    outcomes = run_all(PROBLEM, BOUNDS, "ab", runs=2, seed=3, max_evals=500, chunk_evals=100,
                       log_json=log)
    lines = [json.loads(line) for line in log.read_text().splitlines()]
    events = [line["event"] for line in lines]
    assert events[0] == "start" and events[-1] == "end"
    assert events.count("run") == 2
    assert events.count("chunk") == sum(-(-o.nfev // 100) for o in outcomes)
    for o in outcomes:
        chunks = [line for line in lines if line["event"] == "chunk" and line["run"] == o.index]
        assert chunks[-1]["nfev"] == o.nfev and chunks[-1]["best_phi"] == o.fun
        assert all(c["nfev"] % 100 == 0 for c in chunks[:-1])
    assert lines[-1]["nfev"] == sum(o.nfev for o in outcomes)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"runs": 0}, "runs must be at least 1"),
    ({"workers": 0}, "workers must be at least 1"),
    ({"chunk_evals": 0}, "chunk_evals must be at least 1"),
    ({"chunk_seconds": 0.0}, "chunk_seconds must be a positive number"),
    ({"seed": -1}, "seed must be a non-negative integer"),
    ({"names": ["a", "b"]}, r"names must give one name per parameter \(8\)"),
    ({"method": "nelder"}, "unknown method 'nelder'"),
    ({"options": {"popsize": 3}}, "unknown option"),
    ({"max_evals": 0}, "max_evals must be an integer"),
])
def test_bad_arguments_are_refused_before_anything_is_written(tmp_path: Path, kwargs: dict,
                                                             message: str) -> None:
    args = {"method": "ab", **kwargs}
    with pytest.raises(ConfigError, match=message):
        run_all(PROBLEM, BOUNDS, store_dir=tmp_path / "out", **args)
    assert not (tmp_path / "out").exists()

"""The agreement stop (``agree``): once the first runs, in index order, end at the same best φ,
the later runs are not needed; the decision is the same with workers and after a resume."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from grouped import run_all

from femupdate.errors import ConfigError
from femupdate.optimize.multistart import PATIENCE_TOL
from femupdate.runs.progress import RunProgress
from femupdate.runs.runner import check_agree
from femupdate.runs.store import ResultsStore
from femupdate.runs.verdict import (
    alone,
    runs_agreeing,
    runs_needed,
    same_phi_level,
    unseen_share,
    verdict_of,
)

BOUNDS = [(0.0, 1.0)] * 3
A = np.array([[1.0, 0.2, 0.0], [0.0, 1.0, 0.3], [0.1, 0.0, 1.0], [1.0, 1.0, 1.0]])
B = np.array([0.4, 0.5, 0.3, 2.0])


def linear_residuals(x: np.ndarray) -> np.ndarray:
    """An over-determined linear fit: one minimum, φ > 0 there (every run ends at it)."""
    return A @ x - B


def rosenbrock_residuals(x: np.ndarray) -> np.ndarray:
    """A curved valley: with a budget of a few dozen evaluations, every run stops elsewhere."""
    return np.array([10.0 * (x[1] - x[0] ** 2), 1.0 - x[0], 10.0 * (x[2] - x[1] ** 2)])


# -- the decision ----------------------------------------------------------------------------


def test_the_first_runs_that_agree_are_all_that_is_needed() -> None:
    assert runs_needed([0.5, 0.5 * (1 + PATIENCE_TOL / 2), None, None], 2) == 2
    # run 1 ended elsewhere: run 2 is needed, and agrees with run 0
    assert runs_needed([0.5, 0.9, 0.5, None], 2) == 3
    # a new best: the runs before it no longer agree with the best
    assert runs_needed([0.9, 0.9, None], 3) is None
    assert runs_needed([0.9, 0.9, 0.5, 0.5], 2) == 2
    assert runs_needed([0.9, 0.5, 0.5], 2) == 3


def test_the_runs_are_taken_in_index_order() -> None:
    # runs 1 and 2 agree, but run 0 has not ended: nothing is decided yet
    assert runs_needed([None, 0.5, 0.5], 2) is None
    assert runs_needed([0.7, 0.5, 0.5], 2) == 3


def test_agreement_is_multistarts_patience_tolerance() -> None:
    best = 0.2
    assert same_phi_level(best) == pytest.approx(best * (1 + PATIENCE_TOL))
    assert runs_needed([best, best * (1 + 0.9 * PATIENCE_TOL)], 2) == 2
    assert runs_needed([best, best * (1 + 1.1 * PATIENCE_TOL)], 2) is None
    # at φ ≈ 0 (exact data) a relative tolerance is none: an absolute floor
    assert runs_needed([1e-31, 3e-29], 2) == 2


def test_runs_that_never_evaluated_agree_with_nothing() -> None:
    assert runs_needed([math.inf, math.inf, None], 2) is None
    assert runs_needed([math.inf, 0.3, 0.3], 2) == 3
    assert runs_agreeing([math.inf, 0.3, 0.3, 0.4]) == 2


def test_agree_one_needs_one_run() -> None:
    assert runs_needed([0.7, None, None], 1) == 1


#: Each run's φ, by index, of the friction bridge's own search on a record of its truth with
#: 2 % noise (benchmarks/posterior.py's calibration replicate 14 of 20, agree = 0)
RUGGED = [0.03743, 0.04545, 0.006936, 0.002128, 0.002123, 0.0003785, 0.000344, 0.04546,
          0.04075, 0.002278, 0.0003355, 0.04538, 0.0454, 0.0003365, 0.0455, 0.0003346,
          0.0003429, 0.0455, 0.006504, 0.0003402, 0.03901, 0.03736, 0.04526, 0.04537, 0.037]


def test_runs_that_each_end_alone_at_their_phi_are_not_done() -> None:
    # runs 3 and 4 agree, but runs 0, 1 and 2 each ended alone: another run more likely than
    # not ends at a φ none has reached (Good–Turing)
    assert unseen_share(RUGGED[:5]) == pytest.approx(0.6)
    assert runs_needed([*RUGGED[:5], None], 2) is None
    # a sixth at a φ already found leaves two of six alone: done
    assert runs_needed([*RUGGED[:5], RUGGED[1]], 2) == 6
    # the record's own runs: 14 needed, at φ 0.3 % above the best of all 25, where the stop
    # on agreement alone ended at run 5, at 6.3 times it
    needed = runs_needed(RUGGED, 2)
    assert needed == 14 and runs_needed(RUGGED, 2, unseen=1.0) == 5
    assert min(RUGGED[:needed]) <= min(RUGGED) * (1 + PATIENCE_TOL)
    assert min(RUGGED[:5]) > 6 * min(RUGGED)


def test_the_verdict_keeps_the_share_of_runs_alone_at_their_phi() -> None:
    positions = np.array([[0.5, 0.5], [0.5, 0.5], [0.1, 0.1], [0.2, 0.9], [0.9, 0.3]])
    v = verdict_of([0.2, 0.2001, 0.5, 0.6, 0.7], positions, [{}] * 5)
    assert v.converged and v.unseen == pytest.approx(0.6)
    # two runs at one φ with their parameters apart: two minima, one φ level
    flat = verdict_of([0.2, 0.2001, 0.5, 0.5001, 0.7], positions, [{}] * 5)
    assert flat.minima == 4 and flat.unseen == pytest.approx(0.2)
    # a run that never evaluated the model is neither alone nor counted
    assert alone([math.inf, 0.3, 0.5]).tolist() == [False, True, True]
    assert unseen_share([math.inf, 0.3, 0.3, 0.5]) == pytest.approx(1 / 3)


@pytest.mark.parametrize("value", [-1, 1.5, "2", True])
def test_a_bad_agree_is_refused(value: object) -> None:
    with pytest.raises(ConfigError, match="agree must be 0 or None"):
        check_agree(value)


def test_zero_or_none_is_every_run() -> None:
    assert check_agree(0) is None and check_agree(None) is None and check_agree(3) == 3


def test_the_verdict_says_how_many_of_the_planned_runs_were_needed() -> None:
    positions = np.array([[0.5, 0.5], [0.5, 0.5001]])
    v = verdict_of([0.2, 0.2001], positions, [{}, {}], planned=25)
    assert v.converged and v.planned == 25
    assert v.words.startswith("converged: 2 of 25 runs were needed: they ended at the same "
                              "best minimum")
    # every planned run ran: the words of a full set
    full = verdict_of([0.2, 0.2001], positions, [{}, {}], planned=2)
    assert full.planned is None and full.words.startswith("converged: 2 of 2 runs ended")
    # same φ, parameters apart: the stop's agreement is said beside the verdict
    apart = verdict_of([0.2, 0.2001], np.array([[0.1, 0.1], [0.9, 0.9]]),
                       [{"patience": 5}, {}], planned=25)
    assert "2 of 25 runs were needed: 2 ended at the same best φ" in apart.words


def test_the_progress_log_says_which_runs_were_not_needed(tmp_path: Path) -> None:
    log = tmp_path / "log.jsonl"
    with RunProgress(25, quiet=True, log_json=log, max_evals=100) as progress:
        progress.start()
        progress.not_needed(2, 2)
    events = [json.loads(line) for line in log.read_text().splitlines()]
    event = next(e for e in events if e["event"] == "not_needed")
    assert (event["runs_needed"], event["runs"], event["agreeing"]) == (2, 25, 2)


# -- run_all ---------------------------------------------------------------------------------

KW = dict(runs=6, seed=3, residuals=True)


def test_runs_that_agree_after_two_leave_the_others_not_needed(tmp_path: Path) -> None:
    every = run_all(linear_residuals, BOUNDS, "multistart-lm", max_evals=2000, **KW)
    assert len(every) == 6
    assert runs_needed([o.fun for o in every], 2) == 2  # the set below stops there
    stopped = run_all(linear_residuals, BOUNDS, "multistart-lm", max_evals=2000, agree=2,
                      store_dir=tmp_path, **KW)
    assert [o.index for o in stopped] == [0, 1]
    for a, b in zip(stopped, every[:2], strict=True):  # run i is still child i
        np.testing.assert_array_equal(a.x, b.x)
        assert (a.fun, a.nfev, a.seed) == (b.fun, b.nfev, b.seed)
    with ResultsStore.open(tmp_path) as store:  # the others never started
        rows = store.runs()
    assert [r.status for r in rows] == ["done"] * 2 + ["pending"] * 4
    assert all(r.nfev == 0 for r in rows[2:])


def test_runs_that_do_not_agree_all_run() -> None:
    every = run_all(rosenbrock_residuals, BOUNDS, "multistart-lm", max_evals=40, **KW)
    assert runs_needed([o.fun for o in every], 2) is None  # no two runs end together
    with_agree = run_all(rosenbrock_residuals, BOUNDS, "multistart-lm", max_evals=40,
                         agree=2, **KW)
    assert [o.fun for o in with_agree] == [o.fun for o in every]


def test_a_target_or_no_residuals_runs_every_run() -> None:
    target = run_all(linear_residuals, BOUNDS, "multistart-lm", max_evals=2000, agree=2,
                     f_target=1e-12, **KW)
    assert len(target) == 6

    def phi(x: np.ndarray) -> float:
        return float(np.sum(linear_residuals(x) ** 2))

    scalar = run_all(phi, BOUNDS, "ab", runs=4, seed=3, max_evals=300, agree=2)
    assert len(scalar) == 4


def test_workers_make_the_same_decision(tmp_path: Path) -> None:
    inline = run_all(linear_residuals, BOUNDS, "multistart-lm", max_evals=2000, agree=2, **KW)
    spread = run_all(linear_residuals, BOUNDS, "multistart-lm", max_evals=2000, agree=2,
                     workers=2, chunk_evals=20, store_dir=tmp_path, **KW)
    assert [o.index for o in spread] == [o.index for o in inline] == [0, 1]
    for a, b in zip(spread, inline, strict=True):
        np.testing.assert_array_equal(a.x, b.x)
        assert (a.fun, a.nfev) == (b.fun, b.nfev)


class Crashing:
    """The linear residuals, raising at the ``crash_at``-th call in this process."""

    def __init__(self, crash_at: int) -> None:
        self.calls = 0
        self.crash_at = crash_at

    def __call__(self, x: np.ndarray) -> np.ndarray:
        self.calls += 1
        if self.calls == self.crash_at:
            raise RuntimeError("simulated crash")
        return linear_residuals(x)


def test_a_resumed_set_makes_the_same_decision(tmp_path: Path) -> None:
    kw = dict(max_evals=2000, agree=2, chunk_evals=15, **KW)
    reference = run_all(linear_residuals, BOUNDS, "multistart-lm", store_dir=tmp_path / "ref",
                        **kw)
    crash_at = reference[0].nfev + reference[1].nfev // 2  # midway through run 1
    with pytest.raises(RuntimeError, match="simulated crash"):
        run_all(Crashing(crash_at), BOUNDS, "multistart-lm", store_dir=tmp_path / "cut", **kw)
    resumed = run_all(linear_residuals, BOUNDS, "multistart-lm", store_dir=tmp_path / "cut",
                      resume=True, **kw)
    assert [o.index for o in resumed] == [0, 1]
    for a, b in zip(resumed, reference, strict=True):
        np.testing.assert_array_equal(a.x, b.x)
        assert (a.fun, a.nfev, a.nit, a.stop) == (b.fun, b.nfev, b.nit, b.stop)
    for directory in ("cut", "ref"):
        with ResultsStore.open(tmp_path / directory) as store:
            assert [r.status for r in store.runs()] == ["done"] * 2 + ["pending"] * 4
    # a finished set resumes to the same decision, and with agree = 0 runs the rest
    again = run_all(linear_residuals, BOUNDS, "multistart-lm", store_dir=tmp_path / "cut",
                    resume=True, **kw)
    assert [o.fun for o in again] == [o.fun for o in reference]
    every = run_all(linear_residuals, BOUNDS, "multistart-lm", store_dir=tmp_path / "cut",
                    resume=True, **{**kw, "agree": 0})
    fresh = run_all(linear_residuals, BOUNDS, "multistart-lm", max_evals=2000, **KW)
    assert [(o.fun, o.nfev) for o in every] == [(o.fun, o.nfev) for o in fresh]

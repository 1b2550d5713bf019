"""A set of runs killed with SIGKILL midway resumes to exactly the uninterrupted results."""

from __future__ import annotations

import os
import signal
import sys
from pathlib import Path

import numpy as np
import pytest

from femupdate.paper.problems.dynamic import DynamicProblem
from femupdate.runs import Execution, run_all
from femupdate.runs.store import FILENAME, ResultsStore
from kill_midway import kill_midway, store_progress

pytestmark = pytest.mark.skipif(not hasattr(os, "killpg"), reason="needs POSIX process groups")

# No target (and for AB no σ criterion; multistart-lm without patience, which on these exact
# data ends a run once searches keep ending at φ ≈ 0): every run makes exactly max_evals
# evaluations. multistart-lm runs on residual vectors.
RUNS = {
    "ab": (dict(runs=4, seed=21, max_evals=6000, options={"sigma_min": 0.0}), "__call__"),
    "multistart-lm": (dict(runs=4, seed=21, max_evals=3000, options={"patience": None},
                           residuals=True),
                      "residuals"),
}
EXECUTION = dict(chunk_evals=100, workers=2)

# The killed set evaluates the same function slowed down (same values), so that it is still
# running when the poller sees its first checkpoints, however loaded the machine is.
CHILD = """
import sys, time
from femupdate.paper.problems.dynamic import DynamicProblem
from femupdate.runs import Execution, run_all

class Slow(DynamicProblem):
    def {fun}(self, x):
        time.sleep(3e-4)
        return super().{fun}(x)

p = Slow()
run_all(p.{fun}, p.bounds, {method!r}, store_dir=sys.argv[1],
        execution=Execution(**{execution!r}), **{settings!r})
"""


def _kill_midway(out: Path, method: str) -> tuple[int, int]:
    settings, fun = RUNS[method]
    total = settings["runs"] * settings["max_evals"]
    code = CHILD.format(fun=fun, method=method, execution=EXECUTION, settings=settings)
    exit_code = kill_midway([sys.executable, "-c", code, str(out)], out / FILENAME,
                            total // 8, 2)
    assert exit_code == -signal.SIGKILL, "the runs ended before they could be killed"
    return store_progress(out / FILENAME)


@pytest.mark.slow
@pytest.mark.parametrize("method", sorted(RUNS))
def test_sigkill_midway_then_resume_equals_an_uninterrupted_set(tmp_path: Path,
                                                                method: str) -> None:
    settings, fun_name = RUNS[method]
    evals, ckpts = _kill_midway(tmp_path / "killed", method)
    assert 0 < evals < settings["runs"] * settings["max_evals"] and ckpts >= 1

    # What survived the kill: per run, evaluations 0 … checkpoint − 1 and nothing else.
    with ResultsStore.open(tmp_path / "killed") as store:
        for row in store.runs():
            idx = store.evaluations(row.run)[0]
            ckpt = store.checkpoint(row.run)
            expected = {"done": row.nfev, "running": ckpt.nfev if ckpt else 0, "pending": 0}
            np.testing.assert_array_equal(idx, np.arange(expected[row.status]))

    p = DynamicProblem()
    fun = getattr(p, fun_name)
    resumed = run_all(fun, p.bounds, method, store_dir=tmp_path / "killed", resume=True,
                      execution=Execution(**EXECUTION), **settings)
    reference = run_all(fun, p.bounds, method, store_dir=tmp_path / "whole",
                        execution=Execution(**EXECUTION), **settings)
    for a, b in zip(resumed, reference, strict=True):
        np.testing.assert_array_equal(a.x, b.x)
        assert (a.fun, a.nfev, a.nit, a.stop) == (b.fun, b.nfev, b.nit, b.stop)
    with ResultsStore.open(tmp_path / "killed") as got, \
            ResultsStore.open(tmp_path / "whole") as want:
        for run in range(settings["runs"]):
            i1, x1, f1, _ = got.evaluations(run)
            i2, x2, f2, _ = want.evaluations(run)
            np.testing.assert_array_equal(i1, np.arange(settings["max_evals"]))  # none twice
            np.testing.assert_array_equal(i1, i2)
            assert x1.tobytes() == x2.tobytes() and f1.tobytes() == f2.tobytes()
            h1, h2 = got.history(run), want.history(run)
            assert h1.keys() == h2.keys()
            assert all(h1[k].tobytes() == h2[k].tobytes() for k in h1)


# multistart-lm with its patience and the agreement stop: on these exact data runs 0 and 1 end
# at φ ≈ 1e-31 (2,169 and 2,966 evaluations), so runs 2 and 3 are not needed.
AGREE = dict(runs=4, seed=21, max_evals=3000, residuals=True, agree=2)


@pytest.mark.slow
def test_a_killed_set_with_agree_resumes_to_the_same_decision(tmp_path: Path) -> None:
    code = CHILD.format(fun="residuals", method="multistart-lm", execution=EXECUTION,
                        settings=AGREE)
    exit_code = kill_midway([sys.executable, "-c", code, str(tmp_path / "killed")],
                            tmp_path / "killed" / FILENAME, 1500, 2)
    assert exit_code == -signal.SIGKILL, "the runs ended before they could be killed"
    p = DynamicProblem()
    resumed = run_all(p.residuals, p.bounds, "multistart-lm", store_dir=tmp_path / "killed",
                      resume=True, execution=Execution(**EXECUTION), **AGREE)
    reference = run_all(p.residuals, p.bounds, "multistart-lm", store_dir=tmp_path / "whole",
                        execution=Execution(**EXECUTION), **AGREE)
    assert [o.index for o in resumed] == [o.index for o in reference] == [0, 1]
    for a, b in zip(resumed, reference, strict=True):
        np.testing.assert_array_equal(a.x, b.x)
        assert (a.fun, a.nfev, a.nit, a.stop) == (b.fun, b.nfev, b.nit, b.stop)
    with ResultsStore.open(tmp_path / "killed") as got, \
            ResultsStore.open(tmp_path / "whole") as want:
        for run in (0, 1):  # the runs needed: the same evaluations, none twice
            i1, x1, f1, _ = got.evaluations(run)
            i2, x2, f2, _ = want.evaluations(run)
            np.testing.assert_array_equal(i1, np.arange(i2.size))
            np.testing.assert_array_equal(i1, i2)
            assert x1.tobytes() == x2.tobytes() and f1.tobytes() == f2.tobytes()
        # run 3 is not needed and never ends: with two workers it starts only if run 2 ends
        # before run 1 (on a loaded machine), and is then in flight when 0 and 1 agree
        assert {got.runs()[3].status, want.runs()[3].status} <= {"pending", "running"}

"""The advice of a sampled posterior whose runs stopped before β = 1 (issue 33)."""

from __future__ import annotations

import numpy as np

from femupdate.pipeline.posterior.run import short_advice
from femupdate.runs import RunOutcome


def _outcome(stop: dict) -> RunOutcome:
    return RunOutcome(index=0, seed={}, x=np.zeros(1), fun=1.0, nfev=10, nit=1, success=False,
                      status=0, message="", stop=stop, wall_s=0.0)


def test_a_larger_budget_is_advised_only_when_the_budget_stopped_the_runs() -> None:
    assert short_advice([_outcome({"max_evals": True})] * 2) == (
        "raise [posterior] max_evals and resume")
    words = short_advice([_outcome({"max_evals": True}), _outcome({"max_stages": 1.0})])
    assert words.startswith("not the budget: max_stages stopped them")
    assert "max_evals" not in short_advice([_outcome({"no_finite_likelihood": 1.0})])

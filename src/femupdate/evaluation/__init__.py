"""Compiled evaluation of an update problem's error function.

:class:`Evaluator` computes φ(x) of a trial of an update problem — assembly,
the integrator's preparation, the simulation, the prediction's processing and the comparison —
in one compiled call with buffers allocated once, for one point or a batch.
"""

from typing import Any

from femupdate.evaluation.evaluator import Evaluator, UpdateProblem

__all__ = ["Evaluator", "evaluator_for"]


def evaluator_for(problem: UpdateProblem) -> Any:
    """The compiled evaluator of ``problem``: :class:`Evaluator`, or for a case with support
    groups :class:`femupdate.evaluation.supports.SupportEvaluator`."""
    if getattr(getattr(problem, "model", None), "groups", ()):
        from femupdate.evaluation.supports import SupportEvaluator

        return SupportEvaluator(problem)  # type: ignore[arg-type]
    return Evaluator(problem)

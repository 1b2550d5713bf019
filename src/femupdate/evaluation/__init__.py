"""Compiled evaluation of an update problem's error function.

:class:`Evaluator` computes φ(x) of a trial of an update problem — assembly,
the integrator's preparation, the simulation, the prediction's processing and the comparison —
in one compiled call with buffers allocated once, for one point or a batch.
"""

from femupdate.evaluation.evaluator import Evaluator, evaluator_for

__all__ = ["Evaluator", "evaluator_for"]

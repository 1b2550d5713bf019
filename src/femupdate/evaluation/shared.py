"""Trials that share one record, simulated once per point: :func:`shared_groups`,
:func:`phi_rows`, :func:`residual_rows`.

Windows of one test (``[[trials]]`` with the same records and different ``score_window``) drive
the same model with the same record: their simulations are the same. Trials are taken to share
one when what the compiled evaluator simulates and how it processes the outputs are the same:
the model's input record byte for byte (after every preprocessing step, so the same files read
with a different window, delay or filter are different records), its sample interval, the
integrator (method, direction, substeps), the output DOFs and their influence, and the
processing of the prediction (integration, high-pass of the prediction, compared quantity).
Such a group is simulated once per point by its first trial's evaluator (with the friction
kernel in SIMD lanes, four points per run, as a batch of one trial), and each trial compares its
own window with that one set of outputs, by the same compiled comparison its own evaluation
uses: the values are those of evaluating the trials one by one, bit for bit (tested).

Points the compiled path does not reach, and failed evaluations, go to each trial's step-by-step
path, as they do trial by trial (which says why a failed one failed).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["phi_rows", "record_key", "residual_rows", "shared_groups"]


def record_key(trial: Any) -> tuple | None:
    """What makes two trials' simulated outputs the same (see the module docstring), or None
    for a trial evaluated step by step (it shares nothing).

    Parameters
    ----------
    trial : femupdate.problem.update.TrialProblem
    """
    if not trial.compiled:
        return None
    ag = np.ascontiguousarray(trial._ag, dtype=float)
    model = trial.model
    outputs = np.ascontiguousarray(model.outputs, dtype=np.int64)
    influence = np.ascontiguousarray(model.influence, dtype=float)
    return (ag.shape, ag.tobytes(), float(trial.experiment.dt), model.method, model.direction,
            int(model.substeps), outputs.tobytes(), influence.tobytes(), bool(trial.integrate),
            bool(trial.filter), trial.experiment.quantity)


def shared_groups(trials: Sequence[Any]) -> list[list[int]]:
    """The trials (indices into ``trials``) grouped by :func:`record_key`, each group in the
    trials' order, the groups in the order of their first trial; a trial evaluated step by
    step is a group of its own."""
    groups: list[list[int]] = []
    by_key: dict[tuple, list[int]] = {}
    for i, trial in enumerate(trials):
        key = record_key(trial)
        if key is None:
            groups.append([i])
        elif key in by_key:
            by_key[key].append(i)
        else:
            by_key[key] = [i]
            groups.append(by_key[key])
    return groups


def phi_rows(trials: Sequence[Any], X: np.ndarray) -> np.ndarray:
    """φ of each trial of one group (:func:`shared_groups`) at every row of ``X``, as a
    (len(trials), k) array: one simulation per row, each trial's comparison of it.

    The first trial's evaluator simulates; the others compare first (its comparison overwrites
    the outputs it holds).
    """
    X = np.ascontiguousarray(X, dtype=float)
    out = np.empty((len(trials), X.shape[0]))
    simulating = trials[0].evaluator
    last_first = range(len(trials) - 1, -1, -1)
    for i, (x, (y, phi)) in enumerate(zip(X, simulating.simulated_rows(X), strict=True)):
        for t in last_first:
            trial = trials[t]
            value = phi if y is None else trial.evaluator.compare_with(y)
            if math.isfinite(value):
                trial.last_failure = None
            else:  # not compiled, or failed: step by step (which says why)
                value = trial.phi_reference(x)
            out[t, i] = value
    return out


def residual_rows(trials: Sequence[Any], X: np.ndarray,
                  out: Sequence[np.ndarray] | None = None) -> list[list[np.ndarray]]:
    """The residual vectors of each trial of one group at every row of ``X``
    (``rows[t][i]``), as :meth:`femupdate.problem.update.TrialProblem.residuals_rows` gives
    them, from
    one simulation per row; with ``out`` (one (k, m_t) array per trial), each written into its
    row as it comes (the lists then hold those rows)."""
    X = np.ascontiguousarray(X, dtype=float)
    rows: list[list[np.ndarray]] = [[] for _ in trials]
    simulating = trials[0].evaluator
    last_first = range(len(trials) - 1, -1, -1)
    # a zero-phase filter's residuals are the step-by-step path's, as trial by trial
    simulated = ((None, np.nan) for _ in X) if simulating.zero_phase else \
        simulating.simulated_rows(X)
    for i, (x, (y, _)) in enumerate(zip(X, simulated, strict=True)):
        for t in last_first:
            trial = trials[t]
            r = None if y is None else trial.evaluator.compare_with(y, residuals=True)
            if r is None:
                r = trial.residuals(trial.case.to_physical(x))
            else:
                trial.last_failure = None
            if out is not None:
                out[t][i] = r
                r = out[t][i]
            rows[t].append(r)
    return rows

"""``femupdate bench dynamic``: benchmark 1 of the paper (Tables 1–2), repeated runs."""

from __future__ import annotations

import time

from femupdate.optimize.minimize import objective_for
from femupdate.paper.problems.dynamic import F_TARGET, MAX_EVALS, PARAMETER_NAMES, DynamicProblem
from femupdate.runs.outcome import RunOutcome, run_seeds
from femupdate.runs.repeat import RunTask, repeat
from femupdate.runs.stats import evaluation_stats

#: Methods compared side by side by ``--method all``, with the paper's settings (the
#: comparison optimizers of benchmarks/plugins join when registered).
ALL_METHODS: dict[str, dict[str, object]] = {
    "ib": {},
    "ab": {},
    "cmaes": {"popsize": 5},
    "multistart-lm": {},
    "de": {},
    "ga": {},
    "scipy-lsq": {},
}


def run_benchmark(
    method: str = "ab",
    *,
    runs: int = 100,
    seed: int | None = 0,
    workers: int = 1,
    max_evals: int = MAX_EVALS,
    f_target: float = F_TARGET,
    options: dict[str, object] | None = None,
) -> dict[str, object]:
    """Independent runs of ``method`` on the two-mode benchmark, summarised as Table 2.

    Returns
    -------
    dict
        ``method, runs, successes, success_ratio, evals_min, evals_mean, evals_median,
        evals_max, wall_s`` (evaluations over successful runs, each counted up to the first
        evaluation that reached ``f_target``), ``options``, ``seed`` and ``per_run``.
    """
    opts = dict(ALL_METHODS.get(method, {}) if options is None else options)
    start = time.perf_counter()
    problem = DynamicProblem()
    fun, residuals = objective_for(problem, method)
    outcomes = repeat(
        fun,
        problem.bounds,
        method,
        runs=runs,
        seed=seed,
        workers=workers,
        max_evals=max_evals,
        f_target=f_target,
        residuals=residuals,
        **opts,
    )
    wall = time.perf_counter() - start
    stats = evaluation_stats([o.nfev for o in outcomes], [o.success for o in outcomes])
    return {
        "method": method,
        **stats,
        "wall_s": wall,
        "workers": workers,
        "seed": seed,
        "options": opts,
        "per_run": [o.to_dict(PARAMETER_NAMES) for o in outcomes],
    }


def run_with_history(method: str = "ab", *, seed: int | None = 0, run_index: int = 0,
                     options: dict[str, object] | None = None,
                     max_evals: int = MAX_EVALS) -> RunOutcome:
    """Run ``run_index`` of :func:`run_benchmark` again (the same child seed), with its
    history: what the paper's Figs. 2–5 draw."""
    problem = DynamicProblem()
    child = run_seeds(seed, run_index + 1)[run_index]
    opts = dict(ALL_METHODS.get(method, {}) if options is None else options)
    fun, residuals = objective_for(problem, method)
    return RunTask(fun, problem.bounds, method,
                   run_index, child, max_evals, F_TARGET, opts, keep_history=True,
                   residuals=residuals)()

"""``femupdate posterior --surrogate``: the surrogate-aided posterior of a case, recorded as
the sampled one is.

The design (true model runs, :func:`femupdate.inference.surrogate.surrogate_posterior`) runs
on the case's workers or Dask scheduler; every run is kept in ``OUT/surrogate-design.npz`` as
its batch comes back (:class:`DesignStore`), so a run killed part-way and started again with
``--resume`` (same case, same seed) replays the runs it has and runs only the rest. The
result goes into ``OUT/summary.json``'s ``posterior`` (a :class:`PosteriorRecord` of method
``"surrogate"``: model runs, the final check, marginals, intervals), which ``femupdate report``
and the console table show as they show TMCMC's; the samples into ``OUT/posterior.npz`` (the
report's corner plot) and ``OUT/surrogate.npz``. A summary of ``femupdate run`` already in
``OUT`` for the same case keeps its search and gets the posterior; otherwise the summary's one
"run" is the best design point (no search is made: an expensive model's runs are the point).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from femupdate.case import Case
from femupdate.case.posterior_section import DEFAULT_POSTERIOR
from femupdate.errors import ConfigError
from femupdate.inference.best_fit import case_priors
from femupdate.inference.laplace import interval_spread, sentences
from femupdate.inference.likelihood import ErrorModel
from femupdate.inference.priors import Prior
from femupdate.inference.records import (
    PosteriorRecord,
    StageRecord,
    SurrogateCheckRecord,
    correlation_rows,
    marginals,
)
from femupdate.inference.surrogate import (
    ErrorModelAt,
    Evaluate,
    SurrogateResult,
    surrogate_posterior,
)
from femupdate.inference.surrogate_check import COVERAGE_BAND, MIN_CHECK_ESS
from femupdate.pipeline.posterior.bands import save_bands
from femupdate.pipeline.results import (
    POSTERIOR_FILE,
    SUMMARY_FILE,
    Best,
    RunRecord,
    Spread,
    Summary,
    read_summary,
    write_summary,
)
from femupdate.pipeline.run import N_FREQUENCIES, trial_records
from femupdate.problem.update import UpdateProblem
from femupdate.runs.stats import at_bounds
from femupdate.trials.experiment import load_experiments

#: The samples (NPZ) and the design's true runs as they come (NPZ, for --resume).
SAMPLES_FILE, DESIGN_FILE = "surrogate.npz", "surrogate-design.npz"
METHOD = "surrogate"


def residual_rows(problem: Any, rows: Sequence[np.ndarray]) -> list[tuple[np.ndarray,
                                                                          str | None]]:
    """The residual vector of each search-space row and why it is not finite (None when it
    is): one task of :func:`problem_evaluator`'s batches (a worker process runs it)."""
    out = []
    for x in rows:
        r = np.asarray(problem.residuals(np.asarray(x, dtype=float)), dtype=float)
        ok = bool(np.all(np.isfinite(r)))
        out.append((r, None if ok else (problem.last_failure or "residuals not finite")))
    return out


def problem_evaluator(problem: Any, executor: Any = None) -> Evaluate:
    """:data:`Evaluate` of an UpdateProblem, its batches spread over a
    :class:`femupdate.runs.executors.RunExecutor` (local workers or Dask) when given."""

    def evaluate(X: np.ndarray) -> tuple[np.ndarray, list[str | None]]:
        rows = [np.asarray(x, dtype=float) for x in np.atleast_2d(X)]
        if executor is None or executor.inline or executor.capacity == 1 or len(rows) <= 1:
            got = residual_rows(problem, rows)
        else:
            parts = np.array_split(np.arange(len(rows)), min(executor.capacity, len(rows)))
            shared = executor.share(problem)
            futures = [executor.submit(residual_rows, shared, [rows[i] for i in part])
                       for part in parts]
            got = [item for fut in futures for item in fut.result()]
        out = np.array([np.where(why is None, r, np.nan) for r, why in got])
        return out, [why for _, why in got]

    return evaluate


#: The error model when ``[posterior] error_model`` names none: the posterior's default.
SURROGATE_KIND = "neff"


def wants_surrogate(case: Any, flag: bool | None = None) -> bool:
    """``flag`` (``--surrogate``/``--no-surrogate``) when given, else ``[posterior]
    surrogate`` when set, else on for an external model (``[model.python]``,
    ``[model.opensees]``) and off for femupdate's own."""
    if flag is not None:
        return bool(flag)
    section = getattr(case, "posterior", None)
    if section is not None and section.surrogate is not None:
        return bool(section.surrogate)
    return case.model.python is not None or case.model.opensees is not None


def case_error_model_at(problem: Any, kind: str) -> ErrorModelAt:
    """:data:`ErrorModelAt` of an UpdateProblem: ``kind`` fixed at a run's residuals (the
    product's kinds need no Jacobian: no model runs beyond the run's own)."""
    from femupdate.inference.error_models import problem_error_model

    def at(x: np.ndarray, r: np.ndarray) -> tuple[ErrorModel, int]:
        return problem_error_model(problem, r, kind, point=x), 0

    return at


class DesignStore:
    """:data:`Evaluate` that keeps every true run in a file as its batch comes back and, on
    resume, gives the stored run of a row asked again instead of running the model.

    The surrogate's choices are a function of its seed and the runs' results, so a resumed
    run with the same seed asks the same rows in the same order: bit for bit the stored ones.

    Parameters
    ----------
    path : Path
        The NPZ file.
    evaluate : Evaluate
        The true model.
    key : str
        What the runs belong to (the case's fingerprint and the seed); a stored design of
        another key is not resumed: ConfigError.
    resume : bool
        Read the stored runs (else start the file afresh).
    """

    def __init__(self, path: Path, evaluate: Evaluate, key: str, resume: bool) -> None:
        self.path, self.evaluate, self.key = Path(path), evaluate, key
        self.x: list[np.ndarray] = []
        self.rows: list[np.ndarray] = []
        self.why: list[str] = []
        self.reused = 0
        if resume and self.path.is_file():
            with np.load(self.path, allow_pickle=False) as data:
                if str(data["key"]) != key:
                    raise ConfigError(f"{self.path}: --resume: the stored design belongs to "
                                      "another case or seed (allowed: the same case file and "
                                      "--seed as the interrupted run; without --resume it "
                                      "starts afresh)")
                self.x, self.rows = list(data["x"]), list(data["rows"])
                self.why = [str(w) for w in data["why"]]
        self._index = {x.tobytes(): i for i, x in enumerate(self.x)}

    def __call__(self, X: np.ndarray) -> tuple[np.ndarray, list[str | None]]:
        X = np.atleast_2d(np.asarray(X, dtype=float))
        found = [self._index.get(x.tobytes()) for x in X]
        todo = [i for i, j in enumerate(found) if j is None]
        if todo:
            rows, why = self.evaluate(X[todo])
            for i, r, w in zip(todo, np.atleast_2d(rows), why, strict=True):
                found[i] = len(self.x)
                self._index[X[i].tobytes()] = len(self.x)
                self.x.append(X[i].copy())
                self.rows.append(np.asarray(r, dtype=float))
                self.why.append("" if w is None else w)
            self._save()
        self.reused += len(X) - len(todo)
        return (np.array([self.rows[j] for j in found]),
                [self.why[j] or None for j in found])

    def _save(self) -> None:
        tmp = self.path.with_name(self.path.name + ".tmp.npz")
        np.savez(tmp, key=np.array(self.key), x=np.array(self.x), rows=np.array(self.rows),
                 why=np.array(self.why))
        os.replace(tmp, self.path)


def surrogate_record(result: SurrogateResult, prior: Prior, seed: int | None
                     ) -> PosteriorRecord:
    """The summary's record of a surrogate-aided posterior: marginals and intervals of its
    samples, the model runs, the final check (and, in ``message``, whether it reached its
    accuracy); TMCMC's stages and effective samples are those of its run on the surrogate."""
    names = list(result.names)
    if not result.reached:  # never a posterior it did not reach: no marginals (the message)
        return PosteriorRecord(
            method=METHOD, error_model=result.error_model.kind,
            samples=result.samples.shape[0], seed=seed, nfev=result.model_runs,
            wall_s=result.wall_s, reached=False, message=result.message, log_evidence=None,
            ess=None, names=names, failed_evaluations=len(result.failures),
            failure=result.failures[0] if result.failures else None,
            surrogate=check_record(result))
    search = prior.to_search(result.samples_unit)
    q = np.quantile(search, [0.05, 0.5, 0.95], axis=0)
    spread = interval_spread(q[0], q[2], prior)
    corr = np.corrcoef(search, rowvar=False) if len(names) > 1 else np.ones((1, 1))
    post = result.sampler
    ess = (None if post is None or post.ess_params is None else
           {n: float(v) for n, v in zip(names, post.ess_params, strict=True)})
    check = result.check
    return PosteriorRecord(
        method=METHOD, error_model=result.error_model.kind, samples=search.shape[0],
        seed=seed, nfev=result.model_runs, wall_s=result.wall_s, reached=result.reached,
        message=result.message,
        log_evidence=float(result.log_evidence) if result.reached else None,
        ess=None if ess is None else float(min(ess.values())),
        stages=[] if post is None else [
            StageRecord(beta=s["beta"], acceptance=_finite(s.get("acceptance")),
                        ess=s["weights_ess"]) for s in post.stages],
        names=names, params=marginals(result.samples, names),
        correlations=correlation_rows(np.atleast_2d(corr)),
        undetermined=[n for n, s in zip(names, spread, strict=True) if s >= 0.5],
        sentences=sentences(prior, prior.search_to_physical(q), spread),
        failed_evaluations=len(result.failures),
        failure=result.failures[0] if result.failures else None,
        ess_params=ess or {}, agreement=f"surrogate check: {check.words(names)}",
        surrogate=check_record(result))


def check_record(result: SurrogateResult) -> SurrogateCheckRecord:
    """The design and final check of a surrogate-aided posterior, for the summary."""
    names, check = list(result.names), result.check
    return SurrogateCheckRecord(
        model_runs=result.model_runs, iterations=result.iterations,
        accuracy_nats=_finite(result.accuracy), tolerance_nats=result.tolerance,
        check_runs=check.runs, check_ess=check.ess, min_check_ess=MIN_CHECK_ESS,
        shifts_sd=_named(names, check.shifts), sd_ratios=_named(names, check.sd_ratios),
        coverage=_named(names, check.coverage[0]),
        reverse_coverage=_named(names, check.coverage[1]), coverage_band=list(COVERAGE_BAND),
        check_error_nats=_finite(check.error),
        passed=check.passed, failures=list(result.failures),
        history=[dict(h) for h in result.history])


def _finite(value: Any) -> float:
    return float(value) if value is not None and math.isfinite(float(value)) else math.nan


def _named(names: list[str], values: np.ndarray) -> dict[str, float | None]:
    return {n: float(v) if math.isfinite(float(v)) else None
            for n, v in zip(names, values, strict=True)}


def design_summary(problem: UpdateProblem, result: SurrogateResult, seed: int | None
                   ) -> Summary:
    """A summary whose one run is the best design point (the surrogate makes no search):
    its φ, parameters and each trial's fit there (one more simulation per trial)."""
    case = problem.case
    rows = np.asarray(result.design_rows, dtype=float)
    phi = np.where(np.all(np.isfinite(rows), axis=1), np.einsum("ij,ij->i", rows, rows),
                   np.inf)
    i = int(np.argmin(phi))
    x = case_priors(case).to_search(np.asarray(result.design_unit)[i][None, :])[0]
    trials = trial_records(problem, x)
    per_channel = (dict(trials[0].nmse_per_channel) if len(trials) == 1 else
                   {f"{t.name}/{c}": v for t in trials for c, v in t.nmse_per_channel.items()})
    values = problem.values(x)
    case_dict = case.to_dict()
    if case_dict.get("data") is not None:
        case_dict["data"]["directory"] = str(case.data_directory().resolve())
    run = RunRecord(index=0, seed={"seed": seed}, success=False, status=0,
                    message=f"the best of the surrogate's {result.model_runs} design points "
                            "(no search)", stop={}, phi=float(phi[i]),
                    nfev=result.model_runs, nit=result.iterations,
                    nfail=len(result.failures), wall_s=result.wall_s, x=x.tolist(),
                    params=values, at_bounds=at_bounds(x, problem.bounds, problem.names))
    return Summary(
        case=case_dict, case_file=str(case.source) if case.source is not None else None,
        settings={"posterior": METHOD}, delays_s={}, fingerprint=case.fingerprint(),
        method=METHOD, successes=0, success_ratio=0.0, evals_min=None, evals_mean=None,
        evals_median=None, evals_max=None, evals_per_success=None,
        success_rule="none: no search (the surrogate's design points only)",
        wall_s=result.wall_s, runs=[run],
        best=Best(run=0, phi=float(phi[i]), nmse_percent=100.0 * float(phi[i]), params=values,
                  frequencies_hz=problem.frequencies(x)[:N_FREQUENCIES].tolist(),
                  nmse_per_channel=per_channel),
        spread=Spread(), trials=trials)


def run_case_surrogate(case: Case, out_dir: Path, *, seed: int | None = None,
                       workers: int = 1, scheduler: str | None = None, resume: bool = False,
                       progress: Callable[[str], None] | None = None) -> SurrogateResult:
    """The surrogate-aided posterior of a case (module docstring), its design batches on
    ``workers`` local processes or the Dask ``scheduler``; its record into
    ``out_dir/summary.json`` (``posterior``) and its samples into ``out_dir/posterior.npz``
    and ``out_dir/surrogate.npz``.

    The error model is ``[posterior] error_model`` (default ``neff``), the seed ``seed`` or
    ``[posterior] seed``. ``resume``: replay the runs stored in ``out_dir`` by an interrupted
    run of the same case and seed.
    """
    from femupdate.runs.executors import open_executor

    settings = case.posterior if case.posterior is not None else DEFAULT_POSTERIOR
    seed = settings.seed if seed is None else seed
    kind = settings.error_model or SURROGATE_KIND
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    problem = UpdateProblem(case, load_experiments(case))
    prior = case_priors(case)
    try:
        with open_executor(workers, scheduler) as executor:
            store = DesignStore(out / DESIGN_FILE, problem_evaluator(problem, executor),
                                f"{case.fingerprint()}:{seed}", resume)
            result = surrogate_posterior(store, prior, case_error_model_at(problem, kind),
                                         rng=np.random.default_rng(seed), progress=progress)
        if store.reused:
            result.message += (f" ({store.reused} of them replayed from {DESIGN_FILE}, "
                               "not run again)")
        record = surrogate_record(result, prior, seed)
        old = out / SUMMARY_FILE
        summary = read_summary(old) if old.is_file() else None
        if summary is None or summary.fingerprint != case.fingerprint():
            summary = design_summary(problem, result, seed)
    finally:
        problem.close()
    np.savez(out / SAMPLES_FILE, names=np.array(result.names), samples=result.samples)
    (out / POSTERIOR_FILE).unlink(missing_ok=True)  # never an earlier run's samples
    if result.reached:
        save_bands(out / POSTERIOR_FILE, list(result.names), result.samples,
                   np.empty((0, 0)), [])
    write_summary(summary.model_copy(update={"posterior": record}), out)
    return result

"""``femupdate posterior CASE.toml --out DIR``: the full posterior of a case by TMCMC.

1. The best fit: the case's search in ``DIR`` as ``femupdate run`` does it (a finished search
   already there is reused; ``--restart`` discards it). It fixes the error model (each
   channel's residual correlation is measured there) and gives the Laplace approximation,
   TMCMC's starting Gaussian.
2. ``[posterior] runs`` independent TMCMC runs through ``run_all`` (method ``"tmcmc"``,
   :mod:`femupdate.inference.method`): their own results store in ``DIR/posterior``
   (checkpointed: ``--resume`` after a kill continues to the identical samples), workers or
   Dask, seeded by ``[posterior] seed`` (run i by its child i).
3. Whether the runs agree (:mod:`femupdate.pipeline.posterior.agreement`): each parameter's
   effective
   samples, the smaller of the runs' own estimates and what the scatter of their means shows;
   a parameter with too few is called unsettled, in words.
4. Whether the start was the best fit (:mod:`femupdate.pipeline.posterior.start`): when the sampler
   found a better one, it is polished, and the error model, the Laplace Gaussian and steps
   2–3 are taken again there (in the store ``DIR/posterior/recentred-k``),
   ``[posterior] recentre`` times at most; that, and the search's verdict when it did not
   converge, said in words.
5. What the pooled samples say: marginals and correlations of the parameters, the natural
   frequencies and damping ratios over a thinned subset, predictive bands on every trial with
   the share of each measured record they cover; into ``DIR/summary.json`` (``posterior``)
   and ``DIR/posterior.npz``, read by the report.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.special import logsumexp

from femupdate.case import Case
from femupdate.case.fields import Range, field_range
from femupdate.case.posterior_section import (
    DEFAULT_POSTERIOR,
    SAMPLES_PER_PARAMETER,
    PosteriorSection,
)
from femupdate.errors import ConfigError, DataError
from femupdate.inference.best_fit import best_fit_gaussian
from femupdate.inference.error_models import DEFAULT_KIND, case_kinds
from femupdate.inference.laplace import interval_spread, sentences
from femupdate.inference.likelihood import ErrorModel
from femupdate.inference.method import METHOD, SampledProblem, register, sampler_options
from femupdate.inference.priors import Prior
from femupdate.inference.records import (
    PosteriorRecord,
    StageRecord,
    correlation_rows,
    marginals,
)
from femupdate.inference.tmcmc import INFLATE, MIN_REFERENCE_MASS, mass_inside, safe_cholesky
from femupdate.pipeline.posterior.agreement import MIN_ESS, Agreement, runs_agreement
from femupdate.pipeline.posterior.bands import Bands, predictive_bands, save_bands
from femupdate.pipeline.posterior.modes import sample_modes
from femupdate.pipeline.posterior.start import (
    better_fit,
    polish,
    recentred_sentence,
    search_sentence,
    unfollowed_sentence,
)
from femupdate.pipeline.results import POSTERIOR_FILE, Summary, write_summary
from femupdate.pipeline.run import UpdateResult, run_case
from femupdate.problem.update import UpdateProblem
from femupdate.runs import CaseIdentity, Execution, RunOutcome, run_all
from femupdate.runs.changes import file_hashes
from femupdate.runs.store import FILENAME
from femupdate.trials.experiment import Experiment, data_files, load_experiments

#: The sampler's own results store, beside the search's.
POSTERIOR_DIR = "posterior"
#: Inside it, the stores of the passes sampled again from a better fit (``recentred-1``, …).
RECENTRED_DIR = "recentred"
#: Inside a pass's store, the stores of the runs added while a parameter is unsettled.
MORE_RUNS_DIR = "more"
#: Effective samples per parameter each sampler run reaches at β = 1 (at least): TMCMC's last
#: stage is importance sampling (:mod:`femupdate.inference.importance`) until every parameter
#: has them; the default four runs pool about 2,000, and their agreement checks them.
RUN_ESS = 500
#: The tempering goes to β = 1 by importance sampling once a stage reaches this β (TMCMC's
#: ``importance_from``): from the Laplace start, a defensive mixture fitted to the population at
#: β ≥ 0.3 is wide enough for the posterior. On the viscous bridge (issue 36's record, four
#: runs of 1,000 with RUN_ESS = 500, posterior seeds 11–13) 23,523–30,339 evaluations gave a
#: least ESS of 1,297–2,422, where tempering to β = 1 by moves took 51,462 for 3,425 with
#: RUN_ESS = 1,000.
IMPORTANCE_FROM = 0.3
#: Spawn keys of the seed's children: the bands' draws (1), the start's mass estimate (2),
#: the polish before re-centring pass k (3 + k), the added runs' root seeds (1000, batch).
BANDS_KEY, START_KEY, POLISH_KEY, MORE_RUNS_KEY = 1, 2, 3, 1000


@dataclass
class PosteriorResult:
    """What ``femupdate posterior`` produced."""

    summary: Summary
    record: PosteriorRecord
    samples: np.ndarray  # (N, n) physical (empty when β = 1 was not reached)
    bands: list[Bands]
    search: UpdateResult
    error_model: ErrorModel


def posterior_settings(case: Case) -> PosteriorSection:
    """``[posterior]``, or its defaults, with the default error model when the case names
    none."""
    settings = case.posterior if case.posterior is not None else DEFAULT_POSTERIOR
    if settings.error_model is None:
        settings = settings.model_copy(update={"error_model": DEFAULT_KIND})
    return settings


def check_records(experiments: Sequence[Experiment], case: Case) -> None:
    """A posterior of all-zero records has no error variance to learn: DataError naming the
    trial and channel."""
    for exp in experiments:
        if exp.role != "fit":
            continue
        zero = [c for c, col in zip(exp.channels, np.atleast_2d(exp.target.T), strict=True)
                if not np.any(col)]
        if zero:
            raise DataError(f"{case.label}: trial {exp.name!r}: the measured record of "
                            f"channel(s) {', '.join(zero)} is all zero, so no error variance "
                            "can be estimated (allowed: records with a response; drop the "
                            "channel from [[data.outputs]])")


@dataclass
class Sampled:
    """The posterior sampled from one fit: the error model measured there, the prior, why
    there was no Laplace Gaussian to start from (or None), how the start was changed (or
    None), and the sampler runs' outcomes."""

    model: ErrorModel
    prior: Prior
    why: str | None
    start_note: str | None
    outcomes: list[RunOutcome]


@dataclass
class FitSampler:
    """Samples the posterior from a fit (:meth:`sample`), each time in its own store, and
    counts the evaluations and wall time of every pass."""

    problem: SampledProblem
    identity: CaseIdentity
    settings: PosteriorSection
    seed: int | None
    population: int
    counts_from: ErrorModel | None
    resume: bool
    execution: Execution
    evaluations: int = 0
    wall_s: float = 0.0
    tmcmc: dict[str, Any] = dataclasses.field(default_factory=dict)

    def sample(self, x: np.ndarray, store_dir: Path, recentre_below: float | None = None
               ) -> Sampled:
        """The error model and Laplace Gaussian at ``x``, then ``[posterior] runs`` TMCMC
        runs from that Gaussian (or the prior) through ``run_all`` in ``store_dir``, and more
        while a parameter is unsettled, unless a run found a better fit than
        ``recentre_below`` (the start's φ, when the caller will sample again from it)."""
        problem, settings, seed = self.problem, self.settings, self.seed
        model, prior, gaussian, why = best_fit_gaussian(problem, x, settings.error_model,
                                                        self.counts_from)
        specs = {n: p.spec() for n, p in settings.priors.items()}
        reference, start_note = None, None
        if gaussian is not None and settings.start != "prior":
            reference, start_note = start_reference(
                gaussian.mean_unit, gaussian.cov_unit,
                np.random.default_rng(derived_seed(seed, x, START_KEY)))
        run_ess = max(RUN_ESS, math.ceil(2 * (settings.ess or MIN_ESS) / settings.runs))
        options = sampler_options(model, prior, specs, self.population, reference,
                                  **{"final": "importance", "ess": run_ess,
                                     "importance_from": IMPORTANCE_FROM, **self.tmcmc})
        outcomes = self._runs(options, store_dir, seed)
        # runs are added, `runs` at a time, while a parameter is unsettled (module agreement);
        # not to one run, which asked for no check
        batch = 0
        while (settings.runs > 1 and len(outcomes) + settings.runs <= settings.max_runs
               and (recentre_below is None or better_fit(outcomes, recentre_below) is None)
               and (agreement := outcomes_agreement(prior, outcomes, problem.names,
                                                    settings.ess or MIN_ESS)) is not None
               and agreement.unsettled):
            batch += 1
            outcomes += self._runs(options, store_dir / f"{MORE_RUNS_DIR}-{batch}",
                                   batch_seed(seed, batch))
        return Sampled(model, prior, why, start_note, outcomes)

    def _runs(self, options: dict[str, Any], store_dir: Path, seed: int | None
              ) -> list[RunOutcome]:
        """``[posterior] runs`` TMCMC runs with ``options`` through ``run_all``."""
        problem = self.problem
        outcomes = run_all(
            problem.residuals, problem.bounds, METHOD, runs=self.settings.runs, seed=seed,
            max_evals=self.settings.max_evals, options=options, store_dir=store_dir,
            resume=self.resume, identity=self.identity, execution=self.execution,
            residuals=True)
        self.evaluations += sum(o.nfev for o in outcomes)
        self.wall_s += sum(o.wall_s for o in outcomes)
        return list(outcomes)


def derived_seed(seed: int | None, x: np.ndarray, key: int) -> np.random.SeedSequence:
    """Child ``key`` of ``seed``; without a seed, of the point ``x`` instead of fresh entropy,
    so that a resumed posterior (whose runs' stores recorded their entropy and give the same
    points again) makes the same choices."""
    entropy = seed if seed is not None else [
        int(v) for v in np.frombuffer(np.ascontiguousarray(x, dtype=float).tobytes(),
                                      dtype=np.uint32)]
    return np.random.SeedSequence(entropy, spawn_key=(key,))


def batch_seed(seed: int | None, batch: int) -> int | None:
    """The root seed of the ``batch``-th runs added (None: fresh entropy, as ``seed``): a
    child of ``seed`` apart from those of the first runs, the bands and the start."""
    if seed is None:
        return None
    state = np.random.SeedSequence(seed, spawn_key=(MORE_RUNS_KEY, batch)).generate_state(2)
    return int(state[0]) << 31 | int(state[1]) >> 1


def run_samples(prior: Prior, outcomes: Sequence[RunOutcome], count: int
                ) -> tuple[list[np.ndarray], list[np.ndarray]] | None:
    """Each sampler run's samples (search space) and its own effective samples of each of
    the ``count`` parameters; None unless every run reached the posterior."""
    extras: list[dict[str, Any]] = [o.extras or {} for o in outcomes]
    if not all(e.get("reached") for e in extras):
        return None
    searches = [prior.to_search(np.asarray(e["samples_unit"], dtype=float)) for e in extras]
    own = [np.asarray(e.get("ess_params") or [e["ess"]] * count, dtype=float) for e in extras]
    return searches, own


def outcomes_agreement(prior: Prior, outcomes: Sequence[RunOutcome], names: Sequence[str],
                       min_ess: float = MIN_ESS) -> Agreement | None:
    """The agreement of sampler runs, a parameter with fewer than ``min_ess`` effective
    samples unsettled (None unless every run reached the posterior)."""
    got = run_samples(prior, outcomes, len(names))
    return None if got is None else runs_agreement(*got, list(names), min_ess)


def run_posterior(case: Case, out_dir: Path, *, seed: int | None = None,
                  samples: int | None = None, runs: int | None = None,
                  max_runs: int | None = None, recentre: int | None = None,
                  workers: int | None = None,
                  resume: bool = False, restart: bool = False,
                  execution: Execution | None = None,
                  experiments: Sequence[Experiment] | None = None,
                  counts_from: ErrorModel | None = None,
                  error_model: str | None = None,
                  search_from: Path | None = None, ess: int | None = None,
                  tmcmc: dict[str, Any] | None = None) -> PosteriorResult:
    """The search's best fit, then TMCMC, then what the samples say (module docstring).

    Parameters
    ----------
    case : Case
    out_dir : Path
        Results directory (the search's results, ``posterior/`` and ``posterior.npz``).
    seed, samples, runs, max_runs, recentre, ess : int or None
        Override ``[posterior] seed``, ``samples``, ``runs``, ``max_runs``, ``recentre`` and
        ``ess``.
    workers : int or None
        Override ``[search] workers`` (for the search and the sampler).
    resume : bool
        Continue the sampler's store in ``out_dir/posterior`` (and the search's).
    restart : bool
        Discard both stores and start over.
    execution : Execution or None
        Progress, scheduler, chunks (:class:`femupdate.runs.Execution`).
    experiments : sequence of Experiment or None
        The case's processed trials, when the caller has them.
    counts_from : ErrorModel or None
        Take the effective counts N_c (and ρ_c) of this error model instead of measuring them
        at this case's best fit: model classes compared by their evidence must share one
        likelihood of the data (:mod:`femupdate.pipeline.posterior.classes`).
    error_model : str or None
        Override ``[posterior] error_model`` (one of
        :func:`~femupdate.inference.error_models.case_kinds`).
    search_from : Path or None
        Take the search of this results directory (``femupdate run --out``, the same case):
        its store is resumed there (a finished search is not run again) and only the
        sampler's results go into ``out_dir``. ``restart`` then discards only the sampler's.
    tmcmc : dict or None
        Options of :class:`~femupdate.inference.tmcmc.TMCMC` beyond the case's (e.g.
        ``{"final": "importance", "ess": 500}``), for studies of the sampler (benchmarks);
        stored with the runs, so a resume with other ones is refused.
    """
    settings = posterior_settings(case)
    # every override checked before any work (a bad --seed raised after the whole search)
    for name, value in (("runs", runs), ("max_runs", max_runs), ("recentre", recentre),
                        ("ess", ess), ("seed", seed), ("samples", samples)):
        if value is None:
            continue
        allowed = typing.cast(Range, field_range(PosteriorSection.model_fields[name]))
        if isinstance(value, bool) or not isinstance(value, int) or not allowed.contains(value):
            raise ConfigError(f"{case.label}: {name}: got {value!r} (allowed: "
                              f"{allowed.describe()})")
        if name in ("runs", "max_runs", "recentre", "ess"):
            settings = settings.model_copy(update={name: value})
    if settings.runs > settings.max_runs:
        raise ConfigError(f"{case.label}: runs = {settings.runs} with max_runs = "
                          f"{settings.max_runs} (allowed: runs <= max_runs, the most runs "
                          "there may be)")
    if resume and not restart and not ((out_dir / FILENAME).is_file()
                                       or (out_dir / POSTERIOR_DIR).is_dir()):
        raise ConfigError(f"{case.label}: --resume: nothing is stored in {out_dir} to continue "
                          "(allowed: --resume into the --out of an interrupted `femupdate "
                          "posterior`; without --resume a posterior starts)")
    if error_model is not None:
        if error_model not in (allowed_kinds := case_kinds()):
            raise ConfigError(f"{case.label}: error_model: got {error_model!r} (allowed: "
                              f"{', '.join(allowed_kinds)})")
        settings = settings.model_copy(update={"error_model": error_model})
    if seed is None:  # the posterior is as reproducible as the case's search
        seed = settings.seed if settings.seed is not None else case.search.seed
    population = settings.samples if samples is None else samples
    need = SAMPLES_PER_PARAMETER * len(case.parameters)
    if population < need:
        raise ConfigError(f"{case.label}: samples: got {population} for "
                          f"{len(case.parameters)} parameters (allowed: at least {need}, "
                          f"{SAMPLES_PER_PARAMETER} per parameter)")
    if search_from is not None and not (search_from / FILENAME).is_file():
        raise ConfigError(f"{case.label}: --from {search_from}: no search results there "
                          f"(allowed: the --out directory of `femupdate run` on this case, "
                          f"holding {FILENAME})")
    experiments = list(experiments or load_experiments(case))
    check_records(experiments, case)
    register()  # method "tmcmc" in run_all's registry
    execution = execution or Execution(label=case.label)
    out_dir.mkdir(parents=True, exist_ok=True)
    sampler_dir = out_dir / POSTERIOR_DIR
    if restart and sampler_dir.is_dir():
        from femupdate.pipeline.run import start_over

        # the stores of re-centred passes and added runs inside it, deepest first
        for store in sorted(sampler_dir.rglob(FILENAME), key=lambda f: -len(f.parts)):
            start_over(store.parent)
        start_over(sampler_dir)
    if search_from is not None:  # the user's fit, not searched again
        search = run_case(case, search_from, workers=workers, resume=True, execution=execution,
                          keep_history=False, experiments=experiments)
    else:
        reuse = not restart and (out_dir / FILENAME).is_file()
        search = run_case(case, out_dir, workers=workers, resume=reuse, restart=restart,
                          execution=execution, keep_history=False, experiments=experiments)
    problem = SampledProblem.of(search.problem)
    best = search.summary.runs[search.summary.best.run]
    workers = case.search.workers if workers is None else workers
    # what the stores belong to (the data files hashed once, for every pass and added run)
    identity = CaseIdentity(case.to_dict(), case.fingerprint(), problem.names,
                            data=file_hashes(data_files(case)))
    sampling = FitSampler(problem, identity, settings, seed, population, counts_from, resume,
                          dataclasses.replace(execution, workers=workers), tmcmc=dict(tmcmc or {}))
    x, phi = np.asarray(best.x, dtype=float), float(best.phi)
    done = sampling.sample(x, sampler_dir, phi if settings.recentre else None)
    start_words: list[str] = []
    # the sampler found a better fit than its start: sample again from it (module start)
    passes, polish_evals = 0, 0
    while (better := better_fit(done.outcomes, phi)) is not None:
        if passes == settings.recentre:
            start_words.append(unfollowed_sentence(phi, better.fun))
            break
        passes += 1
        x, phi, evals = polish(problem.residuals, problem.bounds, better.x,
                               derived_seed(seed, better.x, POLISH_KEY + passes))
        polish_evals += evals
        done = sampling.sample(x, sampler_dir / f"{RECENTRED_DIR}-{passes}",
                               phi if passes < settings.recentre else None)
    if passes:
        start_words.insert(0, recentred_sentence(float(best.phi), phi, passes))
    if (words := search_sentence(search.summary.verdict, passes > 0)) is not None:
        start_words.append(words)
    record, physical = posterior_record(problem, done.prior, done.outcomes, done.model.kind,
                                        seed, population, settings.ess or MIN_ESS)
    record.start_phi, record.recentred, record.start_warnings = phi, passes, start_words
    record.error_model_notes = done.model.notes()
    if record.runs > settings.runs:
        record.message += (f"; runs added, {settings.runs} at a time, while a parameter was "
                           f"unsettled: {settings.runs} → {record.runs} ([posterior] "
                           f"max_runs = {settings.max_runs})")
    # every pass and polish counts (the record's own figures are the last pass's)
    record.nfev, record.wall_s = sampling.evaluations + polish_evals, sampling.wall_s
    if done.why is not None:
        record.message += f"; started from the prior: no Laplace approximation ({done.why})"
    elif done.start_note is not None:
        record.message += f"; started from {done.start_note}"
    bands: list[Bands] = []
    (out_dir / POSTERIOR_FILE).unlink(missing_ok=True)  # never an earlier run's samples
    if physical.shape[0]:
        subset = thinned(physical, settings.modes_samples)
        freqs, zetas = sample_modes(problem, subset)
        _modes_into(record, freqs, zetas, subset.shape[0])
        record.joint_names, record.joint_correlations = joint_correlations(
            list(problem.names), done.prior.physical_to_search(subset), freqs, zetas)
        rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(BANDS_KEY,)))
        bands = predictive_bands(problem, subset, search.summary, rng)
        save_bands(out_dir / POSTERIOR_FILE, list(problem.names), physical, freqs, bands)
    summary = search.summary.model_copy(update={"posterior": record})
    write_summary(summary, out_dir)
    return PosteriorResult(summary, record, physical, bands, search, done.model)


def start_reference(mean: np.ndarray, cov: np.ndarray, rng: np.random.Generator,
                    inflate: float = INFLATE) -> tuple[tuple[np.ndarray, np.ndarray] | None,
                                                       str | None]:
    """TMCMC's first population's Gaussian (unit cube) from the Laplace one, and why it is not
    that one when it is not. A Gaussian wider than the bounds (a parameter the data do not
    determine) centred near one can hold less than :data:`MIN_REFERENCE_MASS` of its mass
    inside, which TMCMC refuses (twice that is asked here, TMCMC estimating it by other
    draws): its standard deviations are then capped at half the range
    (any normalised start density gives the same posterior), and if even that one is mostly
    outside, the walk starts from the prior."""
    mean, cov = np.asarray(mean, dtype=float), np.asarray(cov, dtype=float)
    centre = np.clip(mean, 0.0, 1.0)  # where TMCMC puts it
    candidates = [cov]
    cap = np.minimum(1.0, 0.5 / np.sqrt(np.clip(np.diag(cov), 1e-300, None)))
    if np.any(cap < 1.0):
        candidates.append(cov * np.outer(cap, cap))
    for number, candidate in enumerate(candidates):
        chol = safe_cholesky(candidate * inflate ** 2)
        # twice TMCMC's threshold: its own estimate, by other draws, must not fall below it
        if mass_inside(centre, chol, rng) >= 2.0 * MIN_REFERENCE_MASS:
            return (mean, candidate), (None if number == 0 else
                                       "the Laplace Gaussian with its standard deviations "
                                       "capped at half the range (it lies mostly outside the "
                                       "bounds)")
    return None, "the prior: the Laplace Gaussian lies mostly outside the bounds, even capped"


def thinned(samples: np.ndarray, count: int) -> np.ndarray:
    """``count`` samples spread evenly over the rows (all of them if fewer)."""
    if count <= 0:
        return samples[:0]
    if samples.shape[0] <= count:
        return samples
    return samples[np.linspace(0, samples.shape[0] - 1, count).round().astype(int)]


def posterior_record(problem: UpdateProblem, prior: Prior, outcomes: Sequence[RunOutcome],
                     error_model: str, seed: int | None, population: int,
                     min_ess: float = MIN_ESS) -> tuple[PosteriorRecord, np.ndarray]:
    """The summary's record of independent TMCMC runs and their pooled samples in physical
    units (none unless every run reached β = 1: it never reports a posterior it did not
    reach), with the runs' agreement (:mod:`femupdate.pipeline.posterior.agreement`)."""
    extras: list[dict[str, Any]] = [o.extras or {} for o in outcomes]
    names = list(problem.names)
    stages = [StageRecord(beta=s["beta"], acceptance=_finite(s.get("acceptance")),
                          ess=s["weights_ess"]) for s in extras[0].get("stages", [])]
    reached = [bool(e.get("reached")) for e in extras]
    failures = [o.failure for o in outcomes if o.failure]
    common = dict(method=METHOD, error_model=error_model, seed=seed,
                  nfev=sum(o.nfev for o in outcomes),
                  # the runs' own times over every session (a resumed run counts its earlier)
                  wall_s=sum(o.wall_s for o in outcomes), stages=stages, names=names,
                  runs=len(outcomes),
                  failed_evaluations=sum(int(e.get("failures", o.nfail))
                                         for e, o in zip(extras, outcomes, strict=True)),
                  failure=failures[0] if failures else None)
    got = run_samples(prior, outcomes, len(names))
    if got is None:
        betas = [float(e.get("beta", 0.0)) for e in extras]
        short = [i for i, r in enumerate(reached) if not r]
        message = (f"{len(short)} of {len(outcomes)} sampler runs stopped before tempering "
                   f"exponent β = 1 (lowest β = {min(betas):.4g}; "
                   f"{outcomes[short[0]].message}; {common['nfev']:,} evaluations): "
                   f"{short_advice([outcomes[i] for i in short])}")
        return PosteriorRecord(**common, samples=population * len(outcomes), reached=False,
                               message=message, log_evidence=None,
                               ess=None), np.empty((0, len(names)))
    searches, own = got
    agreement = runs_agreement(searches, own, names, min_ess)
    search = np.vstack(searches)
    physical = prior.search_to_physical(search)
    q = np.quantile(search, [0.05, 0.5, 0.95], axis=0)
    spread = interval_spread(q[0], q[2], prior)
    words = sentences(prior, prior.search_to_physical(q), spread)
    undetermined = [n for n, s in zip(names, spread, strict=True) if s >= 0.5]
    corr = np.corrcoef(search, rowvar=False) if len(names) > 1 else np.ones((1, 1))
    log_z = np.array([float(e["log_evidence"]) for e in extras])
    fell = sum(any(s.get("fallback") for s in e.get("stages", [])) for e in extras)
    record = PosteriorRecord(
        **common, samples=search.shape[0], reached=True,
        message=f"β = 1 reached by {len(outcomes)} independent run(s) in "
                f"{'–'.join(sorted({str(len(e['stages'])) for e in extras}, key=int))} stages"
                + (f"; {fell} of them by moves to β = 1: importance sampling's weights were "
                   "too uneven" if fell else ""),
        # the mean of the runs' unbiased estimates of Z
        log_evidence=float(logsumexp(log_z) - math.log(log_z.size)),
        log_evidence_runs=log_z.tolist(), ess=float(np.min(agreement.ess)),
        ess_params=_by_name(names, agreement.ess), rhat=_by_name(names, agreement.rhat),
        unsettled=agreement.unsettled, agreement=agreement.words,
        params=marginals(physical, names), correlations=correlation_rows(np.atleast_2d(corr)),
        undetermined=undetermined, sentences=words)
    return record, physical


def short_advice(short: Sequence[RunOutcome]) -> str:
    """What to do about sampler runs that stopped before β = 1: a larger budget only when the
    budget is what stopped them (a degenerate prior or likelihood stops them otherwise, and
    "raise max_evals" sent users round in circles)."""
    if all("max_evals" in o.stop for o in short):
        return "raise [posterior] max_evals and resume"
    reasons = sorted({k for o in short for k in o.stop if k != "max_evals"})
    return (f"not the budget: {', '.join(reasons) or 'the runs'} stopped them; look at "
            "[posterior.priors] (a prior far narrower than the data's information leaves the "
            "likelihood nothing to temper) and at the failed evaluations, then "
            "--restart")


def _by_name(names: Sequence[str], values: np.ndarray) -> dict[str, float | None]:
    """Per-parameter figures as JSON (None where not defined, e.g. R̂ of one run; a huge
    number for ∞)."""
    return {n: None if math.isnan(v) else float(min(v, 1e300)) for n, v in
            zip(names, values.tolist(), strict=True)}


def _finite(value: Any) -> float:
    return float(value) if value is not None and math.isfinite(float(value)) else 0.0


def joint_correlations(names: list[str], search: np.ndarray, freqs: np.ndarray,
                       zetas: np.ndarray) -> tuple[list[str], list[list[float | None]]]:
    """Correlations of the parameters (search space: log10 on a log scale) with the natural
    frequencies and damping ratios and among them, over the samples whose modes were
    computed (rows with a NaN left out)."""
    labels = [*names, *(f"f{i + 1}" for i in range(freqs.shape[1])),
              *(f"zeta{i + 1}" for i in range(zetas.shape[1]))]
    table = np.column_stack([search, freqs, zetas])
    table = table[np.all(np.isfinite(table), axis=1)]
    if table.shape[0] < 3:
        return labels, []
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = np.atleast_2d(np.corrcoef(table, rowvar=False))
    return labels, correlation_rows(corr)


def _modes_into(record: PosteriorRecord, freqs: np.ndarray, zetas: np.ndarray,
                count: int) -> None:
    record.modes_from = count
    if freqs.size:
        record.frequencies_hz = marginals(freqs, [f"f{i + 1}" for i in range(freqs.shape[1])])
    if zetas.size:
        record.damping_ratios = marginals(zetas,
                                          [f"zeta{i + 1}" for i in range(zetas.shape[1])])


def run_surrogate_posterior(case: Case, out_dir: Path, *, surrogate: bool | None = None,
                            seed: int | None = None, workers: int | None = None,
                            execution: Execution | None = None, resume: bool = False) -> Any:
    """The surrogate-aided posterior (:mod:`femupdate.pipeline.posterior.surrogate`)
    when ``surrogate`` (else ``[posterior] surrogate``, else an external model) asks for it,
    its batches on ``workers`` (default ``[search] workers``) or the execution's scheduler;
    None when not asked (then :func:`run_posterior`)."""
    from femupdate.pipeline.posterior.surrogate import run_case_surrogate, wants_surrogate

    if not wants_surrogate(case, surrogate):
        return None
    execution = execution or Execution(label=case.label)
    return run_case_surrogate(case, out_dir, seed=seed, scheduler=execution.scheduler,
                              workers=case.search.workers if workers is None else workers,
                              resume=resume, progress=None if execution.quiet else print)

"""Transitional MCMC (Ching & Chen 2007) on the ask/tell loop of the searches.

Why this file is long: the sampler is one state machine (tempering stages, their moves, the
importance-sampled last stage) whose state pickles whole for the checkpoints; its pure parts
(proposals, importance weights) live in their own modules.

The posterior p(ξ | D) ∝ π(ξ) = prior(ξ)·L(ξ) on the unit cube is reached through a sequence
of intermediate densities

    p_j(ξ) ∝ q(ξ)^{1−β_j} · π(ξ)^{β_j},   0 = β_0 < β_1 < … < β_J = 1,

where q is the reference: the prior (Ching & Chen's original), or, when a Gaussian
approximation of the posterior is given (the Laplace approximation at the best fit, inflated),
that Gaussian truncated to the cube, so that the walk starts next to the answer and needs
few stages. Each stage:

1. choose β_{j+1} by bisection so that the coefficient of variation of the weights
   w_i = (π(ξ_i)/q(ξ_i))^{β_{j+1} − β_j} equals ``cov_target`` (1.0: an effective sample
   size of about half the population), or 1 if it is reached;
2. accumulate the log-evidence, log Z += log mean(w) (exact in expectation: q is normalised);
3. resample the population by the weights (systematic resampling);
4. move every particle by ``steps`` Metropolis–Hastings steps targeting p_{j+1}
   (``final_steps`` at β = 1): by default independent draws from a Gaussian mixture fitted
   to the resampled population (``proposal = "mixture"``: one component per k-means cluster,
   :mod:`femupdate.inference.proposals`), or from the Gaussian of the weighted population's
   mean and covariance (``"independent"``), both inflated, or, with ``proposal = "rw"``, a
   random walk with the weighted population's covariance scaled by c (adapted from stage to
   stage toward an acceptance of 0.25).

With ``final = "importance"`` the last stage draws batches from a defensive mixture (the
clusters beside a Student-t of the whole population) and weighs them by π/q instead
(:mod:`femupdate.inference.importance`); the weighted draws say where the moves' population
was too narrow. Where the weights degenerate (a curved posterior the mixture does not cover:
the least effective samples per draw below :data:`FALLBACK_EFFICIENCY`, or one draw holding
more than :data:`FALLBACK_WEIGHT` of the weight), the run falls back: it drops the draws
(their evaluations stay counted), takes up the population at the β it reached and goes on
tempering by moves to β = 1 and its final moves, as ``final = "moves"`` does.

Every step's candidates are one population (``ask`` → (k, n)), evaluated by the loop's
batches, workers or Dask; proposals outside the cube are rejected without evaluation. A
failed evaluation (non-finite residuals) has zero likelihood: never accepted, weight 0,
counted per stage. All randomness comes from the Generator passed in; the state pickles
(the checkpoint of a long run).

After the last stage the result is the population (equally weighted samples), their
log-likelihoods, the log-evidence, the stage table and an effective sample size that counts
the correlation of particles sharing an ancestor (:func:`ess_by_ancestry`). If the run ends
(its budget) before β = 1, :meth:`TMCMC.posterior` says so and gives no posterior.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.special import logsumexp

from femupdate.errors import ConfigError, FemupdateError
from femupdate.inference.importance import (
    defensive_mixture,
    importance_ess,
    kish_ess,
    normalised_weights,
    resampled_ess,
)
from femupdate.inference.likelihood import ErrorModel
from femupdate.inference.priors import Prior
from femupdate.inference.proposals import GaussianMixture, fit_mixture
from femupdate.optimize.base import StepTrace, check_option_names, int_option, real_option

OPTIONS = ("population", "cov_target", "steps", "proposal", "reference", "inflate",
           "max_stages", "final_steps", "components", "final", "ess", "final_inflate",
           "importance_from", "fallback")
PROPOSALS = ("rw", "independent", "mixture")
#: What the last stage (β = 1) does: importance sampling from a defensive mixture fitted to
#: the population (:mod:`femupdate.inference.importance`), or ``final_steps`` sweeps of moves
FINALS = ("importance", "moves")
#: Importance batches (of a population each) at most at β = 1, whatever ESS is reached
MAX_BATCHES = 50
#: Importance batches at β = 1 that only adapt the proposal (each refits it to all the weighted
#: draws so far) before the batches that count, drawn from the last proposal
ADAPT_BATCHES = 4
TARGET_ACCEPTANCE = 0.25
FINAL_STEPS = 12  # default moves at β = 1: they decorrelate the final resampled copies
#: The widening of the importance proposal's clusters at β = 1 (module importance)
FINAL_INFLATE = 1.3
#: Importance sampling at β = 1 falls back to moves when, after any batch that counts, the
#: least parameter's effective samples (or Kish's) per draw is below this: on issue 36's
#: viscous bridge the first such batch gave 0.14–0.23 (0.15–0.19 after three), on its
#: Rayleigh-damped building 0.015–0.10 (0.003–0.029 after three; docs/posterior.md)
FALLBACK_EFFICIENCY = 0.05
#: ... or when one draw holds more than this share of the normalised weight (0.010–0.021 on
#: the bridge's first batch that counts, 0.03–0.10 on the building's, up to 0.31 later)
FALLBACK_WEIGHT = 0.1
#: The mixture proposal's k-means clusters: on the viscous bridge 16 mixed better per
#: evaluation than 8 or 32 (docs/posterior.md, "Effective samples, measured across seeds")
COMPONENTS = 16


@dataclass
class TMCMCPosterior:
    """What a finished (or unfinished) TMCMC run has.

    Attributes
    ----------
    reached : bool
        β reached 1 and the last stage's moves are done: the samples are the posterior's.
        False: ``samples`` is None and ``beta`` says how far it got.
    beta : float
    samples : ndarray (N, n) or None
        Equally weighted posterior samples in the unit cube.
    loglike : ndarray (N,) or None
    log_evidence : float
        log Z (NaN until β = 1).
    stages : list of dict
        Per stage: beta, acceptance, weights_ess, scale, evaluations, failures.
    ess : float
        Effective sample size of the final population for the posterior mean: the minimum
        over the parameters of ``ess_params`` (NaN if not reached).
    ess_params : ndarray (n,) or None
        Per parameter, the smaller of :func:`ess_by_ancestry` and :func:`ess_of_population`.
    evaluations : int
    failures : int
    """

    reached: bool
    beta: float
    samples: np.ndarray | None
    loglike: np.ndarray | None
    log_evidence: float
    stages: list[dict[str, float]] = field(default_factory=list)
    ess: float = math.nan
    evaluations: int = 0
    failures: int = 0
    ess_params: np.ndarray | None = None


def next_beta(loglike_ratio: np.ndarray, beta: float, cov_target: float) -> float:
    """The next tempering exponent: the β' in (β, 1] at which the weights
    exp((β' − β)·g), g = log(π/q) per particle, have a coefficient of variation of
    ``cov_target`` (bisection on Δβ), or 1 when even β' = 1 stays below it."""
    g = np.where(np.isfinite(loglike_ratio), loglike_ratio, -np.inf)

    def cov(dbeta: float) -> float:
        a = dbeta * g
        a = a - np.max(a)
        w = np.exp(a)
        mean = w.mean()
        return float(w.std() / mean)

    if cov(1.0 - beta) <= cov_target:
        return 1.0
    low, high = 0.0, 1.0 - beta
    for _ in range(60):  # bisection to ~1e-18 of the range
        mid = 0.5 * (low + high)
        if cov(mid) > cov_target:
            high = mid
        else:
            low = mid
    return beta + max(low, 1e-12)


def importance_degenerate(ess: np.ndarray, log_w: np.ndarray, drawn: int,
                          efficiency: float = FALLBACK_EFFICIENCY,
                          weight: float = FALLBACK_WEIGHT) -> bool:
    """Whether importance weights are too uneven to go on with: the least of the parameters'
    effective samples ``ess`` and Kish's, per draw (``drawn``, those outside the cube
    included), is below ``efficiency``, or the largest normalised weight of ``log_w`` is above
    ``weight`` (a few draws decide every estimate, and the ESS itself is a guess)."""
    least = min(float(np.min(ess)), kish_ess(log_w))
    return least < efficiency * drawn or float(np.max(normalised_weights(log_w))) > weight


def systematic_resample(weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Indices of a systematic resampling of normalised ``weights`` (one uniform draw)."""
    n = weights.size
    positions = (rng.random() + np.arange(n)) / n
    cumulative = np.cumsum(weights)
    cumulative[-1] = 1.0
    return np.searchsorted(cumulative, positions, side="right").clip(0, n - 1)


def weighted_moments(x: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and covariance of the rows of ``x`` with normalised ``weights``."""
    mean = weights @ x
    d = x - mean
    return mean, (weights[:, None] * d).T @ d


def gaussian_logpdf(x: np.ndarray, mean: np.ndarray, chol: np.ndarray) -> np.ndarray:
    """log N(x; mean, L Lᵀ) of rows x (k, n), with the Cholesky factor L."""
    z = np.linalg.solve(chol, (x - mean).T)
    n = mean.size
    return (-0.5 * np.sum(z * z, axis=0) - np.log(np.diag(chol)).sum()
            - 0.5 * n * math.log(2 * math.pi))


#: The default widening of the reference's and the independent proposals' covariance.
INFLATE = 1.5
#: A reference Gaussian with less of its mass inside the unit cube is refused.
MIN_REFERENCE_MASS = 0.01


def mass_inside(mean: np.ndarray, chol: np.ndarray, rng: np.random.Generator,
                draws: int = 20_000) -> float:
    """The share of the Gaussian (``mean``, ``chol`` its covariance's Cholesky factor) inside
    the unit cube, by drawing (the truncated Gaussian's normaliser)."""
    x = mean + rng.standard_normal((draws, mean.size)) @ chol.T
    return float(np.all((x >= 0) & (x <= 1), axis=1).mean())


def safe_cholesky(cov: np.ndarray) -> np.ndarray:
    """The Cholesky factor of a covariance, with a growing jitter on its diagonal if it is
    not positive definite (a population that collapsed along some direction)."""
    cov = 0.5 * (cov + cov.T)
    scale = max(float(np.mean(np.diag(cov))), 1e-300)
    for jitter in (0.0, 1e-12, 1e-10, 1e-8, 1e-6, 1e-4):
        try:
            return np.linalg.cholesky(cov + jitter * scale * np.eye(cov.shape[0]))
        except np.linalg.LinAlgError:
            continue
    raise FemupdateError("TMCMC: the population's covariance is not positive definite")


def ess_of_weights(weights: np.ndarray) -> float:
    """(Σw)²/Σw² of normalised weights."""
    return float(1.0 / np.sum(weights ** 2))


def ess_by_ancestry(samples: np.ndarray, ancestors: np.ndarray) -> np.ndarray:
    """Effective sample size of the mean of each parameter of a final population, from its
    genealogy (per parameter, at most N).

    Particles that descend from the same particle of the first stage (``ancestors``, its index)
    are correlated through every resampling and Markov move since; descendants of different
    first-stage particles are taken independent. The variance of the population mean is then
    estimated by the sum over the ancestors' families of their squared summed deviations,
    V = Σ_a (Σ_{i: a_i = a} (x_i − x̄))² / N² (the cluster estimator of SMC's variance by
    ancestry), and ESS = s²/V with s² the population's variance. It needs many families:
    with few of them V is noisy, which is why :meth:`TMCMC.posterior` takes the smaller of
    this and :func:`ess_of_population`.
    """
    n = samples.shape[0]
    d = samples - samples.mean(axis=0)
    _, family = np.unique(ancestors, return_inverse=True)
    sums = np.zeros((int(family.max()) + 1, samples.shape[1]))
    np.add.at(sums, family, d)
    v = np.sum(sums ** 2, axis=0) / n ** 2
    s2 = np.sum(d ** 2, axis=0) / n
    with np.errstate(invalid="ignore", divide="ignore"):
        ess = s2 / v
    return np.minimum(np.where(np.isfinite(ess), ess, float(n)), float(n))


def ess_of_population(start: np.ndarray, end: np.ndarray, copies: np.ndarray) -> np.ndarray:
    """Effective sample size of a final population per parameter, from the last resampling
    alone (a model of the correlation it leaves).

    The N particles at the end of the last stage descend from the resampled population
    ``start`` (N, n), in which parent k appears ``copies[k]`` times. Two particles of the same
    parent, each moved by the same Markov kernel for T steps, are correlated by about ρ_T²,
    ρ_T the kernel's lag-T autocorrelation, measured as the correlation between ``start`` and
    ``end`` across particles; particles of different parents are taken independent. So the
    variance of the sample mean is σ²/N · (1 + ρ_T² Σ_k c_k(c_k − 1)/N), and
    ESS = N / (1 + ρ_T² Σ_k c_k(c_k − 1)/N).
    """
    n = start.shape[0]
    pairs = float(np.sum(copies * (copies - 1.0))) / n
    a, b = start - start.mean(axis=0), end - end.mean(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        rho = np.sum(a * b, axis=0) / np.sqrt(np.sum(a * a, axis=0) * np.sum(b * b, axis=0))
    rho = np.where(np.isfinite(rho), rho, 1.0)
    return n / (1.0 + rho ** 2 * pairs)


class TMCMC:
    """Transitional MCMC as an ask/tell optimizer on the unit cube (module docstring).

    Parameters
    ----------
    n : int
        Number of parameters.
    rng : numpy.random.Generator
    error_model : ErrorModel
        log L of the residual rows the loop tells (the loop must run with residuals).
    prior : Prior
    population : int
        Particles per stage (≥ 2n + 2, ≥ 20).
    cov_target : float
        Coefficient of variation of the weights that sets each β (Ching & Chen: 1.0).
    steps : int
        Metropolis–Hastings steps per particle and stage.
    final_steps : int, optional
        Steps per particle at β = 1 (at least ``steps``; default the larger of ``steps`` and
        12): the last stage's moves, which decorrelate the resampled copies.
    proposal : {"mixture", "independent", "rw"}
        Independent draws from a Gaussian mixture of the population's k-means clusters
        (inflated), the default; from the weighted population's single Gaussian (inflated);
        or a random walk. On the viscous bridge the mixture needs a third to a quarter of
        the single Gaussian's evaluations per effective sample (ESS measured across seeds,
        worst parameter), which needed a third of the random walk's (docs/posterior.md,
        "Effective samples, measured across seeds").
    components : int
        The mixture's k-means clusters (fewer when the population has fewer than
        ``MEMBERS_PER_PARAMETER`` · n members for each).
    reference : (mean, cov) in the unit cube, optional
        A Gaussian approximation of the posterior (the Laplace one): the start q.
    inflate : float
        Its covariance (and the independent proposal's) is multiplied by inflate².
    max_stages : int
    final : {"moves", "importance"}
        The last stage (β = 1): ``final_steps`` sweeps of moves (the default), or importance
        sampling from a defensive mixture (:mod:`femupdate.inference.importance`):
        :data:`ADAPT_BATCHES` batches that refit the proposal to the weighted draws, then
        batches from the last proposal until every parameter has ``ess`` effective samples
        (at most :data:`MAX_BATCHES`), resampled into as many equally weighted samples.
    ess : int, optional
        With ``final = "importance"``: the effective samples per parameter to reach (default
        the population).
    final_inflate : float
        With ``final = "importance"``: the widening of the proposal's clusters.
    importance_from : float
        With ``final = "importance"``: a stage whose β reaches this goes to β = 1 by importance
        sampling at once (1: only the stage that reaches β = 1).
    fallback : float
        With ``final = "importance"``: the least effective samples per draw below which (or
        one draw holding more than :data:`FALLBACK_WEIGHT` of the weight) importance sampling
        is dropped for moves to β = 1 (:func:`importance_degenerate`); 0 never drops it.
    """

    needs_residuals = True

    def __init__(self, n: int, rng: np.random.Generator, *, error_model: ErrorModel,
                 prior: Prior, population: int = 1000, cov_target: float = 1.0,
                 steps: int = 3, final_steps: int | None = None,
                 proposal: str = "mixture",
                 reference: tuple[np.ndarray, np.ndarray] | None = None,
                 inflate: float = INFLATE, max_stages: int = 100,
                 components: int = COMPONENTS, final: str = "moves",
                 ess: int | None = None, final_inflate: float = FINAL_INFLATE,
                 importance_from: float = 1.0,
                 fallback: float = FALLBACK_EFFICIENCY) -> None:
        method = "tmcmc"
        if not isinstance(error_model, ErrorModel):
            raise ConfigError(f"option 'error_model' of method 'tmcmc' must be an ErrorModel, "
                              f"got {error_model!r}")
        if not isinstance(prior, Prior) or prior.dim != n:
            raise ConfigError(f"option 'prior' of method 'tmcmc' must be a Prior of {n} "
                              f"parameters, got {prior!r}")
        self.n = n
        self.rng = rng
        self.error_model = error_model
        self.prior = prior
        self.population = int_option(method, "population", population, max(20, 2 * n + 2))
        self.cov_target = float(real_option(method, "cov_target", cov_target, 0.0, 10.0,
                                            low_open=True))
        self.steps = int_option(method, "steps", steps, 1, 1000)
        self.final_steps = (max(self.steps, FINAL_STEPS) if final_steps is None
                            else int_option(method, "final_steps", final_steps, self.steps,
                                            10_000))
        if proposal not in PROPOSALS:
            raise ConfigError(f"option 'proposal' of method 'tmcmc' must be one of "
                              f"{', '.join(PROPOSALS)}, got {proposal!r}")
        self.proposal = proposal
        self.inflate = float(real_option(method, "inflate", inflate, 0.0, 100.0,
                                         low_open=True))
        self.max_stages = int_option(method, "max_stages", max_stages, 1, 10_000)
        self.components = int_option(method, "components", components, 1, 1000)
        if final not in FINALS:
            raise ConfigError(f"option 'final' of method 'tmcmc' must be one of "
                              f"{', '.join(FINALS)}, got {final!r}")
        self.final = final
        self.ess_target = (self.population if ess is None
                           else int_option(method, "ess", ess, 1, 10_000_000))
        self.final_inflate = float(real_option(method, "final_inflate", final_inflate, 0.0,
                                               100.0, low_open=True))
        self.importance_from = float(real_option(method, "importance_from", importance_from,
                                                 0.0, 1.0, low_open=True))
        self.fallback = float(real_option(method, "fallback", fallback, 0.0, 1.0))
        self._trace = StepTrace()
        self.phase = "init"
        self.beta = 0.0
        self.log_evidence = 0.0
        self.stages: list[dict[str, float]] = []
        self.evaluations = 0
        self.failures = 0
        self.scale = 2.38 / math.sqrt(n)
        self.stopped: dict[str, object] = {}
        self._ref: tuple[np.ndarray, np.ndarray, float] | None = None
        if reference is not None:
            self._ref = self._reference(reference)
        # population state (unit cube), filled by the first tell
        self.x = np.empty((0, n))
        self.ll = np.empty(0)
        self.lp = np.empty(0)
        self.lq = np.empty(0)
        self._pending: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None
        self._stage_step = 0
        self._stage_accepted = 0
        self._stage_proposed = 0
        self._stage_evaluations = 0
        self._stage_failures = 0
        self._final_start: np.ndarray | None = None  # the population entering β = 1
        self._final_copies: np.ndarray | None = None  # copies of each parent in it
        self._move: tuple[np.ndarray, np.ndarray] | None = None  # proposal mean, Cholesky
        self._eve = np.arange(self.population)  # each particle's ancestor in the first stage
        # importance sampling at β = 1: the draws, their log-weights and log-likelihoods
        self._draws = np.empty((0, n))
        self._log_w = np.empty(0)
        self._draws_ll = np.empty(0)
        self._drawn = 0  # draws made, those outside the cube included
        self._ess: np.ndarray | None = None  # per parameter, of the samples handed back
        self._adapt_left = ADAPT_BATCHES
        self._jumped_from: float | None = None  # the β importance sampling went to 1 from
        self._pool_x = np.empty((0, n))  # the adapting batches' draws and log-weights
        self._pool_log_w = np.empty(0)
        self._fell_back = False  # importance sampling degenerated: moves to β = 1 instead

    def __setstate__(self, state: dict[str, Any]) -> None:
        # a checkpoint written before the ancestry was kept: ancestry from the resume on
        state.setdefault("_eve", np.arange(state["population"]))
        # and before the mixture proposal existed
        state.setdefault("components", COMPONENTS)
        # and before the last stage could be importance sampling: its moves
        state.setdefault("final", "moves")
        state.setdefault("importance_from", 1.0)
        state.setdefault("_jumped_from", None)
        state.setdefault("_ess", None)
        state.setdefault("_adapt_left", 0)
        # and before it could fall back to moves
        state.setdefault("_fell_back", False)
        state.setdefault("fallback", 0.0)
        self.__dict__.update(state)

    # -- the reference density ----------------------------------------------------------------

    def _reference(self, reference: tuple[np.ndarray, np.ndarray]
                   ) -> tuple[np.ndarray, np.ndarray, float]:
        mean, cov = (np.asarray(a, dtype=float) for a in reference)
        if mean.shape != (self.n,) or cov.shape != (self.n, self.n) or not (
                np.all(np.isfinite(mean)) and np.all(np.isfinite(cov))):
            raise ConfigError(f"option 'reference' of method 'tmcmc' must be a finite (mean "
                              f"({self.n},), cov ({self.n}, {self.n})) pair in the unit cube")
        mean = np.clip(mean, 0.0, 1.0)
        chol = safe_cholesky(cov * self.inflate ** 2)
        mass = mass_inside(mean, chol, self.rng)
        if mass < MIN_REFERENCE_MASS:
            raise ConfigError("option 'reference' of method 'tmcmc': less than 1 % of the "
                              "Gaussian lies inside the bounds (allowed: a Gaussian centred in "
                              "the bounds)")
        return mean, chol, math.log(mass)

    def _log_q(self, x: np.ndarray, lp: np.ndarray) -> np.ndarray:
        if self._ref is None:
            return lp
        mean, chol, log_mass = self._ref
        return gaussian_logpdf(x, mean, chol) - log_mass

    def _draw_reference(self, k: int) -> np.ndarray:
        mean, chol, _ = self._ref
        out = np.empty((0, self.n))
        while out.shape[0] < k:
            z = self.rng.standard_normal((k, self.n))
            x = mean + z @ chol.T
            out = np.vstack([out, x[np.all((x >= 0) & (x <= 1), axis=1)]])
        return out[:k]

    # -- ask / tell ---------------------------------------------------------------------------

    def ask(self) -> np.ndarray:
        if self.phase == "init":
            if self._ref is None:
                x = self.prior.sample(self.rng, self.population)[0]
            else:
                x = self._draw_reference(self.population)
            self._pending = (x, np.arange(self.population), np.zeros(self.population),
                             np.zeros(self.population))
            return x
        if self.phase == "importance":
            return self._ask_importance()
        if self.phase != "mcmc":
            raise FemupdateError(f"TMCMC: ask() after the run ended ({self.phase})")
        while self.phase == "mcmc":  # until a proposal falls inside the cube
            x, chains, log_g_new, log_g_old = self._propose()
            if x.shape[0]:
                self._pending = (x, chains, log_g_new, log_g_old)
                return x
            self._end_step(0)  # every proposal outside: all rejected, a step without cost
        # that step ended the run: ask one point whose value is not used (the loop needs
        # candidates; its stop() fires after this tell)
        self._pending = (self.x[:1].copy(), np.empty(0, dtype=int), np.empty(0), np.empty(0))
        return self._pending[0]

    def _propose(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        if isinstance(self._move, GaussianMixture):
            return self._propose_mixture(self._move)
        mean, chol = self._move
        z = self.rng.standard_normal((self.population, self.n))
        if self.proposal == "rw":
            proposals = self.x + z @ chol.T
        else:
            proposals = mean + z @ chol.T
        inside = np.all((proposals >= 0) & (proposals <= 1), axis=1)
        chains = np.flatnonzero(inside)
        x = proposals[chains]
        if self.proposal == "independent" and chains.size:
            log_g_new = gaussian_logpdf(x, mean, chol)
            log_g_old = gaussian_logpdf(self.x[chains], mean, chol)
        else:
            log_g_new = log_g_old = np.zeros(chains.size)
        return x, chains, log_g_new, log_g_old

    def _propose_mixture(self, mixture: GaussianMixture
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        proposals = mixture.sample(self.rng, self.population)
        chains = np.flatnonzero(np.all((proposals >= 0) & (proposals <= 1), axis=1))
        x = proposals[chains]
        if not chains.size:
            return x, chains, np.zeros(0), np.zeros(0)
        return x, chains, mixture.logpdf(x), mixture.logpdf(self.x[chains])

    def tell(self, xs: np.ndarray, fs: np.ndarray, rs: np.ndarray | None = None) -> None:
        if self._pending is None:
            raise FemupdateError("TMCMC: tell() without a pending ask()")
        x, chains, log_g_new, log_g_old = self._pending
        if rs is None:
            raise ConfigError("method 'tmcmc' needs residual vectors: run it with "
                              "residuals=True")
        if xs.shape != x.shape or not np.array_equal(np.asarray(xs), x):
            raise FemupdateError("TMCMC: tell() with other points than ask() gave")
        self._pending = None
        ll = self.error_model.loglike_rows(rs)
        failed = int(np.sum(~np.isfinite(ll)))
        self.evaluations += ll.size
        self.failures += failed
        self._stage_evaluations += ll.size
        self._stage_failures += failed
        if self.phase == "importance":
            self._tell_importance(x, ll, log_g_new)
            return
        if self.phase not in ("init", "mcmc"):
            return  # the point asked after the run ended
        if self.phase == "init":
            self.x = x
            self.ll = ll
            self.lp = self.prior.logpdf_unit(x)
            self.lq = self._log_q(x, self.lp)
            self._trace.append(stage=0.0, beta=0.0, acceptance=math.nan,
                               weights_ess=float(self.population),
                               log_evidence=0.0, evaluations=float(self.evaluations))
            self._next_stage()
            return
        lp = self.prior.logpdf_unit(x)
        lq = self._log_q(x, lp)
        beta = self.beta
        new = (1 - beta) * lq + beta * (lp + ll)
        old = (1 - beta) * self.lq[chains] + beta * (self.lp[chains] + self.ll[chains])
        log_alpha = new - old + log_g_old - log_g_new
        u = self.rng.random(chains.size)
        accept = np.isfinite(ll) & (np.log(u) < log_alpha)
        idx = chains[accept]
        self.x[idx] = x[accept]
        self.ll[idx] = ll[accept]
        self.lp[idx] = lp[accept]
        self.lq[idx] = lq[accept]
        self._end_step(int(accept.sum()))

    def _end_step(self, accepted: int) -> None:
        """Count a step's moves; after the stage's last step, the next stage (or the end)."""
        self._stage_accepted += accepted
        self._stage_proposed += self.population
        self._stage_step += 1
        final = self.beta >= 1.0
        acceptance = self._stage_accepted / self._stage_proposed
        self._trace.append(stage=float(len(self.stages)), beta=self.beta,
                           acceptance=acceptance,
                           weights_ess=self.stages[-1]["weights_ess"],
                           log_evidence=self.log_evidence, evaluations=float(self.evaluations))
        if self._stage_step < (self.final_steps if final else self.steps):
            return
        stage = self.stages[-1]
        stage.update(acceptance=acceptance, evaluations=self._stage_evaluations,
                     failures=self._stage_failures)
        # toward the target acceptance, within a factor 2 a stage
        self.scale *= math.exp(min(max(2.0 * (acceptance - TARGET_ACCEPTANCE), -0.7), 0.7))
        if final:
            self.phase = "done"
            self.stopped = {"beta_reached": 1.0}
            return
        self._next_stage()

    def _next_stage(self) -> None:
        """Choose β, weigh, resample and set up the moves of the next stage."""
        g = (self.lp + self.ll) - self.lq  # log(π/q)
        finite = np.isfinite(g)
        if not np.any(finite):
            self.phase = "failed"
            self.stopped = {"no_finite_likelihood": float(self.beta)}
            return
        if len(self.stages) >= self.max_stages:
            self.phase = "failed"
            self.stopped = {"max_stages": float(self.beta)}
            return
        beta = next_beta(g, self.beta, self.cov_target)
        # importance sampling takes the population at β ≥ importance_from to β = 1 at once
        importance = self.final == "importance" and not self._fell_back
        jump = importance and self.importance_from <= beta < 1.0
        a = np.where(finite, (beta - self.beta) * g, -np.inf)
        log_mean = float(logsumexp(a) - math.log(a.size))
        self.log_evidence += log_mean
        w = np.exp(a - logsumexp(a))
        mean, cov = weighted_moments(self.x, w)
        idx = systematic_resample(w, self.rng)
        if beta >= 1.0 or jump:
            self._final_start = self.x[idx].copy()
            self._final_copies = np.bincount(idx, minlength=idx.size).astype(float)
        self._eve = self._eve[idx]
        self.x, self.ll, self.lp, self.lq = (self.x[idx].copy(), self.ll[idx].copy(),
                                             self.lp[idx].copy(), self.lq[idx].copy())
        self.beta = 1.0 if jump else beta
        if self.beta >= 1.0 and importance:
            self._move = defensive_mixture(self.x, self.components, self.final_inflate,
                                           self.rng, safe_cholesky)
        else:
            self._move = self._moves(mean, cov)
        self.stages.append({"beta": self.beta, "weights_ess": ess_of_weights(w),
                            "scale": self.scale, "log_evidence": self.log_evidence,
                            "acceptance": math.nan, "evaluations": 0, "failures": 0})
        self.phase = "importance" if self.beta >= 1.0 and importance else "mcmc"
        self._jumped_from = beta if jump else None
        self._stage_step = 0
        self._stage_accepted = self._stage_proposed = 0
        self._stage_evaluations = self._stage_failures = 0

    def _moves(self, mean: np.ndarray, cov: np.ndarray) -> GaussianMixture | tuple[
            np.ndarray, np.ndarray]:
        """The proposal of the moves from the population ``self.x`` (its weighted ``mean``
        and ``cov`` for the single Gaussian and the random walk)."""
        if self.proposal == "rw":
            return mean, safe_cholesky(self.scale ** 2 * cov)
        if self.proposal == "mixture":
            return fit_mixture(self.x, self.components, self.inflate, self.rng, safe_cholesky)
        return mean, safe_cholesky(self.inflate ** 2 * cov)

    # -- importance sampling at β = 1 (femupdate.inference.importance) -------------------------

    def _ask_importance(self) -> np.ndarray:
        """A population drawn from the defensive mixture; draws outside the cube weigh 0
        unevaluated (counted as draws)."""
        mixture = self._move
        while True:
            proposals = mixture.sample(self.rng, self.population)
            self._drawn += self.population
            x = proposals[np.all((proposals >= 0) & (proposals <= 1), axis=1)]
            if x.shape[0]:
                self._pending = (x, np.arange(x.shape[0]), mixture.logpdf(x), np.zeros(0))
                return x

    def _tell_importance(self, x: np.ndarray, ll: np.ndarray, log_q: np.ndarray) -> None:
        """Weigh a batch by π/q; once every parameter has ``ess`` effective samples (or after
        :data:`MAX_BATCHES`), resample the weighted draws into as many equally weighted ones."""
        lp = self.prior.logpdf_unit(x)
        log_w = np.where(np.isfinite(ll), lp + ll - log_q, -np.inf)
        if self._adapt_left > 0:  # the population was too narrow: refit to the weighted draws
            self._adapt_left -= 1
            self._pool_x = np.vstack([self._pool_x, x])
            self._pool_log_w = np.append(self._pool_log_w, log_w)
            self._trace.append(stage=float(len(self.stages)), beta=1.0, acceptance=math.nan,
                               weights_ess=kish_ess(self._pool_log_w),
                               log_evidence=self.log_evidence,
                               evaluations=float(self.evaluations))
            idx = systematic_resample(normalised_weights(self._pool_log_w), self.rng)
            self._move = defensive_mixture(self._pool_x[idx], self.components,
                                           self.final_inflate, self.rng, safe_cholesky)
            self._drawn = 0
            return
        self._draws = np.vstack([self._draws, x])
        self._log_w = np.append(self._log_w, log_w)
        self._draws_ll = np.append(self._draws_ll, ll)
        ess = importance_ess(self._draws, self._log_w)
        batches = self._drawn // self.population
        self._trace.append(stage=float(len(self.stages)), beta=1.0, acceptance=math.nan,
                           weights_ess=float(np.min(ess)), log_evidence=self.log_evidence,
                           evaluations=float(self.evaluations))
        if np.min(ess) < self.ess_target and batches < MAX_BATCHES:
            if self.fallback > 0 and importance_degenerate(ess, self._log_w, self._drawn,
                                                           self.fallback):
                self._fall_back()
            return
        count = self._draws.shape[0]
        idx = systematic_resample(normalised_weights(self._log_w), self.rng)
        self.x, self.ll = self._draws[idx].copy(), self._draws_ll[idx].copy()
        self.lp = self.prior.logpdf_unit(self.x)
        self.lq = self._log_q(self.x, self.lp)
        self._ess = resampled_ess(ess, count)
        if self._jumped_from is not None:  # log Z by the draws themselves: E_q[p L / q]
            self.log_evidence = float(logsumexp(self._log_w) - math.log(self._drawn))
        self.stages[-1].update(acceptance=math.nan, evaluations=self._stage_evaluations,
                               failures=self._stage_failures, draws=float(self._drawn),
                               efficiency=kish_ess(self._log_w) / self._drawn)
        self.phase = "done"
        self.stopped = {"beta_reached": 1.0}

    def _fall_back(self) -> None:
        """Leave importance sampling for moves: the population (resampled at the β the
        tempering reached, not yet moved) takes up that stage's moves, and the tempering goes
        on to β = 1 by moves. log Z is the tempering's sum to that β, which the later stages
        continue; the draws are dropped, their evaluations stay in the stage's count."""
        stage = self.stages[-1]
        stage.update(fallback=1.0, draws=float(self._drawn),
                     efficiency=kish_ess(self._log_w) / max(self._drawn, 1))
        if self._jumped_from is not None:
            self.beta = self._jumped_from
            stage["beta"] = self.beta
        self._fell_back = True
        self._jumped_from = None
        self._draws, self._log_w, self._draws_ll = (np.empty((0, self.n)), np.empty(0),
                                                    np.empty(0))
        self._pool_x, self._pool_log_w = np.empty((0, self.n)), np.empty(0)
        self._move = self._moves(*weighted_moments(self.x, np.full(self.population,
                                                                    1.0 / self.population)))
        self.phase = "mcmc"
        self._stage_step = 0
        self._stage_accepted = self._stage_proposed = 0

    # -- the protocol's rest --------------------------------------------------------------------

    def stop(self) -> dict[str, object]:
        """``beta_reached`` once the last stage's moves are done; ``no_finite_likelihood``
        or ``max_stages`` when it cannot go on."""
        return dict(self.stopped)

    def trace_since(self, step: int) -> dict[str, np.ndarray]:
        return self._trace.since(step)

    def close(self) -> None:
        """Nothing to release."""

    def posterior(self) -> TMCMCPosterior:
        """The samples if β reached 1, else what the run has (``reached`` False, no
        samples): never a posterior it did not reach."""
        stages = [dict(s) for s in self.stages]
        if self.phase != "done":
            return TMCMCPosterior(False, self.beta, None, None, math.nan, stages,
                                  evaluations=self.evaluations, failures=self.failures)
        if self._ess is not None:  # importance sampling at β = 1
            ess = self._ess
        else:
            ess = np.minimum(ess_of_population(self._final_start, self.x, self._final_copies),
                             ess_by_ancestry(self.x, self._eve))
        return TMCMCPosterior(True, 1.0, self.x.copy(), self.ll.copy(), self.log_evidence,
                              stages, ess=float(np.min(ess)), evaluations=self.evaluations,
                              failures=self.failures, ess_params=ess)


def make_tmcmc(n: int, rng: np.random.Generator, **options: Any) -> TMCMC:
    """The factory of the registry: ``error_model`` and ``prior`` are required; the other
    options are :class:`TMCMC`'s."""
    check_option_names("tmcmc", options, ("error_model", "prior", *OPTIONS))
    for required in ("error_model", "prior"):
        if required not in options:
            raise ConfigError(f"method 'tmcmc' needs the option {required!r}")
    return TMCMC(n, rng, **options)


def run_tmcmc(residuals: Any, prior: Prior, error_model: ErrorModel, *, seed: Any = None,
              max_evals: int = 1_000_000, map: Any = None,
              **options: Any) -> tuple[TMCMCPosterior, Any]:
    """Run TMCMC to the end on ``minimize``'s loop (:class:`MinimizeState`), in this process.

    Parameters
    ----------
    residuals : callable
        r(x) at a search-space point x; as the ``residuals`` method of an object with
        ``residuals_batch`` (an UpdateProblem) a whole population goes in one call.
    prior, error_model
    seed : None, int, SeedSequence or Generator
        The run's only randomness.
    max_evals : int
        The budget; a run that ends before β = 1 returns ``reached`` False.
    map : map-like, optional
        ``map(fun, rows)``: workers or an executor's map (default: in this process).
    **options
        :class:`TMCMC`'s.

    Returns
    -------
    (TMCMCPosterior, MinimizeState)
    """
    import builtins

    from femupdate.optimize.minimize import MinimizeState
    from femupdate.optimize.termination import check_max_evals

    rng = np.random.default_rng(seed)
    sampler = make_tmcmc(prior.dim, rng, error_model=error_model, prior=prior, **options)
    state = MinimizeState(sampler, "tmcmc", prior.search_low.copy(), prior.search_high.copy(),
                          check_max_evals(max_evals), None, residuals=True)
    while not state.done:
        state.step(residuals, builtins.map if map is None else map)
    return sampler.posterior(), state

"""Surrogate-aided posterior for expensive models: TMCMC on a Gaussian-process surrogate.

Every error model of :mod:`femupdate.inference.likelihood` is a function of the (whitened)
residual sums S_c = ‖r_c‖² of its blocks (one per trial × channel),
log L(x) = Σ_c ℓ_c(S_c(x)) (``ErrorModel.loglike_of_squares``; for the default ``"neff"``,
ℓ_c(S) = −(N_c/2)·S/S_c* + const, S_c* the best fit's), so a surrogate of the C functions
y_c(x) = log S_c(x) is a surrogate of the likelihood. Each y_c is modelled on the unit cube
by a quadratic trend (least squares) plus a Gaussian process (scikit-learn's
``GaussianProcessRegressor``, Matérn 5/2 with one length per parameter) on what the trend
leaves; design points far below the best in log L are fitted loosely (they
only need to say "unlikely here"), those near it exactly. The surrogate's own uncertainty
enters the likelihood through the expected residual energy: with y_c ~ N(μ_c, σ_c²),
E[S_c] = exp(μ_c + σ_c²/2) takes the place of S_c, so where the surrogate is unsure the
likelihood is lower, never spuriously higher.

The design points (true model runs) are chosen where the posterior mass is, in the spirit of
quoFEM's GP-aided TMCMC (Taflanidis et al. 2025): an initial Latin hypercube over the bounds,
then batches of points drawn from the surrogate's posterior (spread apart: exploit) and
points of the largest log-likelihood variance near it (explore). Before a batch is added, the
surrogate's log-likelihood at its posterior points is compared with the true one: the batch's
error is the 90th percentile of |e_i − median(e)| (a constant offset in log L does not change
the posterior). Once it is within the tolerance, the surrogate is refitted with every point,
TMCMC (:mod:`femupdate.inference.tmcmc`, unchanged) samples it, and random draws of its
samples are run on the true model as the final check (:func:`importance_check`): the true
posterior is the surrogate's reweighted by exp(true − surrogate log L), so what matters is
how much those weights spread (their effective share) and how far they move each mean (in
posterior sds), not the largest error at a point of little posterior mass. A check that fails
adds its runs to the design and the batches go on while the budget lasts. A surrogate that
does not reach its accuracy or check within its budget says so and what it reached; a design
point at which the model fails is reported with the model's own message, not silently
dropped.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from femupdate._optional import require
from femupdate._parallel import single_blas_thread
from femupdate.errors import ConfigError, ModelError
from femupdate.inference.likelihood import ErrorModel
from femupdate.inference.priors import Prior
from femupdate.inference.surrogate_check import Check, centred_error, importance_check
from femupdate.inference.tmcmc import TMCMC, TMCMCPosterior

#: True model runs at most, all included (design, batches, error model, final check).
MAX_RUNS = 300
#: Largest accepted error of the surrogate's log-likelihood over the posterior, in nats (the
#: 90th percentile of the centred error at a batch's posterior points).
TOLERANCE = 1.0
#: Posterior samples run on the true model in the final check.
CHECK_RUNS = 16
#: TMCMC's population on the surrogate while design points are chosen (the batch needs
#: only the bulk of the posterior; the final samples take :data:`POPULATION`).
DESIGN_POPULATION = 400
#: TMCMC's population on the surrogate (evaluations there are cheap).
POPULATION = 1000
#: Design points within this log-likelihood deficit of the best (per channel, nats) are
#: interpolated; those farther below are fitted with an error of LOOSENESS × their excess
#: (they only need to say "unlikely here"), and weigh exponentially less in the quadratic
#: trend.
NEAR_NATS, LOOSENESS = 20.0, 0.2
#: A batch: this share of it from the surrogate's posterior, the rest where it is unsure.
EXPLOIT_SHARE = 0.75

#: ``evaluate(X)`` of search-space rows → residual rows (NaN rows where the model failed)
#: and, per row, why it failed (None where it did not).
Evaluate = Callable[[np.ndarray], tuple[np.ndarray, list[str | None]]]
#: ``error_model_at(x, r)`` → the error model fixed at search point x with residuals r, and
#: the true model runs that took (a Jacobian's).
ErrorModelAt = Callable[[np.ndarray, np.ndarray], tuple[ErrorModel, int]]


def log_sums(model: ErrorModel, rows: np.ndarray) -> np.ndarray:
    """log S_c of each residual row (k, m): shape (k, C)."""
    with np.errstate(divide="ignore"):
        return np.log(model.sums_of_squares(np.atleast_2d(rows)))


def loglike_of_sums(model: ErrorModel, log_s: np.ndarray) -> np.ndarray:
    """log L of rows of log S_c (k, C), as ``model.loglike_rows`` of their residuals."""
    return model.loglike_of_squares(np.exp(log_s))


def quadratic_features(unit: np.ndarray) -> np.ndarray:
    """1, u_i and u_i·u_j (i ≤ j) of rows of the unit cube, centred at ½: (k, 1 + n + n(n+1)/2)."""
    u = np.atleast_2d(unit) - 0.5
    n = u.shape[1]
    cross = [u[:, i] * u[:, j] for i in range(n) for j in range(i, n)]
    return np.column_stack([np.ones(u.shape[0]), u, *cross])


def convex_trend(features: np.ndarray, y: np.ndarray, n: int) -> np.ndarray:
    """Least-squares coefficients of :func:`quadratic_features` (or of its constant and
    linear columns alone) with the quadratic form made positive semi-definite (its negative
    eigenvalues set to zero, the constant and linear terms fitted again): log S may not
    fall away from the data, where a saddle of the trend would put spurious likelihood."""
    coef = np.linalg.lstsq(features, y, rcond=None)[0]
    if features.shape[1] == n + 1:
        return coef
    pairs = [(i, j) for i in range(n) for j in range(i, n)]
    q = np.zeros((n, n))
    for (i, j), value in zip(pairs, coef[n + 1:], strict=True):
        q[i, j] = q[j, i] = value if i == j else 0.5 * value
    values, vectors = np.linalg.eigh(q)
    if values.min() >= 0.0:
        return coef
    q = (vectors * np.maximum(values, 0.0)) @ vectors.T
    quad = np.array([q[i, j] if i == j else 2.0 * q[i, j] for i, j in pairs])
    low = np.linalg.lstsq(features[:, :n + 1], y - features[:, n + 1:] @ quad, rcond=None)[0]
    return np.concatenate([low, quad])


class ChannelSurrogate:
    """The surrogate of y_c(u) = log S_c on the unit cube, one model per channel c: a
    quadratic trend by least squares and a Gaussian process on its remainder.

    Parameters
    ----------
    unit : ndarray (k, n)
        Design points in the unit cube.
    targets : ndarray (k, C)
        log S_c there (finite).
    rng : numpy.random.Generator
        Seeds the optimiser restarts of the kernel's hyperparameters.
    counts : ndarray (C,) or None
        The error model's N_c: with them, points more than :data:`NEAR_NATS` below the best
        in log L are fitted loosely and weigh less in the trend (None: all alike).
    previous : ChannelSurrogate or None
        The surrogate of the previous batch: its fitted kernels start the optimiser, once,
        without random restarts (a batch moves the hyperparameters little; a cold start with
        a restart per channel and batch was most of the surrogate's own time).
    """

    def __init__(self, unit: np.ndarray, targets: np.ndarray, rng: np.random.Generator,
                 counts: np.ndarray | None = None,
                 previous: ChannelSurrogate | None = None) -> None:
        gp_module = require("sklearn.gaussian_process", "posterior")
        kernels = require("sklearn.gaussian_process.kernels", "posterior")
        unit, targets = np.atleast_2d(unit), np.atleast_2d(targets)
        n, channels = unit.shape[1], targets.shape[1]
        features = quadratic_features(unit)
        if features.shape[1] > unit.shape[0] // 2:  # too few points for the quadratic terms
            features = features[:, :n + 1]
        self._terms = features.shape[1]
        self.coef = np.empty((self._terms, channels))
        self.models = []
        for c in range(channels):
            y = targets[:, c]
            # each point's share of the log-likelihood deficit from the best (nats): points
            # far below the posterior are fitted loosely, those near it exactly
            excess = (np.zeros_like(y) if counts is None
                      else 0.5 * counts[c] * (y - y.min()))
            # the trend is a response surface of the points near the best: their deficit
            # scale widened until twice as many points as terms weigh in
            reach = max(NEAR_NATS, float(np.sort(excess)[min(2 * self._terms, y.size) - 1]))
            weight = np.exp(-0.5 * excess / reach)
            self.coef[:, c] = convex_trend(features * weight[:, None], y * weight, n)
            remainder = y - features @ self.coef[:, c]
            loose = (np.zeros_like(y) if counts is None else
                     LOOSENESS * np.maximum(excess - NEAR_NATS, 0.0) / (0.5 * counts[c]))
            alpha = (loose / max(float(remainder.std()), 1e-300)) ** 2 + 1e-10
            warm = previous is not None and len(previous.models) == channels
            kernel = (previous.models[c].kernel_ if warm else
                      kernels.ConstantKernel(1.0, (1e-6, 1e6))
                      * kernels.Matern(np.full(n, 0.3), (1e-3, 1e2), nu=2.5)
                      + kernels.WhiteKernel(1e-8, (1e-12, 1e-3)))
            gp = gp_module.GaussianProcessRegressor(
                kernel, alpha=alpha, normalize_y=True, n_restarts_optimizer=0 if warm else 1,
                random_state=int(rng.integers(2**31 - 1)))
            with warnings.catch_warnings():  # a kernel bound reached is no error here
                warnings.simplefilter("ignore", category=Warning)
                self.models.append(gp.fit(unit, remainder))

    def predict(self, unit: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mean and variance of log S_c at rows of the unit cube: two (k, C) arrays."""
        unit = np.atleast_2d(unit)
        trend = quadratic_features(unit)[:, :self._terms] @ self.coef
        mean, var = np.empty_like(trend), np.empty_like(trend)
        for c, gp in enumerate(self.models):
            m, s = gp.predict(unit, return_std=True)
            mean[:, c], var[:, c] = trend[:, c] + m, s ** 2
        return mean, var


def surrogate_loglike(model: ErrorModel, mean: np.ndarray, var: np.ndarray) -> np.ndarray:
    """log L with the expected residual energies E[S_c] = exp(μ_c + σ_c²/2) (module
    docstring): the surrogate's variance lowers the likelihood where it is unsure."""
    return loglike_of_sums(model, mean + 0.5 * var)


def loglike_variance(model: ErrorModel, mean: np.ndarray, var: np.ndarray) -> np.ndarray:
    """The variance of log L from the surrogate's (channels taken independent, log L linear
    in log S_c about the surrogate's mean)."""
    return (model.log_squares_slope(np.exp(mean)) ** 2 * var).sum(axis=1)


def pseudo_model(model: ErrorModel) -> ErrorModel:
    """An error model of C one-value blocks with ``model``'s likelihood: its log L of the
    rows √E[S_c] is ``surrogate_loglike`` (so TMCMC samples the surrogate unchanged)."""
    return model.of_sums()


def spread_points(candidates: np.ndarray, k: int, scale: np.ndarray,
                  chosen: np.ndarray | None = None, score: np.ndarray | None = None
                  ) -> np.ndarray:
    """Indices of ``k`` rows of ``candidates`` chosen greedily: each the farthest (in units of
    ``scale`` per column) from those already chosen (and from ``chosen``), weighted by
    ``score`` when given; the first the highest score or the first row."""
    x = candidates / scale
    taken = [] if chosen is None else list(np.atleast_2d(chosen) / scale)
    picks: list[int] = []
    weight = np.ones(len(x)) if score is None else np.asarray(score, dtype=float)
    dist = np.full(len(x), np.inf)
    for p in taken:
        dist = np.minimum(dist, np.linalg.norm(x - p, axis=1))
    for _ in range(min(k, len(x))):
        value = weight * np.where(np.isfinite(dist), dist, 1.0)
        value[picks] = -np.inf
        i = int(np.argmax(value))
        picks.append(i)
        dist = np.minimum(dist, np.linalg.norm(x - x[i], axis=1))
    return np.array(picks, dtype=int)


@dataclass
class SurrogateResult:
    """What the surrogate-aided posterior found.

    Attributes
    ----------
    reached : bool
        The surrogate reached the tolerance and passed the final check.
    samples_unit, samples : ndarray (N, n)
        Equally weighted posterior samples of the surrogate (unit cube; physical units).
    model_runs : int
        True model runs, all included (failed ones too).
    accuracy : float
        The last batch's error of log L (nats, :func:`centred_error`).
    check_error : float
        The same error at the final check's posterior samples.
    check : Check
        The final check (the importance weights of true against surrogate likelihood).
    failures : list of str
        Each design point at which the model failed: its values and the model's message.
    sampler : TMCMCPosterior
        TMCMC's run on the final surrogate (its stages and effective samples).
    design_unit, design_rows : ndarray
        Every true run: its unit-cube row and residual row (NaN where it failed).
    """

    names: list[str]
    reached: bool
    samples_unit: np.ndarray
    samples: np.ndarray
    model_runs: int
    accuracy: float
    check_error: float
    tolerance: float
    iterations: int
    error_model: ErrorModel
    log_evidence: float
    wall_s: float
    message: str
    check: Check
    failures: list[str] = field(default_factory=list)
    history: list[dict[str, float]] = field(default_factory=list)
    sampler: TMCMCPosterior | None = None
    design_unit: np.ndarray | None = None
    design_rows: np.ndarray | None = None

    def means(self) -> np.ndarray:
        return self.samples.mean(axis=0)

    def sds(self) -> np.ndarray:
        return self.samples.std(axis=0, ddof=1)


@dataclass
class _Design:
    """The true runs so far: unit-cube rows, residual rows (NaN where failed), failures."""

    unit: list[np.ndarray] = field(default_factory=list)
    rows: list[np.ndarray] = field(default_factory=list)
    failures: list[str] = field(default_factory=list)
    runs: int = 0

    def ok(self) -> np.ndarray:
        return np.array([bool(np.all(np.isfinite(r))) for r in self.rows])


def _run(design: _Design, unit: np.ndarray, evaluate: Evaluate, prior: Prior) -> np.ndarray:
    """Evaluate unit-cube rows on the true model, recording them and their failures."""
    rows, reasons = evaluate(prior.to_search(unit))
    rows = np.atleast_2d(np.asarray(rows, dtype=float))
    design.runs += unit.shape[0]
    for u, r, why in zip(unit, rows, reasons, strict=True):
        design.unit.append(u)
        design.rows.append(r)
        if why is not None or not np.all(np.isfinite(r)):
            values = ", ".join(f"{n} = {v:.6g}" for n, v in
                               zip(prior.names, prior.to_physical(u[None, :])[0], strict=True))
            design.failures.append(f"{values}: {why or 'residuals not finite'}")
    return rows


def _check_settings(max_runs: int, tolerance: float, initial: int, batch: int, check: int,
                    n: int) -> None:
    for name, value, low in (("max_runs", max_runs, 1), ("initial", initial, n + 2),
                             ("batch", batch, 2), ("check", check, 2)):
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            raise ConfigError(f"surrogate: {name}: got {value!r} (allowed: an integer ≥ {low})")
    if not (isinstance(tolerance, (int, float)) and math.isfinite(tolerance) and tolerance > 0):
        raise ConfigError(f"surrogate: tolerance: got {tolerance!r} (allowed: a positive "
                          "number of nats)")
    if initial + check > max_runs:
        raise ConfigError(f"surrogate: max_runs: got {max_runs} for an initial design of "
                          f"{initial} and a check of {check} runs (allowed: at least "
                          f"{initial + check})")


def _sample(surrogate: ChannelSurrogate, prior: Prior, model: ErrorModel,
            rng: np.random.Generator, population: int) -> TMCMCPosterior:
    """TMCMC on the surrogate, driven by its ask/tell (a population is one prediction)."""
    sampler = TMCMC(prior.dim, rng, error_model=pseudo_model(model), prior=prior,
                    population=population)
    while not sampler.stop():
        unit = sampler.ask()
        mean, var = surrogate.predict(unit)
        rows = np.exp(0.5 * (mean + 0.5 * var))
        sampler.tell(unit, np.einsum("ij,ij->i", rows, rows), rows)
    post = sampler.posterior()
    if not post.reached:
        raise ModelError(f"surrogate: TMCMC on the surrogate stopped at β = {post.beta:.3g}")
    return post


def surrogate_posterior(evaluate: Evaluate, prior: Prior, error_model_at: ErrorModelAt, *,
                        rng: np.random.Generator, max_runs: int = MAX_RUNS,
                        tolerance: float = TOLERANCE, initial: int | None = None,
                        batch: int | None = None, check: int = CHECK_RUNS,
                        population: int = POPULATION,
                        progress: Callable[[str], None] | None = None) -> SurrogateResult:
    """The posterior of ``prior`` × L by TMCMC on an adaptive surrogate (module docstring).

    Parameters
    ----------
    evaluate : callable
        ``evaluate(X)``: the true residual rows at search-space rows X and why each failed
        (:data:`Evaluate`); the caller spreads a batch over its workers.
    prior : Prior
    error_model_at : callable
        The error model fixed at the best true run (:data:`ErrorModelAt`), taken again
        whenever a better run is found.
    rng : numpy.random.Generator
        The only randomness (design, GP restarts, TMCMC).
    max_runs : int
        True model runs at most, all included.
    tolerance : float
        Accepted error of log L over the posterior, in nats (:func:`centred_error`).
    initial, batch : int or None
        The Latin hypercube's size (default 10 per parameter) and a batch's (default
        max(8, 2n)).
    check : int
        Posterior samples run on the true model at the end.
    population : int
        TMCMC's population on the surrogate.
    progress : callable or None
        Called with one line per batch.

    Returns
    -------
    SurrogateResult
    """
    with single_blas_thread():  # small dense algebra: many BLAS threads only slow it down
        return _surrogate_posterior(evaluate, prior, error_model_at, rng, max_runs, tolerance,
                                    initial, batch, check, population, progress)


def _surrogate_posterior(evaluate: Evaluate, prior: Prior, error_model_at: ErrorModelAt,
                         rng: np.random.Generator, max_runs: int, tolerance: float,
                         initial: int | None, batch: int | None, check: int, population: int,
                         progress: Callable[[str], None] | None) -> SurrogateResult:
    start = time.perf_counter()
    qmc = require("scipy.stats.qmc", "posterior")
    n = prior.dim
    initial = max(10 * n, 20) if initial is None else initial
    batch = max(8, 2 * n) if batch is None else batch
    _check_settings(max_runs, tolerance, initial, batch, check, n)
    design = _Design()
    _run(design, qmc.LatinHypercube(d=n, rng=rng).random(initial), evaluate, prior)
    if not design.ok().any():
        raise ModelError(f"surrogate: the model failed at all {initial} initial design points "
                         f"(first: {design.failures[0]})")
    best_key: float | None = None
    model: ErrorModel | None = None
    previous: ChannelSurrogate | None = None
    history: list[dict[str, float]] = []
    accuracy, converged, iterations = math.inf, False, 0
    checks: list[Check] = []

    def refit() -> tuple[ChannelSurrogate, ErrorModel]:
        nonlocal best_key, model, previous
        ok = design.ok()
        unit, rows = np.array(design.unit)[ok], np.array(design.rows)[ok]
        phi = np.einsum("ij,ij->i", rows, rows)
        i = int(np.argmin(phi))
        if best_key is None or phi[i] < best_key:  # the error model at the best true run
            best_key = float(phi[i])
            model, extra = error_model_at(prior.to_search(unit[i]), rows[i])
            design.runs += extra
        targets = log_sums(model, rows)
        keep = np.all(np.isfinite(targets), axis=1)
        previous = ChannelSurrogate(unit[keep], targets[keep], rng, model.counts, previous)
        return previous, model

    while True:
        surrogate, model = refit()
        room = design.runs + batch + check <= max_runs  # for a batch and the check after it
        if converged or not room:
            # the posterior of the surrogate, then its check on the true model at random
            # draws of it (representative of its mass, as the reweighting needs)
            post = _sample(surrogate, prior, model, rng, population)
            samples = post.samples
            picks = samples[rng.choice(len(samples), size=check, replace=False)]
            mean, var = surrogate.predict(picks)
            predicted = surrogate_loglike(model, mean, var)
            true = model.loglike_rows(_run(design, picks, evaluate, prior))
            checks.append(importance_check(picks, predicted, true, samples.std(axis=0)))
            if progress is not None:
                progress(f"surrogate: {design.runs} model runs, final check: "
                         f"{checks[-1].words(prior.names)}")
            # a failed check: its runs join the design and the batches go on, budget allowing
            if checks[-1].passed or design.runs + batch + check > max_runs:
                break
            converged = False
            continue
        samples = _sample(surrogate, prior, model, rng,
                          min(population, DESIGN_POPULATION)).samples
        iterations += 1
        scale = np.maximum(samples.std(axis=0), 1e-6)
        # exploit: spread over the bulk of the posterior (among a few random samples, so
        # not only its extreme tails), away from the points already run
        k = max(2, round(EXPLOIT_SHARE * batch))
        bulk = samples[rng.choice(len(samples), size=min(len(samples), 8 * k), replace=False)]
        exploit = bulk[spread_points(bulk, k, scale, chosen=np.array(design.unit))]
        # explore: where log L is least sure, among draws of the posterior widened 2×
        wide = samples.mean(axis=0) + 2.0 * (samples[rng.integers(len(samples), size=4000)]
                                              - samples.mean(axis=0))
        wide = wide[np.all((wide >= 0) & (wide <= 1), axis=1)]
        wide_mean, wide_var = surrogate.predict(wide)
        explore = wide[spread_points(wide, batch - len(exploit), scale,
                                     chosen=np.vstack([design.unit, exploit]),
                                     score=loglike_variance(model, wide_mean, wide_var))]
        mean, var = surrogate.predict(exploit)
        predicted = surrogate_loglike(model, mean, var)
        rows = _run(design, np.vstack([exploit, explore]), evaluate, prior)
        true = model.loglike_rows(rows[:len(exploit)])
        accuracy = centred_error(predicted, true)
        history.append({"runs": float(design.runs), "error": accuracy})
        if progress is not None:
            progress(f"surrogate: {design.runs} model runs, log-likelihood error "
                     f"{accuracy:.3g} nats (tolerance {tolerance:g})")
        converged = accuracy <= tolerance
    final = checks[-1]
    reached = converged and final.passed
    failed = (f"; the model failed at {len(design.failures)} of {design.runs} design points "
              f"(first: {design.failures[0]})" if design.failures else "")
    earlier = (f"; {len(checks) - 1} earlier check(s) failed and the design went on"
               if len(checks) > 1 else "")
    if reached:
        message = (f"surrogate posterior in {design.runs} model runs: log-likelihood error "
                   f"{accuracy:.3g} nats at the last batch (tolerance {tolerance:g}); "
                   f"{final.words(prior.names)}{earlier}{failed}")
    elif not converged:
        message = (f"the surrogate did not reach its accuracy: log-likelihood error "
                   f"{accuracy:.3g} nats against a tolerance of {tolerance:g} after "
                   f"{design.runs} model runs (max_runs {max_runs}; raise it, or a looser "
                   f"tolerance); {final.words(prior.names)}{failed}")
    else:
        message = (f"the surrogate failed its final check after {design.runs} model runs "
                   f"(max_runs {max_runs}; raise it): {final.words(prior.names)}; the "
                   f"last batch's log-likelihood error {accuracy:.3g} nats{earlier}{failed}")
    return SurrogateResult(
        names=list(prior.names), reached=reached, samples_unit=samples,
        samples=prior.to_physical(samples), model_runs=design.runs, accuracy=accuracy,
        check_error=final.error, tolerance=float(tolerance), iterations=iterations,
        error_model=model, log_evidence=float(post.log_evidence),
        wall_s=time.perf_counter() - start, message=message, check=final,
        failures=list(design.failures), history=history, sampler=post,
        design_unit=np.array(design.unit), design_rows=np.array(design.rows))

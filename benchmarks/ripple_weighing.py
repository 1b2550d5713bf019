"""Weighing the ripples of the viscous bridge's kp1 valley: do intervals that weigh every
ripple, not the one the search ended in, hold the truth where users stand?

    python benchmarks/ripple_weighing.py --replicates 50 [--prior] [--out rows.jsonl]
    python benchmarks/ripple_weighing.py --quick     # CI: one record, a short profile

Each replicate is a record of benchmarks/posterior.py's product calibration (the same truth,
noise and search seed: ``--only calibration --product --fit-runs 0``, at the example's truth
or with ``--prior`` at a truth drawn from the prior), fitted by the example's own
``[search]`` (``f_target`` removed), as ``femupdate run`` ends. Then:

1. **The truth's ripple.** A local least-squares fit started at the truth stays in the
   truth's ripple of the valley; its φ beside the search's says whether any likelihood of φ
   could prefer the truth's ripple to the search's.
2. **A profile along the rippled parameter** (the one whose 1 % secant widens its interval
   most, :func:`posterior.secant_widening`, among those it determines): at steps of ``STEP``
   of its range the others are refitted (Gauss–Newton over the 1 % secant Jacobian,
   ``NEWTON_STEPS`` steps) until the log-posterior has fallen ``DROP`` below the profile's
   highest, each side. The profile weighs every ripple by its own height (a 1-D mixture, as
   INLA integrates a hyperparameter): the rippled parameter's interval from the weights, each other
   parameter's from a mixture of Gaussians at the refitted points, of the count's own
   conditional spread (``within = kind``) or of the sandwich's (``within = sandwich``, the
   noise's own scatter of the estimate within a ripple). Counts: ``neff`` (the product's)
   and ``spectral`` (benchmarks/error_models).
3. **A bootstrap of the search's hop between ripples**: data = the fit's prediction plus the
   fit's residual with its Fourier phases randomised (one set of phases for a trial's
   channels, so that their spectra and cross-spectra are kept: Prichard & Theiler 1994); the
   estimate is the profile point of least φ (‖d_k‖² − 2 d_kᵀe for d_k the prediction's
   change), plus the sandwich's conditional scatter within the ripple.

Prints each method's share of replicates whose 90 % interval holds the truth.
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
from error_models.mode import log_posterior
from error_models.sandwich import sandwich_covariance
from posterior import (
    SEED,
    local_fit,
    problem_error_model,
    searched_record,
    secant_widening,
)
from scipy.special import logsumexp
from scipy.stats import norm

from femupdate.inference import Prior, jacobian_unit
from femupdate.inference.jacobian import LOCAL_STEP, UNIT_STEP
from femupdate.inference.laplace import gaussian_precision
from femupdate.inference.likelihood import ErrorModel, residual_blocks
from femupdate.problem.update import UpdateProblem

#: The profile's step and farthest reach along the rippled parameter (unit range)
STEP, REACH = 4e-4, 0.25
#: Gauss–Newton steps of the other parameters at each profile point
NEWTON_STEPS = 3
#: The profile ends, each side, where the log-posterior is this far below its highest
DROP = 25.0
#: Bootstrap draws of the search's hop
DRAWS = 400
KINDS = ("neff", "spectral")
Z90 = 1.6449


def profile(problem: UpdateProblem, prior: Prior, model: ErrorModel, unit: np.ndarray,
            j: int, jac: np.ndarray, reach: float = REACH
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """(grid of parameter j, log-posterior, refitted points (k, n), evaluations) of the
    profile along parameter ``j`` from the fit ``unit``."""
    free = [k for k in range(unit.size) if k != j]

    def refit(u: np.ndarray) -> tuple[float, np.ndarray, int]:
        r = problem.residuals(prior.to_search(u))
        best, evals = (log_posterior(r, u, model, prior), u, r), 1
        for _ in range(NEWTON_STEPS):
            precision, gradient = gaussian_precision(jac, best[2], model)
            step = np.linalg.solve(precision[np.ix_(free, free)], gradient[free])
            trial = best[1].copy()
            trial[free] = np.clip(trial[free] + step, 0.0, 1.0)
            r_trial = problem.residuals(prior.to_search(trial))
            evals += 1
            value = log_posterior(r_trial, trial, model, prior)
            improved = value > best[0] + 1e-3
            if value > best[0]:
                best = (value, trial, r_trial)
            if not improved:
                break
        return best[0], best[1], evals

    points: dict[float, tuple[float, np.ndarray]] = {}
    evals = 0
    for sign in (1, -1):
        u, previous, k, top = unit.copy(), unit.copy(), 0 if sign == 1 else 1, -np.inf
        while 0.0 <= (t := unit[j] + sign * k * STEP) <= 1.0 and abs(t - unit[j]) <= reach:
            start = np.clip(u + (u - previous) if k > 1 else u.copy(), 0.0, 1.0)
            start[j] = t
            value, fitted, used = refit(start)
            evals += used
            points[round(t, 9)] = (value, fitted)
            top = max(top, value)
            if value < top - DROP:
                break
            previous, u, k = u, fitted, k + 1
    grid = np.array(sorted(points))
    return (grid, np.array([points[t][0] for t in grid]),
            np.array([points[t][1] for t in grid]), evals)


def mixture_interval(means: np.ndarray, sd: float, log_weights: np.ndarray,
                     level: float = 0.90) -> tuple[float, float]:
    """The central ``level`` interval of a mixture of Gaussians of one sd."""
    w = np.exp(log_weights - logsumexp(log_weights))
    grid = np.linspace(means.min() - 8 * sd, means.max() + 8 * sd, 4001)
    cdf = (w[None, :] * norm.cdf((grid[:, None] - means[None, :]) / sd)).sum(axis=1)
    return (float(np.interp((1 - level) / 2, cdf, grid)),
            float(np.interp((1 + level) / 2, cdf, grid)))


def given(cov: np.ndarray, j: int) -> np.ndarray:
    """The covariance (n, n) of the parameters given parameter j (row and column j zero)."""
    return cov - np.outer(cov[:, j], cov[j, :]) / cov[j, j]


def profile_intervals(grid: np.ndarray, log_post: np.ndarray, points: np.ndarray, j: int,
                      within_sd: np.ndarray) -> np.ndarray:
    """(2, n) 90 % intervals: parameter j's from the profile's weights, the others' from the
    mixture at the refitted points with ``within_sd``."""
    cdf = np.cumsum(np.exp(log_post - logsumexp(log_post)))
    out = np.empty((2, points.shape[1]))
    for k in range(points.shape[1]):
        out[:, k] = ((np.interp(0.05, cdf, grid), np.interp(0.95, cdf, grid)) if k == j
                     else mixture_interval(points[:, k], max(within_sd[k], 1e-12), log_post))
    return out


def phase_randomised(problem: UpdateProblem, r: np.ndarray, draws: int,
                     rng: np.random.Generator) -> np.ndarray:
    """(draws, m) copies of the residual r with random Fourier phases, one set per trial."""
    blocks = residual_blocks(problem)[0]
    out = np.zeros((draws, r.size))
    first = 0
    for trial in problem.fitted:
        n, channels = trial.objective.target.shape
        mine = blocks[first:first + channels]
        first += channels
        spectra = [np.fft.rfft(r[b]) for b in mine]
        for d in range(draws):
            phases = np.exp(2j * np.pi * rng.random(n // 2 + 1))
            phases[0] = 1.0
            if n % 2 == 0:
                phases[-1] = 1.0
            for b, spectrum in zip(mine, spectra, strict=True):
                out[d, b] = np.fft.irfft(spectrum * phases, n)
    return out


def hop_bootstrap(problem: UpdateProblem, prior: Prior, unit: np.ndarray, r: np.ndarray,
                  points: np.ndarray, j: int, sandwich: np.ndarray, draws: int,
                  rng: np.random.Generator) -> np.ndarray:
    """(2, n) 90 % percentile intervals of the bootstrap of the search's hop (module
    docstring, item 3)."""
    change = problem.residuals_batch(prior.to_search(points)) - r[None, :]
    noise = phase_randomised(problem, r, draws, rng)
    score = np.einsum("ij,ij->i", change, change)[None, :] - 2 * noise @ change.T
    pick = np.argmin(np.hstack([np.zeros((draws, 1)), score]), axis=1)
    estimates = np.vstack([unit[None, :], points])[pick]
    free = [k for k in range(unit.size) if k != j]
    within = given(sandwich, j)[np.ix_(free, free)]
    estimates[:, free] += rng.standard_normal((draws, len(free))) @ np.linalg.cholesky(
        within + 1e-30 * np.eye(len(free))).T
    return np.quantile(estimates, [0.05, 0.95], axis=0)


def replicate(i: int, root: Path, prior_truth: bool, reach: float, draws: int
              ) -> dict[str, Any]:
    """One record: the truth's ripple, the profiles' and the bootstrap's intervals."""
    problem, prior, unit, r, truth_values = searched_record(i, root, prior_truth)
    truth = prior.from_physical(truth_values)
    _, r_truth, _ = local_fit(problem, truth)
    jac = jacobian_unit(problem.residuals_batch, unit, prior, step=UNIT_STEP)
    jac_local = jacobian_unit(problem.residuals_batch, unit, prior, step=LOCAL_STEP)
    widening = secant_widening(problem, r, unit, jac, jac_local, prior)
    finite = np.isfinite(widening)  # not an undetermined parameter (inf or nan)
    j = int(np.argmax(np.where(finite, widening, -np.inf)))
    sandwich = sandwich_covariance(jac_local, r, residual_blocks(problem)[0])
    out: dict[str, Any] = {"replicate": i, "names": list(prior.names),
                           "rippled": prior.names[j],
                           "widening": widening[j], "hits": {}, "evals": {},
                           "phi_search_over_truths_ripple": float(r @ r) / float(
                               r_truth @ r_truth)}

    def hit(name: str, q: np.ndarray) -> None:
        out["hits"][name] = ((q[0] <= truth) & (truth <= q[1])).tolist()

    prior_curvature = np.diag(prior.curvature_unit(unit)[1])
    for kind in KINDS:
        model = problem_error_model(problem, r, kind, jac)
        grid, log_post, points, evals = profile(problem, prior, model, unit, j, jac, reach)
        out["evals"][kind] = evals
        own = np.linalg.inv(gaussian_precision(jac_local, r, model)[0] - prior_curvature)
        for within, cov in (("kind", own), ("sandwich", sandwich)):
            hit(f"{kind} profile, within = {within}", profile_intervals(
                grid, log_post, points, j, np.sqrt(np.maximum(np.diag(given(cov, j)), 0.0))))
        hit(f"{kind} Laplace (local)", unit + np.array([[-Z90], [Z90]])
            * np.sqrt(np.diag(own)))
        if kind == KINDS[0]:
            hit("bootstrap of the hop + sandwich", hop_bootstrap(
                problem, prior, unit, r, points, j, sandwich, draws,
                np.random.default_rng(np.random.SeedSequence(SEED, spawn_key=(i, 7)))))
    return out


def table(rows: list[dict[str, Any]], names: tuple[str, ...]) -> str:
    """Each method's share of replicates whose interval holds the truth, per parameter."""
    lines = [f"{'share holding the truth':42s}" + " ".join(f"{n:>5s}" for n in names)]
    for method in rows[0]["hits"]:
        shares = np.mean([row["hits"][method] for row in rows], axis=0)
        lines.append(f"{method:42s}" + " ".join(f"{s:5.2f}" for s in shares))
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--replicates", type=int, default=50)
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--prior", action="store_true",
                        help="truths drawn from the prior (default: the example's truth)")
    parser.add_argument("--out", type=Path, help="append each replicate's row (JSON lines)")
    parser.add_argument("--quick", action="store_true", help="one record, a short profile")
    args = parser.parse_args()
    reach, draws = (0.004, 40) if args.quick else (REACH, DRAWS)
    replicates = 1 if args.quick else args.replicates
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.first, args.first + replicates):
            row = replicate(i, Path(tmp), args.prior, reach, draws)
            rows.append(row)
            if args.out:
                with args.out.open("a") as f:
                    f.write(json.dumps(row) + "\n")
            print(f"replicate {i}: rippled {row['rippled']} (secant widening "
                  f"{row['widening']:.1f}); the search's φ / the truth's ripple's "
                  f"{row['phi_search_over_truths_ripple']:.5f}; profile evaluations "
                  f"{row['evals']}", flush=True)
    names = tuple(rows[0]["names"])
    ratios = np.array([row["phi_search_over_truths_ripple"] for row in rows])
    print(f"\nthe search's φ below its truth's ripple's in {int(np.sum(ratios < 1))} of "
          f"{len(rows)} records (ratio {ratios.min():.5f}–{ratios.max():.5f})")
    print(table(rows, names))


if __name__ == "__main__":
    main()

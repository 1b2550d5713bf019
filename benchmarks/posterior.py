"""The posterior's figures: analytic check, calibration, speed beside emcee, evidence spread.

    python benchmarks/posterior.py                  # everything (tens of minutes)
    python benchmarks/posterior.py --quick          # CI: analytic check, small bridge runs
    python benchmarks/posterior.py --only calibration --replicates 50
    python benchmarks/posterior.py --only calibration --replicates 20 --kinds neff \
        --tmcmc-kinds neff --hits tmcmc.jsonl
    python benchmarks/posterior.py --only calibration --product --fit-evals 2000 \
        --hits product.jsonl
    python benchmarks/posterior.py --only speed --population 6000 [--threads 2]
    python benchmarks/posterior.py --only evidence --evidence-population 4000 --seeds 20 \
        --threads 2

Sections (``--only`` takes a comma-separated list):

- ``analytic``: a model linear in its parameters, Gaussian noise of known variance: TMCMC
  (from the prior and from the Laplace Gaussian) and Laplace against the closed-form
  posterior (means within 0.1 sd, sds within 5 %, correlations within 0.05) and evidence.
- ``calibration``: viscous bridge, 2 % noise, replicates with truths drawn from the prior and
  fresh noise: the best fit by a local least-squares search started at the truth (where
  multistart-lm ends at this noise level, at a tenth of its cost), then the **Laplace** 90 %
  interval of every parameter for each error model kind (``--kinds``, with ``sandwich``: the
  least-squares fit's sandwich covariance, ``gls-sandwich``: ``arp``'s mode with the GLS
  sandwich, ``eiv-sandwich``: ``eiv-all``'s mode with the exact covariance of its score, as
  the Laplace record gave it) and TMCMC's for ``--tmcmc-kinds``; the share of
  replicates whose interval holds the truth, with its binomial interval. ``--hits FILE``
  keeps each replicate as a JSON line: a run resumes there, several processes can share it.
  ``--case-search`` fits each replicate with the example's own ``[search]`` instead (as
  ``femupdate run`` ends on it), ``--truth FILE`` fixes the truth (only the noise fresh).
  ``--product`` runs each replicate through ``femupdate posterior`` itself instead (the
  case's search of ``--fit-runs`` runs of ``--fit-evals`` evaluations, or with ``--fit-runs
  0`` the example's own ``[search]`` as a user runs it, then the default
  ``[posterior]``, without re-centring and with ``--recentre``), and prints the start's
  verdict beside the runs'.
- ``rayleigh`` (not in the default list): a 3-storey shear building with Rayleigh damping
  at its truth, 2 % noise on every record (the table's too): ``femupdate posterior``'s
  intervals over ``--replicates``, or with ``--rayleigh-kinds`` the Laplace intervals of
  those error model kinds and of the sandwich at the search's best fit (and TMCMC's for
  those of its whitening kinds also in ``--tmcmc-kinds``).
- ``whitening`` (not in the default list): does ``arp``, centred at its own mode, fit the
  scatter of its estimate? The truth's Mahalanobis distance on the first replicates, with
  the table's record noisy and clean, and the scatter over noise draws at one truth
  (:func:`whitening`).
- ``speed``: viscous bridge (9 parameters), 2 % noise: TMCMC started from the Laplace
  Gaussian against emcee on the same log-posterior (unit cube, same batches), both started
  from the Laplace Gaussian, in the same run: evaluations, wall time, effective samples.
  ``--threads`` (default 1) evaluates TMCMC's populations over that many threads of this
  process (the compiled evaluator releases the GIL; ``femupdate posterior --workers 2``
  does the same); emcee's ensemble of 36 walkers is evaluated in one thread.
- ``real`` (not in the default list): each of the six trials of the real 1-storey specimen
  fitted alone with the linear storey, and the Laplace record's intervals of k1 and c1 under
  ``neff`` (skipped without the shared records).
- ``ripples`` (not in the default list): φ along kp1 around the truth on both bridges,
  without and with ``[preprocess] lowpass_hz`` (100 and 60 Hz): its local extrema.
- ``friction``: friction bridge (13 parameters): best fit, Laplace, TMCMC: wall time.
- ``evidence``: TMCMC's log-evidence on the viscous bridge (``--evidence-model friction``:
  the friction bridge) over ``--seeds`` seeds (spawned), and the effective sample size
  measured across them (posterior variance over the variance of the seeds' means: no
  autocorrelation model needed), with its 90 % χ² interval, the wall time per run
  (``--threads``) and how often the truth lies inside each 90 % interval; then
  ``femupdate posterior``'s verdict (:mod:`femupdate.pipeline.posterior.agreement`) on consecutive
  sets of its default number of runs (4) among these seeds: which parameters each set calls
  unsettled.
  ``--proposal``, ``--components``, ``--final-steps`` change TMCMC's moves (MOVES) in the
  speed, friction and evidence sections.

Wall times are of this machine at its load (printed beside them). BLAS runs one thread (set
before numpy loads): the residuals' small products cost 200 times more when a busy machine's
BLAS threads contend for them.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy loads

import argparse
import json
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from error_models.gls_sandwich import gls_sandwich_laplace
from error_models.kinds import AR_MAX_ORDER, registry
from error_models.mode import WHITENING_KINDS, mode_jacobians
from error_models.sandwich import curvature_adjustment, eiv_sandwich_laplaces, sandwich_laplace

from femupdate import minimize
from femupdate.case import parse_case
from femupdate.case.posterior_section import DEFAULT_POSTERIOR
from femupdate.errors import FemupdateError
from femupdate.inference import Prior, jacobian_unit, laplace
from femupdate.inference.analytic import Residuals, exact_log_evidence, linear_gaussian
from femupdate.inference.best_fit import centred, coarse_choices
from femupdate.inference.error_models import DEFAULT_KIND
from femupdate.inference.error_models import problem_error_model as product_error_model
from femupdate.inference.input_noise import magnitude_adjusted, trial_groups
from femupdate.inference.jacobian import LOCAL_STEP, UNIT_STEP
from femupdate.inference.likelihood import ErrorModel, residual_blocks
from femupdate.inference.tmcmc import run_tmcmc
from femupdate.paper.problems import bridge
from femupdate.pipeline.posterior.agreement import runs_agreement
from femupdate.pipeline.posterior.run import start_reference
from femupdate.problem.update import UpdateProblem
from femupdate.runs.verdict import verdict_of
from femupdate.trials.experiment import load_experiment, load_experiments

SEED = 2026
FIT_EVALS = 2000
#: The product's error models and, registered here explicitly, those measured and set aside
#: (benchmarks/error_models)
REGISTRY = registry()
KINDS = ("neff", "neff-integrated", "tau", "iid", "ar1", "arp", "adjusted", "eiv")
#: The kinds that take their count from the Jacobian at the best fit
ADJUSTED = ("adjusted", "adjusted-least")
#: Not an error model: the Gaussian at the best fit with the sandwich covariance of the
#: least-squares estimate (benchmarks/error_models/sandwich.py), measured beside them
SANDWICH = "sandwich"
#: Not an error model either: the Gaussian at arp's mode with the covariance of that estimate
#: when the whitening leaves the errors coloured (benchmarks/error_models/gls_sandwich.py)
GLS_SANDWICH = "gls-sandwich"
#: eiv's Gaussian at its mode with the covariance of its score under its own noise model
#: (``eiv-all``'s, benchmarks/error_models/sandwich.py, eiv_sandwich_laplaces)
EIV_SANDWICH = "eiv-sandwich"
#: The errors-in-variables kinds: the product's, over the band each trial trusts, and the
#: lab's over every frequency
EIV_KINDS = ("eiv", "eiv-all")
#: The i.i.d. likelihood with the curvature adjustment (benchmarks/error_models/sandwich.py):
#: sampled by TMCMC at ξ* + C (ξ − ξ*), its Laplace the sandwich Gaussian (by construction).
#: Measured too narrow (docs/history.md, "The curvature adjustment, tried")
CURVATURE = "curvature"
#: The same with C from the Jacobian of steps LOCAL_STEP (the curvature at the fit's own scale)
CURVATURE_LOCAL = "curvature-local"


def problem_error_model(problem: UpdateProblem, r: np.ndarray, kind: str,
                        jacobian: np.ndarray | None = None,
                        ar_max_order: int = AR_MAX_ORDER, *,
                        point: np.ndarray | None = None) -> ErrorModel:
    """The product's ``problem_error_model`` over this benchmark's registry."""
    options = {"ar_max_order": ar_max_order} if kind in ("arp", *EIV_KINDS) else {}
    return product_error_model(problem, r, kind, jacobian, point=point, registry=REGISTRY,
                               **options)


class CurvatureAdjusted:
    """The residuals of ``problem`` at ξ* + C (ξ − ξ*) (unit cube, clipped to it): the
    curvature-adjusted likelihood is the i.i.d. one of these. ``residuals_batch`` keeps a
    population one call."""

    def __init__(self, problem: UpdateProblem, prior: Prior, centre: np.ndarray,
                 adjustment: np.ndarray) -> None:
        self.problem, self.prior = problem, prior
        self.centre, self.adjustment = np.asarray(centre, dtype=float), adjustment

    def _moved(self, x: np.ndarray) -> np.ndarray:
        unit = self.prior.to_unit(x)
        moved = self.centre + (unit - self.centre) @ self.adjustment.T
        return self.prior.to_search(np.clip(moved, 0.0, 1.0))

    def residuals(self, x: np.ndarray) -> np.ndarray:
        return self.problem.residuals(self._moved(np.asarray(x, dtype=float)))

    def residuals_batch(self, X: np.ndarray, **options: Any) -> np.ndarray:
        return self.problem.residuals_batch(self._moved(np.atleast_2d(X)), **options)
#: TMCMC's moves on the bridge: independent proposals from a Gaussian mixture of 16 k-means
#: clusters of the population, 12 steps at β = 1 (measured across seeds: about 3× fewer
#: evaluations per effective sample of the worst parameter than the single Gaussian, which
#: needed 3.2× fewer than random-walk moves); since they are TMCMC's defaults, this only pins
#: them for the benchmark's figures
MOVES = {"proposal": "mixture", "components": 16, "final_steps": 12}


def load() -> str:
    return "load average " + ", ".join(f"{x:.1f}" for x in os.getloadavg())


# -------------------------------------------------------------------------------- analytic


def analytic(population: int) -> dict[str, Any]:
    case = linear_gaussian()
    sd = np.sqrt(np.diag(case.cov))
    corr = case.cov / np.outer(sd, sd)
    best_theta = np.linalg.lstsq(case.design, case.data, rcond=None)[0]
    best = case.prior.to_unit(best_theta)
    lap = laplace(jacobian_unit(case.residuals_batch, best, case.prior),
                  case.residuals_batch(best_theta)[0], best, case.model, case.prior)
    rows = {"laplace": (lap.mean, lap.cov, None, 0)}
    for start in ("prior", "laplace"):
        options = {} if start == "prior" else {"reference": (lap.mean_unit, lap.cov_unit)}
        post, _ = run_tmcmc(Residuals(case).residuals, case.prior, case.model, seed=SEED,
                            population=population, **options)
        x = case.prior.to_search(post.samples)
        rows[f"tmcmc from {start}"] = (x.mean(axis=0), np.cov(x.T), post.log_evidence,
                                       post.evaluations)
    print(f"\n## Analytic check (3 parameters, closed-form Gaussian posterior; "
          f"log-evidence {exact_log_evidence(case):.4f})")
    print(f"{'':20s} {'max |Δmean|/sd':>15s} {'max |sd/sd−1|':>14s} {'max |Δcorr|':>12s} "
          f"{'log Z':>9s} {'evals':>7s}  pass")
    out = {}
    for name, (mean, cov, log_z, evals) in rows.items():
        s = np.sqrt(np.diag(cov))
        dm = float(np.max(np.abs(mean - case.mean) / sd))
        ds = float(np.max(np.abs(s / sd - 1)))
        dc = float(np.max(np.abs(cov / np.outer(s, s) - corr)))
        ok = dm <= 0.1 and ds <= 0.05 and dc <= 0.05
        z = "" if log_z is None else f"{log_z:.4f}"
        print(f"{name:20s} {dm:15.3f} {ds:14.3f} {dc:12.3f} {z:>9s} {evals:7d}  "
              f"{'yes' if ok else 'NO'}")
        out[name] = {"mean_error_sd": dm, "sd_error": ds, "corr_error": dc, "log_z": log_z,
                     "pass": ok}
    return out


# -------------------------------------------------------------------------------- the bridge


def bridge_spec(model: str, work: Path, lowpass_hz: float | None = None) -> dict[str, Any]:
    """The bridge's narrow-band case on the records in ``work``, its records and prediction
    low-passed at ``lowpass_hz`` when given (``[preprocess] lowpass_hz``)."""
    spec = bridge.bridge_case(model, "narrow", directory=str(work))
    if lowpass_hz is not None:
        spec["preprocess"]["lowpass_hz"] = lowpass_hz
    return spec


def bridge_problem(model: str, truth: dict[str, float], work: Path, seed: int,
                   clean_input: bool = False, lowpass_hz: float | None = None
                   ) -> UpdateProblem:
    """The bridge's update problem on a virtual experiment of ``truth`` with 2 % noise (on
    the outputs only with ``clean_input``), low-passed at ``lowpass_hz`` when given
    (:func:`bridge_spec`)."""
    case = parse_case(bridge_spec(model, work, lowpass_hz), source=work / f"{model}.toml")
    bridge.ensure_records(case, truth, work, seed=seed, snr=0.02, clean_input=clean_input)
    return UpdateProblem(case, load_experiment(case))


def best_fit(problem: UpdateProblem, rng: np.random.Generator, max_evals: int = FIT_EVALS
             ) -> tuple[np.ndarray, np.ndarray, int, bool]:
    """(best fit in the unit cube, its residuals, evaluations, converged) by multistart-lm;
    converged: the search's verdict, as ``femupdate run`` gives it for one run (its best found
    again by its own searches: femupdate.runs.verdict)."""
    res = minimize(problem.residuals, problem.bounds, "multistart-lm", residuals=True,
                   seed=rng, max_evals=max_evals)
    prior = Prior.from_case(problem.case)
    unit = prior.to_unit(res.x)
    converged = verdict_of([res.fun], unit[None, :], [dict(res.stop)]).converged
    return unit, res.residuals, int(res.nfev), converged


def local_fit(problem: UpdateProblem, start_unit: np.ndarray) -> tuple[np.ndarray,
                                                                       np.ndarray, int]:
    """(best fit in the unit cube, its residuals, evaluations) by a local trust-region
    least-squares search (scipy) from ``start_unit``: the calibration's replicates start it at
    their truth, where the global search ends at this noise level, at a tenth of its cost."""
    from scipy.optimize import least_squares

    prior = Prior.from_case(problem.case)
    calls = {"n": 0}

    def residuals(unit: np.ndarray) -> np.ndarray:
        calls["n"] += 1
        return problem.residuals(prior.to_search(unit))

    res = least_squares(residuals, np.clip(start_unit, 1e-6, 1 - 1e-6), bounds=(0.0, 1.0),
                        diff_step=1e-3, x_scale="jac", max_nfev=60)
    return res.x, problem.residuals(prior.to_search(res.x)), calls["n"] + 1


def laplace_of(problem: UpdateProblem, unit: np.ndarray, r: np.ndarray, kind: str):
    prior = Prior.from_case(problem.case)
    # steps of 1 % of each range: the slope of the kp1 valley, not of one of its ripples
    jac = jacobian_unit(problem.residuals_batch, unit, prior, step=1e-2)
    # "adjusted" takes its count from this Jacobian (k does not depend on its coordinates)
    model = problem_error_model(problem, r, kind, jac if kind in ADJUSTED else None,
                                point=prior.to_search(unit))
    return laplace(jac, r, unit, model, prior), model, prior


# -------------------------------------------------------------------------------- calibration


def capped_reference(lap: Any) -> tuple[np.ndarray, np.ndarray]:
    """TMCMC's first population's Gaussian: the Laplace one, its sd capped at half the range
    (neff's exceeds the range for kp1, c1, c4): any normalised start density gives the same
    posterior, this one keeps enough of its mass inside the bounds."""
    cap = np.minimum(1.0, 0.5 / np.sqrt(np.diag(lap.cov_unit)))
    return np.clip(lap.mean_unit, 0.0, 1.0), lap.cov_unit * np.outer(cap, cap)


def sampled_hits(samples: np.ndarray, prior: Prior, truth: np.ndarray) -> list[bool]:
    """Whether each parameter's 90 % interval of posterior ``samples`` (unit cube) holds
    ``truth`` (physical values)."""
    q = np.quantile(prior.to_physical(samples), [0.05, 0.95], axis=0)
    return ((q[0] <= truth) & (truth <= q[1])).tolist()


def eiv_sampled(problem: UpdateProblem, prior: Prior, model: ErrorModel, unit: np.ndarray,
                r: np.ndarray, centre: np.ndarray, r_c: np.ndarray, jac: np.ndarray
                ) -> tuple[ErrorModel, Any]:
    """(the errors-in-variables likelihood TMCMC samples, its Laplace Gaussian at its mode):
    ``model`` (built at the least-squares fit ``unit``, residuals ``r``) magnitude-adjusted at
    its mode ``centre`` (residuals ``r_c``, Jacobian ``jac`` there)."""
    model = magnitude_adjusted(problem, model, prior.to_search(unit), r, jac, r_c)
    return model, centred(laplace(jac, r_c, centre, model, prior), centre, prior)


def coverage_row(hits: np.ndarray) -> list[tuple[float, float, float]]:
    """(share, low, high) per parameter of boolean hits (replicates, n): the share of
    replicates whose interval holds the truth and its 95 % Clopper–Pearson interval (the
    binomial spread of the share itself: ±8 points at 50 replicates)."""
    from scipy.stats import binomtest

    out = []
    for column in np.asarray(hits, dtype=bool).T:
        k, n = int(column.sum()), column.size
        ci = binomtest(k, n).proportion_ci(0.95, method="exact")
        out.append((k / n, float(ci.low), float(ci.high)))
    return out


def two_scale_quantiles(coarse: Any, local: Any) -> np.ndarray:
    """The Laplace record's two scales (femupdate.inference.best_fit.coarse_choices): the
    quantiles (3, n) of the Gaussian over the local Jacobian (steps of 1e-4 of each range),
    but the one over 1 % of each range (the kp1 valley's slope, not a ripple's) where that
    one says undetermined, or is NOT_QUADRATIC_RATIO times wider."""
    undetermined, not_quadratic, _ = coarse_choices(local, coarse)
    q = local.quantiles.copy()
    q[:, undetermined | not_quadratic] = coarse.quantiles[:, undetermined | not_quadratic]
    return q


def secant_widening(problem: UpdateProblem, r: np.ndarray, unit: np.ndarray,
                    coarse_jac: np.ndarray, local_jac: np.ndarray, prior: Prior) -> list[float]:
    """Per parameter, the 90 % interval of the Gaussian over the 1 % secant (the Jacobian of
    steps UNIT_STEP) over that of the local one, under the i.i.d. likelihood's shape (the
    same for any count per channel): well above 1 where φ ripples along the parameter at a
    scale between the two steps (the Laplace record's NOT_QUADRATIC_RATIO is 3)."""
    model = problem_error_model(problem, r, "iid")
    return coarse_choices(laplace(local_jac, r, unit, model, prior),
                          laplace(coarse_jac, r, unit, model, prior))[2].tolist()


def distances(q: np.ndarray, truth: np.ndarray) -> list[float]:
    """(truth − median) / σ per parameter, σ the 90 % interval's half-width over 1.645: the
    truth's distance in the interval's own standard deviations (root mean square 1 over
    replicates for calibrated Gaussian intervals; below 1 too wide, above too narrow)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return ((truth - q[1]) / ((q[2] - q[0]) / (2 * 1.6449))).tolist()


def case_fit(case: Any) -> tuple[UpdateProblem, np.ndarray, np.ndarray, bool]:
    """(problem, best fit in the unit cube, its residuals, the verdict's converged) of the
    case's ``[search]``, run as ``femupdate run`` runs it (nothing written)."""
    from femupdate.pipeline.run import run_case
    from femupdate.runs import Execution

    got = run_case(case, None, execution=Execution(quiet=True), sensitivities=False)
    prior = Prior.from_case(case)
    x = prior.physical_to_search(np.array([got.summary.best.params[n] for n in prior.names]))
    verdict = got.summary.verdict
    return (got.problem, prior.to_unit(x), got.problem.residuals(x),
            bool(verdict and verdict.converged))


def own_search(search: dict[str, Any], seed: int, **settings: Any) -> dict[str, Any]:
    """The example's ``[search]`` as a user runs it on noisy records: ``f_target`` removed,
    ``seed`` (and any other ``settings``) given."""
    return {k: v for k, v in search.items() if k != "f_target"} | {"seed": seed, **settings}


def replicate_seeds(child: np.random.SeedSequence) -> tuple[int, int]:
    """(search seed, posterior seed) of a replicate: the case's ``[search]`` and
    ``[posterior]`` seeds, the same in every flow that runs the replicate's own search."""
    search, posterior = np.random.SeedSequence(
        child.entropy, spawn_key=(*child.spawn_key, 96)).generate_state(2)
    return int(search), int(posterior)


def bridge_replicate(model: str, child: np.random.SeedSequence, work: Path,
                     truth: dict[str, float] | None = None, lowpass_hz: float | None = None
                     ) -> tuple[dict[str, Any], Prior, np.ndarray]:
    """A calibration replicate's case (spec, low-passed at ``lowpass_hz`` when given), prior
    and truth (drawn from the prior, or ``truth`` by parameter name), its noisy records
    written in ``work``."""
    rng = np.random.default_rng(child)
    spec = bridge_spec(model, work, lowpass_hz)
    prior = Prior.from_case(parse_case(spec, source=work / f"{model}.toml"))
    drawn = prior.sample(rng, 1)[1][0]  # drawn either way: the noise seed is the same
    truth_values = drawn if truth is None else np.array([truth[n] for n in prior.names])
    bridge_problem(model, dict(zip(prior.names, truth_values.tolist(), strict=True)), work,
                   int(rng.integers(2 ** 31)))
    return spec, prior, truth_values


def searched_record(i: int, root: Path, prior_truth: bool, lowpass_hz: float | None = None
                    ) -> tuple[UpdateProblem, Prior, np.ndarray, np.ndarray, np.ndarray]:
    """(problem, prior, best fit in the unit cube, its residuals, truth (physical)) of the
    viscous bridge's calibration record ``i`` (the product's calibration rows' records, truths
    and search seeds; its truth from the prior or the example's), fitted by the example's own
    ``[search]`` as a user runs it (:func:`own_search`, :func:`case_fit`); in ``root``."""
    child = np.random.SeedSequence(SEED).spawn(i + 1)[i]
    work = root / f"replicate-{i}"
    spec, prior, truth_values = bridge_replicate(
        "viscous", child, work, None if prior_truth else bridge.truth("viscous"), lowpass_hz)
    spec = dict(spec, search=own_search(spec["search"], replicate_seeds(child)[0]))
    problem, unit, r, _ = case_fit(parse_case(spec, source=work / "viscous.toml"))
    return problem, prior, unit, r, truth_values


def searched_records(description: str, replicates: int,
                     replicate: Callable[[int, Path, bool, float], dict[str, Any]],
                     describe: Callable[[dict[str, Any]], str]) -> list[dict[str, Any]]:
    """The command line of the scripts that study :func:`searched_record`'s records one by one
    (``--replicates``, ``--prior``, ``--lowpass-hz``, ``--first-replicate``, ``--quick`` for
    one record): each record's row from ``replicate(i, root, prior_truths, lowpass_hz)``,
    printed by ``describe`` as it comes."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--replicates", type=int, default=replicates)
    parser.add_argument("--prior", action="store_true", help="truths drawn from the prior")
    parser.add_argument("--lowpass-hz", type=float, default=100.0)
    parser.add_argument("--quick", action="store_true", help="one record")
    parser.add_argument("--first-replicate", type=int, default=0,
                        help="start at this record (runs it to --replicates − 1)")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.first_replicate, 1 if args.quick else args.replicates):
            rows.append(replicate(i, Path(tmp), args.prior, args.lowpass_hz))
            print(f"replicate {i}: {describe(rows[-1])}", flush=True)
    return rows


def case_search_fit(spec: dict[str, Any], source: Path, seed: int
                    ) -> tuple[np.ndarray, np.ndarray, bool]:
    """(best fit in the unit cube, its residuals, the verdict's converged) of the case's own
    ``[search]`` (:func:`own_search`): :func:`case_fit`."""
    spec = dict(spec, search=own_search(spec["search"], seed))
    return case_fit(parse_case(spec, source=source))[1:]


def replicate(i: int, child: np.random.SeedSequence, root: Path, kinds: list[str],
              tmcmc_kinds: list[str], tmcmc_population: int, coarse_only: bool = False,
              clean_input: bool = False, ar_max_order: int = AR_MAX_ORDER,
              search_fit: bool = False, tmcmc_from_prior: bool = False,
              lowpass_hz: float | None = None, fit_evals: int = FIT_EVALS,
              tmcmc_runs: int = 1, case_search: bool = False,
              truth: dict[str, float] | None = None) -> dict[str, Any]:
    """One calibration replicate: truth from the prior, fresh noise, the best fit of a local
    search started at the truth, then per error model kind whether the Laplace (and, for
    ``tmcmc_kinds``, TMCMC's) 90 % interval of each parameter holds the truth. The Laplace of
    a whitening kind (``ar1``, ``arp``) is taken at that kind's own mode, climbed to from the
    least-squares fit (benchmarks/error_models/mode.py), as the product does; ``KIND@fit`` is the
    same Gaussian centred at the least-squares fit instead. ``case_search``: the fit of the
    example's own ``[search]`` (:func:`case_search_fit`, seeded as :func:`product_replicate`
    seeds it) instead; ``truth`` (physical values by name): every replicate has that truth,
    only its noise fresh (the same records as :func:`product_replicate`'s)."""
    # the kinds of the library when these seeds were spawned (their order fixes them)
    ALL_KINDS = ("neff", "neff-integrated", "tau", "iid", "ar1", "arp", "adjusted", "known", "eiv")
    rng = np.random.default_rng(child)
    # TMCMC's seeds: one child per kind of the library, whichever kinds this run measures
    tm_seeds = dict(zip(ALL_KINDS, child.spawn(len(ALL_KINDS)), strict=True))
    # the case's own search runs on the low-passed records too
    spec = bridge_spec("viscous", root / f"replicate-{i}", lowpass_hz)
    prior = Prior.from_case(parse_case(spec, source=root / "viscous.toml"))
    drawn = prior.sample(rng, 1)[1][0]  # drawn either way: the noise seed is the same
    truth_values = drawn if truth is None else np.array([truth[n] for n in prior.names])
    truth = dict(zip(prior.names, truth_values.tolist(), strict=True))
    problem = bridge_problem("viscous", truth, root / f"replicate-{i}",
                             int(rng.integers(2 ** 31)), clean_input, lowpass_hz)
    converged: bool | None = None
    if case_search:  # as `femupdate run` ends on the example, with product_replicate's seed
        unit, r, converged = case_search_fit(spec, root / f"replicate-{i}" / "viscous.toml",
                                             replicate_seeds(child)[0])
    elif search_fit:  # as a user's update ends: multistart-lm from nowhere in particular
        unit, r, _, converged = best_fit(problem, np.random.default_rng(
            np.random.SeedSequence(child.entropy, spawn_key=(*child.spawn_key, 98))),
            max_evals=fit_evals)
    else:
        unit, r, _ = local_fit(problem, prior.from_physical(truth_values))
    # the Laplace record's two scales (two_scale_quantiles); with ``coarse_only`` the 1 % one
    # for every parameter
    jac = jacobian_unit(problem.residuals_batch, unit, prior, step=UNIT_STEP)
    jac_local = jac if coarse_only else jacobian_unit(problem.residuals_batch, unit, prior,
                                                      step=LOCAL_STEP)
    blocks = residual_blocks(problem)[0]
    fit_error = (unit - prior.from_physical(truth_values)).tolist()
    widening = secant_widening(problem, r, unit, jac, jac_local, prior)

    def two_scale(estimate: Any, jacobians: tuple[np.ndarray, np.ndarray] | None = None
                  ) -> tuple[Any, np.ndarray]:
        coarse_jac, local_jac = jacobians or (jac, jac_local)
        local = estimate(local_jac)
        return local, two_scale_quantiles(estimate(coarse_jac), local)

    out: dict[str, Any] = {"replicate": i, "laplace": {}, "distance": {}, "tmcmc": {},
                           "tmcmc_evals": {}, "mode_evals": {}, "search_converged": converged,
                           "fit_error": fit_error, "widening": widening}

    def record(kind: str, q: np.ndarray) -> None:
        out["laplace"][kind] = ((q[0] <= truth_values) & (truth_values <= q[2])).tolist()
        out["distance"][kind] = distances(q, truth_values)
    for kind in kinds:
        if kind == GLS_SANDWICH:
            model = problem_error_model(problem, r, "arp", ar_max_order=ar_max_order)
            centre, ((r_c, local_c), (_, coarse_c)), evals = mode_jacobians(
                problem, prior, model, unit, r, jac_local)
            _, q = two_scale(lambda j, m=model, c=centre, rc=r_c: gls_sandwich_laplace(
                j, rc, c, m, prior, trial_groups(problem)), (coarse_c, local_c))
            record(kind, q)
            out["mode_evals"][kind] = evals
            continue
        if kind == EIV_SANDWICH:
            point = prior.to_search(unit)
            model = problem_error_model(problem, r, "eiv-all", point=point)
            centre, ((r_c, local_c), (_, coarse_c)), evals = mode_jacobians(
                problem, prior, model, unit, r, jac_local)
            # both scales' Gaussians in one pass over the noise paths, then the product's rule
            gaussians = eiv_sandwich_laplaces(problem, model, point, r,
                                              [(r_c, coarse_c), (r_c, local_c)], centre, prior)
            by_jacobian = {id(coarse_c): gaussians[0], id(local_c): gaussians[1]}
            _, q = two_scale(lambda j, g=by_jacobian: g[id(j)], (coarse_c, local_c))
            record(kind, q)
            out["mode_evals"][kind] = evals
            continue
        if kind == SANDWICH:
            _, q = two_scale(lambda j: sandwich_laplace(j, r, unit, blocks, prior))
            record(kind, q)
            continue
        if kind in (CURVATURE, CURVATURE_LOCAL):  # TMCMC only: its Laplace is the sandwich's
            j = jac if kind == CURVATURE else jac_local
            lap = sandwich_laplace(j, r, unit, blocks, prior)
            wrapped = CurvatureAdjusted(problem, prior, unit, curvature_adjustment(j, r, blocks))
            reference = capped_reference(lap)
            seed = np.random.SeedSequence(child.entropy, spawn_key=(*child.spawn_key, 99))
            post, _ = run_tmcmc(wrapped.residuals, prior, problem_error_model(problem, r, "iid"),
                                seed=seed, population=tmcmc_population, reference=reference,
                                **MOVES)
            if not post.reached:
                raise RuntimeError(f"replicate {i}: TMCMC ({kind}) did not reach β = 1")
            out["tmcmc"][kind] = sampled_hits(post.samples, prior, truth_values)
            out["tmcmc_evals"][kind] = post.evaluations
            continue
        model = problem_error_model(problem, r, kind, jac if kind in ADJUSTED else None,
                                    ar_max_order=ar_max_order, point=prior.to_search(unit))
        if kind in WHITENING_KINDS:
            # beside it, the same Gaussian at the least-squares fit, no step to the mode (as
            # the Laplace record took it before): the cost of the wrong centre
            _, q_fit = two_scale(lambda j, m=model: centred(laplace(j, r, unit, m, prior),
                                                            unit, prior))
            out["laplace"][f"{kind}@fit"] = ((q_fit[0] <= truth_values)
                                             & (truth_values <= q_fit[2])).tolist()
            # at the kind's own mode, as the Laplace record does
            centre, ((r_c, local_c), (_, coarse_c)), evals = mode_jacobians(
                problem, prior, model, unit, r, jac_local if not coarse_only else
                jacobian_unit(problem.residuals_batch, unit, prior, step=LOCAL_STEP))
            if coarse_only:
                local_c = coarse_c
            out["mode_evals"][kind] = evals
            lap, q = two_scale(lambda j, m=model, c=centre, rc=r_c: laplace(j, rc, c, m, prior),
                               (coarse_c, local_c))
        else:
            lap, q = two_scale(lambda j, m=model: laplace(j, r, unit, m, prior))
        record(kind, q)
        if kind in tmcmc_kinds:
            if kind in EIV_KINDS:
                model, lap = eiv_sampled(problem, prior, model, unit, r, centre, r_c, coarse_c)
            reference = capped_reference(lap)
            # as femupdate posterior: the prior where even the capped one is mostly outside
            reference, _ = start_reference(*reference, np.random.default_rng(
                np.random.SeedSequence(child.entropy, spawn_key=(*child.spawn_key, 97))))
            # one run on the kind's own seed, or, as femupdate posterior, runs on its children
            # a kind added after these seeds were spawned takes its parent kind's
            kind_seed = tm_seeds["eiv" if kind in EIV_KINDS else kind]
            seeds = [kind_seed] if tmcmc_runs == 1 else kind_seed.spawn(tmcmc_runs)
            posts = [run_tmcmc(problem.residuals, prior, model, seed=seed,
                               population=tmcmc_population,
                               reference=None if tmcmc_from_prior else reference, **MOVES)[0]
                     for seed in seeds]
            if not all(post.reached for post in posts):
                raise RuntimeError(f"replicate {i}: TMCMC ({kind}) did not reach β = 1")
            out["tmcmc"][kind] = sampled_hits(np.vstack([post.samples for post in posts]),
                                              prior, truth_values)
            out["tmcmc_evals"][kind] = sum(post.evaluations for post in posts)
            if tmcmc_runs > 1:  # the product's verdict on them
                out.setdefault("tmcmc_unsettled", {})[kind] = runs_agreement(
                    [prior.to_search(post.samples) for post in posts],
                    [post.ess_params for post in posts], list(prior.names)).unsettled
    return out


def inside(marginals: dict[str, Any], names: tuple[str, ...], truth: np.ndarray
           ) -> list[bool]:
    """Whether each parameter's 5–95 % interval (summary marginals) holds its truth."""
    return [bool(marginals[n].q05 <= t <= marginals[n].q95)
            for n, t in zip(names, truth.tolist(), strict=True)]


def product_replicate(i: int, child: np.random.SeedSequence, root: Path, fit_evals: int,
                      fit_runs: int, recentre: int, error_model: str | None = None,
                      truth: dict[str, float] | None = None, model: str = "viscous",
                      lowpass_hz: float | None = None, start: str | None = None
                      ) -> dict[str, Any]:
    """One calibration replicate through ``femupdate posterior`` itself (``run_posterior``):
    the truth and noise of :func:`replicate`, the case's search (multistart-lm, ``fit_runs``
    runs of ``fit_evals`` evaluations, seeded from the replicate), the default
    ``[posterior]`` (its error model, or ``error_model``; four runs of 1,000, pooled, more
    while a parameter is unsettled; the Laplace record's error model is the case's too). It
    runs twice on one results directory: without re-centring (``tmcmc`` KIND), then,
    resuming both stores, with ``recentre`` (``tmcmc`` KIND-recentred: the same samples
    unless the sampler found a better fit than the search's). With ``truth`` (physical values
    by name) every replicate has that truth and only its noise is fresh. ``model``: the
    bridge's ``"viscous"`` or ``"friction"`` model class; ``lowpass_hz``: the case's
    ``[preprocess] lowpass_hz``."""
    from femupdate.pipeline.posterior.run import run_posterior
    from femupdate.runs import Execution

    work = root / f"replicate-{i}"
    spec, prior, truth_values = bridge_replicate(model, child, work, truth, lowpass_hz)
    search_seed, posterior_seed = replicate_seeds(child)
    if fit_runs:
        spec["search"] = {"method": "multistart-lm", "runs": fit_runs, "seed": search_seed,
                          "max_evals": fit_evals}
    else:  # the case's own search, as a user runs it on noisy records
        spec["search"] = own_search(spec["search"], search_seed)
    spec["posterior"] = {"seed": posterior_seed} | (
        {} if error_model is None else {"error_model": error_model}) | (
        {} if start is None else {"start": start})
    sampled = error_model or DEFAULT_KIND
    case = parse_case(spec, source=work / f"{model}.toml")
    out: dict[str, Any] = {"replicate": i, "laplace": {}, "tmcmc": {}, "tmcmc_evals": {},
                           "tmcmc_unsettled": {}, "mode_evals": {}}
    for kind, passes, resume in ((sampled, 0, False), (f"{sampled}-recentred", recentre, True)):
        got = run_posterior(case, work / "out", recentre=passes, resume=resume,
                            execution=Execution(quiet=True))
        out["tmcmc"][kind] = inside(got.record.params, prior.names, truth_values)
        out["tmcmc_evals"][kind] = got.record.nfev
        out["tmcmc_unsettled"][kind] = got.record.unsettled
        out.setdefault("start_warnings", {})[kind] = got.record.start_warnings
        out.setdefault("recentred", {})[kind] = got.record.recentred
    laplace_record = got.summary.laplace
    if laplace_record is not None and laplace_record.params:
        out["laplace"][laplace_record.error_model] = inside(laplace_record.params, prior.names,
                                                            truth_values)
    verdict = got.summary.verdict
    out["search_converged"] = None if verdict is None else verdict.converged
    out["search_phi"], out["start_phi"] = got.summary.best.phi, got.record.start_phi
    # what a miss looks like: the truth and each sampled 90 % interval, by name
    out["truth"] = dict(zip(prior.names, truth_values.tolist(), strict=True))
    out["intervals"] = {n: [got.record.params[n].q05, got.record.params[n].q95]
                        for n in prior.names}
    return out


#: The 3-storey shear building with Rayleigh damping: 1,000 kg floors, storey stiffnesses
#: giving 2.94, 7.66 and 11.26 Hz, α and β for ζ = 2 % at 2.94 and 11.26 Hz
RAYLEIGH_TRUTH = {"k1": 2006418.5, "k2": 1581412.0, "k3": 1246431.9, "alpha": 0.58591853,
                  "beta": 4.4832378e-4}


def rayleigh_spec(work: Path, fit_evals: int) -> dict[str, Any]:
    """The building's case: floors' and table's accelerations (CSV in ``work/data``), the
    relative displacements fitted, k's on a log scale; α, β over 0.1–10 times the truth."""
    params = [{"name": f"k{i}", "lower": 3e5, "upper": 1e7, "scale": "log"} for i in (1, 2, 3)]
    params += [{"name": "alpha", "lower": 0.05, "upper": 5.0, "scale": "log"},
               {"name": "beta", "lower": 4e-5, "upper": 4e-3, "scale": "log"}]
    return {"case": {"name": "rayleigh-3-storey"},
            "model": {"shear_building": {"masses": [1000.0] * 3,
                                         "stiffnesses": ["k1", "k2", "k3"]},
                      "rayleigh": {"alpha": "alpha", "beta": "beta"}},
            "parameters": params,
            "data": {"format": "csv", "directory": str(work / "data"), "time_column": "t",
                     "input": {"file": "table.csv", "column": "table"},
                     "outputs": [{"file": "floors.csv", "column": f"a{i}", "node": f"F{i}",
                                  "dof": "ux"} for i in (1, 2, 3)]},
            "preprocess": {"highpass_hz": 0.5},
            "objective": {"quantity": "displacement", "experimental_parameters": True},
            "search": {"method": "multistart-lm", "runs": 1, "max_evals": fit_evals}}


def rayleigh_replicate(i: int, child: np.random.SeedSequence, root: Path, fit_evals: int,
                       snr: float = 0.02, laplace_kinds: list[str] | None = None,
                       tmcmc_kinds: tuple[str, ...] = (), error_model: str | None = None
                       ) -> dict[str, Any]:
    """One replicate of the Rayleigh building at its truth: fresh noise (``snr`` on every
    record, the table's too: ``femupdate synth --rate 200 --snr 0.02 --length-scale 1
    --duration 20``), then ``femupdate posterior`` with every default (but ``[posterior]
    error_model = error_model``, when given); with
    ``laplace_kinds``, instead, the case's search and the Laplace intervals of those kinds
    (and of the sandwich) at its best fit, with the counts N_c of each kind, and TMCMC's for
    those of them in ``tmcmc_kinds``."""
    from femupdate.pipeline.posterior.run import run_posterior
    from femupdate.runs import Execution
    from femupdate.trials.virtual import virtual_experiment

    rng = np.random.default_rng(child)
    work = root / f"rayleigh-{i}"
    spec = rayleigh_spec(work, fit_evals)
    search_seed, noise_seed = (int(v) for v in rng.integers(2 ** 31, size=2))
    spec["search"]["seed"] = search_seed
    if error_model is not None:
        spec["posterior"] = {"error_model": error_model}
    case = parse_case(spec, source=work / "case.toml")
    virtual_experiment(case, RAYLEIGH_TRUTH, work / "data", seed=noise_seed, snr=snr,
                       rate=200.0, duration=20.0, length_scale=1.0)
    names = tuple(RAYLEIGH_TRUTH)
    truth = np.array([RAYLEIGH_TRUTH[n] for n in names])
    if laplace_kinds:
        return rayleigh_laplaces(i, case, truth, laplace_kinds, tmcmc_kinds,
                                 np.random.SeedSequence(child.entropy,
                                                        spawn_key=(*child.spawn_key, 95)))
    got = run_posterior(case, work / "out", execution=Execution(quiet=True))
    out: dict[str, Any] = {"replicate": i, "laplace": {}, "tmcmc": {}, "tmcmc_evals": {},
                           "tmcmc_unsettled": {}}
    kind = got.record.error_model
    out["tmcmc"][kind] = inside(got.record.params, names, truth)
    out["tmcmc_evals"][kind] = got.record.nfev
    out["tmcmc_unsettled"][kind] = got.record.unsettled
    lap = got.summary.laplace
    if lap is not None and lap.params:
        out["laplace"][lap.error_model] = inside(lap.params, names, truth)
    return out


def rayleigh_laplaces(i: int, case: Any, truth: np.ndarray, kinds: list[str],
                      tmcmc_kinds: tuple[str, ...] = (),
                      seed: np.random.SeedSequence | None = None) -> dict[str, Any]:
    """The case's search (``femupdate run``'s), then the Laplace record's intervals (its two
    scales) of each of ``kinds`` and of the sandwich at its best fit (a whitening kind's at
    its own mode, climbed to from there): whether they hold ``truth``, and each kind's counts
    N_c; for the whitening kinds in ``tmcmc_kinds`` TMCMC's intervals too (one run of 1,000 on
    ``seed``, from the Laplace Gaussian at the mode, the errors in the variables
    magnitude-adjusted, as the bridge's calibration samples them)."""
    problem, unit, r, _ = case_fit(case)
    prior = Prior.from_case(case)
    jacobians = [jacobian_unit(problem.residuals_batch, unit, prior, step=step)
                 for step in (UNIT_STEP, LOCAL_STEP)]
    blocks = residual_blocks(problem)[0]
    out: dict[str, Any] = {"replicate": i, "laplace": {}, "distance": {}, "tmcmc": {},
                           "counts": {}, "fit_error": (unit - prior.from_physical(truth)).tolist(),
                           "widening": secant_widening(problem, r, unit, *jacobians, prior)}
    for kind in (*kinds, SANDWICH):
        if kind == SANDWICH:
            q = two_scale_quantiles(*(sandwich_laplace(j, r, unit, blocks, prior)
                                      for j in jacobians))
        elif kind in WHITENING_KINDS:  # at the kind's own mode, as the bridge's calibration
            model = problem_error_model(problem, r, kind, point=prior.to_search(unit))
            centre, ((r_c, local_c), (_, coarse_c)), _ = mode_jacobians(
                problem, prior, model, unit, r, jacobians[1])
            q = two_scale_quantiles(*(laplace(j, r_c, centre, model, prior)
                                      for j in (coarse_c, local_c)))
            if kind in tmcmc_kinds:
                out["tmcmc"][kind], out.setdefault("tmcmc_evals", {})[kind] = rayleigh_tmcmc(
                    problem, prior, model, kind, unit, r, centre, r_c, coarse_c, truth, seed)
        else:
            model = problem_error_model(problem, r, kind, jacobians[0])
            q = two_scale_quantiles(*(laplace(j, r, unit, model, prior) for j in jacobians))
        if kind != SANDWICH:
            out["counts"][kind] = np.asarray(model.counts).tolist()
        out["laplace"][kind] = ((q[0] <= truth) & (truth <= q[2])).tolist()
        out["distance"][kind] = distances(q, truth)
    return out


def rayleigh_tmcmc(problem: UpdateProblem, prior: Prior, model: ErrorModel, kind: str,
                   unit: np.ndarray, r: np.ndarray, centre: np.ndarray, r_c: np.ndarray,
                   jac: np.ndarray, truth: np.ndarray, seed: np.random.SeedSequence | None
                   ) -> tuple[list[bool], int]:
    """(whether TMCMC's 90 % intervals of a whitening ``kind`` hold ``truth``, evaluations):
    one run of 1,000 from its Laplace Gaussian at its mode ``centre`` (residuals ``r_c``,
    Jacobian ``jac`` there; ``unit``, ``r`` the least-squares fit the model was built at)."""
    if kind in EIV_KINDS:
        model, lap = eiv_sampled(problem, prior, model, unit, r, centre, r_c, jac)
    else:
        lap = centred(laplace(jac, r_c, centre, model, prior), centre, prior)
    post, _ = run_tmcmc(problem.residuals, prior, model, seed=seed, population=1000,
                        reference=capped_reference(lap), **MOVES)
    if not post.reached:
        raise RuntimeError(f"Rayleigh building: TMCMC ({kind}) did not reach β = 1")
    return sampled_hits(post.samples, prior, truth), int(post.evaluations)


def rayleigh(replicates: int, root: Path, fit_evals: int, hits_file: Path | None = None,
             laplace_kinds: list[str] | None = None, tmcmc_kinds: tuple[str, ...] = ()
             ) -> dict[str, Any]:
    """Coverage of the Rayleigh building's 90 % intervals over ``replicates`` noise draws
    (``hits_file``: JSON lines, resumable, as the calibration's), through ``femupdate
    posterior`` (its error model the first of ``tmcmc_kinds``, when given), or with
    ``laplace_kinds`` the Laplace intervals of those kinds."""
    children = np.random.SeedSequence(SEED + 3).spawn(replicates)
    done: dict[int, dict[str, Any]] = {}
    if hits_file is not None and hits_file.exists():
        for line in hits_file.read_text().splitlines():
            row = json.loads(line)
            done[row["replicate"]] = row
    print(f"\n## Coverage: 3-storey shear building, Rayleigh damping (ζ = 2 % at 2.94 and "
          f"11.26 Hz), 2 % noise on every record (the table's too), 200 Hz, 20 s, "
          f"{replicates} replicates at the truth, "
          + (f"Laplace intervals of {', '.join(laplace_kinds)} and the sandwich at the search's "
             "best fit" if laplace_kinds else "through femupdate posterior")
          + f" (search: multistart-lm, {fit_evals:,} evaluations)"
          + ("" if laplace_kinds else " with every default"
             + (f" but error_model = {tmcmc_kinds[0]!r}" if tmcmc_kinds else "")))
    start = time.perf_counter()
    for i, child in enumerate(children):
        if i in done:
            continue
        row = rayleigh_replicate(i, child, root, fit_evals, laplace_kinds=laplace_kinds,
                                 tmcmc_kinds=tmcmc_kinds, error_model=None if laplace_kinds
                                 or not tmcmc_kinds else tmcmc_kinds[0])
        done[i] = row
        if hits_file is not None:
            with hits_file.open("a") as f:
                f.write(json.dumps(row) + "\n")
        print(f"  replicate {i:2d}: " + "  ".join(
            f"{k} {''.join('1' if h else '0' for h in v)}"
            for part in ("laplace", "tmcmc") for k, v in row[part].items()), flush=True)
    rows = [done[i] for i in sorted(done) if i < replicates]
    print("\nShare of replicates whose 90 % interval holds the truth (target 0.84–0.96)")
    out = coverage_table(rows, tuple(RAYLEIGH_TRUTH))
    print(f"(replicates run here in {time.perf_counter() - start:.0f} s; {load()})")
    return out


def calibration(replicates: int, root: Path, first: int = 0, *,
                kinds: list[str] | None = None, tmcmc_kinds: list[str] | None = None,
                tmcmc_population: int = 1000, hits_file: Path | None = None,
                coarse_only: bool = False, clean_input: bool = False,
                ar_max_order: int = AR_MAX_ORDER, search_fit: bool = False,
                tmcmc_from_prior: bool = False, lowpass_hz: float | None = None,
                fit_evals: int = FIT_EVALS, tmcmc_runs: int = 1, product: bool = False,
                fit_runs: int = 1, recentre: int = 2,
                truth: dict[str, float] | None = None, model: str = "viscous",
                case_search: bool = False, posterior_start: str | None = None
                ) -> dict[str, Any]:
    """Replicates ``first`` … ``replicates − 1`` (a range of them can run in several
    processes: replicate i is the same wherever it runs). With ``hits_file`` (JSON lines)
    each replicate is appended as it ends, replicates already there are not run again
    (resume, or several processes on one file), and the table is of every replicate the
    file holds below ``replicates``. With ``product`` each replicate runs ``femupdate
    posterior`` itself (:func:`product_replicate`, of the bridge's ``model`` class) instead of
    the other options' pieces."""
    kinds = list(kinds or KINDS)
    tmcmc_kinds = list(tmcmc_kinds or [])
    if model != "viscous" and not product:
        raise SystemExit("--bridge-model friction needs --product")
    names = Prior.from_case(parse_case(bridge.bridge_case(model, "narrow",
                                                          directory=str(root)),
                                       source=root / f"{model}.toml")).names
    children = np.random.SeedSequence(SEED).spawn(replicates)
    done: dict[int, dict[str, Any]] = {}
    if hits_file is not None and hits_file.exists():
        for line in hits_file.read_text().splitlines():
            row = json.loads(line)
            done[row["replicate"]] = row
    start = time.perf_counter()
    if product:
        drawn = "from the prior" if truth is None else "fixed: " + ", ".join(
            f"{k} = {v:g}" for k, v in truth.items())
        searched = (f"{fit_runs} run(s) of multistart-lm, {fit_evals:,} evaluations each"
                    if fit_runs else "the example's own [search], f_target removed")
        print(f"\n## Calibration: {model} bridge, 2 % noise, {replicates} replicates (truth "
              f"{drawn}, fresh noise), through femupdate posterior: the case's search "
              f"({searched}), then "
              f"the default [posterior], without re-centring and with recentre = {recentre}"
              + (f"; records and prediction low-passed at {lowpass_hz:g} Hz" if lowpass_hz
                 else ""))
    else:
        drawn = "from the prior" if truth is None else "fixed at the example's"
        fitted = ("best fit of the example's own [search] (f_target removed)" if case_search
                  else f"best fit of multistart-lm ({fit_evals:,} evaluations)" if search_fit
                  else "best fit of a local least-squares search started at the truth")
        print(f"\n## Calibration: viscous bridge, 2 % noise, {replicates} replicates (truth "
              f"{drawn}, fresh noise), 90 % intervals (Laplace for {', '.join(kinds)}; TMCMC, "
              f"population {tmcmc_population}, for {', '.join(tmcmc_kinds) or 'none'}) at the "
              + fitted
              + f" (ar1, arp: at "
              f"their own mode from there; arp orders up to {ar_max_order})"
              + ("; the table's record without noise" if clean_input else "")
              + (f"; records and prediction low-passed at {lowpass_hz:g} Hz" if lowpass_hz
                 else ""))
    for i, child in enumerate(children):
        if i < first or i in done:
            continue
        row = (product_replicate(i, child, root, fit_evals, fit_runs, recentre,
                                 (tmcmc_kinds or [None])[0], truth, model, lowpass_hz,
                                 posterior_start) if product
               else replicate(i, child, root, kinds, tmcmc_kinds, tmcmc_population,
                              coarse_only, clean_input, ar_max_order, search_fit,
                              tmcmc_from_prior, lowpass_hz, fit_evals, tmcmc_runs,
                              case_search, truth))
        done[i] = row
        if hits_file is not None:
            with hits_file.open("a") as f:
                f.write(json.dumps(row) + "\n")
        line = [f"{k} {''.join('1' if h else '0' for h in v)}" for k, v in row["laplace"].items()]
        line += [f"tmcmc-{k} {''.join('1' if h else '0' for h in v)}"
                 for k, v in row["tmcmc"].items()]
        print(f"  replicate {i:2d}: " + "  ".join(line), flush=True)
    rows = [done[i] for i in sorted(done) if i < replicates]
    print("\nShare of replicates whose 90 % interval holds the truth (target 0.84–0.96), "
          "95 % Clopper–Pearson interval of the share below each figure; '*' marks a "
          "parameter whose interval excludes 0.90")
    out = coverage_table(rows, names)
    if any(row.get("search_converged") is not None for row in rows):
        # what the user is told: the search's verdict (its best found again, or not)
        for value, words in ((True, "converged"), (False, "not converged")):
            subset = [row for row in rows if row.get("search_converged") is value]
            print(f"\nThe {len(subset)} replicates whose search's verdict is '{words}':")
            if subset:
                out[f"search {words}"] = coverage_table(subset, names)
    for kind in sorted({k for row in rows for k in row.get("tmcmc_unsettled", {})}):
        # what the verdict promises: the settled parameters' intervals are to be trusted
        flagged = np.array([[n in row["tmcmc_unsettled"][kind] for n in names] for row in rows
                            if kind in row.get("tmcmc_unsettled", {})])
        hits = np.array([row["tmcmc"][kind] for row in rows
                         if kind in row.get("tmcmc_unsettled", {})])
        print(f"\nTMCMC ({kind}), the runs' verdict: unsettled in how many replicates, and the "
              "share of the settled ones whose interval holds the truth:")
        for j, n in enumerate(names):
            settled = hits[~flagged[:, j], j]
            share = f"{settled.mean():.2f} of {settled.size}" if settled.size else "–"
            print(f"   {n:4s} unsettled {int(flagged[:, j].sum()):2d}; settled: {share}")
        out[f"tmcmc {kind} verdict"] = {n: {"unsettled": int(flagged[:, j].sum()),
                                            "settled_hits": hits[~flagged[:, j], j].tolist()}
                                        for j, n in enumerate(names)}
    for kind in sorted({k for row in rows for k in row.get("start_warnings", {})}):
        # the start's verdict (femupdate.pipeline.posterior.start): what the user reads beside
        # the runs'
        warned = np.array([bool(row["start_warnings"][kind]) for row in rows])
        recentred = sum(row["recentred"][kind] > 0 for row in rows)
        trusted = np.array([[not w and n not in row["tmcmc_unsettled"][kind] for n in names]
                            for row, w in zip(rows, warned, strict=True)])
        hits = np.array([row["tmcmc"][kind] for row in rows])
        print(f"\nTMCMC ({kind}), the start's verdict: re-centred in {recentred} of "
              f"{len(rows)} replicates, a warning on the start in {int(warned.sum())}; the "
              "share holding the truth where neither the start nor the runs' verdict warns:")
        for j, n in enumerate(names):
            kept = hits[trusted[:, j], j]
            share = f"{kept.mean():.2f} of {kept.size}" if kept.size else "–"
            print(f"   {n:4s} {share}; of the warned, holding it: "
                  f"{int(hits[~trusted[:, j], j].sum())} of {int((~trusted[:, j]).sum())}")
        out[f"tmcmc {kind} start"] = {"recentred": int(recentred),
                                      "warned": int(warned.sum()),
                                      "trusted_hits": {n: hits[trusted[:, j], j].tolist()
                                                       for j, n in enumerate(names)}}
    for name, field in (("TMCMC", "tmcmc_evals"), ("the mode's climb", "mode_evals")):
        for kind in sorted({k for row in rows for k in row.get(field, {})}):
            evals = [row[field][kind] for row in rows if kind in row.get(field, {})]
            print(f"evaluations per replicate of {name} ({kind}): mean {np.mean(evals):.0f}, "
                  f"range {min(evals)}–{max(evals)}")
    print(f"(replicates run here in {time.perf_counter() - start:.0f} s; {load()})")
    return out


def coverage_table(rows: list[dict[str, Any]], names: tuple[str, ...]) -> dict[str, Any]:
    """Print, and return, each estimator's share of ``rows`` whose interval holds the truth,
    per parameter, with its Clopper–Pearson interval."""
    print(f"{'':14s} {'n':>3s} " + " ".join(f"{n:>9s}" for n in names))
    out: dict[str, Any] = {}
    for estimator in ("laplace", "tmcmc"):
        for kind in sorted({k for row in rows for k in row[estimator]}):
            hits = [row[estimator][kind] for row in rows if kind in row[estimator]]
            cov = coverage_row(np.array(hits))
            label = f"{estimator} {kind}"
            print(f"{label:14s} {len(hits):3d} " + " ".join(
                f"{s:8.2f}{'*' if not lo <= 0.9 <= hi else ' '}" for s, lo, hi in cov))
            print(f"{'':14s} {'':3s} " + " ".join(f"{lo:4.2f}–{hi:4.2f}" for _, lo, hi in cov))
            out[label] = {"replicates": len(hits),
                          **{n: {"share": s, "ci95": [lo, hi]}
                             for n, (s, lo, hi) in zip(names, cov, strict=True)}}
    kinds = sorted({k for row in rows for k in row.get("distance", {})})
    if kinds:
        print("\nThe truth's distance from the Laplace median in its interval's standard "
              "deviations (half-width / 1.645), root mean square over the replicates: 1 for "
              "calibrated Gaussian intervals, below 1 too wide, above 1 too narrow")
        for kind in kinds:
            d = np.array([row["distance"][kind] for row in rows if kind in row["distance"]])
            rms = np.sqrt(np.nanmean(d ** 2, axis=0))
            print(f"{'laplace ' + kind:14s} {len(d):3d} " + " ".join(f"{v:9.2f}" for v in rms))
            out[f"distance {kind}"] = dict(zip(names, rms.tolist(), strict=True))
    fitted = [row for row in rows if "fit_error" in row]
    if fitted:
        error = np.array([row["fit_error"] for row in fitted])
        widening = np.array([row["widening"] for row in fitted])
        spread = error.std(axis=0)
        # the parameter along which φ ripples most: the others' errors follow its valley
        lead = int(np.nanargmax(np.nanmedian(widening, axis=0)))
        correlation = np.corrcoef(error.T)[lead]
        print(f"\nThe fit's error (fit − truth in the unit cube) over the {len(fitted)} "
              "replicates: its standard deviation, the 1 % secant's interval over the local "
              "one's (i.i.d. shape), least and largest, and the error's correlation with "
              f"{names[lead]}'s (the widest secant)")
        for label, values in (("sd", spread), ("secant least", np.nanmin(widening, axis=0)),
                              ("secant largest", np.nanmax(widening, axis=0)),
                              (f"corr {names[lead]}", correlation)):
            print(f"{label:18s} " + " ".join(f"{v:9.3g}" for v in values))
        out["fit error"] = {"sd": spread.tolist(), "correlation": correlation.tolist(),
                            "secant": [np.nanmin(widening, axis=0).tolist(),
                                       np.nanmax(widening, axis=0).tolist()]}
    return out


# -------------------------------------------------------------------------------- ripples


def ripples(root: Path, lowpasses: tuple[float | None, ...] = (None, 100.0, 60.0)
            ) -> dict[str, Any]:
    """φ along kp1 around the truth (±5 % of its range, 101 points) on both bridges with 2 %
    noise, without and with low-passes: its local extrema (ripples) and how far it swings."""
    print(f"\n## kp1's ripples: local extrema of φ over ±5 % of kp1's range ({load()})")
    out: dict[str, Any] = {}
    for model in ("viscous", "friction"):
        for lowpass in lowpasses:
            problem = bridge_problem(model, bridge.truth(model), root / f"ripples-{model}",
                                     seed=1, lowpass_hz=lowpass)
            prior = Prior.from_case(problem.case)
            truth = prior.from_physical(np.array([bridge.truth(model)[n]
                                                  for n in prior.names]))
            rows = np.repeat(truth[None], 101, axis=0)
            j = list(prior.names).index("kp1")
            rows[:, j] += np.linspace(-0.05, 0.05, 101)
            phi = problem.evaluate_batch(prior.to_search(rows))
            extrema = int(np.sum(np.diff(np.sign(np.diff(phi))) != 0))
            label = "none" if lowpass is None else f"{lowpass:g} Hz"
            print(f"{model:9s} low-pass {label:7s}: {extrema:3d} local extrema, φ from "
                  f"{phi.min():.4g} to {phi.max():.4g}")
            out[f"{model} {label}"] = {"extrema": extrema, "phi": [phi.min(), phi.max()]}
    return out


# -------------------------------------------------------------------------------- whitening


def mahalanobis(d: np.ndarray, cov: np.ndarray, keep: np.ndarray) -> float:
    """dᵀ Σ⁻¹ d over the parameters ``keep`` (the marginal Gaussian of those)."""
    d, cov = d[keep], cov[np.ix_(keep, keep)]
    return float(d @ np.linalg.solve(cov, d))


def whitening(replicates: int, seeds: int, root: Path) -> dict[str, Any]:
    """The hypothesis that arp, centred at its own mode, is calibrated: on the calibration's
    first replicates, dᵀΣ⁻¹d of the truth (χ²₈ if calibrated: mean 8, 95 % below 15.5; kp1
    aside, whose local curvature is a ripple's) under the sandwich at the least-squares fit,
    arp's Gaussian there and at arp's mode, with the table's record noisy (as measured) and
    clean (noise on the outputs only); then, at the bridge's nominal truth over ``seeds``
    noise draws, the scatter of the least-squares fit and of arp's mode in units of arp's
    standard deviations (1 if arp's curvature is right)."""
    from error_models.sandwich import sandwich_covariance

    children = np.random.SeedSequence(SEED).spawn(max(replicates, 1))
    print(f"\n## Whitening: arp at its own mode ({load()})")
    print("dᵀΣ⁻¹d of the truth, kp1 aside (χ²₈: mean 8, 95 % below 15.5)")
    print(f"{'replicate':>9s} {'table':>6s} {'sandwich@fit':>13s} {'arp@fit':>9s} "
          f"{'arp@mode':>9s} {'mode evals':>10s}")
    out: dict[str, Any] = {"replicates": [], "seeds": {}}
    for i, child in enumerate(children[:replicates]):
        for clean in (False, True):
            rng = np.random.default_rng(child)
            case = parse_case(bridge.bridge_case("viscous", "narrow", directory=str(root)),
                              source=root / "viscous.toml")
            prior = Prior.from_case(case)
            truth = prior.sample(rng, 1)[1][0]
            keep = np.array([n != "kp1" for n in prior.names])
            problem = bridge_problem("viscous", dict(zip(prior.names, truth.tolist(),
                                                         strict=True)),
                                     root / f"whitening-{i}-{clean}",
                                     int(rng.integers(2 ** 31)), clean)
            t_unit = prior.from_physical(truth)
            unit, r, _ = local_fit(problem, t_unit)
            jac = jacobian_unit(problem.residuals_batch, unit, prior, step=LOCAL_STEP)
            model = problem_error_model(problem, r, "arp")
            fit_cov = laplace(jac, r, unit, model, prior).cov_unit
            centre, ((r_c, jac_c),), evals = mode_jacobians(problem, prior, model, unit, r,
                                                            jac, steps=(LOCAL_STEP,))
            mode_cov = laplace(jac_c, r_c, centre, model, prior).cov_unit
            sandwich = sandwich_covariance(jac, r, residual_blocks(problem)[0])
            row = {"replicate": i, "clean_input": clean,
                   "sandwich_at_fit": mahalanobis(t_unit - unit, sandwich, keep),
                   "arp_at_fit": mahalanobis(t_unit - unit, fit_cov, keep),
                   "arp_at_mode": mahalanobis(t_unit - centre, mode_cov, keep),
                   "mode_evals": evals}
            out["replicates"].append(row)
            print(f"{i:9d} {'clean' if clean else 'noisy':>6s} {row['sandwich_at_fit']:13.1f} "
                  f"{row['arp_at_fit']:9.1f} {row['arp_at_mode']:9.1f} {evals:10d}",
                  flush=True)
    case = parse_case(bridge.bridge_case("viscous", "narrow", directory=str(root)),
                      source=root / "viscous.toml")
    prior = Prior.from_case(case)
    names = list(prior.names)
    truth = np.array([bridge.truth("viscous")[n] for n in names])
    t_unit = prior.from_physical(truth)
    for clean in (False, True):
        fits, modes, sds = [], [], []
        for s in range(seeds):
            problem = bridge_problem("viscous", bridge.truth("viscous"),
                                     root / f"seeds-{s}-{clean}", 1000 + s, clean)
            unit, r, _ = local_fit(problem, t_unit)
            jac = jacobian_unit(problem.residuals_batch, unit, prior, step=LOCAL_STEP)
            model = problem_error_model(problem, r, "arp")
            centre, ((r_c, jac_c),), _ = mode_jacobians(problem, prior, model, unit, r, jac,
                                                        steps=(LOCAL_STEP,))
            fits.append(unit)
            modes.append(centre)
            sds.append(np.sqrt(np.diag(laplace(jac_c, r_c, centre, model, prior).cov_unit)))
        sd = np.mean(sds, axis=0)
        fit_scatter = np.std(fits, axis=0, ddof=1) / sd
        mode_scatter = np.std(modes, axis=0, ddof=1) / sd
        label = "clean" if clean else "noisy"
        print(f"\nnominal truth, {seeds} noise draws, table {label}: scatter over the draws in "
              "units of arp's sd at its mode (1 if arp's curvature is right; kp1's local "
              "curvature is a ripple's)")
        print(f"{'':16s}" + " ".join(f"{n:>6s}" for n in names))
        print(f"{'least squares':16s}" + " ".join(f"{v:6.2f}" for v in fit_scatter))
        print(f"{'arp mode':16s}" + " ".join(f"{v:6.2f}" for v in mode_scatter))
        out["seeds"][label] = {"least_squares": fit_scatter.tolist(),
                               "arp_mode": mode_scatter.tolist()}
    return out


# -------------------------------------------------------------------------------- real


def real_trials(kinds: list[str]) -> dict[str, Any]:
    """Each of the six trials of the real 1-storey specimen (examples/minishake-1story)
    fitted alone with the linear storey (multistart-lm, 600 evaluations), and the Laplace
    record's 90 % intervals of k1 and c1 under each error model kind: one specimen, so the
    trials' intervals say how far each kind's width covers what changes between trials."""
    import copy
    import tomllib

    from femupdate.inference.best_fit import laplace_record

    source = Path(__file__).resolve().parents[1] / "examples" / "minishake-1story" / "trials.toml"
    spec = tomllib.loads(source.read_text())
    print(f"\n## Real trials, fitted one by one: 90 % intervals of k1 (N/m) and c1 (N·s/m) "
          f"({load()})")
    out: dict[str, Any] = {}
    for trial in spec["trials"]:
        alone = copy.deepcopy(spec)
        alone["trials"] = [dict(trial, role="fit")]
        case = parse_case(alone, source=source)
        try:
            problem = UpdateProblem(case, load_experiments(case))
        except FemupdateError as exc:  # the shared records are not beside the repository
            print(f"  skipped: {exc}")
            return out
        fit = minimize(problem.residuals, problem.bounds, "multistart-lm", residuals=True,
                       seed=np.random.default_rng(0), max_evals=600)
        row: dict[str, Any] = {"phi": float(fit.fun)}
        line = f"  {trial['name']:13s} φ {fit.fun:.4f}"
        for kind in kinds:
            record = laplace_record(problem, fit.x, kind=kind)
            if record.note:
                line += f" | {kind}: {record.note}"
                continue
            k1, c1 = record.params["k1"], record.params["c1"]
            row[kind] = {"k1": [k1.q05, k1.q95], "c1": [c1.q05, c1.q95]}
            line += (f" | {kind} k1 {k1.q05:.0f}–{k1.q95:.0f} c1 "
                     f"{c1.q05:.3f}–{c1.q95:.3f}")
        print(line, flush=True)
        out[trial["name"]] = row
    return out


# -------------------------------------------------------------------------------- speed


def emcee_run(problem: UpdateProblem, model: Any, prior: Prior, lap: Any,
              rng: np.random.Generator, walkers: int, target_ess: float,
              max_evals: int) -> dict[str, Any]:
    """emcee on the same log-posterior (unit cube, batches), from the Laplace Gaussian,
    until its effective sample size (ArviZ, second half of the chains) reaches
    ``target_ess`` or ``max_evals``; its cost, and the second half's samples."""
    import arviz
    import emcee

    calls = {"evals": 0}

    def log_posterior(unit: np.ndarray) -> np.ndarray:
        unit = np.atleast_2d(unit)
        lp = prior.logpdf_unit(unit)
        out = np.full(unit.shape[0], -np.inf)
        ok = np.isfinite(lp)
        if np.any(ok):
            rows = problem.residuals_batch(prior.to_search(unit[ok]))
            calls["evals"] += int(ok.sum())
            out[ok] = lp[ok] + model.loglike_rows(rows)
        return out

    cov = lap.cov_unit
    start = np.empty((0, prior.dim))
    while start.shape[0] < walkers:  # the Laplace Gaussian truncated to the cube
        draws = rng.multivariate_normal(np.clip(lap.mean_unit, 0, 1), cov, size=10 * walkers)
        start = np.vstack([start, draws[np.all((draws > 0) & (draws < 1), axis=1)]])
    start = start[:walkers]
    sampler = emcee.EnsembleSampler(walkers, prior.dim, log_posterior, vectorize=True)
    sampler.random_state = np.random.RandomState(int(rng.integers(2 ** 31))).get_state()
    t0, c0 = time.perf_counter(), time.process_time()
    state = start
    ess = 0.0
    while calls["evals"] < max_evals:
        state = sampler.run_mcmc(state, 100, progress=False)
        chain = sampler.get_chain()  # (steps, walkers, n)
        half = chain[chain.shape[0] // 2:]
        ess = min(float(arviz.ess(np.ascontiguousarray(half[:, :, i].T), method="bulk"))
                  for i in range(prior.dim))
        if ess >= target_ess:
            break
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    chain = sampler.get_chain()
    return {"evals": calls["evals"], "seconds": seconds, "cpu_seconds": cpu, "ess": ess,
            "steps": int(chain.shape[0]),
            "samples": chain[chain.shape[0] // 2:].reshape(-1, prior.dim)}


class ThreadedBatches:
    """A problem whose residual batches run over ``threads`` threads (its ``residuals`` method
    is what ``run_tmcmc`` takes: a population goes in one ``residuals_batch`` call)."""

    def __init__(self, problem: UpdateProblem, threads: int) -> None:
        self.problem, self.threads = problem, threads

    def residuals(self, x: np.ndarray) -> np.ndarray:
        return self.problem.residuals(x)

    def residuals_batch(self, X: np.ndarray) -> np.ndarray:
        return self.problem.residuals_batch(X, threads=self.threads)


def speed(population: int, steps: int, root: Path, emcee_max: int,
          threads: int = 1, moves: dict[str, Any] | None = None, kind: str = "neff"
          ) -> dict[str, Any]:
    moves = MOVES if moves is None else moves
    rng = np.random.default_rng(SEED)
    problem = bridge_problem("viscous", bridge.truth("viscous"), root / "speed", seed=1)
    t0 = time.perf_counter()
    unit, r, fit_evals, _ = best_fit(problem, rng)
    fit_s = time.perf_counter() - t0
    lap, model, prior = laplace_of(problem, unit, r, kind)
    print(f"\n## Speed: viscous bridge, 9 parameters, 2 % noise, error model {kind!r} "
          f"({load()})")
    print(f"best fit: {fit_evals} evaluations in {fit_s:.1f} s; Laplace: {2 * prior.dim} "
          f"evaluations")
    for sentence in lap.sentences:
        print("  " + sentence)
    t0, c0 = time.perf_counter(), time.process_time()
    fun = ThreadedBatches(problem, threads).residuals if threads > 1 else problem.residuals
    post, _ = run_tmcmc(fun, prior, model, seed=rng, population=population,
                        steps=steps, reference=(lap.mean_unit, lap.cov_unit), **moves)
    tm_s, tm_cpu = time.perf_counter() - t0, time.process_time() - c0
    # the CPU time of this process: what the wall time would be on an otherwise idle core
    print(f"TMCMC (population {population}, {threads} thread(s)): {post.evaluations} "
          f"evaluations in {tm_s:.1f} s "
          f"wall, {tm_cpu:.1f} s CPU ({load()}), "
          f"{len(post.stages)} stages, ESS {post.ess:.0f} -> "
          f"{post.evaluations / post.ess:.1f} evaluations per effective sample (ESS: the "
          f"smaller of the ancestry and last-resampling estimates, worst parameter); "
          f"log Z {post.log_evidence:.3f}")
    for s in post.stages:
        print(f"   β {s['beta']:.4f}  acceptance {s['acceptance']:.2f}  weights ESS "
              f"{s['weights_ess']:.0f}  evaluations {s['evaluations']}")
    samples = prior.to_physical(post.samples)
    q = np.quantile(samples, [0.05, 0.5, 0.95], axis=0)
    for i, name in enumerate(prior.names):
        print(f"   {name:4s} 5/50/95 %: {q[0, i]:.4g} {q[1, i]:.4g} {q[2, i]:.4g}")
    em = emcee_run(problem, model, prior, lap, rng, walkers=36, target_ess=post.ess,
                   max_evals=emcee_max)
    print(f"emcee (36 walkers): {em['evals']} evaluations in {em['seconds']:.1f} s wall, "
          f"{em['cpu_seconds']:.1f} s CPU ({load()}), {em['steps']} steps, ESS "
          f"{em['ess']:.0f} (ArviZ bulk, second half) "
          f"-> {em['evals'] / max(em['ess'], 1e-9):.1f} evaluations per effective sample")
    ratio = (em["evals"] / max(em["ess"], 1e-9)) / (post.evaluations / post.ess)
    print(f"evaluations per effective sample, emcee / TMCMC: {ratio:.1f}")
    return {"tmcmc": {"evals": post.evaluations, "seconds": tm_s, "cpu_seconds": tm_cpu,
                      "ess": post.ess, "population": population,
                      "stages": len(post.stages), "log_z": post.log_evidence},
            "emcee": {k: v for k, v in em.items() if k != "samples"}, "ratio": ratio,
            "fit_evals": fit_evals,
            "sentences": lap.sentences}


def friction(population: int, steps: int, root: Path,
             moves: dict[str, Any] | None = None, kind: str = "neff") -> dict[str, Any]:
    moves = MOVES if moves is None else moves
    rng = np.random.default_rng(SEED)
    problem = bridge_problem("friction", bridge.truth("friction"), root / "friction", seed=1)
    t0 = time.perf_counter()
    unit, r, fit_evals, _ = best_fit(problem, rng, max_evals=3000)
    fit_s = time.perf_counter() - t0
    lap, model, prior = laplace_of(problem, unit, r, kind)
    t1 = time.perf_counter()
    post, _ = run_tmcmc(problem.residuals, prior, model, seed=rng, population=population,
                        steps=steps, reference=(lap.mean_unit, lap.cov_unit), **moves)
    tm_s = time.perf_counter() - t1
    print(f"\n## Friction bridge, 13 parameters, 2 % noise, error model {kind!r} ({load()})")
    print(f"best fit {fit_evals} evaluations {fit_s:.1f} s; TMCMC {post.evaluations} "
          f"evaluations {tm_s:.1f} s, {len(post.stages)} stages, ESS {post.ess:.0f}, "
          f"reached {post.reached}; total {time.perf_counter() - t0:.1f} s")
    return {"fit_evals": fit_evals, "fit_seconds": fit_s, "evals": post.evaluations,
            "seconds": tm_s, "ess": post.ess}


def across_seed_interval(across: np.ndarray, seeds: int, level: float = 0.90
                         ) -> tuple[np.ndarray, np.ndarray]:
    """The ``level`` interval of an ESS measured across ``seeds`` runs (posterior variance over
    the variance of the seeds' means): that variance has seeds − 1 degrees of freedom, so the
    ESS is known within a χ² factor (at 10 seeds 0.37–1.88 of the value, at 20 0.53–1.59)."""
    from scipy.stats import chi2

    dof = seeds - 1
    return (across * chi2.ppf(0.5 - level / 2, dof) / dof,
            across * chi2.ppf(0.5 + level / 2, dof) / dof)


def evidence(population: int, steps: int, root: Path, seeds: int,
             moves: dict[str, Any] | None = None, threads: int = 1,
             model_name: str = "viscous", kind: str = "neff") -> dict[str, Any]:
    moves = MOVES if moves is None else moves
    rng = np.random.default_rng(SEED)
    problem = bridge_problem(model_name, bridge.truth(model_name), root / model_name, seed=1)
    # the friction bridge's best fit as its section takes it (3,000 evaluations)
    unit, r, _, _ = best_fit(problem, rng, **({"max_evals": 3000} if model_name == "friction"
                                           else {}))
    lap, model, prior = laplace_of(problem, unit, r, kind)
    truth = prior.from_physical(np.array([bridge.truth(model_name)[n] for n in prior.names]))
    fun = ThreadedBatches(problem, threads).residuals if threads > 1 else problem.residuals
    log_z, means, variances, ess, evals, walls = [], [], [], [], [], []
    runs_samples, runs_ess = [], []
    inside = np.zeros(prior.dim, dtype=int)
    t0 = time.perf_counter()
    for child in np.random.SeedSequence(SEED + 1).spawn(seeds):
        t1 = time.perf_counter()
        post, _ = run_tmcmc(fun, prior, model, seed=child, population=population,
                            steps=steps, reference=(lap.mean_unit, lap.cov_unit), **moves)
        walls.append(time.perf_counter() - t1)
        log_z.append(post.log_evidence)
        means.append(post.samples.mean(axis=0))
        variances.append(post.samples.var(axis=0))
        ess.append(post.ess)
        runs_samples.append(prior.to_search(post.samples))
        runs_ess.append(post.ess_params)
        evals.append(post.evaluations)
        q = np.quantile(post.samples, [0.05, 0.95], axis=0)
        inside += (q[0] <= truth) & (truth <= q[1])
    across = np.mean(variances, axis=0) / np.var(means, axis=0, ddof=1)
    low, high = across_seed_interval(across, seeds)
    worst = int(np.argmin(across))
    print(f"\n## Evidence over {seeds} seeds ({model_name} bridge, error model {kind!r}, "
          f"population {population}, moves {moves}, {threads} thread(s); "
          f"{time.perf_counter() - t0:.0f} s, {load()})")
    print(f"log Z: mean {np.mean(log_z):.3f}, sd {np.std(log_z, ddof=1):.3f}, range "
          f"[{min(log_z):.3f}, {max(log_z):.3f}]")
    print(f"ESS per run: estimated {np.mean(ess):.0f} (min over parameters); measured across "
          f"the seeds per parameter (posterior variance / variance of the means; 90 % "
          f"interval from the {seeds} seeds):")
    for i, name in enumerate(prior.names):
        print(f"   {name:4s} {across[i]:7.0f}  [{low[i]:.0f}, {high[i]:.0f}]")
    print(f"evaluations per run: {np.mean(evals):.0f}; wall per run {np.mean(walls):.1f} s "
          f"(max {max(walls):.1f} s); worst parameter {prior.names[worst]}: "
          f"{np.mean(evals) / across[worst]:.1f} evaluations per effective sample")
    print("truth inside the 90 % interval, runs of " + str(seeds) + ": "
          + " ".join(f"{n} {k}" for n, k in zip(prior.names, inside, strict=True)))
    verdicts = product_verdicts(runs_samples, runs_ess, list(prior.names))
    return {"verdicts": verdicts, "log_z": log_z, "ess_estimated": ess,
            "ess_across_seeds": across.tolist(),
            "ess_across_low": low.tolist(), "ess_across_high": high.tolist(),
            "evals": evals, "walls": walls, "truth_inside": inside.tolist()}


def product_verdicts(samples: list[np.ndarray], ess: list[np.ndarray], names: list[str],
                     runs: int = DEFAULT_POSTERIOR.runs) -> list[list[str]]:
    """``femupdate posterior``'s verdict (its default number of runs) on consecutive sets of
    these runs: the parameters each set calls unsettled, and how often each is."""
    sets = [runs_agreement(samples[k:k + runs], ess[k:k + runs], names)
            for k in range(0, len(samples) - runs + 1, runs)]
    counts = {n: sum(n in a.unsettled for a in sets) for n in names}
    print(f"femupdate posterior's verdict on {len(sets)} sets of {runs} of these runs: "
          + ("; ".join(f"set {i}: " + (", ".join(a.unsettled) or "all settled")
                       for i, a in enumerate(sets))))
    print("   unsettled in how many sets: " + " ".join(f"{n} {k}" for n, k in counts.items()))
    print(f"   smallest ESS of each set: {', '.join(f'{np.min(a.ess):.0f}' for a in sets)}")
    return [a.unsettled for a in sets]


def moves_of(args: argparse.Namespace) -> dict[str, Any]:
    """MOVES with the command line's overrides."""
    moves = dict(MOVES)
    if args.proposal is not None:
        moves["proposal"] = args.proposal
    if args.final_steps is not None:
        moves["final_steps"] = args.final_steps
    if args.components is not None:
        moves["components"] = args.components
    return moves


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="CI: analytic + a small run")
    parser.add_argument("--only", default="analytic,calibration,speed,friction,evidence")
    parser.add_argument("--replicates", type=int, default=50)
    parser.add_argument("--first-replicate", type=int, default=0,
                        help="calibration: start at this replicate (split a run over processes)")
    parser.add_argument("--kinds", default=",".join((*KINDS, SANDWICH, GLS_SANDWICH,
                                                     EIV_SANDWICH)),
                        help="calibration: the error model kinds (Laplace intervals), "
                        "'sandwich' (the least-squares estimate's sandwich covariance), "
                        "'gls-sandwich' (arp's mode with its estimate's sandwich covariance) "
                        "and 'curvature', 'curvature-local' (TMCMC of the curvature-adjusted "
                        "i.i.d. likelihood, C from the 1 %% or the local Jacobian)")
    parser.add_argument("--tmcmc-kinds", default="",
                        help="calibration (and rayleigh, with --rayleigh-kinds: its whitening "
                        "kinds): kinds whose TMCMC intervals are measured too; with --product "
                        "(rayleigh: without --rayleigh-kinds), the first is femupdate "
                        "posterior's [posterior] error_model")
    parser.add_argument("--tmcmc-population", type=int, default=1000)
    parser.add_argument("--tmcmc-runs", type=int, default=1,
                        help="calibration: TMCMC runs per replicate, pooled, with the product's "
                        "verdict on them (femupdate posterior: 4)")
    parser.add_argument("--coarse-jacobian", action="store_true",
                        help="calibration: the Jacobian over 1 %% of each range for every "
                        "parameter (before: the Laplace record's two scales)")
    parser.add_argument("--search-fit", action="store_true",
                        help="calibration: the best fit of multistart-lm (2,000 evaluations) "
                        "instead of a local search started at the truth")
    parser.add_argument("--case-search", action="store_true",
                        help="calibration: the best fit of the example's own [search] "
                        "(f_target removed), as `femupdate run` ends on it")
    parser.add_argument("--fit-evals", type=int, default=FIT_EVALS,
                        help="calibration with --search-fit: multistart-lm's budget")
    parser.add_argument("--product", action="store_true",
                        help="calibration: each replicate through femupdate posterior itself "
                             "(the case's search, default [posterior] but its error model, the "
                             "first of --tmcmc-kinds), without and with re-centring")
    parser.add_argument("--truth", type=Path, default=None,
                        help="calibration: a JSON file of the truth (by parameter name) "
                        "every replicate has (only the noise fresh), e.g. "
                        "examples/bridge/truth-viscous.json")
    parser.add_argument("--bridge-model", choices=("viscous", "friction"), default="viscous",
                        help="calibration with --product: the bridge's model class (with "
                        "--truth examples/bridge/truth-friction.json for the friction bridge "
                        "at its truth)")
    parser.add_argument("--fit-runs", type=int, default=1,
                        help="with --product: the case's [search] runs (0: the example case's "
                        "own [search], f_target removed, as a user runs it)")
    parser.add_argument("--recentre", type=int, default=2,
                        help="with --product: [posterior] recentre of the second pass")
    parser.add_argument("--rayleigh-kinds", default="",
                        help="rayleigh: instead of femupdate posterior, the Laplace intervals "
                        "of these kinds (and 'sandwich') at the search's best fit")
    parser.add_argument("--tmcmc-from-prior", action="store_true",
                        help="calibration: TMCMC's first population from the prior, not from "
                        "the Laplace Gaussian")
    parser.add_argument("--posterior-start", choices=("laplace", "prior"), default=None,
                        help="calibration with --product: [posterior] start (the default: "
                        "the case's, the Laplace Gaussian)")
    parser.add_argument("--lowpass-hz", type=float, default=None,
                        help="calibration: [preprocess] lowpass_hz of the bridge case (below "
                        "the abutment modes near 226 Hz: kp1's valley without its ripples)")
    parser.add_argument("--clean-input", action="store_true",
                        help="calibration: the table's record without noise (outputs only)")
    parser.add_argument("--ar-max-order", type=int, default=AR_MAX_ORDER,
                        help="calibration: the largest AR order of kind arp (by BIC)")
    parser.add_argument("--whitening-replicates", type=int, default=8,
                        help="whitening: the calibration replicates it looks at")
    parser.add_argument("--noise-seeds", type=int, default=16,
                        help="whitening: noise draws at the nominal truth")
    parser.add_argument("--hits", type=Path, default=None,
                        help="calibration: JSON lines of the replicates (resume, merge)")
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--evidence-population", type=int, default=1000,
                        help="evidence: TMCMC's population (its ESS is measured across the "
                        "seeds too: 6000 checks the speed section's effective samples)")
    parser.add_argument("--evidence-model", choices=("viscous", "friction"), default="viscous",
                        help="evidence: the bridge whose posterior is sampled")
    parser.add_argument("--population", type=int, default=2000)
    parser.add_argument("--steps", type=int, default=3)
    parser.add_argument("--threads", type=int, default=1,
                        help="speed: threads over which TMCMC's populations are evaluated")
    parser.add_argument("--proposal", default=None,
                        help="speed, friction, evidence: TMCMC's proposal (default: MOVES')")
    parser.add_argument("--components", type=int, default=None,
                        help="speed, friction, evidence: the mixture proposal's components")
    parser.add_argument("--final-steps", type=int, default=None,
                        help="speed, friction, evidence: TMCMC's steps at β = 1")
    parser.add_argument("--error-model", default="neff",
                        help="speed, friction, evidence: the error model sampled (default "
                        "neff, as the figures quoted without it)")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    warnings.filterwarnings("ignore", category=FutureWarning)  # ArviZ's refactor notice
    sections = args.only.split(",")
    root = Path(tempfile.mkdtemp(prefix="femupdate-posterior-"))
    out: dict[str, Any] = {}
    if args.quick:
        out["analytic"] = analytic(4000)
        out["speed"] = speed(400, args.steps, root, emcee_max=8000, kind=args.error_model)
        out["calibration"] = calibration(1, root, kinds=["eiv", EIV_SANDWICH])
    else:
        if "analytic" in sections:
            out["analytic"] = analytic(4000)
        if "calibration" in sections:
            out["calibration"] = calibration(
                args.replicates, root, args.first_replicate, kinds=args.kinds.split(","),
                tmcmc_kinds=[k for k in args.tmcmc_kinds.split(",") if k],
                tmcmc_population=args.tmcmc_population, hits_file=args.hits,
                coarse_only=args.coarse_jacobian, clean_input=args.clean_input,
                ar_max_order=args.ar_max_order, search_fit=args.search_fit,
                tmcmc_from_prior=args.tmcmc_from_prior, lowpass_hz=args.lowpass_hz,
                fit_evals=args.fit_evals, tmcmc_runs=args.tmcmc_runs, product=args.product,
                fit_runs=args.fit_runs, recentre=args.recentre,
                posterior_start=args.posterior_start,
                truth=None if args.truth is None else json.loads(args.truth.read_text()),
                model=args.bridge_model, case_search=args.case_search)
        if "rayleigh" in sections:
            out["rayleigh"] = rayleigh(args.replicates, root, args.fit_evals, args.hits,
                                       [k for k in args.rayleigh_kinds.split(",") if k],
                                       tuple(k for k in args.tmcmc_kinds.split(",") if k))
        if "real" in sections:
            out["real"] = real_trials(["neff"])
        if "ripples" in sections:
            out["ripples"] = ripples(root)
        if "whitening" in sections:
            out["whitening"] = whitening(args.whitening_replicates, args.noise_seeds, root)
        if "speed" in sections:
            out["speed"] = speed(args.population, args.steps, root, emcee_max=200_000,
                                 threads=args.threads, moves=moves_of(args),
                                 kind=args.error_model)
        if "friction" in sections:
            out["friction"] = friction(2000, args.steps, root, moves=moves_of(args),
                                       kind=args.error_model)
        if "evidence" in sections:
            out["evidence"] = evidence(args.evidence_population, args.steps, root, args.seeds,
                                       moves=moves_of(args), threads=args.threads,
                                       model_name=args.evidence_model,
                                       kind=args.error_model)
    if args.json is not None:
        args.json.write_text(json.dumps(out, indent=1, default=float))


if __name__ == "__main__":
    main()

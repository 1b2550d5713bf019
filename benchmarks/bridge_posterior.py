"""``femupdate posterior`` on the bridge with 2 % noise (viscous, or friction with --model):
what it says of each parameter, beside the Laplace approximation at the best fit, with its
evaluations and wall time, and beside emcee on the same likelihood.

    python benchmarks/bridge_posterior.py [--model viscous|friction] [--samples N]
        [--runs R] [--max-runs M] [--recentre K] [--error-model KIND] [--workers W]
        [--seed 1] [--noise-seed 0] [--out DIR] [--emcee-steps 3000] [--quick]
        [--case CASE.toml [--from RESULTS]] [--final importance [--run-ess E]]

The case has no ``[posterior]`` section, and ``--samples``, ``--runs``, ``--max-runs``,
``--recentre`` and ``--error-model`` are ``run_posterior``'s overrides: without them, the
product's default path (no option set by hand; its seed is the search's, ``--seed``).
``--workers`` (default 1) is the case's ``[search] workers``, which the sampler uses too.
``--quick`` (a smoke run for CI): 300 samples per run after a search of 2 runs of 600
evaluations, and 200 emcee steps.

**emcee, the peer.** In the same run, emcee's affine-invariant ensemble (4n walkers, started
from n·4 of the posterior's own samples, jittered) samples the same posterior density: the
error model the posterior measured at its (last) best fit, the same prior, on the same unit
cube, each step's walkers one ``residuals_batch``. Its effective samples are ArviZ's bulk ESS
of each parameter over the steps after the first third (the burn-in, whose evaluations count
all the same). Printed for both: evaluations, least ESS, evaluations per effective sample, the
ratio; and each parameter's mean and sd beside emcee's (Δ mean in emcee's sds, sd ratio): the
two samplers must agree on the posterior before their costs are compared. A third estimate,
independent of both samplers' moves, ends it: importance sampling of the same density from a
Student-t mixture fitted to both samplers' samples (40,000 draws; 2,000 with ``--quick``).

The virtual experiment of ``femupdate bench bridge --model MODEL`` (2 % noise, drawn from
``--noise-seed``), or with ``--case`` a case of the bridge and its records as they are (the
record of ``femupdate synth --seed 777``, say; ``--from`` the results of ``femupdate run`` on
it, whose search is then not run again), the
case of ``examples/bridge/MODEL-narrow.toml`` with a short search (2 runs of multistart-lm, 3,000
evaluations each, no target: the records are noisy), then TMCMC. Prints the sampler's
evaluations, wall time, effective sample size, stages and log-evidence, the runs' verdict
(whether they agree) with each parameter's effective samples and R̂, the sentences of the
posterior and of the Laplace approximation, the truth's place in each 90 % interval, the
frequency posteriors and the predictive bands' coverage, with the load average (the machine
may be shared: wall times are inflated by other jobs).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from femupdate.case import Case, load_case, parse_case
from femupdate.inference.best_fit import case_priors
from femupdate.inference.importance import (
    defensive_mixture,
    importance_ess,
    kish_ess,
    normalised_weights,
)
from femupdate.inference.tmcmc import safe_cholesky
from femupdate.paper.problems.bridge import bridge_case, ensure_records, truth
from femupdate.pipeline.posterior.run import PosteriorResult, run_posterior
from femupdate.runs import Execution


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", choices=("viscous", "friction"), default="viscous")
    parser.add_argument("--samples", type=int, default=None)
    parser.add_argument("--runs", type=int, default=None)
    parser.add_argument("--max-runs", type=int, default=None)
    parser.add_argument("--recentre", type=int, default=None)
    parser.add_argument("--error-model", default=None)
    parser.add_argument("--emcee-steps", type=int, default=3000)
    parser.add_argument("--final", choices=("moves", "importance"), default=None,
                        help="TMCMC's last stage (default: the product's)")
    parser.add_argument("--run-ess", type=int, default=None,
                        help="with --final importance: each run's ESS per parameter")
    parser.add_argument("--noise-seed", type=int, default=0, help="the record's noise")
    parser.add_argument("--case", type=Path, default=None,
                        help="a case file of the bridge with its records, taken as it is")
    parser.add_argument("--from", dest="search_from", type=Path, default=None,
                        help="with --case: the results of `femupdate run` on it")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--quick", action="store_true", help="300 samples, a short search (CI)")
    args = parser.parse_args(argv)
    if args.quick:
        args.samples, args.emcee_steps = 300, 200
    out = args.out or Path(tempfile.mkdtemp(prefix="femupdate-bridge-posterior-"))
    data = (out / "data").resolve()
    spec = bridge_case(args.model, "narrow", directory=str(data))
    spec["search"].update(runs=2, f_target=None, max_evals=600 if args.quick else 3000,
                          seed=args.seed,
                          workers=args.workers)
    truth_values = truth(args.model)
    if args.case is not None:  # the user's records of the bridge, its case as it is
        case = load_case(args.case)
    else:
        case = parse_case(spec, source=out / f"{args.model}-narrow.toml")
        ensure_records(case, truth_values, data, seed=args.noise_seed, snr=0.02)
    start = time.perf_counter()
    tmcmc = {k: v for k, v in (("final", args.final), ("ess", args.run_ess)) if v is not None}
    # the case has no [posterior] section: what is not given here is the product's default
    result = run_posterior(case, out / "results", restart=True, search_from=args.search_from,
                           samples=args.samples, runs=args.runs, max_runs=args.max_runs,
                           recentre=args.recentre, error_model=args.error_model,
                           execution=Execution(label="bridge posterior"), tmcmc=tmcmc)
    wall = time.perf_counter() - start
    rec = result.record
    print(f"TMCMC: {rec.message}; {rec.samples:,} samples, {rec.nfev:,} evaluations in "
          f"{rec.wall_s:.1f} s, the runs' times summed ({rec.nfev / rec.ess:.1f} evaluations "
          f"per effective sample), ESS {rec.ess:,.0f}, log-evidence {rec.log_evidence:.3f}"
          f"{rec.evidence_spread()}; search + sampler + modes + bands {wall:.1f} s; "
          f"load average {os.getloadavg()[0]:.2f}")
    print(f"verdict: {rec.agreement}")
    for warning in rec.start_warnings:  # femupdate.pipeline.posterior.start
        print(f"start: {warning}")
    print("effective samples (R̂): " + ", ".join(
        f"{n} {rec.ess_params[n]:,.0f} ({rec.rhat[n]:.3f})" if rec.rhat.get(n) is not None
        else f"{n} {rec.ess_params[n]:,.0f}" for n in rec.names))
    print("stages of the first run (β, acceptance, ESS of the weights): " + "; ".join(
        f"{s.beta:.4g}, {s.acceptance:.2f}, {s.ess:.0f}" for s in rec.stages))
    print("\nposterior:\n  " + "\n  ".join(rec.sentences))
    print("Laplace at the best fit:\n  " + "\n  ".join(result.summary.laplace.sentences))
    inside = [n for n, m in rec.params.items() if m.q05 <= truth_values[n] <= m.q95]
    print(f"\ntruth inside the posterior's 90 % interval: {len(inside)}/{len(rec.params)} "
          f"({', '.join(inside)})")
    print("frequencies [Hz], 5/50/95 %: " + "; ".join(
        f"{k} {m.q05:.3f}/{m.q50:.3f}/{m.q95:.3f}" for k, m in rec.frequencies_hz.items()))
    for b in result.bands:
        print(f"predictive bands, {b.trial}: " + ", ".join(
            f"{c} {100 * v:.1f} %" for c, v in zip(b.channels, b.coverage, strict=True)))
    peer = emcee_peer(result, case, args.emcee_steps, args.seed)
    compare(rec.nfev, rec.ess, result, peer)
    importance_check(result, case, peer, 40_000 if not args.quick else 2_000, args.seed)
    print(f"results in {out / 'results'}")
    return 0


@dataclass
class Peer:
    """emcee's run: its evaluations, per-parameter ESS (ArviZ) and kept samples (unit cube)."""

    evaluations: int
    ess: np.ndarray
    samples: np.ndarray
    wall_s: float


def emcee_peer(result: PosteriorResult, case: Case, steps: int, seed: int) -> Peer:
    """emcee on the posterior density of ``result`` (its error model and prior), its walkers
    started from the posterior's samples; every step's walkers one batch of the problem."""
    import arviz as az
    import emcee

    problem = result.search.problem
    prior = case_priors(case)
    model = result.error_model
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(7,)))
    n = prior.dim
    walkers = 4 * n
    unit = prior.to_unit(prior.physical_to_search(result.samples))
    start = unit[rng.choice(unit.shape[0], walkers, replace=False)]
    start = np.clip(start + 1e-4 * rng.standard_normal(start.shape), 1e-9, 1 - 1e-9)

    def log_density(xi: np.ndarray) -> np.ndarray:
        inside = np.all((xi >= 0) & (xi <= 1), axis=1)
        out = np.full(xi.shape[0], -np.inf)
        if inside.any():
            rows = problem.residuals_batch(prior.to_search(xi[inside]))
            out[inside] = model.loglike_rows(rows) + prior.logpdf_unit(xi[inside])
        return np.where(np.isfinite(out), out, -np.inf)

    sampler = emcee.EnsembleSampler(walkers, n, log_density, vectorize=True)
    # emcee draws from a RandomState of its own: seeded from the Generator, for repeatability
    sampler._random = np.random.RandomState(int(rng.integers(2**31)))
    began = time.perf_counter()
    sampler.run_mcmc(start, steps, progress=False)
    wall = time.perf_counter() - began
    chain = sampler.get_chain()[steps // 3:]  # (steps, walkers, n)
    ess = np.array([float(az.ess(np.ascontiguousarray(chain[:, :, j].T))) for j in range(n)])
    return Peer(walkers * steps, ess, chain.reshape(-1, n), wall)


def importance_check(result: PosteriorResult, case: Case, peer: Peer, draws: int,
                     seed: int) -> None:
    """A third estimate of the marginals, independent of both samplers' moves: importance
    sampling of the same density from a Student-t mixture (ν = 4) fitted to 1,000 samples of
    each, ``draws`` draws in batches of 2,000; each parameter's sd over the default's and
    over emcee's, with the weights' ESS (femupdate.inference.importance)."""
    problem = result.search.problem
    prior = case_priors(case)
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(8,)))
    ours = prior.to_unit(prior.physical_to_search(result.samples))
    both = np.vstack([a[rng.choice(a.shape[0], min(1000, a.shape[0]), replace=False)]
                      for a in (ours, peer.samples)])
    q = defensive_mixture(both, 24, 1.3, rng, safe_cholesky)
    xs, log_ws = [], []
    for _ in range(max(draws // 2000, 1)):
        x = q.sample(rng, 2000)
        x = x[np.all((x >= 0) & (x <= 1), axis=1)]
        ll = result.error_model.loglike_rows(problem.residuals_batch(prior.to_search(x)))
        xs.append(x)
        log_ws.append(prior.logpdf_unit(x) + ll - q.logpdf(x))
    x, log_w = np.vstack(xs), np.concatenate(log_ws)
    w = normalised_weights(log_w)
    sd = np.sqrt(w @ (x - w @ x) ** 2)
    ess = importance_ess(x, log_w)
    print(f"importance check ({draws:,} draws, {x.shape[0]:,} evaluated, Kish ESS "
          f"{kish_ess(log_w):,.0f}): its sd over the default's, over emcee's (its ESS)")
    for j, name in enumerate(prior.names):
        print(f"  {name:>6}: {sd[j] / ours[:, j].std():.2f}, {sd[j] / peer.samples[:, j].std():.2f}"
              f" ({ess[j]:,.0f})")


def compare(nfev: int, least_ess: float, result: PosteriorResult, peer: Peer) -> None:
    """Both samplers' costs per effective sample and their marginals side by side (search
    space: log10 on a log scale)."""
    prior = case_priors(result.search.problem.case)
    ours = prior.physical_to_search(result.samples)
    theirs = prior.to_search(peer.samples)
    ours_rate = nfev / least_ess
    theirs_rate = peer.evaluations / float(np.min(peer.ess))
    print(f"\nthe default sampler: {nfev:,} evaluations, least ESS {least_ess:,.0f}, "
          f"{ours_rate:.1f} evaluations per effective sample")
    print(f"emcee ({peer.samples.shape[0]:,} samples kept): {peer.evaluations:,} evaluations "
          f"in {peer.wall_s:.1f} s, least ESS {np.min(peer.ess):,.0f} (ArviZ), "
          f"{theirs_rate:.1f} evaluations per effective sample")
    print(f"emcee's evaluations per effective sample over the default's: "
          f"{theirs_rate / ours_rate:.2f}")
    print("parameter: Δ mean (emcee sds), sd ratio (default/emcee), emcee's ESS")
    sd = theirs.std(axis=0)
    for j, name in enumerate(prior.names):
        print(f"  {name:>6}: {(ours[:, j].mean() - theirs[:, j].mean()) / sd[j]:+.2f}, "
              f"{ours[:, j].std() / sd[j]:.2f}, {peer.ess[j]:,.0f}")


if __name__ == "__main__":
    raise SystemExit(main())

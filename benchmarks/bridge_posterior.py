"""``femupdate posterior`` on the bridge with 2 % noise (viscous, or friction with --model):
what it says of each parameter, beside the Laplace approximation at the best fit, with its
evaluations and wall time.

    python benchmarks/bridge_posterior.py [--model viscous|friction] [--samples N]
        [--runs R] [--max-runs M] [--recentre K] [--error-model KIND] [--workers W]
        [--seed 1] [--out DIR] [--quick]

``--samples``, ``--runs``, ``--max-runs``, ``--recentre`` and ``--error-model`` default to
``[posterior]``'s defaults (1,000 samples per run, 4 independent runs, up to 12 while a
parameter is unsettled, 2 re-centrings, ``neff``); ``--workers`` (default 1) is the case's
``[search] workers``, which the sampler uses too. ``--quick`` (a smoke run for CI): 300
samples per run after a search of 2 runs of 600 evaluations.

The virtual experiment of ``femupdate bench bridge --model MODEL`` (seed 0, 2 % noise), the
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
from pathlib import Path

from femupdate.case import parse_case
from femupdate.case.posterior_section import DEFAULT_POSTERIOR
from femupdate.paper.problems.bridge import bridge_case, ensure_records, truth
from femupdate.pipeline.posterior.run import run_posterior
from femupdate.runs import Execution


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", choices=("viscous", "friction"), default="viscous")
    parser.add_argument("--samples", type=int, default=DEFAULT_POSTERIOR.samples)
    parser.add_argument("--runs", type=int, default=DEFAULT_POSTERIOR.runs)
    parser.add_argument("--max-runs", type=int, default=DEFAULT_POSTERIOR.max_runs)
    parser.add_argument("--recentre", type=int, default=DEFAULT_POSTERIOR.recentre)
    parser.add_argument("--error-model", default=DEFAULT_POSTERIOR.error_model)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--quick", action="store_true", help="300 samples, a short search (CI)")
    args = parser.parse_args(argv)
    if args.quick:
        args.samples = 300
    out = args.out or Path(tempfile.mkdtemp(prefix="femupdate-bridge-posterior-"))
    data = (out / "data").resolve()
    spec = bridge_case(args.model, "narrow", directory=str(data))
    spec["search"].update(runs=2, f_target=None, max_evals=600 if args.quick else 3000, seed=1,
                          workers=args.workers)
    spec["posterior"] = {"samples": args.samples, "runs": args.runs, "seed": args.seed,
                         "max_runs": args.max_runs, "recentre": args.recentre,
                         "error_model": args.error_model, "modes_samples": 100}
    case = parse_case(spec, source=out / f"{args.model}-narrow.toml")
    truth_values = truth(args.model)
    ensure_records(case, truth_values, data, seed=0, snr=0.02)
    start = time.perf_counter()
    result = run_posterior(case, out / "results", restart=True,
                           execution=Execution(label="bridge posterior"))
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
    print(f"results in {out / 'results'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

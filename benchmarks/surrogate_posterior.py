"""The surrogate-aided posterior of an OpenSeesPy model against direct TMCMC on the same model.

The model: examples/surrogate/shear_frame_opensees.py, a three-storey shear frame in
OpenSeesPy (storey stiffnesses k1, k2, k3 updated, uniform priors on [1e5, 4e5] N/m), under a
seeded EC8-compatible artificial record (``--duration`` s at ``--rate`` Hz); its measured
records are its own response at the truth (2.4e5, 2.0e5, 1.6e5 N/m) at floors 1 and 3 plus
white noise of ``--noise`` of each channel's RMS. The likelihood is femupdate's, error model
``neff`` fixed at the truth's residuals, the same for both posteriors.

1. The surrogate-aided posterior (femupdate.inference.surrogate) with its design batches on
   ``--workers`` local worker processes: model runs, wall time, the final check.
2. Direct TMCMC (femupdate.inference.tmcmc, population ``--population``) on the true model,
   the same workers: model runs and wall time (skipped with ``--no-direct``).
3. Means and standard deviations of both, their ratios, and whether the truth lies inside
   each 90 % interval of the surrogate posterior.

    python benchmarks/surrogate_posterior.py [--seed 0] [--workers 2] [--population 1000]
        [--duration 6] [--rate 100] [--noise 0.05] [--max-runs 300] [--json out.json]
    python benchmarks/surrogate_posterior.py --quick  # a 2 s record, no direct TMCMC (CI)
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from femupdate.case import parse_case
from femupdate.inference.best_fit import case_priors
from femupdate.inference.error_models import problem_error_model
from femupdate.inference.likelihood import ErrorModel
from femupdate.inference.surrogate import surrogate_posterior
from femupdate.inference.tmcmc import run_tmcmc
from femupdate.pipeline.posterior.surrogate import problem_evaluator
from femupdate.problem.update import UpdateProblem
from femupdate.runs.executors import open_executor
from femupdate.trials.experiment import Experiment
from femupdate.trials.virtual import ec8_motion

SCRIPT = (Path(__file__).resolve().parents[1] / "examples" / "surrogate"
          / "shear_frame_opensees.py")
TRUTH = {"k1": 2.4e5, "k2": 2.0e5, "k3": 1.6e5}
BOUNDS = (1e5, 4e5)
CHANNELS = ("F1", "F3")


def frame_problem(duration: float, rate: float, noise: float, seed: int) -> UpdateProblem:
    """The case of the OpenSeesPy frame on its virtual experiment (seeded record and noise)."""
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(7,)))
    motion = ec8_motion(rng, rate=rate, duration=duration, length_scale=1.0)
    case = parse_case({
        "case": {"name": "frame-opensees"},
        "model": {"opensees": {"build": f"{SCRIPT}:build", "outputs": [[1, 1], [3, 1]],
                               "direction": 1, "algorithm": "linear",
                               "eigen_solver": "-fullGenLapack", "n_modes": 3}},
        "parameters": [{"name": n, "lower": BOUNDS[0], "upper": BOUNDS[1], "unit": "N/m"}
                       for n in TRUTH],
        "data": {"format": "csv", "rate": rate, "input": {"file": "x.csv", "column": 0},
                 "outputs": [{"file": "x.csv", "column": i + 1, "name": c}
                             for i, c in enumerate(CHANNELS)]},
        "objective": {"quantity": "acceleration"},
    })
    t = np.arange(motion.ag.size) * motion.dt
    ones = np.ones((t.size, 2))  # a placeholder target: only the prediction is used
    blank = Experiment(t=t, ag=motion.ag, accelerations=ones, target=ones, quantity="acceleration",
                       channels=CHANNELS, weights=np.ones(2), name="frame-opensees")
    trial = UpdateProblem(case, blank).fitted[0]
    clean = trial.prediction(trial.simulate(TRUTH))
    trial.close()
    measured = clean + noise * clean.std(axis=0) * rng.standard_normal(clean.shape)
    exp = Experiment(t=t, ag=motion.ag, accelerations=measured, target=measured,
                     quantity="acceleration", channels=CHANNELS, weights=np.ones(2),
                     name="frame-opensees")
    return UpdateProblem(case, exp)


class Timed:
    """An evaluate function that sums the wall time spent in it (the model's batches)."""

    def __init__(self, evaluate: Any) -> None:
        self.evaluate, self.seconds = evaluate, 0.0

    def __call__(self, X: np.ndarray) -> Any:
        t0 = time.perf_counter()
        try:
            return self.evaluate(X)
        finally:
            self.seconds += time.perf_counter() - t0


class Rows:
    """The true residual rows of a problem, a population a batch over the executor's
    workers (TMCMC's loop calls ``residuals_batch``)."""

    def __init__(self, problem: UpdateProblem, executor: Any) -> None:
        self.evaluate = problem_evaluator(problem, executor)

    def residuals_batch(self, X: np.ndarray) -> np.ndarray:
        return self.evaluate(np.atleast_2d(X))[0]

    def residuals(self, x: np.ndarray) -> np.ndarray:
        return self.residuals_batch(np.asarray(x)[None, :])[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--population", type=int, default=1000, help="direct TMCMC's")
    parser.add_argument("--duration", type=float, default=3.0, help="record, s")
    parser.add_argument("--rate", type=float, default=50.0, help="Hz")
    parser.add_argument("--noise", type=float, default=0.3, help="share of each RMS")
    parser.add_argument("--max-runs", type=int, default=300)
    parser.add_argument("--no-direct", action="store_true", help="skip direct TMCMC")
    parser.add_argument("--no-surrogate", action="store_true",
                        help="direct TMCMC only (the reference alone)")
    parser.add_argument("--json", type=Path)
    parser.add_argument("--quick", action="store_true",
                        help="a 2 s record, 60 model runs at most, no direct TMCMC (smoke run)")
    args = parser.parse_args()
    if args.quick:
        args.duration, args.max_runs, args.no_direct = 2.0, 60, True

    problem = frame_problem(args.duration, args.rate, args.noise, args.seed)
    prior = case_priors(problem.case)
    names = list(prior.names)
    truth = np.array([TRUTH[n] for n in names])
    print(f"OpenSeesPy shear frame, {names}, record {args.duration:g} s at {args.rate:g} Hz, "
          f"noise {args.noise:.0%}, {args.workers} workers", flush=True)

    # one likelihood for both: error model neff fixed at the truth's residuals
    model = problem_error_model(problem, problem.residuals(problem.case.to_search(TRUTH)),
                                "neff")

    def fixed(x: np.ndarray, r: np.ndarray) -> tuple[ErrorModel, int]:
        return model, 0

    # the surrogate's randomness and direct TMCMC's: children 0 and 1 of --seed, the same
    # whichever of the two runs
    seeds = [np.random.SeedSequence(args.seed, spawn_key=(i,)) for i in (0, 1)]
    rows: dict[str, Any] = {}
    result = None
    with open_executor(args.workers) as ex:
        if not args.no_surrogate:
            timed = Timed(problem_evaluator(problem, ex))
            t0 = time.perf_counter()
            result = surrogate_posterior(
                timed, prior, fixed,
                rng=np.random.default_rng(seeds[0]), max_runs=args.max_runs,
                progress=lambda line: print(f"  {line}", flush=True))
            wall = time.perf_counter() - t0
            print(f"surrogate: {result.message}")
            print("surrogate: final check, each sd reweighted over unweighted: " + ", ".join(
                f"{n} {r:.3f}" for n, r in zip(names, result.check.sd_ratios, strict=True)))
            print(f"surrogate: {result.model_runs} model runs, {wall:.1f} s wall "
                  f"({args.workers} workers): {timed.seconds:.1f} s in the model's batches, "
                  f"{wall - timed.seconds:.1f} s the surrogate's own work", flush=True)
            rows["surrogate"] = {"model_runs": result.model_runs, "wall_s": wall,
                                 "model_batches_s": timed.seconds,
                                 "reached": result.reached, "accuracy": result.accuracy,
                                 "check_error": result.check_error,
                                 "check_ess": result.check.ess,
                                 "check_shifts_sd": result.check.shifts.tolist(),
                                 "means": result.means().tolist(),
                                 "sds": result.sds().tolist()}
        if not args.no_direct:
            t0 = time.perf_counter()
            post, _ = run_tmcmc(Rows(problem, ex).residuals, prior, model,
                                seed=np.random.default_rng(seeds[1]),
                                population=args.population)
            wall = time.perf_counter() - t0
            direct = prior.to_physical(post.samples)
            if post.ess_params is not None:
                print("direct TMCMC: effective samples " + ", ".join(
                    f"{n} {e:.0f}" for n, e in zip(names, post.ess_params, strict=True)))
            print(f"direct TMCMC: {post.evaluations:,} model runs, {wall:.1f} s wall "
                  f"({args.workers} workers), {len(post.stages)} stages", flush=True)
            rows["direct"] = {"model_runs": post.evaluations, "wall_s": wall,
                              "means": direct.mean(axis=0).tolist(),
                              "sds": direct.std(axis=0, ddof=1).tolist(),
                              "samples": direct}
    problem.close()
    samples = result.samples if result is not None else rows["direct"].pop("samples")
    rows.get("direct", {}).pop("samples", None)
    label = "surrogate" if result is not None else "direct"
    q = np.quantile(samples, [0.05, 0.95], axis=0)
    inside = (q[0] <= truth) & (truth <= q[1])
    both = "surrogate" in rows and "direct" in rows
    print(f"{'':>4} {'truth':>10} {label + ' mean':>15} {'sd':>9}" +
          (f" {'direct mean':>12} {'sd':>9} {'Δmean':>7} {'sd ratio':>8}" if both else "")
          + "  truth in 90 %")
    for i, name in enumerate(names):
        mean, sd = samples[:, i].mean(), samples[:, i].std(ddof=1)
        line = f"{name:>4} {truth[i]:10.5g} {mean:15.6g} {sd:9.4g}"
        if both:
            dm, ds = rows["direct"]["means"][i], rows["direct"]["sds"][i]
            line += f" {dm:12.6g} {ds:9.4g} {mean / dm - 1:+7.2%} {sd / ds:8.3f}"
        print(f"{line}  {'yes' if inside[i] else 'no'}")
    print(f"truth inside the {label} posterior's 90 % interval: {int(inside.sum())} of "
          f"{len(names)}")
    if both:
        print(f"model runs: surrogate {rows['surrogate']['model_runs']} against direct "
              f"{rows['direct']['model_runs']:,}; wall {rows['surrogate']['wall_s']:.0f} s "
              f"against {rows['direct']['wall_s']:.0f} s ({args.workers} workers)")
    if args.json:
        args.json.write_text(json.dumps({"args": {k: str(v) for k, v in vars(args).items()},
                                         "rows": rows, "truth_inside": inside.tolist()},
                                        indent=2) + "\n")


if __name__ == "__main__":
    main()

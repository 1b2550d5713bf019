"""Where multistart-lm's evaluations go on the noise-free broad-band bridge.

Each run of ``femupdate bench bridge --model viscous --band broad --snr 0 --seed S --method
multistart-lm`` again (run i seeded by child i of SeedSequence(S), target φ < 1e-6, 20,000
evaluations), driven step by step so that every local search is seen: where it started (the
pool or a valley hop), its evaluations, the φ it ended at and whether a parameter ended at a
bound. Prints each run, then the evaluations per success (as the bench counts them: the same
bits, the runs made with one BLAS thread as in the bench's worker processes), by phase (the
pool, the noise table, the fine and coarse Jacobians, trial steps, extensions) and by kind of
search (a run's first search counts its pool). ``--dump`` keeps every search's φ after each
accepted step, for trying stopping rules on the record.

    python benchmarks/multistart_budget.py --seed 5 [--runs 25] [--options '{"broyden": 0}']
    python benchmarks/multistart_budget.py --quick     # 2 runs, seed 0, budget 3,000
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
from pathlib import Path

import numpy as np

from femupdate._parallel import single_blas_thread
from femupdate.case import parse_case
from femupdate.optimize.minimize import start
from femupdate.paper.problems.bridge import bridge_case, ensure_records, truth
from femupdate.problem.update import UpdateProblem
from femupdate.trials.experiment import load_experiment

#: The bench's target for the noise-free viscous bridge.
F_TARGET = 1e-6
#: A search that ends below this φ reached the kp1 valley (the spurious minima lie at 3.4e-2
#: and above; the valley's ripple minima at 1e-7 … 1e-5).
VALLEY = 1e-4


def bridge_problem(seed: int, work: Path) -> UpdateProblem:
    """The bench's noise-free broad-band viscous bridge with accelerogram ``seed``."""
    data_dir = work / f"data-viscous-snr0-seed{seed}"
    spec = bridge_case("viscous", "broad", directory=str(data_dir.resolve()))
    spec["search"].pop("f_target", None)
    case = parse_case(spec, source=work / "viscous-broad.toml")
    ensure_records(case, truth("viscous"), data_dir, seed=seed, snr=0.0)
    return UpdateProblem(case, load_experiment(case))


def searches_of_run(problem: UpdateProblem, seed: np.random.SeedSequence, max_evals: int,
                    options: dict) -> tuple[list[dict], dict[str, int], int, float]:
    """One run as the bench runs it (one BLAS thread, as in its worker processes: the bits
    differ otherwise), with each local search recorded as it ends: a hop or not, its
    evaluations, the φ it ended at, whether a parameter ended at a bound, and φ after each of
    its accepted steps (with the evaluations spent by then). Returns the searches, the
    evaluations by phase, the run's evaluations and its best φ."""
    state = start(problem.residuals, problem.bounds, "multistart-lm", seed=seed,
                  max_evals=max_evals, f_target=F_TARGET, residuals=True, **options)
    opt = state.optimizer
    searches: list[dict] = []
    began = [0]
    path: list[tuple[int, float]] = []
    end_search, move = opt._end_search, opt._move

    def ended(reason: str) -> None:
        x, phi, hop = opt.x.copy(), opt.phi, opt.hopping
        end_search(reason)
        searches.append({"hop": hop, "evals": state.nfev - began[0], "phi": phi,
                         "bound": bool(np.any((x <= 0.0) | (x >= 1.0))), "reason": reason,
                         "path": list(path)})
        began[0] = state.nfev
        path.clear()

    def moved(x: np.ndarray, phi: float, rs: np.ndarray | None, new_step: bool) -> None:
        move(x, phi, rs, new_step)
        path.append((state.nfev - began[0], phi))

    opt._end_search, opt._move = ended, moved
    phases: dict[str, int] = {}
    with single_blas_thread():
        while not state.done:
            phase = opt.phase + (" (coarse)" if opt.phase == "jacobian" and opt.coarse else "")
            before = state.nfev
            state.step(problem.residuals)
            phases[phase] = phases.get(phase, 0) + state.nfev - before
    if path or state.nfev > began[0]:  # the search the target or the budget ended
        searches.append({"hop": bool(opt.hopping), "evals": state.nfev - began[0],
                         "phi": float(state.best_f), "bound": False, "path": list(path)})
    return searches, phases, state.nfev, state.best_f


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=5)
    parser.add_argument("--runs", type=int, default=25)
    parser.add_argument("--max-evals", type=int, default=20_000)
    parser.add_argument("--options", default="{}", help="multistart-lm options as JSON")
    parser.add_argument("--dump", type=Path, help="write every run's searches here (JSON)")
    parser.add_argument("--quick", action="store_true", help="2 runs, seed 0, 3,000 evals")
    args = parser.parse_args()
    if args.quick:
        args.seed, args.runs, args.max_evals = 0, 2, 3000
    options = json.loads(args.options)
    with tempfile.TemporaryDirectory(prefix="msbudget-") as tmp:
        problem = bridge_problem(args.seed, Path(tmp))
        kinds: dict[str, list[int]] = {"pool, improper end": [], "pool, other end": [],
                                       "pool, valley": [], "hop": []}
        total, successes = 0, 0
        phases: dict[str, int] = {}
        runs = []
        for i, ss in enumerate(np.random.SeedSequence(args.seed).spawn(args.runs)):
            searches, by_phase, nfev, best = searches_of_run(problem, ss, args.max_evals,
                                                              options)
            total += nfev
            for phase, evals in by_phase.items():
                phases[phase] = phases.get(phase, 0) + evals
            runs.append({"nfev": nfev, "best": best, "searches": searches})
            successes += best < F_TARGET
            for s in searches:
                kind = ("hop" if s["hop"] else "pool, valley" if s["phi"] < VALLEY
                        else "pool, improper end" if s["bound"] else "pool, other end")
                kinds[kind].append(s["evals"])
            print(f"run {i:2d}: {nfev:6d} evaluations, best φ {best:.3g}, "
                  f"{len(searches)} searches ({sum(s['hop'] for s in searches)} hops)",
                  flush=True)
    if args.dump is not None:
        args.dump.write_text(json.dumps(runs))
    print(f"\nseed {args.seed}, {args.runs} runs, options {options}: {successes}/{args.runs} "
          f"below {F_TARGET:g}, {total / max(successes, 1):,.0f} evaluations per success "
          f"(load average {os.getloadavg()[0]:.1f})")
    print("  by phase: " + ", ".join(f"{phase} {100 * evals / total:.1f} %"
                                     for phase, evals in phases.items()))
    for kind, evals in kinds.items():
        if evals:
            print(f"  {kind:20s} {len(evals):4d} searches, {sum(evals):7d} evaluations "
                  f"({100 * sum(evals) / total:4.1f} %), {np.mean(evals):6.0f} each")


if __name__ == "__main__":
    main()

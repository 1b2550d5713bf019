"""Jacobian of the viscous bridge's residuals: finite differences against sensitivity equations.

At a few points of the unit cube, three Jacobians of r (φ = ‖r‖²) with respect to the unit-cube
coordinates, each compared with a reference (Richardson-extrapolated central differences,
steps 1e-4 and 5e-5) and timed:

* ``fd``: forward differences with multistart-lm's noise-chosen steps — n full evaluations
  (assembly, eigendecomposition, simulation, processing each);
* ``sens``: the sensitivity equations M ÿ_p + C ẏ_p + K y_p = −(M_p ÿ + C_p ẏ + K_p y), run
  through the same prepared exact simulator as nodal forces (no new eigendecomposition: one
  full-state simulation, then n force-driven ones), the prediction's processing and the
  objective's projection and normalisation differentiated by hand. The simulator takes its
  inputs as piecewise linear between samples (first-order hold); the forcing −(C_p ẏ + K_p y)
  is not, so these sensitivities carry an O((ω dt)²) error.

Both cost n simulations per Jacobian (every simulation is an evaluation), so they differ only
in accuracy and wall time.

    python benchmarks/jacobian_cost.py [--points 5]
    python benchmarks/jacobian_cost.py --quick     # one point: a smoke run (CI)
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from femupdate.data import signal
from femupdate.optimize.trust import forward_columns, forward_steps, noise_level, step_signs
from femupdate.paper.problems.bridge import truth, viscous_problem
from femupdate.simulate import prepare


def reference_jacobian(residuals, u: np.ndarray) -> np.ndarray:
    """Central differences at h and h/2, Richardson-extrapolated (error O(h⁴))."""
    def central(h: float) -> np.ndarray:
        return np.column_stack([(residuals(u + h * e) - residuals(u - h * e)) / (2 * h)
                                for e in np.eye(u.size)])

    return (4.0 * central(5e-5) - central(1e-4)) / 3.0


def sensitivity_jacobian(problem, low: np.ndarray, span: np.ndarray,
                         u: np.ndarray) -> np.ndarray:
    """dr/du by the sensitivity equations through one prepared exact simulator."""
    x = low + span * u
    names = problem.names
    values = problem.values(x)
    system = problem.system(values)
    trial = problem.fitted[0]  # the case's one trial
    sim = prepare(system, problem.experiment.dt, method="exact")  # all DOFs out
    state = sim.run(trial._ag)
    yhat = trial.scored(problem.prediction(_at_outputs(state, trial.outputs)))
    obj = problem.objective
    q, target = obj._q, obj.target
    d = yhat - target
    qty = q.T @ yhat
    energy = obj._perp_energy + np.sum(qty**2, axis=0)
    scale = np.sqrt(obj.weights / (obj.weights.sum() * energy))
    proj = d - q @ (q.T @ d)
    cols = []
    for i, name in enumerate(names):
        delta = 1e-6 * max(abs(values[name]), span[i])
        bumped = problem.system(dict(values, **{name: values[name] + delta}))
        k_p = (bumped.K - system.K) / delta  # K and C are linear in each parameter
        c_p = (bumped.C - system.C) / delta
        force = -(state.displacement @ k_p.T + state.velocity @ c_p.T)
        sens = sim.run(None, force)
        acc = sens.acceleration[:, trial.outputs]  # relative: no base motion here
        # the prediction's processing is linear: high-pass (if any), integrate, score
        dyhat = trial.scored(signal.integrate_twice(trial._filtered(acc), problem.experiment.dt))
        dproj = dyhat - q @ (q.T @ dyhat)
        denergy = 2.0 * np.sum(qty * (q.T @ dyhat), axis=0)
        dscale = -0.5 * scale * denergy / energy
        cols.append(((dproj * scale + proj * dscale) * span[i]).ravel(order="F"))  # as r
    return np.column_stack(cols)


def _at_outputs(response, outputs: np.ndarray):
    from femupdate.simulate.response import Response

    return Response(t=response.t, displacement=response.displacement[:, outputs],
                    velocity=response.velocity[:, outputs],
                    acceleration=response.acceleration[:, outputs],
                    diverged=response.diverged)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--points", type=int, default=5)
    parser.add_argument("--quick", action="store_true", help="one point (a smoke run)")
    args = parser.parse_args()
    if args.quick:
        args.points = 1
    problem = viscous_problem(seed=0, snr=0.0)
    low, high = np.array(problem.bounds).T
    span = high - low

    def residuals(u: np.ndarray) -> np.ndarray:
        return problem.residuals(low + span * u)

    u_truth = (problem.case.to_search(truth("viscous")) - low) / span
    rng = np.random.default_rng(0)
    points = [np.clip(u_truth + 0.02 * rng.standard_normal(u_truth.size), 0.01, 0.99)
              for _ in range(args.points)]
    print(f"{'point':>5} {'fd err':>9} {'sens err':>9} {'fd ms':>7} {'sens ms':>8}")
    for k, u in enumerate(points):
        ref = reference_jacobian(residuals, u)
        base = residuals(u)
        d = rng.standard_normal(u.size)
        d /= np.linalg.norm(d)
        table = np.array([residuals(u + i * 1e-8 * d) for i in range(7)])
        noise = noise_level(table)
        slopes = np.sqrt(np.mean(ref**2, axis=0))
        h = step_signs(u, forward_steps(noise, slopes, float(np.sqrt(np.mean(base**2)))))
        t0 = time.perf_counter()
        fd = forward_columns(base, np.array([residuals(u + hi * e)
                                             for hi, e in zip(h, np.eye(u.size), strict=True)]),
                             h)
        t_fd = time.perf_counter() - t0
        t0 = time.perf_counter()
        sens = sensitivity_jacobian(problem, low, span, u)
        t_sens = time.perf_counter() - t0
        norm = np.linalg.norm(ref, axis=0)
        e_fd = np.max(np.linalg.norm(fd - ref, axis=0) / norm)
        e_sens = np.max(np.linalg.norm(sens - ref, axis=0) / norm)
        print(f"{k:5d} {e_fd:9.1e} {e_sens:9.1e} {1e3 * t_fd:7.1f} {1e3 * t_sens:8.1f}")
    print("errors: the largest over columns of ‖J_col − J_ref‖/‖J_ref‖; times: one Jacobian "
          "(n = 9) with the base point known")


if __name__ == "__main__":
    main()

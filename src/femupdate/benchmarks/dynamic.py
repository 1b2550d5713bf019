"""Benchmark 1 of the paper: identification of a two-mode free vibration (METHOD.md §7).

    y(t) = Σ_k A_k exp(-ζ_k ω_k t) sin(ω_k √(1-ζ_k²) t + θ_k),   k = 1, 2

sampled every 0.01 s over 0–5 s, eight bounded parameters, φ = NMSE (Eq. 1).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

PARAMETER_NAMES: tuple[str, ...] = ("w1", "z1", "A1", "theta1", "w2", "z2", "A2", "theta2")
LOWER = np.array([0.1, 0.0, 1.0, -np.pi, 5.0, 0.0, 1.0, -np.pi])
TRUTH = np.array([4.0, 0.1, 5.0, -2.0, 12.0, 0.15, 2.0, -1.5])
UPPER = np.array([5.0, 1.0, 10.0, np.pi, 20.0, 1.0, 10.0, np.pi])
TIME = np.linspace(0.0, 5.0, 501)
F_TARGET = 1e-10
MAX_EVALS = 50_000


def two_mode_response(params: np.ndarray, t: np.ndarray = TIME) -> np.ndarray:
    """Free vibration of two damped modes (Eq. 17) at times ``t``.

    A damping ratio of 1 gives a zero damped frequency (critically damped), which is allowed.
    """
    w1, z1, a1, th1, w2, z2, a2, th2 = params
    y = a1 * np.exp(-z1 * w1 * t) * np.sin(w1 * np.sqrt(1.0 - z1 * z1) * t + th1)
    y += a2 * np.exp(-z2 * w2 * t) * np.sin(w2 * np.sqrt(1.0 - z2 * z2) * t + th2)
    return y


@dataclass
class DynamicProblem:
    """The error function φ(x) = Σ(ŷ − y)² / Σy² of the two-mode benchmark (picklable)."""

    t: np.ndarray = field(default_factory=lambda: TIME.copy())
    truth: np.ndarray = field(default_factory=lambda: TRUTH.copy())

    def __post_init__(self) -> None:
        self.target = two_mode_response(self.truth, self.t)
        self.target_energy = float(self.target @ self.target)

    @property
    def bounds(self) -> list[tuple[float, float]]:
        return list(zip(LOWER.tolist(), UPPER.tolist(), strict=True))

    def __call__(self, x: np.ndarray) -> float:
        residual = two_mode_response(x, self.t) - self.target
        return float(residual @ residual) / self.target_energy

    def residuals(self, x: np.ndarray) -> np.ndarray:
        """r = (ŷ − y)/‖y‖, so that φ(x) = r·r to rounding."""
        return (two_mode_response(x, self.t) - self.target) / np.sqrt(self.target_energy)


#: Methods compared side by side by ``--method all``, with the paper's settings.
ALL_METHODS: dict[str, dict[str, object]] = {
    "ib": {},
    "ab": {},
    "cmaes": {"popsize": 5},
    "de": {},
    "ga": {},
}


def run_benchmark(
    method: str = "ab",
    *,
    runs: int = 100,
    seed: int | None = 0,
    workers: int = 1,
    max_evals: int = MAX_EVALS,
    f_target: float = F_TARGET,
    options: dict[str, object] | None = None,
) -> dict[str, object]:
    """Independent runs of ``method`` on the two-mode benchmark, summarised as Table 2.

    Returns
    -------
    dict
        ``method, runs, successes, success_ratio, evals_min, evals_mean, evals_median,
        evals_max, wall_s`` (evaluations over successful runs, each counted up to the first
        evaluation that reached ``f_target``), ``options``, ``seed`` and ``per_run``.
    """
    # Imported here: the runner imports the optimizers, which import nothing from benchmarks.
    import time

    from femupdate.optimize.minimize import RESIDUAL_METHODS
    from femupdate.runs.runner import repeat
    from femupdate.runs.stats import evaluation_stats

    opts = dict(ALL_METHODS.get(method, {}) if options is None else options)
    start = time.perf_counter()
    problem = DynamicProblem()
    residuals = method in RESIDUAL_METHODS
    outcomes = repeat(
        problem.residuals if residuals else problem,
        problem.bounds,
        method,
        runs=runs,
        seed=seed,
        workers=workers,
        max_evals=max_evals,
        f_target=f_target,
        residuals=residuals,
        **opts,
    )
    wall = time.perf_counter() - start
    stats = evaluation_stats([o.nfev for o in outcomes], [o.success for o in outcomes])
    return {
        "method": method,
        **stats,
        "wall_s": wall,
        "workers": workers,
        "seed": seed,
        "options": opts,
        "per_run": [o.to_dict(PARAMETER_NAMES) for o in outcomes],
    }

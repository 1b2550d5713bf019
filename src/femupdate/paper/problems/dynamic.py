"""Benchmark 1 of the paper: identification of a two-mode free vibration (Zapico-Valle et al.
2010, §4)::

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

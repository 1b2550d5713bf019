"""The analytic check of the posterior: a model linear in its parameters with Gaussian noise of
known variance, whose posterior is Gaussian in closed form (a Gaussian prior on one parameter,
uniform on the others, with bounds too far to matter), and its log-evidence. Used by the tests
and ``benchmarks/posterior.py``."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from femupdate.inference.error_models import error_model
from femupdate.inference.likelihood import ErrorModel
from femupdate.inference.priors import Prior

SIGMA = 0.2


@dataclass
class LinearGaussian:
    design: np.ndarray  # (m, n): r(θ) = A θ − y
    data: np.ndarray
    prior: Prior
    model: ErrorModel
    mean: np.ndarray  # closed-form posterior, physical units
    cov: np.ndarray

    def residuals_batch(self, thetas: np.ndarray) -> np.ndarray:
        return np.atleast_2d(thetas) @ self.design.T - self.data


def linear_gaussian(seed: int = 0, m: int = 60) -> LinearGaussian:
    """Three correlated parameters, a Gaussian prior on the first, uniform on the others."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, m)
    design = np.column_stack([np.ones(m), t, np.sin(3 * t) + 0.5 * t])
    truth = np.array([1.0, -2.0, 0.5])
    data = design @ truth + SIGMA * rng.standard_normal(m)
    prior_mean, prior_sd = 0.8, 0.3
    # bounds ±10 posterior sds or more away: truncation changes nothing measurable
    prior = Prior(["a", "b", "c"], [-3.0, -12.0, -10.0], [5.0, 8.0, 11.0],
                  specs={"a": {"kind": "normal", "mean": prior_mean, "sd": prior_sd}})
    precision = design.T @ design / SIGMA ** 2
    precision[0, 0] += 1 / prior_sd ** 2
    cov = np.linalg.inv(precision)
    rhs = design.T @ data / SIGMA ** 2
    rhs[0] += prior_mean / prior_sd ** 2
    model = error_model([slice(0, m)], "known", sigma=SIGMA)
    return LinearGaussian(design, data, prior, model, cov @ rhs, cov)


def exact_log_evidence(case: LinearGaussian) -> float:
    """log ∫ prior·L dθ of the case in closed form (the bounds' truncation neglected)."""
    y = case.data
    prior_mean, prior_sd = case.prior.params[0]["mean"], case.prior.params[0]["sd"]
    precision = np.linalg.inv(case.cov)
    rhs = precision @ case.mean
    constant = (-0.5 * y @ y / SIGMA ** 2 - 0.5 * y.size * math.log(2 * math.pi * SIGMA ** 2)
                - 0.5 * prior_mean ** 2 / prior_sd ** 2
                - 0.5 * math.log(2 * math.pi * prior_sd ** 2)
                - math.log(case.prior.span[1]) - math.log(case.prior.span[2]))
    return float(constant + 0.5 * rhs @ case.mean + 1.5 * math.log(2 * math.pi)
                 - 0.5 * np.linalg.slogdet(precision)[1])


class Residuals:
    """r(θ) of a linear Gaussian case as an UpdateProblem gives it: ``residuals`` and
    ``residuals_batch`` (a population in one call), counting calls and failing on demand."""

    def __init__(self, case: LinearGaussian, fail_at: int | None = None) -> None:
        self.case = case
        self.calls = 0
        self.fail_at = fail_at  # the evaluation (0-based) that returns NaN

    def residuals(self, theta: np.ndarray) -> np.ndarray:
        return self.residuals_batch(np.asarray(theta)[None, :])[0]

    def residuals_batch(self, thetas: np.ndarray) -> np.ndarray:
        out = self.case.residuals_batch(thetas)
        first = self.calls
        self.calls += out.shape[0]
        if self.fail_at is not None and first <= self.fail_at < self.calls:
            out[self.fail_at - first] = np.nan
        return out

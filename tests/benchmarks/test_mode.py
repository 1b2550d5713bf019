"""The mode of a whitening error model: generalised least squares, in closed form when linear."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from error_models.kinds import WhitenedModel
from error_models.mode import whitened_mode

from femupdate.case import parse_case
from femupdate.errors import DataError
from femupdate.inference.laplace import jacobian_unit, laplace
from femupdate.inference.likelihood import ErrorModel
from femupdate.inference.priors import Prior
from femupdate.problem.update import UpdateProblem
from femupdate.trials.experiment import load_experiments
from femupdate.trials.virtual import virtual_experiment
from two_storey_case import TRUTH, two_storey_spec

RHO = 0.9
M = 400


def _ar1_noise(rng: np.random.Generator, m: int, rho: float) -> np.ndarray:
    e = np.empty(m)
    e[0] = rng.standard_normal() / np.sqrt(1 - rho ** 2)
    for t in range(1, m):
        e[t] = rho * e[t - 1] + rng.standard_normal()
    return 0.1 * e


class Linear:
    """r(θ) = Aθ − y with AR(1) errors, counting the residual vectors it evaluates."""

    def __init__(self, seed: int = 0) -> None:
        rng = np.random.default_rng(seed)
        t = np.linspace(0.0, 1.0, M)
        # fast sensitivities, mixed with slow ones where the AR(1) noise has its power: least
        # squares is then inefficient, GLS is not
        self.design = np.column_stack([np.sin(150 * t) + 2 * t, np.cos(90 * t) + t ** 2,
                                       t * np.sin(200 * t) + 1, np.sin(3 * t)])
        self.data = self.design @ np.array([1.0, -0.5, 0.3, 0.2]) + _ar1_noise(rng, M, RHO)
        self.calls = 0

    def residuals_batch(self, thetas: np.ndarray) -> np.ndarray:
        thetas = np.atleast_2d(thetas)
        self.calls += thetas.shape[0]
        return thetas @ self.design.T - self.data


def _model(kind: str) -> ErrorModel:
    """One block of M samples, the AR(1) coefficient known: as ``"ar1"`` or as ``"arp"``."""
    one = np.array([0]), np.array([M])
    if kind == "ar1":
        return WhitenedModel("ar1", *one, np.array([M - 1.0]), np.array([RHO]))
    return WhitenedModel("arp", *one, np.array([M - 1.0]), np.zeros(1), ar=np.array([[RHO]]))


def _gls(problem: Linear) -> tuple[np.ndarray, np.ndarray]:
    """The GLS estimate and its covariance σ̂²(ÃᵀÃ)⁻¹ (σ̂² = ‖r̃‖²/N, the variance integrated
    out under Jeffreys' prior), physical units."""
    a = problem.design[1:] - RHO * problem.design[:-1]
    y = problem.data[1:] - RHO * problem.data[:-1]
    theta = np.linalg.lstsq(a, y, rcond=None)[0]
    e = y - a @ theta
    return theta, (e @ e / (M - 1)) * np.linalg.inv(a.T @ a)


@pytest.mark.parametrize("kind", ["ar1", "arp"])
def test_the_mode_of_a_linear_model_with_ar1_errors_is_the_gls_estimate(kind: str) -> None:
    problem = Linear()
    prior = Prior(list("abcd"), [-5.0] * 4, [5.0] * 4)
    model = _model(kind)
    ols = np.linalg.lstsq(problem.design, problem.data, rcond=None)[0]
    gls, gls_cov = _gls(problem)
    sd = np.sqrt(np.diag(gls_cov))
    assert np.max(np.abs(ols - gls) / sd) > 0.5  # the least-squares fit is not the mode
    problem.calls = 0
    mode = whitened_mode(problem.residuals_batch, prior, model, prior.to_unit(ols))
    assert mode.converged
    assert np.allclose(prior.to_search(mode.unit), gls, rtol=0, atol=1e-6 * sd.min())
    assert mode.evaluations == problem.calls
    assert mode.log_posterior > mode.start_log_posterior
    # the Laplace Gaussian there is the GLS estimate's
    jac = jacobian_unit(problem.residuals_batch, mode.unit, prior)
    lap = laplace(jac, mode.residuals, mode.unit, model, prior)
    assert np.allclose(lap.mean, gls, rtol=0, atol=1e-6 * sd.min())
    assert np.allclose(lap.cov, gls_cov, rtol=1e-6)


def test_the_mode_stays_in_the_cube_and_reuses_the_start_jacobian() -> None:
    problem = Linear(seed=1)
    gls, _ = _gls(problem)
    # the upper bound of b cuts through the likelihood: the mode lies on it
    prior = Prior(list("abcd"), [-5.0] * 4, [5.0, gls[1] - 0.05, 5.0, 5.0])
    model = _model("arp")
    start = np.full(4, 0.5)
    jac = jacobian_unit(problem.residuals_batch, start, prior)
    r = problem.residuals_batch(prior.to_search(start))[0]
    problem.calls = 0
    mode = whitened_mode(problem.residuals_batch, prior, model, start, residuals=r,
                         jacobian=jac)
    assert mode.evaluations == problem.calls
    assert np.all((mode.unit >= 0.0) & (mode.unit <= 1.0))
    assert mode.unit[1] == pytest.approx(1.0)
    # nothing better nearby: the mode of the constrained problem
    for trial in (mode.unit + 1e-3 * np.eye(4)[i] * s for i in (0, 2, 3) for s in (-1, 1)):
        assert model.loglike(problem.residuals_batch(prior.to_search(trial))[0]) \
            <= mode.log_posterior + 1e-12


def test_a_nonlinear_model_climbs_to_a_stationary_point() -> None:
    t = np.linspace(0.0, 2.0, M)
    rng = np.random.default_rng(3)
    data = 2.0 * np.exp(-0.8 * t) + _ar1_noise(rng, M, RHO)

    def residuals_batch(thetas: np.ndarray) -> np.ndarray:
        thetas = np.atleast_2d(thetas)
        return thetas[:, :1] * np.exp(-thetas[:, 1:2] * t) - data

    prior = Prior(["amplitude", "decay"], [0.5, 0.1], [4.0, 3.0])
    model = _model("arp")
    mode = whitened_mode(residuals_batch, prior, model, prior.to_unit(np.array([1.0, 2.0])),
                         tolerance=1e-6)
    assert mode.converged and mode.iterations >= 3
    jac = jacobian_unit(residuals_batch, mode.unit, prior)
    lap = laplace(jac, mode.residuals, mode.unit, model, prior)
    # at the mode the Newton step of the Laplace approximation is nil
    assert np.allclose(lap.mean_unit, mode.unit, rtol=0, atol=1e-5 * np.sqrt(
        np.diag(lap.cov_unit)).min())


def test_a_start_that_cannot_be_evaluated_is_an_error() -> None:
    prior = Prior(["a"], [0.0], [1.0])
    with pytest.raises(DataError, match="mode: a finite-difference point failed"):
        whitened_mode(lambda x: np.full((np.atleast_2d(x).shape[0], 5), np.nan), prior,
                      _model("arp"), np.array([0.5]))


def _two_storey(root: Path) -> UpdateProblem:
    """The two-storey building's displacements (accelerations with 3 % noise, high-passed and
    integrated twice: coloured errors), one trial."""
    spec = two_storey_spec(root)
    case = parse_case(spec, source=root / "case.toml")
    virtual_experiment(case, TRUTH, root, seed=1, rate=200.0, duration=2.0, snr=0.03,
                       clean_input=True)
    return UpdateProblem(case, load_experiments(case))


def test_a_clean_input_leaves_the_table_record_without_sensor_errors(tmp_path: Path) -> None:
    case = _two_storey(tmp_path / "a").case
    records = {}
    for name, settings in (("exact", {"snr": 0.0, "offset": 0.0, "drift": 0.0}),
                           ("clean", {"snr": 0.03, "clean_input": True}),
                           ("noisy", {"snr": 0.03})):
        manifest = virtual_experiment(case, TRUTH, tmp_path / name, seed=1, rate=200.0,
                                      duration=1.0, **settings)
        assert manifest.get("clean_input", False) == (name == "clean")
        records[name] = {f: np.genfromtxt(tmp_path / name / f, delimiter=",", names=True,
                                          skip_header=1)
                         for f in ("table.csv", "floors.csv")}
    table = {k: v["table.csv"]["table"] for k, v in records.items()}
    floor = {k: v["floors.csv"]["a1"] for k, v in records.items()}
    assert np.array_equal(table["clean"], table["exact"])
    assert not np.allclose(table["noisy"], table["exact"])
    assert np.array_equal(floor["clean"], floor["noisy"])  # the outputs' errors unchanged
    assert not np.allclose(floor["clean"], floor["exact"])

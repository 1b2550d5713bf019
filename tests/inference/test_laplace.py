"""Laplace at the best fit: exact for a linear Gaussian problem; identifiability in words."""

from __future__ import annotations

import numpy as np
import pytest

from femupdate.errors import DataError
from femupdate.inference.analytic import linear_gaussian
from femupdate.inference.laplace import jacobian_unit, laplace, summarize_gaussian
from femupdate.inference.priors import Prior


def test_laplace_is_exact_for_a_linear_gaussian_problem() -> None:
    case = linear_gaussian()
    # the least-squares fit (not the posterior mode: the prior pulls a) as the best fit
    lsq = np.linalg.lstsq(case.design, case.data, rcond=None)[0]
    best = case.prior.to_unit(lsq)
    jac = jacobian_unit(case.residuals_batch, best, case.prior)
    r = case.residuals_batch(lsq)[0]
    result = laplace(jac, r, best, case.model, case.prior)
    assert np.allclose(result.mean, case.mean, rtol=0, atol=1e-6 * np.sqrt(np.diag(case.cov)))
    assert np.allclose(result.cov, case.cov, rtol=1e-6)
    assert np.allclose(result.std, np.sqrt(np.diag(case.cov)), rtol=1e-6)
    corr = case.cov / np.outer(result.std, result.std)
    assert np.allclose(result.correlations, corr, atol=1e-6)
    assert not result.undetermined.any()


def test_a_parameter_the_data_do_not_see_is_said_so() -> None:
    prior = Prior(["E", "kp1"], [1e11, 1e7], [3e11, 5e8])
    # E known to ±1 %, kp1 with a posterior sd of 40 % of its range
    cov = np.diag([0.005 ** 2, 0.4 ** 2])
    result = summarize_gaussian(np.array([0.55, 0.5]), cov, prior)
    assert result.undetermined.tolist() == [False, True]
    assert result.sentences[1].startswith("kp1 is not determined by the data: its 90 % "
                                          "interval [1e+07, 5e+08] spans 100 % of its range")
    assert result.sentences[0].startswith("E = 2.1e+11, 90 % interval [")
    assert result.quantiles[:, 0] == pytest.approx(
        2.1e11 + np.array([-1, 0, 1]) * 1.6449 * 0.005 * 2e11, rel=1e-4)
    half = summarize_gaussian(np.array([0.5, 0.5]), np.diag([1e-4, 0.12 ** 2]), prior)
    assert half.spread[1] == pytest.approx(2 * 1.6449 * 0.12 / 0.9, rel=1e-4)
    assert "spans 39 % of its range" not in " ".join(half.sentences)


def test_a_failed_jacobian_point_is_an_error() -> None:
    case = linear_gaussian()

    def failing(rows: np.ndarray) -> np.ndarray:
        out = case.residuals_batch(rows)
        out[1] = np.inf
        return out

    with pytest.raises(DataError, match="failed to evaluate"):
        jacobian_unit(failing, np.full(3, 0.5), case.prior)
    with pytest.raises(DataError, match="allowed: J of shape"):
        laplace(np.ones((5, 3)), np.ones(4), np.full(3, 0.5), case.model, case.prior)


def test_a_parameter_whose_interval_widens_with_the_step_is_not_called_gaussian() -> None:
    from femupdate.inference.best_fit import NOT_QUADRATIC_RATIO, two_scale_record

    prior = Prior(["E", "kp1", "kp2"], [1e11, 1e7, 1e7], [3e11, 5e8, 5e8])
    mean = np.array([0.55, 0.5, 0.5])
    local = summarize_gaussian(mean, np.diag([0.005, 0.002, 0.01]) ** 2, prior)
    # over 1 % steps: E the same, kp1 20× wider (the friction bridge's ripple), kp2 2× wider
    coarse = summarize_gaussian(mean, np.diag([0.005, 0.04, 0.02]) ** 2, prior)
    assert coarse.spread[1] / local.spread[1] >= NOT_QUADRATIC_RATIO
    assert coarse.spread[2] / local.spread[2] < NOT_QUADRATIC_RATIO
    record = two_scale_record(local, coarse, prior, "neff", 13)
    assert record.not_quadratic == ["kp1"] and record.undetermined == []
    assert record.params["kp1"].sd == pytest.approx(0.04 * 4.9e8, rel=1e-9)  # the coarse one
    assert record.params["kp2"].sd == pytest.approx(0.01 * 4.9e8, rel=1e-9)  # the local one
    said = record.flagged_sentences()
    assert len(said) == 1 and said[0].startswith("kp1: the Gaussian at the best fit does not "
                                                 "describe it (its 90 % interval is 20× wider")

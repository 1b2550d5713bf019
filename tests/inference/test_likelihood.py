"""The error model: blocks of a case's residuals, the integrated-variance likelihood, the
product's kinds ("neff", "known") and their registry."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate

from femupdate.case import parse_case
from femupdate.errors import ConfigError, DataError
from femupdate.inference.error_models import (
    ERROR_MODELS,
    case_kinds,
    error_model,
    problem_error_model,
)
from femupdate.inference.known import Known
from femupdate.inference.likelihood import (
    ErrorModel,
    Registry,
    lag1_autocorrelation,
    residual_blocks,
)
from femupdate.inference.method import error_model_data, error_model_from
from femupdate.inference.neff import NEff, effective_count
from femupdate.problem.update import UpdateProblem
from femupdate.trials.experiment import load_experiments
from femupdate.trials.virtual import virtual_experiment
from two_storey_case import TRUTH, two_storey_spec


def unknown_variance(blocks: list[slice], counts: list[float]) -> ErrorModel:
    """The core likelihood with given counts N_c (no kind measures them)."""
    starts = np.array([b.start for b in blocks])
    stops = np.array([b.stop for b in blocks])
    return ErrorModel("given", starts, stops, np.asarray(counts, float), np.zeros(len(blocks)))


def _spec(root: Path) -> dict:
    return two_storey_spec(root / "a", trials=[
        {"name": "a", "directory": str(root / "a")},
        {"name": "b", "directory": str(root / "b"), "weight": 3.0}])


@pytest.fixture(scope="module")
def problem(tmp_path_factory: pytest.TempPathFactory) -> UpdateProblem:
    root = tmp_path_factory.mktemp("blocks")
    case = parse_case(_spec(root), source=root / "case.toml")
    for folder, seed, rate in (("a", 1, 200.0), ("b", 2, 250.0)):
        virtual_experiment(case, TRUTH, root / folder, seed=seed, rate=rate, duration=2.0,
                           snr=0.03)
    return UpdateProblem(case, load_experiments(case))


def test_blocks_follow_the_residual_layout_trial_by_channel(problem: UpdateProblem) -> None:
    blocks, removed = residual_blocks(problem)
    x = problem.case.to_search(TRUTH)
    r = problem.residuals(x)
    assert len(blocks) == 4 and blocks[-1].stop == r.size
    assert removed == (2, 2, 2, 2)  # experimental parameters: a + b t fitted per channel
    # each block is one trial's channel: its squared norm is that channel's share of φ
    trial_a = problem.fitted[0]
    ra = trial_a.residuals(problem.case.to_physical(x))
    n_a = trial_a.objective.target.shape[0]
    assert blocks[0] == slice(0, n_a) and blocks[1] == slice(n_a, 2 * n_a)
    share_a = 0.25  # weights 1 and 3
    assert np.allclose(r[blocks[0]], math.sqrt(share_a) * ra[:n_a])
    assert np.allclose(r[blocks[1]], math.sqrt(share_a) * ra[n_a:])


def test_integrated_variance_matches_numerical_integration() -> None:
    rng = np.random.default_rng(3)
    r = 0.3 * rng.standard_normal(12)
    model = unknown_variance([slice(0, 12)], [12])

    def integrand(s: float) -> float:  # Gaussian likelihood × Jeffreys prior 1/v, v = e^s
        v = math.exp(s)
        return (2 * math.pi * v) ** -6 * math.exp(-(r @ r) / (2 * v))

    centre = math.log(r @ r / 12)
    value, _ = integrate.quad(integrand, centre - 30, centre + 30, limit=200)
    assert model.loglike(r) == pytest.approx(math.log(value), rel=1e-8)


def test_blocks_are_independent_and_scale_free() -> None:
    rng = np.random.default_rng(4)
    r = rng.standard_normal(30)
    two = unknown_variance([slice(0, 10), slice(10, 30)], [10, 20])
    a = unknown_variance([slice(0, 10)], [10]).loglike(r[:10])
    b = unknown_variance([slice(0, 20)], [20]).loglike(r[10:])
    assert two.loglike(r) == pytest.approx(a + b)
    scaled = r.copy()
    scaled[:10] *= 7.0  # a block's scale only shifts log L by a constant
    shift = two.loglike(scaled) - two.loglike(r)
    r2 = r + 0.1 * rng.standard_normal(30)
    s2 = r2.copy()
    s2[:10] *= 7.0
    assert two.loglike(s2) - two.loglike(r2) == pytest.approx(shift)


def test_batch_rows_equal_single_calls_and_failures_are_minus_inf() -> None:
    rng = np.random.default_rng(5)
    rows = rng.standard_normal((4, 40))
    rows[2, 7] = np.nan
    model = error_model([slice(0, 25), slice(25, 40)], "neff", best_residuals=rows[0])
    out = model.loglike_rows(rows)
    assert out[2] == -np.inf
    for i in (0, 1, 3):
        assert out[i] == model.loglike(rows[i])


def test_effective_count_of_an_ar1_series() -> None:
    rng = np.random.default_rng(6)
    rho, n = 0.9, 200_000
    e = np.empty(n)
    e[0] = rng.standard_normal()
    for t in range(1, n):
        e[t] = rho * e[t - 1] + rng.standard_normal()
    assert lag1_autocorrelation(e) == pytest.approx(rho, abs=0.005)
    model = error_model([slice(0, n)], "neff", best_residuals=e)
    assert model.counts[0] == pytest.approx(n * 0.1 / 1.9, rel=0.06)
    assert effective_count(100, -0.5) == 100.0  # never more than N


def test_weights_are_the_hessian_of_the_log_likelihood() -> None:
    """−∂²log L/∂θ² of r(θ) = a·θ − y at θ where aᵀr = 0 equals aᵀ W a."""
    rng = np.random.default_rng(8)
    a = rng.standard_normal(50)
    y = rng.standard_normal(50)
    theta = (a @ y) / (a @ a)
    model = unknown_variance([slice(0, 20), slice(20, 50)], [20, 30])
    h = 1e-4
    f = [model.loglike(a * (theta + s) - y) for s in (-h, 0.0, h)]
    hess = -(f[0] - 2 * f[1] + f[2]) / h ** 2
    w = model.weights(a * theta - y)
    # the dropped (Jᵀr)(rᵀJ) terms are of the blocks' own aᵀr, not zero per block
    assert a @ (w * a) == pytest.approx(hess, rel=0.15)
    known = error_model([slice(0, 50)], "known", sigma=0.5)
    assert np.all(known.weights(y) == 4.0)


def test_problem_error_model_and_bad_input(problem: UpdateProblem) -> None:
    r = problem.residuals(problem.case.to_search(TRUTH))
    model = problem_error_model(problem, r)
    assert model.kind == "neff" and model.size == r.size and not model.whitens
    assert np.all(model.counts < (model.stops - model.starts))  # correlated residuals
    with pytest.raises(ConfigError, match=r"got 'tau' \(allowed: neff, eiv, known\)"):
        problem_error_model(problem, r, "tau")
    with pytest.raises(ConfigError, match="allowed: neff, eiv, known"):
        error_model([slice(0, 5)], "gaussian")
    with pytest.raises(ConfigError, match="needs the residuals"):
        error_model([slice(0, 5)], "neff")
    with pytest.raises(DataError, match="all zero"):
        error_model([slice(0, 5)], "neff", best_residuals=np.zeros(5))
    with pytest.raises(ConfigError, match="sigma must be > 0"):
        error_model([slice(0, 5)], "known", sigma=0.0)
    with pytest.raises(ConfigError, match="needs sigma"):
        error_model([slice(0, 5)], "known")
    with pytest.raises(ConfigError, match="sigma is only for kind 'known'"):
        error_model([slice(0, 5)], "neff", best_residuals=np.ones(5), sigma=1.0)
    with pytest.raises(ConfigError, match="2 values for 1 blocks"):
        error_model([slice(0, 5)], "known", sigma=[1.0, 2.0])
    with pytest.raises(ConfigError, match="contiguous from 0"):
        error_model([slice(1, 5)], "known", sigma=1.0)


def test_neff_fixes_each_variance_at_the_best_fit() -> None:
    """``neff``'s log L is Gaussian with each block's variance ‖r_c*‖²/N_c of the best fit;
    at the best fit its curvature is the integrated variance's (the same weights), farther
    out it falls faster; the surrogate's one-value blocks of √S_c give the same log L."""
    rng = np.random.default_rng(11)
    best = rng.standard_normal(60)
    model = error_model([slice(0, 20), slice(20, 60)], "neff", best_residuals=best)
    ref, n_c = np.array([best[:20] @ best[:20], best[20:] @ best[20:]]), model.counts
    r = 1.7 * best
    squares = np.array([r[:20] @ r[:20], r[20:] @ r[20:]])
    expected = float(np.sum(-0.5 * n_c * (squares / ref + np.log(2 * math.pi * ref / n_c))))
    assert model.loglike(r) == pytest.approx(expected, rel=1e-12)
    integrated = unknown_variance([slice(0, 20), slice(20, 60)], n_c)
    assert np.allclose(model.weights(best), integrated.weights(best), rtol=1e-12)
    drop = model.loglike(best) - model.loglike(r)
    assert drop > integrated.loglike(best) - integrated.loglike(r) > 0
    rows = np.vstack([best, r])
    sums = np.sqrt(np.column_stack([model.sums_of_squares(rows)]))
    assert np.allclose(model.of_sums().loglike_rows(sums), model.loglike_rows(rows))


def test_known_is_the_gaussian_of_that_variance() -> None:
    rng = np.random.default_rng(9)
    r = rng.standard_normal(40)
    model = error_model([slice(0, 15), slice(15, 40)], "known", sigma=[0.5, 2.0])
    expected = sum(-0.5 * float(r[s] @ r[s]) / sd ** 2 - 0.5 * (s.stop - s.start)
                   * math.log(2 * math.pi * sd ** 2)
                   for s, sd in ((slice(0, 15), 0.5), (slice(15, 40), 2.0)))
    assert model.loglike(r) == pytest.approx(expected, rel=1e-12)


def test_the_models_round_trip_as_plain_data() -> None:
    rng = np.random.default_rng(10)
    r = rng.standard_normal(60)
    rows = np.vstack([r, 1.3 * r, np.full_like(r, np.nan)])
    for model in (error_model([slice(0, 20), slice(20, 60)], "neff", best_residuals=r),
                  error_model([slice(0, 60)], "known", sigma=0.3)):
        again = error_model_from(error_model_data(model))
        assert type(again) is type(model) and again.kind == model.kind
        assert np.array_equal(again.loglike_rows(rows), model.loglike_rows(rows))


def test_the_registry_holds_the_kinds_a_user_chooses_and_takes_others_explicitly() -> None:
    assert ERROR_MODELS.names == ("neff", "eiv", "known") and case_kinds() == ("neff", "eiv")

    class Halved(NEff):  # a plug-in: half of neff's counts
        name = "halved"

        def build(self, fit):  # type: ignore[no-untyped-def]
            model = super().build(fit)
            return ErrorModel(self.name, model.starts, model.stops, model.counts / 2, model.rho)

    mine = ERROR_MODELS.copy()
    mine.register(Halved())
    r = np.random.default_rng(11).standard_normal(30)
    neff = error_model([slice(0, 30)], "neff", best_residuals=r)
    halved = error_model([slice(0, 30)], "halved", best_residuals=r, registry=mine)
    assert halved.counts[0] == pytest.approx(neff.counts[0] / 2)
    assert "halved" not in ERROR_MODELS  # the product's registry is untouched
    with pytest.raises(ConfigError, match="'neff' is empty or taken"):
        mine.register(NEff())
    with pytest.raises(ConfigError, match="is empty or taken"):
        Registry(Known(), Known())


def test_importing_the_posterior_registers_no_method() -> None:
    """method "tmcmc" is registered by femupdate.inference.method.register(), called by
    femupdate posterior, not by importing a module."""
    code = ("import femupdate.inference.method, femupdate.pipeline.posterior.run\n"
            "from femupdate.optimize.minimize import METHODS\n"
            "assert 'tmcmc' not in METHODS, 'registered on import'\n"
            "femupdate.inference.method.register()\n"
            "assert 'tmcmc' in METHODS\n")
    subprocess.run([sys.executable, "-c", code], check=True)


@pytest.mark.parametrize("size", [4e153, 1e200])
def test_a_diverged_rows_residuals_give_minus_inf_without_a_warning(size):
    """Residuals whose squares (or π times them) pass the largest float: that row's log L is
    -inf, the other rows' stay finite, and nothing warns (a warning per row flooded the
    surrogate posterior's console)."""
    import warnings

    model = unknown_variance([slice(0, 4), slice(4, 8)], [4.0, 4.0])
    rows = np.vstack([np.full(8, size), np.linspace(-1.0, 1.0, 8)])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = model.loglike_rows(rows)
    assert out[0] == -np.inf
    assert np.isfinite(out[1])

"""The surrogate-aided posterior against the exact one of a cheap analytic model, and what it
says when it cannot reach its accuracy or the model fails at design points."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from pydantic import ValidationError

from femupdate.case import parse_case
from femupdate.case.posterior_section import PosteriorSection
from femupdate.errors import ConfigError, ModelError
from femupdate.inference.likelihood import ErrorModel
from femupdate.inference.priors import Prior
from femupdate.inference.surrogate import (
    ChannelSurrogate,
    convex_trend,
    log_sums,
    pseudo_model,
    quadratic_features,
    spread_points,
    surrogate_loglike,
    surrogate_posterior,
)
from femupdate.inference.surrogate_check import (
    COVERAGE_BAND,
    centred_error,
    coverage_of,
    importance_check,
)
from femupdate.pipeline.posterior.surrogate import (
    DesignStore,
    problem_evaluator,
    surrogate_record,
    wants_surrogate,
)
from femupdate.problem.update import UpdateProblem
from femupdate.trials.experiment import Experiment

pytest.importorskip("sklearn", reason="the surrogate needs scikit-learn (extra 'posterior')")

T = np.linspace(0.0, 2.0, 200)
TRUTH = (1.5, 0.8)
PRIOR = Prior(["f", "d"], [1.0, 0.2], [2.0, 2.0], ["linear", "linear"], {})
#: One channel of 200 independent values (an unknown variance integrated out).
MODEL = ErrorModel("iid", np.array([0]), np.array([T.size]), np.array([float(T.size)]),
                   np.zeros(1))


def response(f: float, d: float) -> np.ndarray:
    """A decaying oscillation of frequency f (Hz) and decay rate d (1/s)."""
    return np.exp(-d * T) * np.sin(2.0 * np.pi * f * T)


DATA = response(*TRUTH) + 0.05 * np.random.default_rng(1).standard_normal(T.size)


def evaluate(X: np.ndarray) -> tuple[np.ndarray, list[str | None]]:
    return np.array([response(*x) - DATA for x in X]), [None] * len(X)


def fixed_model(x: np.ndarray, r: np.ndarray) -> tuple[ErrorModel, int]:
    return MODEL, 0


def exact_moments() -> tuple[np.ndarray, np.ndarray]:
    """Means and standard deviations of the exact posterior by quadrature on a fine grid."""
    f, d = np.meshgrid(np.linspace(1.0, 2.0, 801), np.linspace(0.2, 2.0, 801), indexing="ij")
    ll = np.array([MODEL.loglike_rows(np.array([response(a, b) - DATA
                                               for a, b in zip(fa, da, strict=True)]))
                   for fa, da in zip(f, d, strict=True)])
    w = np.exp(ll - ll.max())
    w /= w.sum()
    means = np.array([(w * f).sum(), (w * d).sum()])
    sds = np.sqrt([(w * (f - means[0]) ** 2).sum(), (w * (d - means[1]) ** 2).sum()])
    return means, sds


@pytest.mark.slow
def test_matches_the_exact_posterior_in_few_runs() -> None:
    result = surrogate_posterior(evaluate, PRIOR, fixed_model, rng=np.random.default_rng(3),
                                 population=1000)
    means, sds = exact_moments()
    assert result.reached, result.message
    assert result.model_runs <= 80
    np.testing.assert_allclose(result.means(), means, rtol=0.005)
    np.testing.assert_allclose(result.sds(), sds, rtol=0.15)
    assert result.check.passed and result.check.ess >= 0.5
    assert np.all(result.check.coverage >= COVERAGE_BAND[0])
    assert "model runs" in result.message


def test_a_surrogate_short_of_its_budget_says_what_it_reached() -> None:
    result = surrogate_posterior(evaluate, PRIOR, fixed_model, rng=np.random.default_rng(3),
                                 max_runs=18, initial=12, batch=4, check=2, population=100)
    assert not result.reached
    assert result.model_runs == 18
    assert result.accuracy > result.tolerance
    assert "did not reach its accuracy" in result.message
    assert f"{result.accuracy:.3g} nats against a tolerance of 1" in result.message
    # the final check ran all the same, and says what it found
    assert result.check.runs == 2 and "effective share" in result.message
    record = surrogate_record(result, PRIOR, 3)
    assert not record.reached and record.params == {} and record.nfev == 18
    assert record.surrogate is not None and record.surrogate.check_runs == 2


def test_the_check_weighs_true_against_surrogate_likelihood() -> None:
    rng = np.random.default_rng(0)
    unit = rng.random((16, 2))
    sd = unit.std(axis=0)
    predicted = rng.normal(size=16)
    # a constant error in log L changes nothing: flat weights, no shift
    same = importance_check(unit, predicted, predicted - 3.0, sd)
    assert same.passed and same.ess == pytest.approx(1.0)
    np.testing.assert_allclose(same.shifts, 0.0, atol=1e-12)
    np.testing.assert_allclose(same.sd_ratios, 1.0)
    # an error that grows along the first parameter moves its mean that way, not the other's
    tilted = importance_check(unit, predicted, predicted + 3.0 * (unit[:, 0] - 0.5) / sd[0],
                              sd)
    assert not tilted.passed and tilted.shifts[0] > 0.5
    # the narrower reweighted sd keeps it inside the surrogate's interval: the reverse
    # coverage (the surrogate's inside the reweighted interval) is what fails
    assert tilted.coverage[1, 0] < COVERAGE_BAND[0] < tilted.coverage[1, 1]
    assert "largest shift of a mean" in tilted.words(["f", "d"]) and "sd (f)" in \
        tilted.words(["f", "d"])
    # fewer than two finite true log L: no check
    none = importance_check(unit[:2], predicted[:2], np.array([np.nan, 1.0]), sd)
    assert not none.passed and "fewer than two" in none.words(["f", "d"])


def test_a_failed_check_continues_the_design(monkeypatch: pytest.MonkeyPatch) -> None:
    """A check that fails adds its runs to the design and the batches go on; one that never
    passes ends at the budget and says so, with the check's figures."""
    import femupdate.inference.surrogate as module

    real, calls = module.importance_check, []

    def first_fails(*args: object) -> object:
        calls.append(args)
        return dataclasses.replace(real(*args), passed=len(calls) > 1)

    monkeypatch.setattr(module, "importance_check", first_fails)
    settings = dict(rng=np.random.default_rng(3), max_runs=60, initial=12, batch=4, check=4,
                    population=100, tolerance=1e6)
    result = surrogate_posterior(evaluate, PRIOR, fixed_model, **settings)
    assert len(calls) == 2 and result.reached, result.message
    # 12 initial, a batch, the failed check, a batch, the check that passed
    assert result.model_runs == 12 + 4 + 4 + 4 + 4 and result.iterations == 2
    assert "1 earlier check(s) failed and the design went on" in result.message

    def never(*args: object) -> object:
        return dataclasses.replace(real(*args), passed=False)

    monkeypatch.setattr(module, "importance_check", never)
    settings["rng"] = np.random.default_rng(3)
    result = surrogate_posterior(evaluate, PRIOR, fixed_model, **settings)
    assert not result.reached and result.model_runs <= 60
    assert result.model_runs + 4 + 4 > 60  # no room for another batch and check
    assert f"failed its final check after {result.model_runs} model runs (max_runs 60" in \
        result.message and "effective share" in result.message


def test_the_coverage_of_a_90_percent_interval() -> None:
    np.testing.assert_allclose(coverage_of(np.zeros(1), np.ones(1)), 0.90)
    # the rule's bounds: a mean 0.55 sd away, or an sd 14 % too wide or 16 % too narrow
    assert coverage_of(np.array([0.545]), np.ones(1))[0] == pytest.approx(0.85, abs=0.001)
    assert coverage_of(np.zeros(1), np.array([1.143]))[0] == pytest.approx(0.85, abs=0.001)
    assert coverage_of(np.zeros(1), np.array([0.839]))[0] == pytest.approx(0.95, abs=0.001)


def test_a_resumed_design_replays_its_stored_runs(tmp_path: Path) -> None:
    calls: list[int] = []

    def counted(X: np.ndarray) -> tuple[np.ndarray, list[str | None]]:
        calls.append(len(X))
        return evaluate(X)

    X = PRIOR.to_search(np.random.default_rng(1).random((5, 2)))
    first = DesignStore(tmp_path / "d.npz", counted, "case:3", resume=False)
    rows, _ = first(X[:3])
    again = DesignStore(tmp_path / "d.npz", counted, "case:3", resume=True)
    replayed, why = again(X)
    assert calls == [3, 2] and again.reused == 3 and why == [None] * 5
    np.testing.assert_array_equal(replayed[:3], rows)
    with pytest.raises(ConfigError, match="another case or seed"):
        DesignStore(tmp_path / "d.npz", counted, "case:4", resume=True)


def test_failing_design_points_are_reported() -> None:
    def fragile(X: np.ndarray) -> tuple[np.ndarray, list[str | None]]:
        rows, why = evaluate(X)
        for i, x in enumerate(X):
            if x[0] > 1.8:
                rows[i], why[i] = np.nan, f"no convergence at f = {x[0]:.3f}"
        return rows, why

    result = surrogate_posterior(fragile, PRIOR, fixed_model, rng=np.random.default_rng(3),
                                 max_runs=18, initial=12, batch=4, check=2, population=100)
    assert result.failures and all("no convergence at f = 1.8" in f or
                                   "no convergence at f = 1.9" in f for f in result.failures)
    assert f"the model failed at {len(result.failures)} of {result.model_runs}" in \
        result.message
    assert result.failures[0].startswith("f = ")


def test_a_model_failing_everywhere_is_an_error() -> None:
    def broken(X: np.ndarray) -> tuple[np.ndarray, list[str | None]]:
        return np.full((len(X), T.size), np.nan), ["section undefined"] * len(X)

    with pytest.raises(ModelError, match=r"failed at all 20 initial design points.*section"):
        surrogate_posterior(broken, PRIOR, fixed_model, rng=np.random.default_rng(0),
                            initial=20)


@pytest.mark.parametrize(("option", "value", "words"), [
    ("max_runs", 10, "max_runs: got 10"), ("tolerance", 0.0, "tolerance: got 0.0"),
    ("initial", 3, "initial: got 3"), ("batch", 1, "batch: got 1"),
    ("check", True, "check: got True")])
def test_bad_settings_are_refused(option: str, value: object, words: str) -> None:
    with pytest.raises(ConfigError, match=words):
        surrogate_posterior(evaluate, PRIOR, fixed_model, rng=np.random.default_rng(0),
                            **{option: value})


@pytest.mark.slow
def test_the_same_seed_gives_the_same_bits() -> None:
    runs = [surrogate_posterior(evaluate, PRIOR, fixed_model, rng=np.random.default_rng(5),
                                max_runs=18, initial=12, batch=4, check=2, population=100)
            for _ in range(2)]
    assert np.array_equal(runs[0].samples, runs[1].samples)


def test_the_pseudo_rows_give_the_surrogate_likelihood() -> None:
    rng = np.random.default_rng(2)
    unit = rng.random((30, 2))
    rows, _ = evaluate(PRIOR.to_search(unit))
    surrogate = ChannelSurrogate(unit, log_sums(MODEL, rows), rng)
    mean, var = surrogate.predict(unit[:5])
    pseudo = np.exp(0.5 * (mean + 0.5 * var))
    np.testing.assert_allclose(pseudo_model(MODEL).loglike_rows(pseudo),
                               surrogate_loglike(MODEL, mean, var), rtol=1e-12)
    # at its own design points the surrogate interpolates log S
    np.testing.assert_allclose(mean[:, 0], log_sums(MODEL, rows[:5])[:, 0], atol=1e-3)


def test_the_surrogate_variance_only_lowers_the_likelihood() -> None:
    mean = np.array([[0.0], [0.0]])
    ll = surrogate_loglike(MODEL, mean, np.array([[0.0], [0.1]]))
    assert ll[1] < ll[0]


def test_spread_points_and_centred_error() -> None:
    x = np.array([[0.0, 0.0], [0.01, 0.0], [1.0, 1.0], [0.5, 0.5]])
    assert set(spread_points(x, 2, np.ones(2)).tolist()) == {0, 2}
    assert centred_error(np.array([1.0, 2.0, 3.0]), np.array([0.0, 1.0, 2.0])) == 0.0
    assert centred_error(np.array([1.0]), np.array([0.0])) == np.inf


# ------------------------------------------------------------- a case's model and the default

FRAGILE = '''
def model(values, ag, dt):
    if values["a"] > 3.5:
        raise ValueError("unstable above a = 3.5")
    return (values["a"] * ag)[:, None]
'''


def fragile_problem(tmp_path: Path) -> UpdateProblem:
    """A one-channel Python model that fails above a = 3.5, on a target made by a = 2."""
    (tmp_path / "fragile.py").write_text(FRAGILE)
    case = parse_case({
        "case": {"name": "fragile"},
        "model": {"python": {"function": f"{tmp_path / 'fragile.py'}:model",
                             "isolate": False}},
        "parameters": [{"name": "a", "lower": 0.0, "upper": 5.0}],
        "data": {"format": "csv", "rate": 100.0, "input": {"file": "x.csv", "column": 0},
                 "outputs": [{"file": "x.csv", "column": 1, "name": "roof"}]},
    })
    t = np.arange(200) * 0.01
    ag = np.sin(2 * np.pi * 3.0 * t) * np.exp(-t)
    exp = Experiment(t=t, ag=ag, accelerations=(2.0 * ag)[:, None], target=(2.0 * ag)[:, None],
                     quantity="acceleration", channels=("roof",), weights=np.ones(1),
                     name="fragile")
    return UpdateProblem(case, exp)


def test_a_case_model_failure_comes_back_with_its_message(tmp_path: Path) -> None:
    problem = fragile_problem(tmp_path)
    rows, why = problem_evaluator(problem)(np.array([[2.0], [4.0]]))
    assert np.all(np.isfinite(rows[0])) and np.all(np.isnan(rows[1]))
    assert why[0] is None and "unstable above a = 3.5" in str(why[1])
    assert np.allclose(rows[0], problem.residuals(np.array([2.0])))


def test_the_surrogate_is_on_for_external_models_unless_asked_otherwise(tmp_path: Path
                                                                        ) -> None:
    external = fragile_problem(tmp_path).case
    assert wants_surrogate(external)
    assert not wants_surrogate(external, False)
    spec = external.to_dict()
    spec["posterior"] = {"surrogate": False}
    assert not wants_surrogate(parse_case(spec))
    built_in = parse_case({
        "case": {"name": "one-storey"},
        "model": {"shear_building": {"masses": [1.0], "stiffnesses": ["k"]}},
        "parameters": [{"name": "k", "lower": 1.0, "upper": 10.0}],
        "data": {"format": "csv", "rate": 100.0, "input": {"file": "x.csv", "column": 0},
                 "outputs": [{"file": "x.csv", "column": 1, "name": "F1", "node": "F1",
                              "dof": "ux"}]},
    })
    assert not wants_surrogate(built_in)
    assert wants_surrogate(built_in, True)


def test_the_surrogate_field_takes_only_a_boolean() -> None:
    with pytest.raises(ValidationError):
        PosteriorSection(surrogate="often")


@pytest.mark.slow
def test_femupdate_posterior_of_an_external_model_takes_the_surrogate(tmp_path: Path) -> None:
    """The CLI on a case file: an external model gets the surrogate by default, its record
    and samples written, the model runs counted."""
    import json

    from typer.testing import CliRunner

    from femupdate.cli.commands import app

    (tmp_path / "gain.py").write_text(FRAGILE)
    t = np.arange(300) * 0.01
    ag = np.sin(2 * np.pi * 3.0 * t) * np.exp(-t)
    roof = 2.0 * ag + 0.1 * np.random.default_rng(0).standard_normal(t.size)
    np.savetxt(tmp_path / "table.csv", np.column_stack([t, ag]), delimiter=",",
               header="t,table", comments="")
    np.savetxt(tmp_path / "roof.csv", np.column_stack([t, roof]), delimiter=",",
               header="t,roof", comments="")
    (tmp_path / "case.toml").write_text(f'''
[case]
name = "gain"
[model.python]
function = "gain.py:model"
isolate = false
[[parameters]]
name = "a"
lower = 0.0
upper = 3.0
[data]
format = "csv"
directory = "{tmp_path}"
time_column = "t"
input = {{file = "table.csv", column = "table"}}
outputs = [{{file = "roof.csv", column = "roof"}}]
[objective]
quantity = "acceleration"
[posterior]
seed = 3
''')
    result = CliRunner().invoke(app, ["posterior", str(tmp_path / "case.toml"), "--out",
                                      str(tmp_path / "out"), "--quiet"])
    assert result.exit_code == 0, result.output
    record = json.loads((tmp_path / "out" / "summary.json").read_text())["posterior"]
    assert record["method"] == "surrogate" and record["reached"], record["message"]
    assert record["nfev"] <= 300 and record["surrogate"]["failures"] == []
    assert record["surrogate"]["passed"]
    assert abs(record["params"]["a"]["mean"] - 2.0) < 0.05
    assert "surrogate posterior in" in record["message"]
    assert "Gaussian-process surrogate" in result.output
    samples = np.load(tmp_path / "out" / "surrogate.npz")["samples"]
    assert samples.shape[1] == 1
    assert np.array_equal(np.load(tmp_path / "out" / "posterior.npz")["samples"], samples)
    # killed and resumed: the stored design points are replayed, not run again
    resumed = CliRunner().invoke(app, ["posterior", str(tmp_path / "case.toml"), "--out",
                                       str(tmp_path / "out"), "--quiet", "--resume"])
    assert resumed.exit_code == 0, resumed.output
    again = json.loads((tmp_path / "out" / "summary.json").read_text())["posterior"]
    assert again["params"] == record["params"]
    assert f"({record['nfev']} of them replayed" in again["message"]


def test_the_trend_never_falls_away_from_the_data() -> None:
    rng = np.random.default_rng(0)
    u = rng.random((40, 2))
    saddle = (u[:, 0] - 0.5) ** 2 - (u[:, 1] - 0.5) ** 2
    coef = convex_trend(quadratic_features(u), saddle, 2)
    q = np.array([[coef[3], coef[4] / 2], [coef[4] / 2, coef[5]]])
    assert np.linalg.eigvalsh(q).min() >= -1e-12
    bowl = 1.0 + (u[:, 0] - 0.3) ** 2 + 2.0 * (u[:, 1] - 0.6) ** 2
    np.testing.assert_allclose(quadratic_features(u) @ convex_trend(quadratic_features(u),
                                                                     bowl, 2), bowl,
                               atol=1e-12)


def test_an_unset_surrogate_field_leaves_the_fingerprint_alone(tmp_path: Path) -> None:
    spec = fragile_problem(tmp_path).case.to_dict()
    spec["posterior"] = {"samples": 500}
    unset = parse_case(spec)
    assert "surrogate" not in unset.to_dict()["posterior"]
    spec["posterior"]["surrogate"] = True
    assert parse_case(spec).fingerprint() != unset.fingerprint()

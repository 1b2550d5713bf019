"""Priors: maps, sampling, densities, and one error per bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, stats

from femupdate.errors import ConfigError
from femupdate.inference.priors import Prior


def _prior(**specs: dict) -> Prior:
    return Prior(["E", "k", "c"], [1e11, 1e3, 0.0], [3e11, 1e5, 10.0],
                 ["linear", "log", "linear"], specs, source="case.toml")


def test_maps_round_trip_and_log_scale() -> None:
    prior = _prior()
    unit = np.array([[0.0, 0.5, 1.0], [0.25, 0.0, 0.1]])
    physical = prior.to_physical(unit)
    assert physical[0].tolist() == pytest.approx([1e11, 1e4, 10.0])
    assert np.allclose(prior.from_physical(physical), unit)


def test_samples_are_repeatable_and_follow_the_marginals() -> None:
    prior = _prior(E={"kind": "normal", "mean": 2e11, "sd": 2e10},
                   c={"kind": "lognormal", "median": 2.0, "sigma": 0.5})
    unit, physical = prior.sample(np.random.default_rng(1), 4000)
    again, _ = prior.sample(np.random.default_rng(1), 4000)
    assert np.array_equal(unit, again)
    assert np.all((unit >= 0) & (unit <= 1))
    truncnorm = stats.truncnorm(-5, 5, loc=2e11, scale=2e10)
    assert stats.kstest(physical[:, 0], truncnorm.cdf).pvalue > 0.01
    loguniform = stats.loguniform(1e3, 1e5)
    assert stats.kstest(physical[:, 1], loguniform.cdf).pvalue > 0.01
    assert np.median(physical[:, 2]) == pytest.approx(2.0, rel=0.05)


@pytest.mark.parametrize("i, spec", [
    (0, {"kind": "normal", "mean": 1.2e11, "sd": 3e10}),
    (1, {"kind": "normal", "mean": 5e3, "sd": 4e3}),
    (1, {"kind": "lognormal", "median": 2e4, "sigma": 1.0}),
    (2, {"kind": "lognormal", "median": 3.0, "sigma": 0.8}),
    (1, None),
])
def test_densities_integrate_to_one(i: int, spec: dict | None) -> None:
    full = _prior()
    name = full.names[i]
    prior = Prior([name], full.lower[[i]], full.upper[[i]], [full.scales[i]],
                  {name: spec} if spec else None)
    low, high = prior.lower[0], prior.upper[0]

    def unit_density(xi: float) -> float:
        return math.exp(prior.logpdf_unit(np.array([[xi]]))[0])

    def physical_density(x: float) -> float:
        return math.exp(prior.logpdf(np.array([[x]]))[0])

    assert integrate.quad(unit_density, 0, 1, limit=200)[0] == pytest.approx(1, rel=1e-5)
    breaks = np.geomspace(low + 1e-9, high, 12)[:-1]
    assert integrate.quad(physical_density, low, high, limit=400, points=breaks)[0] == \
        pytest.approx(1, rel=1e-4)


def test_outside_is_minus_inf_and_curvature_of_a_normal() -> None:
    prior = _prior(E={"kind": "normal", "mean": 2e11, "sd": 2e10})
    assert prior.logpdf_unit(np.array([[1.1, 0.5, 0.5]]))[0] == -np.inf
    assert prior.logpdf(np.array([[2e11, 1e2, 1.0]]))[0] == -np.inf
    grad, hess = prior.curvature_unit(np.array([0.25, 0.5, 0.5]))
    span = 2e11
    assert hess[0] == pytest.approx(-(span / 2e10) ** 2, rel=1e-5)
    assert grad[0] == pytest.approx(-(1.5e11 - 2e11) / 2e10 ** 2 * span, rel=1e-5)
    assert hess[1] == hess[2] == 0.0
    assert prior.std_search()[2] == pytest.approx(10 / math.sqrt(12), rel=1e-4)


@pytest.mark.parametrize("args, specs, match", [
    (([-1.0], [1.0], ["log"]), None, r"case.toml: parameters\[a\].lower: got -1 with scale = "
                                      r"'log'.*allowed: lower > 0"),
    (([0.0], [1.0], ["linear"]), {"a": {"kind": "normal", "mean": 2.0, "sd": 0.1}},
     r"parameters\[a\].prior.mean: got 2, outside the bounds \(allowed: a value in \[0, 1\]"),
    (([0.0], [1.0], ["linear"]), {"a": {"kind": "normal", "mean": 0.5, "sd": 0.0}},
     r"parameters\[a\].prior.sd: got 0 \(allowed: sd > 0\)"),
    (([0.0], [1.0], ["linear"]), {"a": {"kind": "lognormal", "median": 0.5, "sigma": -1}},
     r"prior.sigma: got -1 \(allowed: sigma > 0"),
    (([0.0], [1.0], ["linear"]), {"a": {"kind": "beta"}}, r"prior.kind: got 'beta'"),
    (([0.0], [1.0], ["linear"]), {"a": {"kind": "normal", "mean": 0.5}},
     r"a normal prior takes mean, sd, got mean"),
    (([0.0], [1.0], ["linear"]), {"b": {"kind": "uniform"}}, r"unknown parameter\(s\) \['b'\]"),
    (([1.0], [1.0], ["linear"]), None, r"parameters\[a\].upper: got bounds \[1, 1\]"),
    (([0.0], [1.0], ["cubic"]), None, r"parameters\[a\].scale: got 'cubic'"),
])
def test_bad_input_is_one_line_naming_the_field(args: tuple, specs: dict | None,
                                                match: str) -> None:
    with pytest.raises(ConfigError, match=match) as info:
        Prior(["a"], *args, specs, source="case.toml")
    assert "\n" not in str(info.value)


def test_bad_sample_size() -> None:
    with pytest.raises(ConfigError, match="allowed: an integer ≥ 1"):
        _prior().sample(np.random.default_rng(0), 0)

"""The errors-in-variables error model (kind "eiv", femupdate.inference.eiv and input_noise):
its pieces against closed forms, its linear maps against their transposes, its score covariance
against simulated noise, its band and lines, and its refusals."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.signal import fftconvolve

from femupdate.case import parse_case
from femupdate.errors import ConfigError
from femupdate.inference import input_noise
from femupdate.inference.error_models import ERROR_MODELS, error_model, problem_error_model
from femupdate.paper.problems import bridge
from femupdate.problem.update import UpdateProblem
from femupdate.trials.experiment import load_experiments
from femupdate.trials.virtual import virtual_experiment
from two_storey_case import TRUTH, two_storey_spec


@pytest.fixture(scope="module")
def problem(tmp_path_factory: pytest.TempPathFactory) -> UpdateProblem:
    """The two-storey building on displacements, 3 % noise on every record (the table's too),
    with offsets and drifts."""
    root = tmp_path_factory.mktemp("eiv")
    case = parse_case(two_storey_spec(root), source=root / "case.toml")
    virtual_experiment(case, TRUTH, root, seed=4, rate=100.0, duration=6.0, snr=0.03)
    return UpdateProblem(case, load_experiments(case))


@pytest.fixture(scope="module")
def truth_point(problem: UpdateProblem) -> np.ndarray:
    return problem.case.to_search(TRUTH)


@pytest.fixture(scope="module")
def model(problem: UpdateProblem, truth_point: np.ndarray):
    return problem_error_model(problem, problem.residuals(truth_point), "eiv",
                               point=truth_point)


def test_folded_transfer_is_the_dtft_of_the_impulse_response_on_the_grid() -> None:
    rng = np.random.default_rng(0)
    n, centre = 16, 5
    response = np.zeros((40, 1))
    response[centre - 2:centre + 30, 0] = rng.standard_normal(32)  # lags −2 … 29
    lags = np.arange(40) - centre
    omega = 2 * np.pi * np.arange(n // 2 + 1) / n
    dtft = (response[:, 0] * np.exp(-1j * np.outer(omega, lags))).sum(axis=1)
    assert np.allclose(input_noise.folded_transfer(response, centre, n)[:, 0], dtft)


def test_expected_periodogram_of_a_moving_average_is_its_closed_form() -> None:
    n, b, variance = 64, 0.7, 2.0
    response = np.array([[1.0], [b]])  # x_t = e_t + b e_{t-1}
    expected = input_noise.expected_periodogram(response, np.array([variance]), n)
    k = np.arange(n // 2 + 1)
    exact = variance * (n * (1 + b * b) + 2 * (n - 1) * b * np.cos(2 * np.pi * k / n))
    assert np.allclose(expected, exact)


def test_the_tapered_expected_periodogram_is_the_sum_over_the_covariance() -> None:
    n, b, variance = 24, 0.7, 2.0
    response = np.array([[1.0], [b]])  # x_t = e_t + b e_{t-1}
    window = input_noise.taper(n)
    lags = np.subtract.outer(np.arange(n), np.arange(n))
    covariance = variance * np.select([lags == 0, np.abs(lags) == 1], [1 + b * b, b], 0.0)
    phases = np.exp(-2j * np.pi * np.outer(np.arange(n // 2 + 1), np.arange(n)) / n)
    weighted = phases * window  # row k: h_t e^{-iω_k t}
    exact = np.einsum("ks,st,kt->k", weighted, covariance, np.conj(weighted)).real
    got = input_noise.expected_periodogram(response, np.array([variance]), n, window)
    assert np.allclose(got, exact)


def test_the_taper_keeps_the_power_and_stops_a_line_leaking_far() -> None:
    n = 4096
    window = input_noise.taper(n)
    assert np.mean(window ** 2) == pytest.approx(1.0)
    assert np.all(input_noise.taper(n, 0.0) == 1.0)
    line = np.cos(2 * np.pi * 1500.5 * np.arange(n) / n)  # between two frequencies
    far = slice(1, 1000)  # at least 500 frequencies below the line
    plain = np.abs(np.fft.rfft(line))[far]
    tapered = np.abs(np.fft.rfft(line * window))[far]
    assert tapered.max() < 1e-3 * plain.max()


def test_whitening_matrices_invert_the_spectrum() -> None:
    rng = np.random.default_rng(1)
    bins, channels, n = 5, 3, 100
    gain = rng.uniform(0.5, 2.0, (bins, channels))
    transfer = rng.standard_normal((bins, channels)) + 1j * rng.standard_normal((bins, channels))
    sigma_out, sigma_in = np.array([0.3, 0.5, 0.2]), 0.7
    w = input_noise.whitening_matrices(gain, transfer, sigma_out, sigma_in, n)
    for f in range(bins):
        spectrum = n * (np.diag(sigma_out ** 2 * gain[f])
                        + sigma_in ** 2 * np.outer(transfer[f], np.conj(transfer[f])))
        assert np.allclose(np.conj(w[f]).T @ w[f], np.linalg.inv(spectrum))


def test_noise_levels_are_recovered_from_coefficients_drawn_from_the_model() -> None:
    rng = np.random.default_rng(2)
    bins, channels, n = 4000, 3, 8000
    freq = np.linspace(0.01, 0.5, bins)
    gain = 1.0 / (1.0 + (freq / 0.1) ** 2)[:, None] * np.array([1.0, 2.0, 0.5])
    resonance = 1.0 / (0.2 ** 2 - freq ** 2 + 0.01j * freq)  # a lightly damped mode
    transfer = resonance[:, None] * np.array([0.02, 0.05, -0.03])
    sigma_out, sigma_in = np.array([0.1, 0.05, 0.2]), 0.3
    draws = []
    for f in range(bins):
        spectrum = n * (np.diag(sigma_out ** 2 * gain[f])
                        + sigma_in ** 2 * np.outer(transfer[f], np.conj(transfer[f])))
        root = np.linalg.cholesky(spectrum)
        z = (rng.standard_normal(channels) + 1j * rng.standard_normal(channels)) / math.sqrt(2)
        draws.append(root @ z)
    fitted_out, fitted_in = input_noise.fit_noise_levels(np.array(draws), gain, transfer, n)
    assert np.allclose(fitted_out, sigma_out, rtol=0.05)
    assert fitted_in == pytest.approx(sigma_in, rel=0.1)


def test_the_adjoints_are_the_transposes_of_the_whitening(model) -> None:
    rng = np.random.default_rng(3)
    x = rng.standard_normal((2, model.size))
    white = model.whiten(x)
    v = rng.standard_normal(white.shape)
    assert np.sum(white * v) == pytest.approx(
        np.sum(x * input_noise.whitening_adjoint(model, v)), rel=1e-10)


def test_the_model_whitens_one_trial_across_channels_and_frequencies(model) -> None:
    assert model.kind == "eiv" and len(model.spectral) == 1 and model.whitens
    trial = model.spectral[0]
    assert trial.blocks == (0, 1)
    # two channels' real and imaginary parts at each kept frequency, less the projected
    # offsets and drifts (4 sensors' … the table's and the two floors': 2 × 3 responses)
    assert model.counts[0] == trial.size - 4 - trial.nuisance.shape[1]
    assert trial.nuisance.shape[1] == 6
    # the responses to offsets and drifts are projected out of the whitened values
    assert np.allclose(trial.nuisance.T @ trial.nuisance, np.eye(6), atol=1e-10)
    described = model.to_dict()["noise"][0]
    assert described["frequencies"] == trial.bins.size and 0 < described["input_share"] < 1


def test_the_fitted_noise_levels_are_the_records(problem: UpdateProblem, model) -> None:
    """3 % of each record's rms: the levels fitted at the truth are within a third of it."""
    experiment = problem.fitted[0].experiment
    rms = [np.sqrt(np.mean(signal ** 2)) for signal in (experiment.ag_unfiltered,)]
    trial = model.spectral[0]
    assert trial.sigma_input == pytest.approx(0.03 * rms[0], rel=0.35)
    assert np.all(trial.sigma_outputs > 0)


def test_the_score_covariance_is_that_of_simulated_noise(problem: UpdateProblem,
                                                         truth_point: np.ndarray,
                                                         model) -> None:
    """Var(Dᵀr) by :func:`score_covariance` against the variance of Dᵀr over residuals made of
    white noise through the same processing and model, from rest."""
    r = problem.residuals(truth_point)
    trial = problem.fitted[0]
    values = problem.values(truth_point)
    samples = trial.objective.target.shape[0]
    rng = np.random.default_rng(5)
    directions = rng.standard_normal((r.size, 2))
    exact = input_noise.score_covariance(problem, model, truth_point, r, directions)
    scales = input_noise.block_scales(trial, values, r.reshape(2, samples).T)
    into, own, centre = input_noise.decayed_impulse_responses(trial, values)
    into, own = into[centre:] * scales, own[centre:] * scales
    fitted = model.spectral[0]
    scores = []
    for _ in range(400):
        table = fitted.sigma_input * rng.standard_normal(samples)
        sensors = fitted.sigma_outputs * rng.standard_normal((samples, 2))
        residual = np.column_stack([fftconvolve(sensors[:, c], own[:, c])[:samples]
                                    + fftconvolve(table, into[:, c])[:samples]
                                    for c in range(2)])
        residual = input_noise._projected_out(residual, trial.objective.t)
        scores.append(directions.T @ residual.T.ravel())
    simulated = np.cov(np.array(scores).T)
    # 400 draws: a variance to about ±7 %
    assert np.allclose(np.diag(exact), np.diag(simulated), rtol=0.25)


def test_the_model_round_trips_as_plain_data(model) -> None:
    again = ERROR_MODELS.from_data(model.data())
    rows = np.random.default_rng(6).standard_normal((3, model.size))
    assert np.array_equal(again.whiten(rows), model.whiten(rows))
    assert np.array_equal(again.loglike_rows(rows), model.loglike_rows(rows))
    # a whitening stored before the taper rebuilds untapered, as it was sampled
    trial = model.spectral[0].to_dict()
    del trial["taper_fraction"]
    assert input_noise.TrialWhitening.from_dict(trial).taper_fraction == 0.0


def test_eiv_needs_the_problem_and_its_point(problem: UpdateProblem,
                                             truth_point: np.ndarray) -> None:
    r = problem.residuals(truth_point)
    with pytest.raises(ConfigError, match="problem_error_model"):
        error_model([slice(0, r.size)], "eiv", best_residuals=r)
    with pytest.raises(ConfigError, match="point"):
        problem_error_model(problem, r, "eiv")


def test_eiv_weighs_the_frequencies_up_to_the_low_pass_only(
        tmp_path: Path, problem: UpdateProblem, model) -> None:
    """The same records low-passed at 10 Hz: ``eiv`` weighs no frequency above it (its
    whitening would divide the filter back out); unfiltered, it weighs them."""
    spec = two_storey_spec(tmp_path)
    spec["preprocess"]["lowpass_hz"] = 10.0
    case = parse_case(spec, source=tmp_path / "case.toml")
    virtual_experiment(case, TRUTH, tmp_path, seed=4, rate=100.0, duration=6.0, snr=0.03)
    low = UpdateProblem(case, load_experiments(case))
    x = low.case.to_search(TRUTH)
    r = low.residuals(x)
    (trial,) = problem_error_model(low, r, "eiv", point=x).spectral
    n = r.size // 2 - model.lag  # one trial, 2 channels
    dt = low.fitted[0].experiment.dt
    assert 10.0 >= trial.bins.max() / (n * dt) > 9.0
    assert model.spectral[0].bins.max() / (n * dt) > 10.0


def test_a_line_the_fit_leaves_is_left_out_and_named(problem: UpdateProblem,
                                                     truth_point: np.ndarray, model) -> None:
    """A sinusoid of half the residual's rms in one channel: its frequency is left out and
    named; at the truth none is."""
    r = problem.residuals(truth_point)
    samples = r.size // 2
    n = samples - model.lag
    dt = problem.fitted[0].experiment.dt
    k = 200  # a bin of the n-point grid: 200/(n dt) Hz
    hz = k / (n * dt)
    t = np.arange(samples) * dt
    lined = r.copy()
    lined[:samples] += 0.5 * np.linalg.norm(r[:samples]) / np.sqrt(samples) * np.sin(
        2 * np.pi * hz * t)
    (trial,) = problem_error_model(problem, lined, "eiv", point=truth_point).spectral
    assert model.spectral[0].lines_hz == ()
    assert any(abs(f - hz) < 1.5 / (n * dt) for f in trial.lines_hz)
    assert k not in trial.bins and k in model.spectral[0].bins
    assert trial.to_dict()["lines_hz"] == list(trial.lines_hz)


def test_given_the_jacobian_eiv_is_magnitude_adjusted(problem: UpdateProblem,
                                                     truth_point: np.ndarray, model) -> None:
    r = problem.residuals(truth_point)
    jac = np.random.default_rng(8).standard_normal((r.size, truth_point.size))
    adjusted = problem_error_model(problem, r, "eiv", jac, point=truth_point)
    again = input_noise.magnitude_adjusted(problem, model, truth_point, r, jac, r)
    assert np.array_equal(adjusted.counts, again.counts)
    assert not np.array_equal(adjusted.counts, model.counts)


def test_a_nonlinear_model_is_refused(tmp_path: Path) -> None:
    case = parse_case(bridge.bridge_case("friction", "narrow", directory=str(tmp_path)),
                      source=tmp_path / "case.toml")
    virtual_experiment(case, bridge.truth("friction"), tmp_path, seed=1, duration=0.5,
                       snr=0.02)
    problem = UpdateProblem(case, load_experiments(case))
    x = problem.case.to_search(bridge.truth("friction"))
    with pytest.raises(ConfigError, match="linear models"):
        problem_error_model(problem, problem.residuals(x), "eiv", point=x)


def test_the_magnitude_adjustment_matches_the_score_variance_on_average(
        problem: UpdateProblem, truth_point: np.ndarray, model) -> None:
    """Raised to k, the likelihood's curvature H_k and its score's variance V_k satisfy
    tr(H_k⁻¹ V_k) = n: on average over the parameters, the sandwich's."""
    r = problem.residuals(truth_point)
    prior_bounds = np.array(problem.bounds)
    jac = np.empty((r.size, truth_point.size))
    for i in range(truth_point.size):  # central differences over 1e-4 of each range
        step = 1e-4 * (prior_bounds[i, 1] - prior_bounds[i, 0])
        up, down = truth_point.copy(), truth_point.copy()
        up[i] += step
        down[i] -= step
        jac[:, i] = (problem.residuals(up) - problem.residuals(down)) / (2e-4)
    adjusted = input_noise.magnitude_adjusted(problem, model, truth_point, r, jac, r)
    k = adjusted.counts / model.counts
    assert np.allclose(k, k[0]) and 0.0 < k[0] < 2.0
    ((precision, meat),) = input_noise.score_meats(problem, adjusted, truth_point, r,
                                                   [(r, jac)])
    assert np.trace(np.linalg.solve(precision, meat)) == pytest.approx(truth_point.size,
                                                                      rel=1e-6)




def test_the_lines_left_out_are_said_in_words(problem: UpdateProblem, truth_point: np.ndarray,
                                              model) -> None:
    from femupdate.inference.eiv import line_ranges

    assert line_ranges([226.4, 225.9, 226.1, 310.0]) == "225.9–226.4 Hz, 310.0 Hz"
    assert model.notes() == []
    r = problem.residuals(truth_point).copy()
    samples = r.size // 2
    dt = problem.fitted[0].experiment.dt
    r[:samples] += 0.5 * np.std(r[:samples]) * np.sin(2 * np.pi * 12.0 * np.arange(samples) * dt)
    (words,) = problem_error_model(problem, r, "eiv", point=truth_point).notes()
    low, high = (float(f) for f in re.search(r"left out ([\d.]+)–([\d.]+) Hz of fitted "
                                             r"trial 1 \(\d+ of \d+ frequencies\)",
                                             words).groups())
    assert low < 12.0 < high

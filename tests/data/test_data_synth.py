"""Tests of femupdate.data.synth: EC8 spectrum, response spectrum, generator, sensors."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from femupdate.data.signal import integrate, integrate_twice
from femupdate.data.synth import (
    EC8_GROUND,
    EC8Spectrum,
    artificial_accelerogram,
    baseline_correct,
    ec8_spectrum,
    response_spectrum,
    saragoni_hart,
    scale_time,
    sensor_record,
    trapezoidal,
)
from femupdate.errors import ConfigError

AG = 0.25 * 9.81


# --------------------------------------------------------------------------- EC8


@pytest.mark.parametrize(("kind", "ground"), [(1, "B"), (1, "D"), (2, "A"), (2, "E")])
def test_ec8_spectrum_closed_form(kind: int, ground: str) -> None:
    s, tb, tc, td = EC8_GROUND[kind][ground]
    periods = np.array([0.0, tb / 2, tb, (tb + tc) / 2, tc, td, 3.0, 4.0])
    expected = AG * s * np.array([1.0, 1.75, 2.5, 2.5, 2.5, 2.5 * tc / td,
                                  2.5 * tc * td / 9.0, 2.5 * tc * td / 16.0])
    np.testing.assert_allclose(ec8_spectrum(periods, AG, ground, kind), expected, rtol=1e-14)


def test_ec8_tables_and_damping_correction() -> None:
    assert EC8_GROUND[1]["C"] == (1.15, 0.20, 0.6, 2.0)  # EN 1998-1 Table 3.2
    assert EC8_GROUND[2]["D"] == (1.80, 0.10, 0.30, 1.2)  # EN 1998-1 Table 3.3
    plateau = ec8_spectrum(0.3, AG, "B", 1, damping=10.0)
    assert plateau == pytest.approx(AG * 1.2 * 2.5 * np.sqrt(10 / 15))
    # η has a floor of 0.55 (ξ = 30 % would give 0.535)
    assert ec8_spectrum(0.3, AG, "B", 1, damping=30.0) == pytest.approx(AG * 1.2 * 2.5 * 0.55)
    assert EC8Spectrum(AG, "C")(np.array([0.4])) == ec8_spectrum(0.4, AG, "C")


@pytest.mark.parametrize(("args", "message"), [
    ({"ground": "F"}, "ground type must be one of A, B, C, D, E"),
    ({"kind": 3}, "kind must be 1 or 2"),
    ({"damping": -1.0}, r"damping must be a ratio in percent in \[0, 100\)"),
])
def test_ec8_rejects_bad_arguments(args: dict, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        ec8_spectrum(1.0, AG, **args)
    with pytest.raises(ConfigError, match=r"periods must lie in \[0, 4.0\] s"):
        ec8_spectrum(5.0, AG)


# --------------------------------------------------------------------------- response spectrum


def sdof_peak(ag: np.ndarray, t: np.ndarray, period: float, zeta: float) -> float:
    """ω² max|u| of u'' + 2ζωu' + ω²u = -ag (lsim: input linear between samples)."""
    w = 2 * np.pi / period
    sys = scipy.signal.StateSpace([[0, 1], [-w * w, -2 * zeta * w]], [[0], [-1]], [[1, 0]],
                                  [[0]])
    _, u, _ = scipy.signal.lsim(sys, ag, t)
    return float(w * w * np.max(np.abs(u)))


@pytest.mark.parametrize("zeta", [0.0, 0.05, 0.2])
def test_response_spectrum_matches_lsim(zeta: float) -> None:
    dt = 0.01
    t = np.arange(1500) * dt
    ag = np.random.default_rng(3).standard_normal(t.size) * np.exp(-(((t - 4) / 3) ** 2))
    periods = np.array([0.2, 0.5, 1.0, 2.0, 3.7])
    expected = [sdof_peak(ag, t, p, zeta) for p in periods]
    np.testing.assert_allclose(response_spectrum(ag, dt, periods, zeta), expected, rtol=1e-9)


def test_response_spectrum_substeps_short_periods() -> None:
    # T = 0.05 s at dt = 0.02 s: stepped in ceil(20·0.02/0.05) = 8 substeps, the input
    # interpolated linearly; lsim on that fine grid gives the same peak
    dt, period = 0.02, 0.05
    t = np.arange(400) * dt
    ag = np.sin(2 * np.pi * 3.1 * t) * np.exp(-t)
    fine = np.arange((t.size - 1) * 8 + 1) * dt / 8
    expected = sdof_peak(np.interp(fine, t, ag), fine, period, 0.05)
    assert response_spectrum(ag, dt, [period])[0] == pytest.approx(expected, rel=1e-9)


def test_response_spectrum_limits() -> None:
    dt = 0.005
    t = np.arange(2000) * dt
    ag = np.sin(2 * np.pi * 0.7 * t)  # smooth and slow
    pga = np.max(np.abs(ag))
    assert response_spectrum(ag, dt, [0.0])[0] == pga
    # a rigid oscillator follows the ground: PSA(T → 0) → PGA
    assert response_spectrum(ag, dt, [0.01])[0] == pytest.approx(pga, rel=1e-3)
    with pytest.raises(ConfigError, match=r"zeta must be a damping ratio in \[0, 1\)"):
        response_spectrum(ag, dt, [1.0], zeta=1.0)


# --------------------------------------------------------------------------- envelopes, baseline


def test_envelopes() -> None:
    t = np.linspace(0, 20, 2001)
    w = saragoni_hart(t, 20.0, eps=0.2, eta=0.05)
    assert t[np.argmax(w)] == pytest.approx(4.0) and np.max(w) == pytest.approx(1.0)
    assert w[-1] == pytest.approx(0.05) and w[0] == 0.0
    tr = trapezoidal(t, 20.0, rise=0.1, decay=0.3)
    np.testing.assert_allclose(tr[[0, 100, 200, 1000, 1400, 1700, 2000]],
                               [0, 0.5, 1, 1, 1, 0.5, 0], atol=1e-12)


def test_baseline_correction_ends_at_rest() -> None:
    dt = 0.01
    t = np.arange(3000) * dt
    rng = np.random.default_rng(5)
    ag = (rng.standard_normal(t.size) + 0.05) * saragoni_hart(t, t[-1])  # a biased record
    out = baseline_correct(ag, dt, weight=saragoni_hart(t, t[-1]))
    raw_v, raw_d = integrate(ag, dt), integrate_twice(ag, dt)
    assert abs(raw_v[-1]) > 0.1 * np.max(np.abs(raw_v))  # the record did drift
    assert abs(raw_d[-1]) > 0.1 * np.max(np.abs(raw_d))
    v, d = integrate(out, dt), integrate_twice(out, dt)
    assert abs(v[-1]) < 1e-9 * np.max(np.abs(v))
    assert abs(d[-1]) < 1e-9 * np.max(np.abs(d))
    assert out[0] == 0.0  # the envelope-weighted correction keeps the quiet start
    both = baseline_correct(np.column_stack([ag, 2 * ag]), dt)
    np.testing.assert_allclose(both[:, 1], 2 * both[:, 0], rtol=1e-12)


# --------------------------------------------------------------------------- generator


@pytest.fixture(scope="module")
def records() -> list:
    target = EC8Spectrum(ag=AG, ground="B", kind=1)
    return [artificial_accelerogram(target, 30.0, 0.01, np.random.default_rng(seed))
            for seed in (0, 1, 2)]


@pytest.mark.slow
def test_generated_spectrum_matches_ec8(records: list) -> None:
    target = EC8Spectrum(ag=AG, ground="B", kind=1)
    # 300 periods, none of them a control period of the generator
    periods = np.geomspace(0.1, 2.0, 300)
    for rec in records:
        ratio = response_spectrum(rec.acceleration, 0.01, periods) / target(periods)
        assert np.max(np.abs(ratio - 1)) <= 0.10
        np.testing.assert_allclose(rec.spectrum, response_spectrum(rec.acceleration, 0.01,
                                                                   rec.periods))
        assert rec.max_deviation == pytest.approx(np.max(np.abs(rec.spectrum / rec.target
                                                                 - 1)))


def test_generated_record_ends_at_rest(records: list) -> None:
    for rec in records:
        v, d = integrate(rec.acceleration, 0.01), integrate_twice(rec.acceleration, 0.01)
        assert abs(v[-1]) < 1e-9 * np.max(np.abs(v))
        assert abs(d[-1]) < 1e-9 * np.max(np.abs(d))
        assert rec.t[-1] == pytest.approx(30.0) and rec.acceleration[0] == 0.0


def test_generator_is_repeatable(records: list) -> None:
    target = EC8Spectrum(ag=AG, ground="B", kind=1)
    again = artificial_accelerogram(target, 30.0, 0.01, np.random.default_rng(0))
    np.testing.assert_array_equal(again.acceleration, records[0].acceleration)
    assert not np.array_equal(records[0].acceleration, records[1].acceleration)


def test_generator_rejects_bad_arguments() -> None:
    target = EC8Spectrum(ag=AG)
    rng = np.random.default_rng(0)
    with pytest.raises(ConfigError, match=r"period_range must satisfy 2·dt"):
        artificial_accelerogram(target, 10.0, 0.01, rng, period_range=(0.01, 2.0))
    with pytest.raises(ConfigError, match="duration must be at least 50 samples"):
        artificial_accelerogram(target, 0.1, 0.01, rng)
    with pytest.raises(ConfigError, match="envelope must be"):
        artificial_accelerogram(target, 10.0, 0.01, rng, envelope_kind="box")  # type: ignore


def test_similitude_time_scaling() -> None:
    t = np.arange(5) * 0.01
    np.testing.assert_allclose(scale_time(t, 1 / 50), t / np.sqrt(50))
    # a 2 Hz prototype sine becomes a 2·√50 Hz model sine
    t_model = scale_time(np.arange(1000) * 0.01)
    f_model = 1 / (scale_time(np.array([0.5]))[0])
    assert f_model == pytest.approx(2 * np.sqrt(50))
    assert t_model[-1] == pytest.approx(9.99 / np.sqrt(50))
    with pytest.raises(ConfigError, match=r"length_scale must be in \(0, 1\]"):
        scale_time(t, 2.0)


# --------------------------------------------------------------------------- sensors


def test_sensor_record_noise_offset_drift() -> None:
    dt = 0.001
    t = np.arange(5000) * dt
    signal = np.column_stack([np.sin(2 * np.pi * 3 * t), 0.1 * np.cos(2 * np.pi * 5 * t)])
    clean = sensor_record(signal, np.random.default_rng(0), offset=np.array([0.2, -0.1]),
                          drift=0.05, dt=dt)
    np.testing.assert_allclose(clean - signal, np.array([0.2, -0.1]) + 0.05 * t[:, None],
                               atol=1e-15)
    noisy = sensor_record(signal, np.random.default_rng(0), snr=0.05)
    noise = noisy - signal
    rms = np.sqrt(np.mean(noise**2, axis=0)) / np.sqrt(np.mean(signal**2, axis=0))
    np.testing.assert_allclose(rms, 0.05, rtol=1e-12)  # per channel, exactly
    lag1 = np.mean(noise[1:] * noise[:-1], axis=0) / np.mean(noise**2, axis=0)
    assert np.all(np.abs(lag1) < 0.05)  # white
    again = sensor_record(signal, np.random.default_rng(0), snr=0.05)
    np.testing.assert_array_equal(noisy, again)


def test_sensor_record_rejects_bad_arguments() -> None:
    rng = np.random.default_rng(0)
    with pytest.raises(ConfigError, match=r"drift .* needs dt"):
        sensor_record(np.ones(10), rng, drift=1.0)
    with pytest.raises(ConfigError, match=r"snr .* must be >= 0"):
        sensor_record(np.ones(10), rng, snr=-1.0)

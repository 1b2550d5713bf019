"""Tests of femupdate.data.signal against closed-form results."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

from femupdate.data.datasets import read_xsens_dot
from femupdate.data.measurement import align
from femupdate.data.signal import (
    advance,
    band,
    detrend,
    estimate_delay,
    fourier_amplitude,
    highpass,
    integrate,
    integrate_twice,
    peak_frequency,
    relative,
    remove_polynomial,
    substep_times,
    substeps,
    transfer_function,
)
from femupdate.errors import ConfigError, DataError

RATE = 1035.0  # the paper's sampling rate


def test_highpass_removes_offset_and_drift_and_passes_10hz_without_delay() -> None:
    t = np.arange(8192) / RATE
    sine = np.sin(2 * np.pi * 10.0 * t)
    y = sine + 0.7 + 0.3 * t
    out = highpass(y, RATE, cutoff=5.0, order=4)
    inner = slice(1000, -1000)  # away from the edge transients
    # |H(10 Hz)|² of a 4th-order Butterworth at 5 Hz is 1/(1 + 2^-8)²: 0.8 % attenuation
    gain = 1.0 / (1.0 + 0.5**8)
    np.testing.assert_allclose(out[inner], gain * sine[inner], atol=2e-3)
    # zero phase: the cross-correlation peaks at lag 0
    xc = scipy.signal.correlate(out[inner], sine[inner], mode="full")
    assert np.argmax(xc) - (len(sine[inner]) - 1) == 0
    causal = highpass(y, RATE, cutoff=5.0, order=4, zero_phase=False)
    lag = np.argmax(scipy.signal.correlate(causal[inner], sine[inner], mode="full"))
    assert lag - (len(sine[inner]) - 1) < 0  # a causal filter leads the 10 Hz sine


def test_band_is_the_highpass_without_a_lowpass_and_cuts_a_tone_above_it() -> None:
    t = np.arange(8192) / RATE
    y = np.sin(2 * np.pi * 10.0 * t) + np.sin(2 * np.pi * 226.0 * t) + 0.5
    for zero_phase in (False, True):
        alone = highpass(y, RATE, 5.0, order=4, zero_phase=zero_phase)
        assert band(y, RATE, 5.0, None, zero_phase=zero_phase).tobytes() == alone.tobytes()
    inner = slice(1000, -1000)  # away from the edge transients
    # forward and back, a 226 Hz tone keeps |H|² of the 4th-order Butterworth low-pass at
    # 100 Hz: 1/(1 + ρ^8), ρ the frequency ratio after the bilinear transform's warping
    ratio = np.tan(np.pi * 226.0 / RATE) / np.tan(np.pi * 100.0 / RATE)
    tone = band(np.sin(2 * np.pi * 226.0 * t), RATE, 5.0, 100.0, zero_phase=True)
    assert np.max(np.abs(tone[inner])) == pytest.approx(1.0 / (1.0 + ratio ** 8), rel=0.05)
    out = band(y, RATE, 5.0, 100.0, zero_phase=True)
    # the offset is gone, the 10 Hz sine passes, the 226 Hz tone leaves what it keeps
    np.testing.assert_allclose(out[inner], band(np.sin(2 * np.pi * 10.0 * t), RATE, 5.0, 100.0,
                                                zero_phase=True)[inner], atol=1e-3)
    assert band(y, RATE, 0.0, None).tobytes() == y.tobytes()  # no filter: unchanged
    with pytest.raises(ConfigError, match=r"lowpass cutoff must be in \(0, 517\.5\) Hz"):
        band(y, RATE, 5.0, 600.0)


def test_highpass_columns_and_bad_arguments() -> None:
    y = np.random.default_rng(1).standard_normal((500, 3))
    out = highpass(y, 100.0, 2.0)
    np.testing.assert_allclose(out[:, 1], highpass(y[:, 1], 100.0, 2.0))
    with pytest.raises(ConfigError, match=r"cutoff must be in \(0, 50\) Hz"):
        highpass(y, 100.0, 60.0)
    with pytest.raises(ConfigError, match=r"order must be an integer in 1\.\.20"):
        highpass(y, 100.0, 2.0, order=0)


def test_relative_subtracts_table() -> None:
    table = np.arange(5.0)
    acc = np.column_stack([table + 1.0, 2 * table])
    np.testing.assert_array_equal(relative(acc, table), np.column_stack([np.ones(5), table]))
    with pytest.raises(DataError, match=r"shape \(5,\)"):
        relative(acc, np.arange(4.0))


def test_double_integration_of_a_sine() -> None:
    # a = -A ω² sin ωt with zero initial velocity and displacement:
    # v = A ω (cos ωt - 1), d = A (sin ωt - ω t)
    amp, omega, dt = 0.02, 2 * np.pi * 3.0, 1e-3
    t = np.arange(4001) * dt
    a = -amp * omega**2 * np.sin(omega * t)
    da = -amp * omega**3 * np.cos(omega * t)  # a'
    v = integrate(a, dt)
    d = integrate_twice(a, dt)
    assert v[0] == 0.0 and d[0] == 0.0
    # Euler–Maclaurin: the trapezoidal rule errs by dt²/12 (f'(t) - f'(0)) + O(dt⁴), so
    # v errs by dt²/12 (a'(t) - a'(0)) and d by dt²/12 (2 (a(t) - a(0)) - a'(0) t)
    v_err = v - amp * omega * (np.cos(omega * t) - 1.0)
    np.testing.assert_allclose(v_err, dt**2 / 12 * (da - da[0]), rtol=0, atol=1e-9)
    d_err = d - amp * (np.sin(omega * t) - omega * t)
    np.testing.assert_allclose(d_err, dt**2 / 12 * (2 * (a - a[0]) - da[0] * t), rtol=0,
                               atol=1e-9)
    assert np.max(np.abs(d_err)) > 1e-5  # the error term is resolved, not negligible


def test_trapezoid_is_exact_for_a_linear_signal() -> None:
    t = np.arange(11) * 0.1
    np.testing.assert_allclose(integrate(3.0 + 2.0 * t, 0.1), 3.0 * t + t**2, atol=1e-14)


@settings(max_examples=30, deadline=None)
@given(n=st.integers(1, 12), m=st.integers(2, 30), k=st.integers(1, 3))
def test_substeps_interpolate_linearly(n: int, m: int, k: int) -> None:
    rng = np.random.default_rng(m * 100 + n)
    y = rng.standard_normal((m, k))
    out = substeps(y, n)
    assert out.shape == ((m - 1) * n + 1, k)
    np.testing.assert_array_equal(out[::n], y)  # the original samples are kept
    fine = substep_times(np.arange(m, dtype=float), n)
    np.testing.assert_allclose(fine, np.arange((m - 1) * n + 1) / n, atol=1e-12)
    for j in range(k):
        np.testing.assert_allclose(out[:, j], np.interp(fine, np.arange(m), y[:, j]),
                                   atol=1e-12)


def test_substeps_reject_bad_n() -> None:
    with pytest.raises(ConfigError, match="integer >= 1"):
        substeps(np.arange(4.0), 0)


def test_detrend_and_polynomial_removal() -> None:
    t = np.linspace(0, 1, 200)
    wave = np.sin(2 * np.pi * 5 * t)
    quad = 1.0 - 2.0 * t + 3.0 * t**2
    residue = remove_polynomial(wave + quad, 2)
    fit = remove_polynomial(wave, 2)  # the part of the wave a quadratic absorbs
    np.testing.assert_allclose(residue, fit, atol=1e-12)
    np.testing.assert_allclose(detrend(4.0 + 2.0 * t), 0.0, atol=1e-12)
    np.testing.assert_allclose(detrend(4.0 + 0 * t, "constant"), 0.0, atol=1e-12)
    pre = remove_polynomial(np.r_[np.full(50, 0.3), np.ones(150)], 0, fit=slice(0, 50))
    np.testing.assert_allclose(pre[:50], 0.0, atol=1e-12)


def test_fourier_amplitude_of_a_sine() -> None:
    dt, n, f0, amp = 0.01, 1000, 5.0, 2.0  # an integer number of cycles
    t = np.arange(n) * dt
    f, spec = fourier_amplitude(amp * np.sin(2 * np.pi * f0 * t), fs=1.0 / dt)
    k = int(np.argmax(spec))
    assert f[k] == pytest.approx(f0)
    assert spec[k] == pytest.approx(amp * n * dt / 2)


def sdof_absolute_acceleration(ag: np.ndarray, t: np.ndarray, fn: float,
                               zeta: float) -> np.ndarray:
    """Absolute acceleration of a base-excited SDOF by scipy.signal.lsim."""
    w = 2 * np.pi * fn
    # relative motion: u'' + 2ζωu' + ω²u = -ag; absolute acceleration = -(2ζωu' + ω²u)
    sys = scipy.signal.StateSpace([[0, 1], [-w * w, -2 * zeta * w]], [[0], [-1]],
                                  [[-w * w, -2 * zeta * w]], [[0]])
    _, y, _ = scipy.signal.lsim(sys, ag, t)
    return y


def test_transfer_function_peak_at_the_natural_frequency() -> None:
    rate, fn, zeta = 200.0, 12.5, 0.02
    t = np.arange(2**15) / rate
    ag = np.random.default_rng(7).standard_normal(t.size)
    acc = sdof_absolute_acceleration(ag, t, fn, zeta)
    f, h, coh = transfer_function(ag, acc, rate, nperseg=4096)
    # |H| of the absolute acceleration peaks at fn √(√(1 + 8ζ²) - 1) / (2ζ), ≈ fn for small ζ
    peak = fn * np.sqrt(np.sqrt(1 + 8 * zeta**2) - 1) / (2 * zeta)
    assert peak_frequency(f, h, band=(5.0, 30.0)) == pytest.approx(peak, abs=0.5 * f[1])
    # below resonance |H| follows the closed-form transmissibility (there the linear
    # interpolation of the input between samples, lsim's hold, changes it by < 0.1 %)
    r = f / fn
    trans = np.sqrt((1 + (2 * zeta * r) ** 2) / ((1 - r**2) ** 2 + (2 * zeta * r) ** 2))
    low = (f > 0.5) & (f < 8.0)
    np.testing.assert_allclose(np.abs(h[low]), trans[low], rtol=0.02)
    assert np.median(coh[(f > 2) & (f < 40)]) > 0.99  # a noise-free linear system
    _, h2, _ = transfer_function(ag, np.column_stack([acc, 2 * acc]), rate, nperseg=4096)
    np.testing.assert_allclose(h2[:, 1], 2 * h, rtol=1e-12)
    np.testing.assert_allclose(peak_frequency(f, h2), peak, atol=0.5 * f[1])


def test_peak_frequency_refines_between_bins() -> None:
    f = np.arange(20.0)
    mag = np.exp(-((f - 7.3) ** 2) / 4.0)  # a Gaussian: its log is a parabola
    assert peak_frequency(f, mag) == pytest.approx(7.3, abs=1e-12)
    with pytest.raises(ConfigError, match="band"):
        peak_frequency(f, mag, band=(30.0, 40.0))


def test_real_minishake_frequency() -> None:
    root = Path(os.environ.get("FEMUPDATE_DATA",
                               Path(__file__).resolve().parents[2] / ".." / "shared" / "data"))
    folder = root / "minishake_1story"
    if not (folder / "stiff1_elcentro_t1_top.csv").is_file():
        pytest.skip(f"real data not found in {folder}: put the shared data beside the checkout "
                    f"(../shared/data) or set FEMUPDATE_DATA")
    ground = read_xsens_dot(folder / "stiff1_elcentro_t1_ground.csv", {"g": "Acc_X"})
    top = read_xsens_dot(folder / "stiff1_elcentro_t1_top.csv", {"r": "Acc_X"})
    g, r = align(ground, top)
    f, h, _ = transfer_function(detrend(g["g"]), detrend(r["r"]), g.rate, nperseg=512)
    # PROVENANCE.md and the authors: first mode near 20 Hz (T ≈ 0.050 s), 20.5–22 Hz by H1
    assert 19.0 < peak_frequency(f, h, band=(10.0, 40.0)) < 23.0


# ----------------------------------------------------------------------------- channel delays

DOT_RATE = 120.0  # the minishake IMUs


def _sines(rng: np.random.Generator, n: int = 20) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return rng.uniform(0.5, 40.0, n), rng.uniform(0.0, 2 * np.pi, n), rng.uniform(0.5, 1.0, n)


def _signal(t: np.ndarray, freqs: np.ndarray, phases: np.ndarray, amps: np.ndarray
            ) -> np.ndarray:
    """A sum of sines below Nyquist plus a drift: its shifted values are known exactly."""
    return (amps * np.sin(2 * np.pi * freqs * t[:, None] + phases)).sum(axis=1) + 0.3 * t


@pytest.mark.parametrize("delay", [0.0123, -0.0071, 0.0, 0.05])
def test_advance_matches_the_shifted_signal(delay: float) -> None:
    parts = _sines(np.random.default_rng(1))
    t = np.arange(2400) / DOT_RATE
    shifted = advance(_signal(t, *parts), delay, DOT_RATE)
    exact = _signal(t + delay, *parts)
    trim = int(np.ceil(abs(delay) * DOT_RATE)) + 4
    scale = np.std(exact)
    assert np.max(np.abs(shifted - exact)[trim:-trim]) < 5e-3 * scale
    assert np.max(np.abs(shifted - exact)[100:-100]) < 2e-5 * scale


def test_advance_shifts_columns_alike() -> None:
    parts = _sines(np.random.default_rng(4))
    t = np.arange(1000) / DOT_RATE
    y = np.column_stack([_signal(t, *parts), -2.0 * _signal(t, *parts) + 1.0])
    out = advance(y, 0.0311, DOT_RATE)
    np.testing.assert_allclose(out[:, 0], advance(y[:, 0], 0.0311, DOT_RATE), atol=1e-12)
    np.testing.assert_allclose(out[:, 1], -2.0 * out[:, 0] + 1.0, atol=1e-11)
    # a whole number of samples: the samples themselves, away from the ends
    np.testing.assert_allclose(advance(y, 3 / DOT_RATE, DOT_RATE)[50:-50], y[53:-47],
                               atol=1e-4 * np.std(y))


def test_advance_rejects_bad_arguments() -> None:
    with pytest.raises(ConfigError, match="delay must be a finite number"):
        advance(np.arange(10.0), float("nan"), DOT_RATE)
    with pytest.raises(ConfigError, match="positive sampling rate"):
        advance(np.arange(10.0), 0.01, 0.0)
    with pytest.raises(DataError, match="n >= 2"):
        advance(np.ones(1), 0.01, DOT_RATE)


def test_estimate_delay_of_a_pure_delay() -> None:
    parts = _sines(np.random.default_rng(2))
    t = np.arange(2400) / DOT_RATE
    for delay in (0.0123, -0.0071, 0.0233):
        x, y = _signal(t, *parts), _signal(t - delay, *parts)
        assert estimate_delay(x, y, DOT_RATE) == pytest.approx(delay, abs=3e-4)


def test_estimate_delay_ignores_a_stiff_storey() -> None:
    """A 22 Hz, 1 % storey driven by white noise, its output delayed by 3 whole samples."""
    rng = np.random.default_rng(3)
    ag = rng.standard_normal(6000)
    wn, zeta = 2 * np.pi * 22.0, 0.01
    storey = scipy.signal.lti([2 * zeta * wn, wn**2], [1.0, 2 * zeta * wn, wn**2])
    roof = scipy.signal.dlsim(storey.to_discrete(1 / DOT_RATE, method="foh"), ag)[1][:, 0]
    assert abs(estimate_delay(ag, roof, DOT_RATE)) < 1e-4
    late = np.concatenate([np.zeros(3), roof[:-3]])
    assert estimate_delay(ag, late, DOT_RATE) == pytest.approx(3 / DOT_RATE, abs=2e-4)


def test_estimate_delay_at_a_high_rate_resolves_the_band() -> None:
    """At 1035 Hz the default segment still puts 16 bins or more in 1-10 Hz."""
    rng = np.random.default_rng(5)
    x = rng.standard_normal(20_000)
    y = np.concatenate([np.zeros(4), x[:-4]])  # 4 samples late: 3.86 ms
    assert estimate_delay(x, y, RATE) == pytest.approx(4 / RATE, abs=5e-5)


def test_estimate_delay_rejects_bad_bands_and_incoherent_records() -> None:
    x = np.random.default_rng(6).standard_normal(2400)
    with pytest.raises(ConfigError, match=r"band = \[1, 70\] Hz: need 0 < low < high < 60 Hz"):
        estimate_delay(x, x, DOT_RATE, band=(1.0, 70.0))
    with pytest.raises(ConfigError, match="holds 1 frequencies"):
        estimate_delay(x, x, DOT_RATE, band=(1.0, 1.5), nperseg=256)
    with pytest.raises(DataError, match="shape"):
        estimate_delay(x, x[:-1], DOT_RATE)
    with pytest.raises(DataError, match="no coherent signal"):
        estimate_delay(x, np.zeros_like(x), DOT_RATE)

"""The defect checks as pure functions, on signals whose answer is known by construction."""

from __future__ import annotations

import numpy as np
import pytest

from femupdate.data import defects
from femupdate.units import STANDARD_GRAVITY

RATE = 100.0


def _response(seed: int, n: int = 2000) -> tuple[np.ndarray, np.ndarray]:
    """A base motion (filtered noise) and a damped 5 Hz oscillator's absolute acceleration."""
    import scipy.signal

    rng = np.random.default_rng(seed)
    b, a = scipy.signal.butter(4, 10.0, fs=RATE)
    x = scipy.signal.lfilter(b, a, rng.standard_normal(n))
    w, zeta = 2 * np.pi * 5.0, 0.03
    system = scipy.signal.dlti(*scipy.signal.cont2discrete(
        ([2 * zeta * w, w ** 2], [1.0, 2 * zeta * w, w ** 2]), 1 / RATE, method="bilinear")[:2],
        dt=1 / RATE)
    _, y = scipy.signal.dlsim(system, x)
    return x, y[:, 0]


def test_a_spike_is_found_at_its_sample_and_interpolated_away() -> None:
    _, y = _response(1)
    assert defects.spike_samples(y).size == 0
    for value in (1e308, 1e5, 20 * np.max(np.abs(y))):
        spiked = y.copy()
        spiked[777] = value
        np.testing.assert_array_equal(defects.spike_samples(spiked), [777])
        mended = defects.interpolate_samples(spiked, np.array([777]))
        assert mended[777] == pytest.approx(0.5 * (y[776] + y[778]))
        np.testing.assert_array_equal(np.delete(mended, 777), np.delete(y, 777))


def test_the_onset_of_motion_is_not_a_spike() -> None:
    _, y = _response(2)
    quiet = np.concatenate((1e-3 * y[:500], y))  # at rest, then shaken
    assert defects.spike_samples(quiet).size == 0


def test_clock_offset_and_drift_are_measured() -> None:
    t = np.arange(1000) / RATE
    offset = defects.check_clocks([defects.ClockRecord("a", "input", t),
                                   defects.ClockRecord("b", "roof", t + 7.0)])
    assert [f.kind for f in offset] == ["clock-offset"]
    assert "+7 s apart (700 samples" in offset[0].evidence
    # a latency of a few samples is not an offset
    assert defects.check_clocks([defects.ClockRecord("a", "input", t),
                                 defects.ClockRecord("b", "roof", t + 0.03)]) == []
    drift = defects.check_clocks([defects.ClockRecord("a", "input", t),
                                  defects.ClockRecord("b", "roof", t * (1 + 2e-3))])
    assert [f.kind for f in drift] == ["clock-drift"]
    assert "(1996 ppm apart)" in drift[0].evidence and "2.0 samples" in drift[0].evidence


def test_a_delayed_output_is_misaligned_and_a_response_is_not() -> None:
    x, y = _response(3, 4000)
    assert defects.check_alignment(x, {"roof": y}, RATE, {}, first_mode_hz=5.0) == []
    late = np.concatenate((np.zeros(300), y[:-300]))
    (found,) = defects.check_alignment(x, {"roof": late}, RATE, {}, first_mode_hz=5.0)
    assert found.kind == "misaligned" and "+3" in found.evidence


def test_duplicates_and_units() -> None:
    x, y = _response(4)
    assert defects.check_duplicates({"input": x, "roof": y}, {}) == []
    (dup,) = defects.check_duplicates({"input": x, "roof": x.copy()}, {})
    assert dup.channel == "roof" and "sample for sample" in dup.evidence
    assert defects.check_units(x, {"roof": y}, RATE, {}, {}, first_mode_hz=5.0) == []
    (unit,) = defects.check_units(x, {"roof": y * STANDARD_GRAVITY}, RATE, {}, {},
                                  first_mode_hz=5.0)
    # 9.81 × the oscillator's own gain below a third of its frequency (1 to 1.13)
    gain = float(unit.evidence.split("gain over the input is ")[1].split()[0])
    assert unit.kind == "unit" and 9.81 <= gain <= 9.81 * 1.13
    strong = x / np.max(np.abs(x)) * 5 * STANDARD_GRAVITY
    assert [f.channel for f in defects.check_units(strong, {}, RATE, {}, {})] == ["input"]


def test_saturation_of_a_float_and_of_a_quantized_record() -> None:
    _, y = _response(5)
    assert defects.check_saturation("roof", y, "") == []
    clipped = np.clip(y, None, 0.8 * y.max())
    assert [f.kind for f in defects.check_saturation("roof", clipped, "")] == ["saturation"]
    quantized = np.round(y / (0.05 * y.max())) * 0.05 * y.max()  # 20 levels: equal neighbours
    assert defects.check_saturation("roof", quantized, "") == []


def test_rate_length_and_time_unit() -> None:
    assert defects.check_length_and_rate(2000, 100.0, 5.0, "f", time_unit="s") == []
    (ms,) = defects.check_length_and_rate(2000, 0.1, 5.0, "f", time_unit="s")
    assert ms.kind == "time-unit" and 'time_unit = "ms"' in ms.repair
    (rate,) = defects.check_length_and_rate(2000, 8.0, 5.0, "f")
    assert rate.kind == "rate"
    (short,) = defects.check_length_and_rate(2, 100.0, 5.0, "f", time_unit="s")
    assert short.kind == "short" and "2 samples" in short.evidence
    assert [f.kind for f in defects.check_length_and_rate(2, 100.0, None, "f")] == ["short"]


# --------------------------------------------------------------------------- issue 33


@pytest.mark.parametrize("at", [0, 1, 2, 777, -3, -2, -1])
@pytest.mark.parametrize("value", [1e308, 1e5, -1e5, np.nan, np.inf, -np.inf])
def test_a_spike_is_found_at_any_sample_the_ends_included(at: int, value: float) -> None:
    _, y = _response(6)
    spiked = y.copy()
    spiked[at] = value
    where = at % y.size
    np.testing.assert_array_equal(defects.spike_samples(spiked), [where])
    (found,) = defects.check_spikes("roof", spiked, np.arange(y.size) / RATE, "top.csv")
    assert found.kind == "spike" and f"(sample {where} of {y.size})" in found.evidence
    mended = defects.interpolate_samples(spiked, np.array([where]))
    assert np.all(np.isfinite(mended)) and np.max(np.abs(mended)) <= np.max(np.abs(y))


@pytest.mark.parametrize("at", [0, 500, -2])
def test_a_two_sided_glitch_is_found(at: int) -> None:
    """+1e5 then -1e5 in adjacent samples (10,000 g each way): both samples."""
    _, y = _response(7)
    glitch = y.copy()
    glitch[at], glitch[at + 1] = 1e5, -1e5
    np.testing.assert_array_equal(defects.spike_samples(glitch),
                                  [at % y.size, (at + 1) % y.size])
    (found,) = defects.check_spikes("roof", glitch, np.arange(y.size) / RATE, "f")
    assert "2 isolated sample(s) far off the signal: 1e+05 m/s²" in found.evidence
    assert "-1e+05 m/s²" in found.evidence


def test_non_finite_samples_are_spikes_however_many() -> None:
    _, y = _response(8)
    holes = y.copy()
    holes[100:110] = np.nan
    holes[-1] = np.inf
    np.testing.assert_array_equal(defects.spike_samples(holes), [*range(100, 110), y.size - 1])
    assert defects.spike_samples(np.full(50, np.nan)).size == 50


def test_crests_cusps_and_kinks_of_a_smooth_record_are_not_spikes() -> None:
    """At 1 kHz a signal's curvature is near 0 but at its corners: a triangle wave, a
    rectified sine (the cusps of a hysteretic reversal) and a record interpolated linearly
    (a kink at every original sample) are a step or two off their median there, never ten."""
    import scipy.signal

    t = np.arange(20000) / 1000.0
    coarse = _response(9)[0]
    for y in (scipy.signal.sawtooth(2 * np.pi * 1.3 * t, 0.5),
              np.abs(np.sin(2 * np.pi * 0.7 * t)),
              np.interp(t, np.arange(coarse.size) / 50.0, coarse)):
        assert defects.spike_samples(y).size == 0
    # a spike on them still is one
    kinked = np.interp(t, np.arange(coarse.size) / 50.0, coarse)
    kinked[5000] += 20 * np.max(np.abs(kinked))
    np.testing.assert_array_equal(defects.spike_samples(kinked), [5000])


def test_a_copy_is_a_duplicate_and_sensors_that_move_alike_are_not() -> None:
    t = np.arange(4000) / RATE
    rng = np.random.default_rng(10)
    # a steady sine below the first mode: two floors in phase to 1e-3 rad (ρ = 0.99999)
    base = np.sin(2 * np.pi * 1.0 * t)
    floor = 1.02 * np.sin(2 * np.pi * 1.0 * t - 1e-3)
    assert np.corrcoef(base, floor)[0, 1] > 0.9999
    assert defects.check_duplicates({"input": base, "roof": floor}, {}) == []
    noisy = {"a": base + 0.02 * rng.standard_normal(t.size),
             "b": base + 0.02 * rng.standard_normal(t.size)}
    assert np.corrcoef(noisy["a"], noisy["b"])[0, 1] > 0.999
    assert defects.check_duplicates(noisy, {}) == []
    # copies: sample for sample, rounded to 6 digits, in g, with the sign flipped
    y = noisy["a"]
    for copy, how in ((y.copy(), "sample for sample"),
                      (np.array([float(f"{v:.6g}") for v in y]), "× 1 to"),
                      (y / 9.80665, "× 0.101972"), (-y, "× -1 to")):
        (dup,) = defects.check_duplicates({"input": y, "roof": copy}, {"roof": "top.csv"})
        assert dup.channel == "roof" and how in dup.evidence, dup.evidence
        assert "a copy, not a second sensor" in dup.evidence


def test_a_noise_free_sine_is_not_saturated_and_a_clipped_one_is() -> None:
    """Sampled in step with its period, a sine repeats its crest value exactly every period:
    no flat top. Clipped, it holds the clip level over runs of samples."""
    t = np.arange(4000) / 200.0
    y = 2.0 * np.sin(2 * np.pi * 2.0 * t)
    assert np.sum(y == y.max()) > 2  # its peak, exactly, at every period
    assert defects.check_saturation("input", y, "") == []
    ramped = y * np.clip(t / 1.0, 0, 1)
    assert defects.check_saturation("input", ramped, "") == []
    clipped = np.clip(y, -1.6, 1.6)
    assert [f.kind for f in defects.check_saturation("input", clipped, "")] == [
        "saturation", "saturation"]
    (dead,) = defects.check_saturation("roof", np.full(500, 0.25), "top.csv")
    assert "constant: all 500 samples are 0.25 m/s²" in dead.evidence


def test_the_gain_needs_averaged_spectra() -> None:
    """A record too short for 8 segments of 6 periods of the first mode says nothing about
    the gain (its coherence would be near 1 whatever the signals); a long one does."""
    x, y = _response(11, 4000)
    (unit,) = defects.check_units(x, {"roof": 9.81 * y}, RATE, {}, {}, first_mode_hz=5.0)
    assert unit.kind == "unit"
    # 6 periods of 0.2 Hz at 100 Hz: 4096-sample segments; 4000 samples hold under one
    assert defects.check_units(x, {"roof": 9.81 * y}, RATE, {}, {}, first_mode_hz=0.2) == []


def test_a_gain_where_the_record_has_no_energy_is_not_a_unit_finding() -> None:
    """An input with nothing below a third of the first mode but noise, and a response with
    its own noise: over 20 noise seeds the averaged coherence there stays low."""
    import scipy.signal

    rate, f1 = 200.0, 1.0
    b, a = scipy.signal.butter(4, [3.0, 30.0], btype="band", fs=rate)
    for seed in range(20):
        rng = np.random.default_rng(seed)
        x = scipy.signal.lfilter(b, a, rng.standard_normal(30000))
        y = x * 1.3 + 0.02 * np.std(x) * rng.standard_normal(x.size)
        x = x + 0.02 * np.std(x) * rng.standard_normal(x.size)
        assert defects.check_units(x, {"roof": y}, rate, {}, {}, first_mode_hz=f1) == []


def test_a_record_at_rest_before_and_after_a_pulse_is_not_saturated() -> None:
    """Noise-free, a pulse's record is exactly 0 before and after it, and 0 is its bottom:
    the structure at rest, not a clipped sensor. The pulse clipped at its top still is."""
    t = np.arange(1200) / 200.0
    y = np.where((t >= 1.0) & (t <= 1.5), np.sin(np.pi * (t - 1.0) / 0.5), 0.0)
    assert defects.check_saturation("input", y, "") == []
    clipped = np.minimum(y, 0.8)
    assert [(f.kind, "top value 0.8" in f.evidence)
            for f in defects.check_saturation("input", clipped, "")] == [("saturation", True)]

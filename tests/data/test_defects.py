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

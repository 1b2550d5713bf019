"""The reduced (truncated modal + static correction) path against the full exact one."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal as ss

from femupdate.errors import ConfigError
from femupdate.model import shear_building
from femupdate.simulate.exact import ExactSimulator
from femupdate.simulate.reduced import (
    FULL_PATH_MAX_DOF,
    ReducedSimulator,
    prepare_linear,
    truncation_error,
)

DT, BAND, N_SAMPLES = 0.005, 25.0, 3000


def building(n: int, extra_damper: bool = False):
    """Uniform shear building with f1 ≈ 1 Hz and Rayleigh damping (optionally one damper)."""
    s = shear_building([1.0] * n, [16.0 * n * n] * n)
    s.set_rayleigh(0.2, 1e-3)
    if extra_damper:  # a viscous damper from the roof to the ground: not proportional
        s.add_damper(f"F{n}", "ux", 100.0)
    return s


def band_limited(seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """A base acceleration whose content lies in the fitted band, and that band's filter."""
    sos = ss.butter(4, BAND, fs=1 / DT, output="sos")
    ag = ss.sosfilt(sos, np.random.default_rng(seed).standard_normal(N_SAMPLES))
    ag[0] = 0.0
    return ag, sos


@pytest.fixture(scope="module")
def case300():
    s = building(300)
    outputs = [99, 199, 299]
    return s.assemble(sparse=True), ExactSimulator(s.assemble(), DT, outputs), outputs


def test_all_modes_kept_reproduce_the_full_exact_response():
    s = building(30, extra_damper=True)
    outputs = [9, 19, 29]
    ag, _ = band_limited()
    force = np.outer(ag, np.linspace(0.0, 1.0, 30))
    full = ExactSimulator(s.assemble(), DT, outputs).run(ag, force)
    red = ReducedSimulator(s.assemble(sparse=True), DT, outputs, n_modes=30).run(ag, force)
    for name in ("displacement", "velocity", "acceleration"):
        a, b = getattr(red, name), getattr(full, name)
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-9 * np.abs(b).max())


def test_truncation_with_static_correction_meets_the_default_cut_off_target(case300):
    sparse, full, outputs = case300
    ag, sos = band_limited()

    def post(y):
        return ss.sosfiltfilt(sos, y, axis=0)

    red = ReducedSimulator(sparse, DT, outputs, band_hz=BAND)
    assert 20 <= red.n_modes <= 30  # modes up to 50 Hz, about 2 Hz apart
    assert red.cutoff_hz == pytest.approx(50.0)
    err = truncation_error(red, full, ag, post)
    assert max(err) < 1e-6
    raw = ReducedSimulator(sparse, DT, outputs, band_hz=BAND, static_correction=False)
    err_raw = truncation_error(raw, full, ag, post)
    assert err.displacement < 0.05 * err_raw.displacement  # the residual flexibility helps


def test_non_proportional_damping_is_kept_on_the_reduced_basis():
    s = building(200, extra_damper=True)
    outputs = [50, 199]
    ag, sos = band_limited(5)
    full = ExactSimulator(s.assemble(), DT, outputs)
    red = ReducedSimulator(s.assemble(sparse=True), DT, outputs, band_hz=BAND)
    phi = red.modes.shapes
    c_red = (phi.T @ (s.assemble(sparse=True).C @ phi))[:5, :5]  # the modes in the band
    coupling = np.abs(c_red - np.diag(np.diag(c_red))).max() / np.abs(np.diag(c_red)).max()
    assert coupling > 0.1  # Φᵀ C Φ is far from diagonal: proportional damping would lose it
    def post(y):
        return ss.sosfiltfilt(sos, y, axis=0)

    # A strong local damper couples kept and truncated modes beyond the static correction of
    # its forces: 3e-6 at the default cut-off, and the error falls as the cut-off rises.
    assert max(truncation_error(red, full, ag, post)) < 1e-5
    wider = ReducedSimulator(s.assemble(sparse=True), DT, outputs, band_hz=BAND, cutoff_factor=4)
    assert max(truncation_error(wider, full, ag, post)) < 1e-6
    plain = ReducedSimulator(s.assemble(sparse=True), DT, outputs, band_hz=BAND,
                             static_correction=False)
    assert max(truncation_error(plain, full, ag, post)) > 5e-5


def test_given_modes_are_reused_bit_for_bit(case300):
    sparse, _, outputs = case300
    ag, _ = band_limited()
    first = ReducedSimulator(sparse, DT, outputs, band_hz=BAND)
    again = ReducedSimulator(sparse, DT, outputs, modes=first.modes)
    warm = ReducedSimulator(sparse, DT, outputs, band_hz=BAND, previous=first.modes)
    a, b, c = first.run(ag), again.run(ag), warm.run(ag)
    np.testing.assert_array_equal(a.acceleration, b.acceleration)
    np.testing.assert_allclose(c.acceleration, a.acceleration, rtol=0,
                               atol=1e-9 * np.abs(a.acceleration).max())


def test_prepare_linear_switches_by_size():
    small = building(FULL_PATH_MAX_DOF).assemble(sparse=True)
    large = building(FULL_PATH_MAX_DOF + 1).assemble(sparse=True)
    assert isinstance(prepare_linear(small, DT, [0]), ExactSimulator)
    assert isinstance(prepare_linear(large, DT, [0], band_hz=BAND), ReducedSimulator)


def test_a_cut_off_below_the_band_and_too_many_modes_are_refused(case300):
    sparse, _, outputs = case300
    with pytest.raises(ConfigError, match=r"cutoff_factor = 0.8 .* allowed >= 1"):
        ReducedSimulator(sparse, DT, outputs, band_hz=BAND, cutoff_factor=0.8)
    with pytest.raises(ConfigError, match=r"n_modes = 301 .* allowed 1 to 300"):
        ReducedSimulator(sparse, DT, outputs, n_modes=301)
    with pytest.raises(ConfigError, match="band_hz"):
        ReducedSimulator(sparse, DT, outputs, band_hz=0.0)


def test_the_stiffness_is_factored_once_for_the_modes_and_the_static_correction(
        monkeypatch: pytest.MonkeyPatch) -> None:
    import importlib

    import scipy.sparse.linalg as spla

    n = 200  # above the dense eigensolver's limit: Lanczos on lumped masses
    building = shear_building(list(np.linspace(1.0, 2.0, n)), [4e6] * n)
    system = building.assemble(sparse=True)
    reference = ReducedSimulator(system, 0.01, [n - 1])
    calls = []
    real = spla.splu

    def counted(*args: object, **kwargs: object) -> object:
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(spla, "splu", counted)
    # ARPACK's shift-invert mode factors with its own reference to splu
    arpack = importlib.import_module("scipy.sparse.linalg._eigen.arpack.arpack")
    monkeypatch.setattr(arpack, "splu", counted)
    sim = ReducedSimulator(system, 0.01, [n - 1])
    assert len(calls) == 1
    np.testing.assert_array_equal(sim.modes.freqs_hz, reference.modes.freqs_hz)
    ag = np.sin(np.linspace(0.0, 20.0, 500))
    np.testing.assert_array_equal(sim.run(ag).acceleration, reference.run(ag).acceleration)

"""Rayleigh damping on the Bouc–Wen elements' initial stiffness (``β K₀``, as OpenSees's
``rayleigh`` with ``betaKinit``): the closed-form decay of a mass on one Bouc–Wen link, the same
damping matrix in the explicit and implicit integrators, the switch that leaves the links out,
and friction sliders, which never enter ``β K₀``."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import find_peaks

from femupdate.model.modes import damped_modes
from femupdate.model.structure import Structure, shear_building
from femupdate.simulate import simulate

MASS = 2.0
#: A Bouc–Wen link whose loop is far away (z_u = A / (β + γ) = 1 m): linear at 1e-5 m.
LINK = {"k": 5000.0, "alpha": 0.2, "A": 1.5, "beta": 0.5, "gamma": 0.5, "n": 1.0}
K0 = LINK["k"] * (LINK["alpha"] + (1.0 - LINK["alpha"]) * LINK["A"])  # initial tangent
OMEGA = np.sqrt(K0 / MASS)
BETA = 1e-3  # Rayleigh β (s): ζ = β ω / 2 = 4.6 %


def _sdof(bouc_wen: bool = True) -> Structure:
    s = shear_building([MASS], [0.0], bouc_wen=[LINK])
    s.set_rayleigh(beta=BETA, bouc_wen=bouc_wen)
    return s


def _decay_ratio(x: np.ndarray, dt: float) -> float:
    """ζ from the slope of the log of the positive peaks over time (−ζ ω)."""
    peaks, _ = find_peaks(x)
    slope = np.polyfit(peaks * dt, np.log(x[peaks]), 1)[0]
    return -slope / OMEGA


def test_damping_matrix_is_beta_times_the_initial_stiffness() -> None:
    system = _sdof().assemble()
    np.testing.assert_allclose(system.C, [[BETA * K0]], rtol=1e-15)
    assert _sdof(bouc_wen=False).assemble().C[0, 0] == 0.0
    # sparse assembly (the reduced path) adds the same
    np.testing.assert_allclose(_sdof().assemble(sparse=True).C.toarray(), [[BETA * K0]],
                               rtol=1e-15)


@pytest.mark.parametrize("sparse", [False, True])
def test_friction_sliders_are_never_in_beta_k(sparse: bool) -> None:
    """A slider's stuck stiffness k_r is a penalty of the stick-slip model: β multiplies the
    storey spring and the Bouc–Wen link's k₀, not k_r (dense and sparse alike)."""
    k_spring, k_r = 3000.0, 2e6
    s = Structure(dofs_per_node=1)
    for i in (1, 2):
        s.add_node(f"F{i}", x=0.0, y=float(i))
        s.add_mass(f"F{i}", m=MASS)
    s.add_spring("F1", "ux", k_spring)
    s.add_friction("F1", "ux", k_r, 1.0)  # slider F1 to the ground
    s.add_bouc_wen("F2", "ux", node2="F1", **LINK)
    s.set_rayleigh(beta=BETA)
    c = s.assemble(sparse=sparse).C
    c = c.toarray() if sparse else c
    expected = BETA * np.array([[k_spring + K0, -K0], [-K0, K0]])
    np.testing.assert_allclose(c, expected, rtol=1e-14)
    s.set_rayleigh(beta=BETA, bouc_wen=False)
    c = s.assemble(sparse=sparse).C
    c = c.toarray() if sparse else c
    np.testing.assert_allclose(c, BETA * np.array([[k_spring, 0.0], [0.0, 0.0]]), rtol=1e-14)


@pytest.mark.parametrize("method", ["nonlinear", "implicit"])
def test_small_free_decay_has_zeta_beta_omega_over_two(method: str) -> None:
    """Set moving at rest position (z = 0 there: the link's state is consistent), to a
    1e-5 m amplitude, the link stays linear (|z| ≪ z_u): the decay of the peaks gives
    ζ = β ω / 2, ω = √(k₀ / m), in the explicit (central differences) and implicit
    (Newmark) integrators alike; without the links in β K the mass does not decay."""
    dt, n = 0.002, 1500
    ag = np.zeros(n)
    x = simulate(_sdof().assemble(), dt, ag=ag, method=method, substeps=20,
                 v0=np.array([1e-5 * OMEGA])).displacement[:, 0]
    assert _decay_ratio(x, dt) == pytest.approx(BETA * OMEGA / 2.0, rel=2e-4)
    still = simulate(_sdof(bouc_wen=False).assemble(), dt, ag=ag, method=method,
                     substeps=20, v0=np.array([1e-5 * OMEGA])).displacement[:, 0]
    assert abs(_decay_ratio(still, dt)) < 1e-4


def test_explicit_and_implicit_agree_on_a_two_storey_building() -> None:
    """Two storeys on Bouc–Wen links with Rayleigh α and β, driven into their loops: the
    explicit and implicit paths use the same C (their difference falls with the step)."""
    laws = [dict(LINK, beta=400.0, gamma=100.0), dict(LINK, beta=300.0, gamma=200.0)]
    s = shear_building([1.0, 0.8], [0.0, 0.0], bouc_wen=laws)
    s.set_rayleigh(alpha=0.3, beta=BETA)
    system = s.assemble()
    links = system.bouc_wen.initial_stiffness(2)
    np.testing.assert_allclose(system.C, 0.3 * system.M + BETA * links, rtol=1e-15)
    dt = 0.005
    t = np.arange(400) * dt
    ag = 12.0 * np.sin(2 * np.pi * 3.0 * t) * np.sin(np.pi * t / t[-1]) ** 2
    explicit = simulate(system, dt, ag=ag, method="nonlinear", substeps=40).displacement
    implicit = simulate(system, dt, ag=ag, method="implicit", substeps=40).displacement
    peak = np.abs(explicit).max()
    assert peak > 2e-3  # |z| reaches the yield region (z_u = 2 mm, 1.7 mm)
    assert np.abs(explicit - implicit).max() < 2e-3 * peak


def test_damped_modes_of_the_link_give_beta_omega_over_two() -> None:
    modes = damped_modes(_sdof().assemble())
    np.testing.assert_allclose(modes.damping_ratios, [BETA * OMEGA / 2.0], rtol=1e-12)
    np.testing.assert_allclose(modes.freqs_hz, [OMEGA / (2 * np.pi)], rtol=1e-12)

"""Undamped and damped modes against closed-form SDOF and characteristic-polynomial roots."""

from __future__ import annotations

import math

import numpy as np
import pytest

from femupdate.errors import ModelError
from femupdate.model import (
    FrictionElements,
    System,
    damped_modes,
    initial_stiffness,
    natural_frequencies,
    shear_building,
)


def sdof(m: float, c: float, k: float) -> System:
    return shear_building([m], [k], [c]).assemble()


def test_damped_sdof_frequency_and_damping_ratio() -> None:
    m, k, zeta = 2.0, 800.0, 0.05
    c = 2 * zeta * math.sqrt(k * m)
    modes = damped_modes(sdof(m, c, k))
    omega = math.sqrt(k / m)
    assert modes.freqs_hz == pytest.approx([omega / (2 * math.pi)], rel=1e-12)
    assert modes.damping_ratios == pytest.approx([zeta], rel=1e-10)
    omega_d = omega * math.sqrt(1 - zeta**2)
    assert modes.damped_freqs_hz == pytest.approx([omega_d / (2 * math.pi)], rel=1e-12)
    _, _, shapes = modes  # unpacks as the 3-tuple of the spec
    assert shapes.shape == (1, 1)
    assert shapes[0, 0] == 1.0


def test_overdamped_sdof_gives_two_real_poles() -> None:
    m, k, zeta = 1.0, 100.0, 2.0
    modes = damped_modes(sdof(m, 2 * zeta * math.sqrt(k * m), k))
    omega = 10.0
    poles = omega * np.array([zeta - math.sqrt(zeta**2 - 1), zeta + math.sqrt(zeta**2 - 1)])
    np.testing.assert_allclose(modes.freqs_hz, poles / (2 * math.pi), rtol=1e-10)
    np.testing.assert_array_equal(modes.damping_ratios, [1.0, 1.0])
    np.testing.assert_array_equal(modes.damped_freqs_hz, [0.0, 0.0])


def test_non_proportional_damping_matches_characteristic_polynomial() -> None:
    """Poles are the roots of det(λ² M + λ C + K) = 0, a quartic for 2 DOF."""
    m = np.array([[2.0, 0.3], [0.3, 1.0]])
    c = np.array([[3.0, -1.0], [-1.0, 1.2]])
    k = np.array([[900.0, -300.0], [-300.0, 400.0]])
    system = System(M=m, C=c, K=k, r=np.ones(2))

    def entry(i: int, j: int) -> np.ndarray:
        return np.array([m[i, j], c[i, j], k[i, j]])

    char = np.polysub(np.polymul(entry(0, 0), entry(1, 1)), np.polymul(entry(0, 1), entry(1, 0)))
    roots = np.roots(char)
    upper = roots[roots.imag > 0]
    expected = np.sort(np.abs(upper))
    modes = damped_modes(system)
    np.testing.assert_allclose(modes.freqs_hz * 2 * math.pi, expected, rtol=1e-10)
    order = np.argsort(np.abs(upper))
    np.testing.assert_allclose(modes.damping_ratios, -upper.real[order] / expected, rtol=1e-9)
    # each shape solves the quadratic eigenproblem
    for lam, psi in zip(upper[order], modes.shapes.T, strict=True):
        residual = (lam**2 * m + lam * c + k) @ psi
        assert np.abs(residual).max() < 1e-9 * np.abs(k).max()


def test_natural_frequencies_are_mass_normalised() -> None:
    system = shear_building([3.0, 2.0, 1.0], [5000.0, 4000.0, 3000.0]).assemble()
    f, shapes = natural_frequencies(system)
    assert np.all(np.diff(f) > 0)
    np.testing.assert_allclose(shapes.T @ system.M @ shapes, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(
        shapes.T @ system.K @ shapes, np.diag((2 * math.pi * f) ** 2), atol=1e-8
    )
    assert np.all(shapes[np.argmax(np.abs(shapes), axis=0), range(3)] > 0)
    f2, shapes2 = natural_frequencies(system, n_modes=2)
    np.testing.assert_allclose(f2, f[:2], rtol=1e-12)
    assert shapes2.shape == (3, 2)
    with pytest.raises(ModelError, match=r"n_modes = 4.*allowed 1\.\.3"):
        natural_frequencies(system, n_modes=4)


def test_undamped_damped_modes_equal_natural_frequencies() -> None:
    system = shear_building([3.0, 2.0], [5000.0, 4000.0]).assemble()
    f, _ = natural_frequencies(system)
    modes = damped_modes(system)
    np.testing.assert_allclose(modes.freqs_hz, f, rtol=1e-10)
    np.testing.assert_allclose(modes.damping_ratios, 0.0, atol=1e-12)


def test_friction_counts_with_its_stuck_stiffness() -> None:
    m, k, k_r = 2.0, 300.0, 500.0
    base = shear_building([m], [k]).assemble()
    friction = FrictionElements(
        dof_i=np.array([0]), dof_j=np.array([-1]), k_r=np.array([k_r]), f_u=np.array([1.0])
    )
    system = System(M=base.M, C=base.C, K=base.K, r=base.r, friction=friction)
    np.testing.assert_allclose(initial_stiffness(system), [[k + k_r]])
    f, _ = natural_frequencies(system)
    assert f[0] == pytest.approx(math.sqrt((k + k_r) / m) / (2 * math.pi), rel=1e-12)
    assert damped_modes(system).freqs_hz[0] == pytest.approx(f[0], rel=1e-12)


def test_rigid_body_mode_gives_zero_frequency() -> None:
    m = np.diag([1.0, 2.0])
    k = np.array([[50.0, -50.0], [-50.0, 50.0]])  # free two-mass chain
    system = System(M=m, C=np.zeros((2, 2)), K=k, r=np.ones(2))
    f, shapes = natural_frequencies(system)
    assert f[0] == pytest.approx(0.0, abs=1e-7)
    assert f[1] == pytest.approx(math.sqrt(50.0 * 1.5) / (2 * math.pi), rel=1e-12)
    np.testing.assert_allclose(shapes[:, 0], 1 / math.sqrt(3.0), rtol=1e-10)
    modes = damped_modes(system)
    assert modes.freqs_hz.shape == (2,)
    assert modes.freqs_hz[0] == 0.0
    assert modes.freqs_hz[1] == pytest.approx(f[1], rel=1e-10)


def test_singular_mass_is_reported() -> None:
    system = System(M=np.diag([1.0, 0.0]), C=np.zeros((2, 2)), K=np.eye(2), r=np.ones(2),
                    dof_labels=("a.uy", "a.rz"))  # fmt: skip
    with pytest.raises(ModelError, match=r"singular.*a\.rz"):
        natural_frequencies(system)
    with pytest.raises(ModelError, match=r"singular.*a\.rz"):
        damped_modes(system)

"""Rigid and near-rigid modes: the λ → 0 limit of the exact discretisation and its fallback."""

from __future__ import annotations

import numpy as np
import pytest

from femupdate.model.system import System
from femupdate.simulate import prepare_exact, simulate
from femupdate.simulate.exact import foh_coefficients, phi_series


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def test_foh_coefficients_limit_and_series():
    """λ = 0 gives e = 1, γ0 = γ1 = h/2; the series (|λh| < 0.5) equals the closed forms
    φ1 = (eˣ - 1)/x, φ2 = (eˣ - 1 - x)/x² where those are accurate, including at the radius."""
    h = 0.01
    e, g0, g1 = foh_coefficients(np.array([0.0]), h)
    assert e[0] == 1.0
    assert g0[0] == pytest.approx(h / 2, rel=1e-15)
    assert g1[0] == pytest.approx(h / 2, rel=1e-15)
    x = np.array([0.3, -0.45 + 0.1j, 0.2j, -0.4999, 0.4999j])
    phi1 = (np.exp(x) - 1) / x
    phi2 = (np.exp(x) - 1 - x) / x**2
    np.testing.assert_allclose(phi_series(x, 1), phi1, rtol=1e-13)
    np.testing.assert_allclose(phi_series(x, 2), phi2, rtol=1e-13)
    e, g0, g1 = foh_coefficients(x / h, h)
    np.testing.assert_allclose(g1, h * phi2, rtol=1e-13)
    np.testing.assert_allclose(g0 + g1, h * phi1, rtol=1e-13)
    # tiny |λh|: the leading terms h(1/2 + x/6) and h(1/2 + x/3)
    x = np.array([1e-7, -1e-7j])
    _, g0, g1 = foh_coefficients(x / h, h)
    np.testing.assert_allclose(g1, h * (0.5 + x / 6), rtol=1e-13)
    np.testing.assert_allclose(g0, h * (0.5 + x / 3), rtol=1e-13)


def test_damped_rigid_body_uses_the_series_and_matches_closed_form():
    """m ẍ + c ẋ = F: a simple zero eigenvalue (modal path, series branch).
    x = (F/c)(t - (m/c)(1 - e^{-ct/m}))."""
    m, c, f = 2.0, 3.0, 1.5
    system = System(M=np.array([[m]]), C=np.array([[c]]), K=np.array([[0.0]]), r=np.array([1.0]))
    dt, n = 0.01, 500
    sim = prepare_exact(system, dt)
    assert sim.modal
    r = sim.run(force=np.full((n, 1), f))
    t = np.arange(n) * dt
    x = f / c * (t - m / c * (1 - np.exp(-c * t / m)))
    v = f / c * (1 - np.exp(-c * t / m))
    assert rel(r.displacement[:, 0], x) <= 1e-9
    assert rel(r.velocity[:, 0], v) <= 1e-9


def test_undamped_free_free_chain_falls_back_and_matches_closed_form():
    """Two masses joined by a spring, no support, no damping: λ = 0 is defective (a rigid
    translation grows as t²), so the modal transform is singular and the matrix-exponential
    discretisation is used. Force F on mass 1: centre of mass F t²/(2(m1+m2)); the relative
    coordinate ξ = x1 - x2 = (F μ/(m1 k))(1 - cos ωt), ω² = k/μ."""
    m1, m2, k, f = 1.0, 3.0, 400.0, 2.0
    M = np.diag([m1, m2])
    K = k * np.array([[1.0, -1.0], [-1.0, 1.0]])
    system = System(M=M, C=np.zeros((2, 2)), K=K, r=np.ones(2))
    dt, n = 0.005, 800
    sim = prepare_exact(system, dt)
    assert not sim.modal
    force = np.zeros((n, 2))
    force[:, 0] = f
    r = sim.run(force=force)
    t = np.arange(n) * dt
    mt, mu = m1 + m2, m1 * m2 / (m1 + m2)
    xcm = f * t**2 / (2 * mt)
    xi = f * mu / (m1 * k) * (1 - np.cos(np.sqrt(k / mu) * t))
    x = np.column_stack([xcm + m2 * xi / mt, xcm - m1 * xi / mt])
    assert rel(r.displacement, x) <= 1e-9
    # nothing holds a free body to the base: under base motion its absolute acceleration is 0
    # and it does not deform; relative to the base it moves by -u_g, the base displacement
    ag = np.sin(np.arange(n) * dt * 7.0)
    rb = sim.run(ag=ag)
    assert np.max(np.abs(rb.acceleration)) <= 1e-9 * np.max(np.abs(ag))
    ug = (t - np.sin(7.0 * t) / 7.0) / 7.0  # ∫∫ sin(7t); the sampled sine is close to it
    np.testing.assert_allclose(rb.displacement[:, 0], rb.displacement[:, 1], rtol=1e-9)
    assert rel(rb.displacement[:, 0], -ug) <= 1e-3


def test_near_rigid_support_agrees_with_fallback(monkeypatch):
    """A support spring 1e-9 of the chain's: tiny |λh|, still the modal path, same as dense."""
    from femupdate.simulate import exact as exact_module

    M = np.diag([1.0, 3.0])
    K = 400.0 * np.array([[1.0, -1.0], [-1.0, 1.0]]) + np.diag([4e-7, 0.0])
    C = np.diag([0.5, 0.0])
    system = System(M=M, C=C, K=K, r=np.ones(2))
    force = np.zeros((600, 2))
    force[:, 1] = np.cos(np.arange(600) * 0.01 * 5.0)
    a = prepare_exact(system, 0.01)
    assert a.modal
    monkeypatch.setattr(exact_module, "MAX_EIGVEC_CONDITION", 0.0)
    b = prepare_exact(system, 0.01)
    ra, rb = a.run(force=force), b.run(force=force)
    assert rel(ra.displacement, rb.displacement) <= 1e-8
    assert rel(ra.acceleration, rb.acceleration) <= 1e-8


def test_all_methods_handle_a_rigid_body(monkeypatch):
    """Central differences and Newmark integrate t² exactly (constant acceleration)."""
    m1, m2 = 1.0, 3.0
    system = System(M=np.diag([m1, m2]), C=np.zeros((2, 2)), K=np.zeros((2, 2)), r=np.ones(2))
    force = np.zeros((200, 2))
    force[:, 0] = 2.0
    t = np.arange(200) * 0.01
    for method in ("exact", "central_difference", "newmark", "nonlinear"):
        r = simulate(system, 0.01, force=force, method=method)
        np.testing.assert_allclose(r.displacement[:, 0], t**2, rtol=1e-10, atol=1e-14)
        np.testing.assert_allclose(r.displacement[:, 1], 0.0, atol=1e-14)

"""Element matrices: textbook limits, shape-function integrals, rigid-body and definiteness."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from femupdate.errors import ModelError
from femupdate.model.elements import (
    beam_mass,
    beam_stiffness,
    frame_element,
    frame_mass,
    frame_rotation,
    frame_stiffness,
    lumped_mass,
    shear_parameter,
    spring,
    spring_matrix,
    timoshenko_beam,
)

positive = st.floats(1e-3, 1e3)


def fk_shape_functions(xi: np.ndarray, L: float, phi: float) -> tuple[np.ndarray, ...]:
    """Friedman & Kosmatka (1993) interdependent shape functions and their x-derivatives."""
    c = 1.0 / (1.0 + phi)
    nv = c * np.array(
        [
            2 * xi**3 - 3 * xi**2 - phi * xi + 1 + phi,
            L * (xi**3 - (2 + phi / 2) * xi**2 + (1 + phi / 2) * xi),
            -2 * xi**3 + 3 * xi**2 + phi * xi,
            L * (xi**3 - (1 - phi / 2) * xi**2 - phi / 2 * xi),
        ]
    )
    dnv = (c / L) * np.array(
        [
            6 * xi**2 - 6 * xi - phi,
            L * (3 * xi**2 - 2 * (2 + phi / 2) * xi + 1 + phi / 2),
            -6 * xi**2 + 6 * xi + phi,
            L * (3 * xi**2 - 2 * (1 - phi / 2) * xi - phi / 2),
        ]
    )
    nt = c * np.array(
        [
            6 / L * (xi**2 - xi),
            3 * xi**2 - (4 + phi) * xi + 1 + phi,
            -6 / L * (xi**2 - xi),
            3 * xi**2 - (2 - phi) * xi,
        ]
    )
    dnt = (c / L) * np.array(
        [
            6 / L * (2 * xi - 1),
            6 * xi - (4 + phi),
            -6 / L * (2 * xi - 1),
            6 * xi - (2 - phi),
        ]
    )
    return nv, dnv, nt, dnt


def integrated_matrices(
    E: float,
    G: float,
    A: float,
    I: float,  # noqa: E741
    kappa: float,
    mu: float,
    rho_i: float,
    L: float,
) -> tuple[np.ndarray, np.ndarray]:
    """K and M by Gauss quadrature of the Timoshenko energies (exact for these polynomials)."""
    phi = 12 * E * I / (kappa * G * A * L**2)
    x, w = np.polynomial.legendre.leggauss(8)
    xi, w = (x + 1) / 2, w * L / 2
    nv, dnv, nt, dnt = fk_shape_functions(xi, L, phi)
    gamma = dnv - nt  # shear strain per DOF
    k = E * I * (dnt * w) @ dnt.T + kappa * G * A * (gamma * w) @ gamma.T
    m = mu * (nv * w) @ nv.T + rho_i * (nt * w) @ nt.T
    return k, m


@pytest.mark.parametrize("phi_scale", [0.0, 0.05, 0.7, 3.0])
def test_beam_matrices_equal_shape_function_integrals(phi_scale: float) -> None:
    E, A, I, L, kappa, rho = 2.0e11, 3.0e-3, 4.0e-6, 0.8, 0.6, 7850.0  # noqa: E741
    # choose G so that Φ = phi_scale (phi_scale 0: practically rigid in shear)
    G = 12 * E * I / (kappa * A * L**2 * phi_scale) if phi_scale else 1e30
    k_ref, m_ref = integrated_matrices(E, G, A, I, kappa, rho * A, rho * I, L)
    k, m = timoshenko_beam(E, A, I, L, rho, G=G, kappa=kappa)
    np.testing.assert_allclose(k, k_ref, rtol=1e-10, atol=1e-10 * np.abs(k_ref).max())
    np.testing.assert_allclose(m, m_ref, rtol=1e-10, atol=1e-12 * np.abs(m_ref).max())


def test_euler_bernoulli_limit_is_the_hermite_textbook_matrices() -> None:
    EI, mu, L = 3.0, 2.0, 1.5
    k = beam_stiffness(EI, L, 0.0)
    m = beam_mass(mu, 0.0, L, 0.0)
    k_ref = (EI / L**3) * np.array(
        [
            [12, 6 * L, -12, 6 * L],
            [6 * L, 4 * L**2, -6 * L, 2 * L**2],
            [-12, -6 * L, 12, -6 * L],
            [6 * L, 2 * L**2, -6 * L, 4 * L**2],
        ]
    )
    m_ref = (mu * L / 420) * np.array(
        [
            [156, 22 * L, 54, -13 * L],
            [22 * L, 4 * L**2, 13 * L, -3 * L**2],
            [54, 13 * L, 156, -22 * L],
            [-13 * L, -3 * L**2, -22 * L, 4 * L**2],
        ]
    )
    np.testing.assert_allclose(k, k_ref, rtol=1e-14)
    np.testing.assert_allclose(m, m_ref, rtol=1e-14)
    # and a vanishing shear parameter tends to them
    np.testing.assert_allclose(beam_stiffness(EI, L, 1e-9), k_ref, rtol=1e-8)


def test_cantilever_tip_deflection_is_exact_with_shear() -> None:
    """One element: v_tip = P L³/(3EI) + P L/(κGA), θ_tip = P L²/(2EI)."""
    E, G, A, I, L, kappa, P = 2.0e11, 8.0e10, 1e-2, 2e-5, 0.5, 5 / 6, 1e3  # noqa: E741
    k, _ = timoshenko_beam(E, A, I, L, G=G, kappa=kappa)
    v, theta = np.linalg.solve(k[2:, 2:], [P, 0.0])
    assert v == pytest.approx(P * L**3 / (3 * E * I) + P * L / (kappa * G * A), rel=1e-12)
    assert theta == pytest.approx(P * L**2 / (2 * E * I), rel=1e-12)


@settings(max_examples=60, deadline=None)
@given(EI=positive, mu=positive, rho_i=st.floats(0.0, 1e2), L=positive, phi=st.floats(0.0, 50.0))
def test_beam_matrices_symmetric_definite_and_rigid(
    EI: float, mu: float, rho_i: float, L: float, phi: float
) -> None:
    k = beam_stiffness(EI, L, phi)
    m = beam_mass(mu, rho_i, L, phi)
    np.testing.assert_array_equal(k, k.T)
    np.testing.assert_array_equal(m, m.T)
    translation = np.array([1.0, 0.0, 1.0, 0.0])
    rotation = np.array([0.0, 1.0, L, 1.0])  # v = x, θ = 1
    scale = np.abs(k).max()
    np.testing.assert_allclose(k @ translation, 0.0, atol=1e-12 * scale * L)
    np.testing.assert_allclose(k @ rotation, 0.0, atol=1e-12 * scale * L)
    kw = np.linalg.eigvalsh(k)
    assert kw[:2] == pytest.approx([0.0, 0.0], abs=1e-10 * kw[-1])
    assert kw[2] > 0
    assert np.linalg.eigvalsh(m)[0] > 0
    # rigid-body kinetic energy: ∫μ and ∫(μ x² + ρI), up to the rounding of m's entries
    tol = 1e-14 * np.abs(m).sum() * max(1.0, L * L)
    assert translation @ m @ translation == pytest.approx(mu * L, rel=1e-12, abs=tol)
    assert rotation @ m @ rotation == pytest.approx(mu * L**3 / 3 + rho_i * L, rel=1e-12, abs=tol)


@settings(max_examples=40, deadline=None)
@given(
    angle=st.floats(-math.pi, math.pi),
    L=positive,
    EA=positive,
    EI=positive,
    phi=st.floats(0.0, 10.0),
)
def test_frame_element_in_global_axes(
    angle: float, L: float, EA: float, EI: float, phi: float
) -> None:
    c, s = math.cos(angle), math.sin(angle)
    t = frame_rotation(c, s)
    np.testing.assert_allclose(t @ t.T, np.eye(6), atol=1e-15)
    k = t.T @ frame_stiffness(EA, EI, L, phi) @ t
    m = t.T @ frame_mass(2.0, 0.1, L, phi) @ t
    np.testing.assert_allclose(k, k.T, atol=1e-12 * np.abs(k).max())
    dx, dy = L * c, L * s
    rigid = np.array(
        [
            [1, 0, 0, 1, 0, 0],  # translation x
            [0, 1, 0, 0, 1, 0],  # translation y
            [0, 0, 1, -dy, dx, 1],  # rotation about node 1
        ],
        dtype=float,
    )
    np.testing.assert_allclose(k @ rigid.T, 0.0, atol=1e-10 * np.abs(k).max() * max(L, 1))
    # a rigid translation in any direction carries the whole mass μL
    for r in rigid[:2]:
        assert r @ m @ r == pytest.approx(2.0 * L, rel=1e-12)
    w = np.linalg.eigvalsh(k)
    assert np.all(w[3:] > 0)


def test_frame_element_front_end_matches_kernels() -> None:
    k, m = frame_element(2e11, 1e-3, 1e-6, 0.0, 0.0, 0.3, 0.4, 7850.0, G=8e10)
    L = 0.5
    phi = shear_parameter(2e11, 1e-6, 8e10, 1e-3, L, 5 / 6)
    t = frame_rotation(0.6, 0.8)
    np.testing.assert_allclose(k, t.T @ frame_stiffness(2e11 * 1e-3, 2e11 * 1e-6, L, phi) @ t)
    np.testing.assert_allclose(m, t.T @ frame_mass(7850e-3, 7850e-6, L, phi) @ t)
    # the axial bar terms
    kl = frame_stiffness(5.0, 1.0, 2.0)
    assert kl[0, 0] == kl[3, 3] == 2.5
    assert kl[0, 3] == -2.5


def test_kernels_vectorise_over_elements() -> None:
    EI = np.array([1.0, 2.0, 3.0])
    L = np.array([0.5, 1.0, 2.0])
    phi = np.array([0.0, 0.1, 1.0])
    stack = beam_stiffness(EI, L, phi)
    assert stack.shape == (3, 4, 4)
    for e in range(3):
        np.testing.assert_array_equal(stack[e], beam_stiffness(EI[e], L[e], phi[e]))
    assert spring_matrix(np.array([1.0, 2.0])).shape == (2, 2, 2)


def test_spring_and_lumped_mass() -> None:
    np.testing.assert_array_equal(spring(3.0), [[3.0, -3.0], [-3.0, 3.0]])
    np.testing.assert_array_equal(lumped_mass(2.0, 0.5, 3), np.diag([2.0, 2.0, 0.5]))
    np.testing.assert_array_equal(lumped_mass(2.0, 0.5, 2), np.diag([2.0, 0.5]))
    np.testing.assert_array_equal(lumped_mass(2.0, 0.0, 1), [[2.0]])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"L": 0.0}, "length L = 0.0"),
        ({"L": -1.0}, "length L = -1.0"),
        ({"E": -2.0}, "E = -2.0"),
        ({"A": 0.0}, "A = 0.0"),
        ({"I": -1e-6}, "I = -1e-06"),
        ({"rho": -7850.0}, "rho = -7850.0"),
        ({"G": -1.0}, "G = -1.0"),
        ({"G": 0.0}, "G = 0.0"),
        ({"L": math.nan}, "length L = nan"),
    ],
)
def test_timoshenko_beam_rejects_bad_input(kwargs: dict[str, float], match: str) -> None:
    args = {"E": 2e11, "A": 1e-3, "I": 1e-6, "L": 1.0, "rho": 7850.0} | kwargs
    with pytest.raises(ModelError, match=match) as info:
        timoshenko_beam(**args, name="deck1")
    assert "deck1" in str(info.value)
    assert "allowed" in str(info.value)


def test_other_front_ends_reject_bad_input() -> None:
    with pytest.raises(ModelError, match=r"spring 'kp'.*k = -1.0"):
        spring(-1.0, name="kp")
    with pytest.raises(ModelError, match=r"mass 'm1'.*m = -2.0"):
        lumped_mass(-2.0, name="m1")
    with pytest.raises(ModelError, match=r"J = -1.0"):
        lumped_mass(1.0, -1.0)
    with pytest.raises(ModelError, match="rotational DOF"):
        lumped_mass(1.0, 1.0, 1)
    with pytest.raises(ModelError, match=r"length L = 0.0"):
        frame_element(1.0, 1.0, 1.0, 1.0, 2.0, 1.0, 2.0)

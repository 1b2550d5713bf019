"""Natural frequencies of assembled beams and frames against closed-form solutions."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from femupdate.model import Structure, natural_frequencies

# a steel strip: E–B checks use a slender section
E, RHO, NU = 2.1e11, 7850.0, 0.3
B, H = 0.05, 0.01
A, I = B * H, B * H**3 / 12  # noqa: E741


def beam_structure(
    L: float,
    n_el: int,
    *,
    h: float = H,
    supports: dict[str, tuple[str, ...]] | None = None,
    timoshenko: bool = False,
    rotary: bool = False,
) -> Structure:
    s = Structure(dofs_per_node=2)
    for i in range(n_el + 1):
        s.add_node(f"N{i}", x=L * i / n_el)
    shear = {"nu": NU, "kappa": 5 / 6} if timoshenko else {}
    for i in range(n_el):
        s.add_beam(
            f"N{i}", f"N{i + 1}", E=E, A=B * h, I=B * h**3 / 12, rho=RHO,
            rotary_inertia=rotary, **shear,
        )  # fmt: skip
    for node, dofs in (supports or {}).items():
        s.fix(node.replace("end", f"N{n_el}"), *dofs)
    return s


def euler_bernoulli(beta_l: np.ndarray, L: float, a: float = A, i: float = I) -> np.ndarray:
    return beta_l**2 / (2 * math.pi * L**2) * math.sqrt(E * i / (RHO * a))


def test_simply_supported_euler_bernoulli() -> None:
    L = 2.0
    s = beam_structure(L, 20, supports={"N0": ("uy",), "end": ("uy",)})
    f, _ = natural_frequencies(s.assemble())
    exact = euler_bernoulli(np.arange(1, 5) * math.pi, L)
    np.testing.assert_allclose(f[:4], exact, rtol=1e-3)


def test_cantilever_euler_bernoulli() -> None:
    L = 1.2
    roots = np.array(
        [brentq(lambda b: math.cos(b) * math.cosh(b) + 1, lo, lo + 3) for lo in (1, 4, 7, 10)]
    )
    assert roots[0] == pytest.approx(1.8751, abs=1e-4)
    s = beam_structure(L, 20, supports={"N0": ("uy", "rz")})
    f, _ = natural_frequencies(s.assemble())
    np.testing.assert_allclose(f[:4], euler_bernoulli(roots, L), rtol=1e-3)


def timoshenko_simply_supported(n: np.ndarray, L: float, h: float) -> np.ndarray:
    """Lower root of (ρ²I/κG) ω⁴ − (ρA + ρI k² (1 + E/κG)) ω² + EI k⁴ = 0, k = nπ/L."""
    a, i = B * h, B * h**3 / 12
    g, kappa = E / (2 * (1 + NU)), 5 / 6
    k = n * math.pi / L
    c4 = RHO**2 * i / (kappa * g)
    c2 = RHO * a + RHO * i * k**2 * (1 + E / (kappa * g))
    c0 = E * i * k**4
    w2 = (c2 - np.sqrt(c2**2 - 4 * c4 * c0)) / (2 * c4)
    return np.sqrt(w2) / (2 * math.pi)


def test_thick_simply_supported_timoshenko() -> None:
    L, h = 0.5, 0.1  # L/h = 5
    s = beam_structure(L, 20, h=h, supports={"N0": ("uy",), "end": ("uy",)},
                       timoshenko=True, rotary=True)  # fmt: skip
    f, _ = natural_frequencies(s.assemble())
    n = np.arange(1, 4)
    exact = timoshenko_simply_supported(n, L, h)
    np.testing.assert_allclose(f[:3], exact, rtol=1e-2)
    # the correction matters: Euler–Bernoulli is further off than the tolerance
    eb = euler_bernoulli(n * math.pi, L, B * h, B * h**3 / 12)
    assert np.all(np.abs(eb / exact - 1) > 5e-2)


def test_free_free_beam_has_two_rigid_body_modes() -> None:
    L = 1.0
    s = beam_structure(L, 16)
    f, _ = natural_frequencies(s.assemble())
    assert np.all(f[:2] < 1e-3 * f[2])
    first_elastic = brentq(lambda b: math.cos(b) * math.cosh(b) - 1, 4.0, 5.0)  # 4.7300
    assert f[2] == pytest.approx(euler_bernoulli(np.array(first_elastic), L), rel=1e-3)


def test_frame_free_free_has_three_rigid_body_modes() -> None:
    s = Structure(dofs_per_node=3)
    for i, (x, y) in enumerate([(0, 0), (0, 1), (1, 1), (1.5, 0.2)]):
        s.add_node(f"N{i}", x=x, y=y)
    for i in range(3):
        s.add_beam(f"N{i}", f"N{i + 1}", E=E, A=A, I=I, rho=RHO, nu=NU)
    f, _ = natural_frequencies(s.assemble())
    assert np.all(f[:3] < 1e-4 * f[3])


def test_axial_bar_frequencies_of_a_vertical_member() -> None:
    """Fixed–free bar along y: f_n = (2n − 1) c / (4L), c = √(E/ρ); frame element rotated 90°."""
    L, n_el = 3.0, 20
    s = Structure(dofs_per_node=3)
    for i in range(n_el + 1):
        s.add_node(f"N{i}", x=0.0, y=L * i / n_el)
        s.fix(f"N{i}", "ux", "rz")  # leave only the axial motion
    for i in range(n_el):
        s.add_beam(f"N{i}", f"N{i + 1}", E=E, A=A, I=I, rho=RHO)
    s.fix("N0", "uy")
    f, _ = natural_frequencies(s.assemble())
    exact = (2 * np.arange(1, 3) - 1) * math.sqrt(E / RHO) / (4 * L)
    np.testing.assert_allclose(f[:2], exact, rtol=3e-3)


def test_portal_frame_sway_frequency() -> None:
    """Fixed-base portal, axially rigid massless members, masses at the beam ends.

    Slope-deflection gives k = (24 EI_c/h³)(1 + 6β)/(4 + 6β), β = (I_b/L)/(I_c/h).
    """
    h, span, ic, ib, m = 3.0, 4.0, 2e-5, 6e-5, 1500.0
    s = Structure(dofs_per_node=3)
    for name, x, y in (("A", 0, 0), ("B", 0, h), ("C", span, h), ("D", span, 0)):
        s.add_node(name, x=x, y=y)
    big_a = 10.0  # EA/L ≫ the bending stiffness: axially rigid
    s.add_beam("A", "B", E=E, A=big_a, I=ic)
    s.add_beam("B", "C", E=E, A=big_a, I=ib)
    s.add_beam("D", "C", E=E, A=big_a, I=ic)
    s.fix("A")
    s.fix("D")
    for node in ("B", "C"):
        s.add_mass(node, m=m, J=1e-6 * m * h**2)  # tiny rotary inertia keeps M definite
    beta = (ib / span) / (ic / h)
    k = 24 * E * ic / h**3 * (1 + 6 * beta) / (4 + 6 * beta)
    f, shapes = natural_frequencies(s.assemble(direction="x"))
    assert f[0] == pytest.approx(math.sqrt(k / (2 * m)) / (2 * math.pi), rel=1e-3)
    # it is the sway mode: both beam ends move equally along x
    assert shapes[s.dof_index("B", "ux"), 0] == pytest.approx(
        shapes[s.dof_index("C", "ux"), 0], rel=1e-6
    )


def test_inclined_cantilever_has_the_frequencies_of_a_horizontal_one() -> None:
    def cantilever(angle: float) -> np.ndarray:
        s = Structure(dofs_per_node=3)
        c, sn = math.cos(angle), math.sin(angle)
        for i in range(11):
            s.add_node(f"N{i}", x=0.1 * i * c, y=0.1 * i * sn)
        for i in range(10):
            s.add_beam(f"N{i}", f"N{i + 1}", E=E, A=A, I=I, rho=RHO, nu=NU)
        s.fix("N0")
        return natural_frequencies(s.assemble())[0]

    reference = cantilever(0.0)
    np.testing.assert_allclose(cantilever(math.radians(30)), reference, rtol=1e-9)
    np.testing.assert_allclose(cantilever(math.radians(-135)), reference, rtol=1e-9)

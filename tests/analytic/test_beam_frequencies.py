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


# ------------------------------------------------------------------ 3-D Euler–Bernoulli beams

#: A thick rectangular section (b ≠ h: two bending planes), L/h = 10: shear deformation
#: lowers the Timoshenko frequencies by several per cent.
B3, H3 = 0.06, 0.1


def column_3d(L: float, n_el: int, *, shear_deformation: bool, rotary: bool = False,
              torsional: bool | None = True, supports: str = "cantilever") -> Structure:
    """A beam along x in 3-D (Iy about the local y = global y, Iz about z), ``nu`` given (the
    torsional stiffness G J) with or without shear deformation."""
    s = Structure(dofs_per_node=6)
    for i in range(n_el + 1):
        s.add_node(f"N{i}", x=L * i / n_el)
    iy, iz = B3 * H3**3 / 12, H3 * B3**3 / 12
    for i in range(n_el):
        s.add_beam(f"N{i}", f"N{i + 1}", E=E, nu=NU, A=B3 * H3, Iy=iy, Iz=iz, J=iy + iz,
                   rho=RHO, vecxz=(0.0, 0.0, 1.0), shear_deformation=shear_deformation,
                   rotary_inertia=rotary, torsional_inertia=torsional)
    if supports == "cantilever":
        s.fix("N0")
    else:  # pinned at both ends, the twist held at one
        s.fix("N0", "ux", "uy", "uz", "rx")
        s.fix(f"N{n_el}", "uy", "uz")
    return s


def _nearest(f: np.ndarray, targets: np.ndarray) -> np.ndarray:
    return f[np.abs(f[:, None] - targets[None, :]).argmin(axis=0)]


@pytest.mark.parametrize("supports", ["cantilever", "pinned"])
def test_3d_euler_bernoulli_beam_without_shear_deformation(supports: str) -> None:
    """shear_deformation=False with G given: both bending planes at the Euler–Bernoulli
    closed form, torsion at c_t / 4L (cantilever; c_t = √(G/ρ), Ip = J); with shear
    deformation the same beam is several per cent lower."""
    L, n_el = 1.0, 24
    if supports == "cantilever":
        beta_l = np.array([brentq(lambda b: math.cos(b) * math.cosh(b) + 1, lo, lo + 3)
                           for lo in (1, 4, 7)])
    else:
        beta_l = np.arange(1, 4) * math.pi
    a, iy, iz = B3 * H3, B3 * H3**3 / 12, H3 * B3**3 / 12
    exact = np.concatenate([euler_bernoulli(beta_l, L, a, iy), euler_bernoulli(beta_l, L, a, iz)])
    f, _ = natural_frequencies(column_3d(L, n_el, shear_deformation=False,
                                         supports=supports).assemble())
    np.testing.assert_allclose(_nearest(f, exact), exact, rtol=1e-4)
    if supports == "cantilever":
        # the first torsion mode (linear elements: (k h)² / 24 = 1.8e-4 high)
        torsion = np.array([math.sqrt(E / (2 * (1 + NU)) / RHO) / (4 * L)])
        np.testing.assert_allclose(_nearest(f, torsion), torsion, rtol=3e-4)
    timoshenko, _ = natural_frequencies(column_3d(L, n_el, shear_deformation=True,
                                                  supports=supports).assemble())
    # the second mode in the stiff plane (h = 0.1 m, L/h = 10): 4.0 % (cantilever) and
    # 4.7 % (pinned) below Euler–Bernoulli
    assert _nearest(timoshenko, exact[[1]])[0] < exact[1] * (1 - 3e-2)


def test_3d_rotary_inertia_switches_by_dof_kind() -> None:
    """rotary_inertia=False, torsional_inertia=True: the bending rotations carry no rotary
    inertia (ρIy, ρIz), the twist keeps ρJ; torsional_inertia defaults to rotary_inertia
    (without either the twist has no inertia: a dense assembly refuses that M)."""
    def m(**kw: bool | None) -> np.ndarray:
        s = column_3d(1.0, 4, shear_deformation=False, **kw)
        return s.assemble(sparse=True).M.toarray()

    both, neither = m(rotary=True, torsional=None), m(rotary=False, torsional=None)
    twist_only = m(rotary=False, torsional=True)
    labels = column_3d(1.0, 4, shear_deformation=False).dof_labels
    rx = [i for i, lab in enumerate(labels) if lab.endswith(".rx")]
    bend = [i for i, lab in enumerate(labels) if lab.endswith((".ry", ".rz"))]
    np.testing.assert_array_equal(twist_only[np.ix_(rx, rx)], both[np.ix_(rx, rx)])
    np.testing.assert_array_equal(twist_only[np.ix_(bend, bend)], neither[np.ix_(bend, bend)])
    assert np.all(np.diag(both)[rx] > 0) and not np.any(neither[np.ix_(rx, rx)])
    assert np.all(np.diag(both)[bend] > np.diag(neither)[bend])

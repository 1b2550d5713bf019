"""The explicit and implicit integrators with Bouc–Wen elements against OpenSeesPy's transient
analysis of the same two-storey building (zeroLength elements with the BoucWen material, node
masses, no beams: the planar beam-mass trap does not arise): central differences against its
central differences, HHT/Newmark with Newton iterations against its Newmark."""

from __future__ import annotations

import numpy as np
import pytest
from bouc_wen_degradation import opensees_building

from femupdate.errors import MissingDependencyError
from femupdate.model.structure import shear_building
from femupdate.simulate import simulate

MASSES = (1.0, 0.8)
LAWS = [{"k": 4000.0, "alpha": 0.1, "A": 1.0, "beta": 7.5e5, "gamma": 2.5e5, "n": 2.0},
        {"k": 3000.0, "alpha": 0.1, "A": 1.0, "beta": 1.0e6, "gamma": 2.5e5, "n": 2.0}]
DT = 0.005
# 1/J: the record dissipates about 0.2 J per element, so A falls by a fifth, ν rises by 40 %
DEGRADING = [dict(law, delta_a=1.0, delta_nu=2.0, delta_eta=1.0) for law in LAWS]
RAYLEIGH_ALPHA = 0.6


@pytest.fixture(scope="module")
def ops():
    """OpenSeesPy, or a skip saying why it is not here."""
    from femupdate.paper.bench.opensees import import_opensees

    try:
        return import_opensees()
    except MissingDependencyError as exc:
        pytest.skip(f"openseespy is not installed or does not import here: {exc}")


def _system(beta: float = 0.0, bouc_wen: bool = True, laws: list[dict] = LAWS):
    """The two-storey building on its Bouc–Wen elements, Rayleigh α (and β on the links'
    initial stiffness when ``bouc_wen``)."""
    s = shear_building(list(MASSES), [0.0, 0.0], bouc_wen=laws)
    s.set_rayleigh(alpha=RAYLEIGH_ALPHA, beta=beta, bouc_wen=bouc_wen)
    return s.assemble()


def _record() -> np.ndarray:
    t = np.arange(400) * DT
    return 8.0 * np.sin(2.0 * np.pi * 3.0 * t) * np.sin(np.pi * t / t[-1]) ** 2


def _opensees(ops, ag: np.ndarray, substeps: int, scheme: str = "central",
              beta_kinit: float = 0.0, masses=MASSES, laws=LAWS) -> np.ndarray:
    """Node displacements by OpenSees (the benchmark's driver) for this module's building:
    ``"central"`` differences or ``"newmark"``; ``beta_kinit``: Rayleigh's β on the initial
    stiffness; ``masses`` and ``laws`` the storeys (default the two of this module)."""
    return opensees_building(ops, ag, substeps, scheme, dt=DT, masses=masses, laws=laws,
                             rayleigh_alpha=RAYLEIGH_ALPHA, beta_kinit=beta_kinit)


def test_building_agrees_with_opensees_at_its_first_order(ops) -> None:
    """Same scheme, same substep; OpenSees updates z by backward Euler (first order), so the
    difference halves with the substep (measured 1.4e-3, 7.0e-4, 3.5e-4 of the peak at 10, 20,
    40 substeps), while femupdate converges to its own solution at 320 substeps at second order
    (2.8e-5, 8.0e-6, 1.9e-6)."""
    ag = _record()
    system = _system()
    fine = simulate(system, DT, ag=ag, method="nonlinear", substeps=320).displacement
    peak = np.abs(fine).max()
    steps = [10, 20, 40]
    gaps, own = [], []
    for count in steps:
        ours = simulate(system, DT, ag=ag, method="nonlinear", substeps=count).displacement
        gaps.append(np.abs(ours - _opensees(ops, ag, count)).max() / peak)
        own.append(np.abs(ours - fine).max() / peak)
    slope = -np.polyfit(np.log(steps), np.log(gaps), 1)[0]
    assert 0.9 < slope < 1.15, gaps
    assert gaps[-1] < 1e-3
    own_slope = -np.polyfit(np.log(steps), np.log(own), 1)[0]
    assert 1.8 < own_slope < 2.6, own


def test_implicit_agrees_with_opensees_newmark(ops) -> None:
    """The same Newmark scheme; OpenSees updates z by backward Euler (first order in the
    step), femupdate by Runge–Kutta over the increment: the difference shrinks with the step."""
    ag = _record()
    system = _system()
    gaps = []
    for count in (5, 10, 20):
        ours = simulate(system, DT, ag=ag, method="implicit", substeps=count).displacement
        theirs = _opensees(ops, ag, count, "newmark")
        gaps.append(float(np.sum((ours - theirs) ** 2) / np.sum(theirs**2)))
    assert gaps[-1] < gaps[0], gaps
    assert gaps[-1] < 1e-4, gaps


def test_rayleigh_beta_on_the_links_is_opensees_betakinit(ops) -> None:
    """Rayleigh's β on the links' initial stiffness (the default) is OpenSees's ``rayleigh``
    with ``betaKinit`` on zeroLength elements with ``-doRayleigh 1``: the implicit paths agree
    as closely as without β (measured NMSE 8.3e-6, 2.1e-6, 5.4e-7 at 5, 10, 20 substeps),
    and leaving the links out of β K (bouc_wen=False) differs by an NMSE of 0.34."""
    beta = 2e-3  # s: ζ = β ω / 2 of 5.5 % and 15 % on the two initial modes
    ag = _record()

    def ours(count: int, bouc_wen: bool = True) -> np.ndarray:
        return simulate(_system(beta, bouc_wen), DT, ag=ag, method="implicit",
                        substeps=count).displacement

    def nmse(a: np.ndarray, b: np.ndarray) -> float:
        return float(np.sum((a - b) ** 2) / np.sum(b**2))

    gaps = []
    for count in (5, 10, 20):
        theirs = _opensees(ops, ag, count, "newmark", beta_kinit=beta)
        gaps.append(nmse(ours(count), theirs))
    assert gaps[-1] < gaps[0], gaps
    assert gaps[-1] < 1e-4, gaps
    assert nmse(ours(20, bouc_wen=False), theirs) > 100 * gaps[-1]


def test_degrading_building_agrees_with_opensees(ops) -> None:
    """With δA, δν, δη on both elements (they move the response by 0.31 of its peak):
    central differences against OpenSees's, the gap halving with the substep as without
    degradation (OpenSees's backward Euler in z and e; measured 1.3e-3, 6.7e-4, 3.3e-4 of the
    peak at 10, 20, 40 substeps), and the implicit path against its Newmark (NMSE 7.4e-6,
    1.9e-6, 4.8e-7 at 5, 10, 20 substeps)."""
    ag = _record()
    system = _system(laws=DEGRADING)
    plain = simulate(_system(), DT, ag=ag, method="nonlinear", substeps=40).displacement
    peak = np.abs(plain).max()
    gaps = []
    steps = [10, 20, 40]
    for count in steps:
        ours = simulate(system, DT, ag=ag, method="nonlinear", substeps=count).displacement
        gaps.append(np.abs(ours - _opensees(ops, ag, count, laws=DEGRADING)).max() / peak)
    slope = -np.polyfit(np.log(steps), np.log(gaps), 1)[0]
    assert 0.9 < slope < 1.15, gaps
    assert gaps[-1] < 1e-3, gaps
    assert np.abs(ours - plain).max() > 0.1 * peak  # the degradation shows
    newmark = []
    for count in (5, 20):
        ours = simulate(system, DT, ag=ag, method="implicit", substeps=count).displacement
        theirs = _opensees(ops, ag, count, "newmark", laws=DEGRADING)
        newmark.append(float(np.sum((ours - theirs) ** 2) / np.sum(theirs**2)))
    assert newmark[-1] < newmark[0], newmark
    assert newmark[-1] < 1e-4, newmark


def test_implicit_n1_links_agree_with_opensees_newmark(ops) -> None:
    """Four storeys on n = 1 links (the exact exponential update inside Newton–Raphson)
    against OpenSees's Newmark with its BoucWen material: the gap falls with the step, at
    first order (OpenSees's backward Euler on z), and is below 1e-4 at 20 substeps (measured
    NMSE 2.3e-5, 5.8e-6, 1.5e-6 at 5, 10, 20 substeps)."""
    masses = (1.0, 0.8, 0.8, 0.6)
    laws = [{"k": k, "alpha": 0.1, "A": 1.0, "beta": 750.0, "gamma": 250.0, "n": 1.0}
            for k in (4000.0, 3500.0, 3000.0, 2500.0)]  # z_u = 1 mm
    s = shear_building(list(masses), [0.0] * 4, bouc_wen=laws)
    s.set_rayleigh(alpha=RAYLEIGH_ALPHA)
    system = s.assemble()
    ag = _record()
    gaps = []
    for count in (5, 10, 20):
        ours = simulate(system, DT, ag=ag, method="implicit", substeps=count)
        theirs = _opensees(ops, ag, count, "newmark", masses=masses, laws=laws)
        gaps.append(float(np.sum((ours.displacement - theirs) ** 2) / np.sum(theirs**2)))
    print(f"n = 1, four links: NMSE against OpenSees Newmark at 5, 10, 20 substeps "
          f"{', '.join(f'{g:.1e}' for g in gaps)}; largest |z| / z_u "
          f"{np.abs(ours.hysteretic_z).max() / 1e-3:.2f}")
    assert np.abs(ours.hysteretic_z).max() > 0.9e-3  # the links yield
    assert gaps[2] < gaps[1] < gaps[0], gaps
    assert gaps[-1] < 1e-4, gaps

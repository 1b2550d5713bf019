"""The paper's bridge as femupdate builds it: frequencies, mass, and its four integrators.

References: the paper's measured frequencies (its §5.2; docs/method.md §8.2), the nominal
mass of the deck and the added masses, the exact discretisation (first-order hold) for the
linear bridge, and the second-order convergence of central differences and Newmark towards it.
"""

from __future__ import annotations

import numpy as np
import pytest

from femupdate.case import Model
from femupdate.model.modes import initial_stiffness, natural_frequencies
from femupdate.model.system import System
from femupdate.paper.bench.simulate import DEFAULT_FRICTION_VALUES, viscous_values
from femupdate.paper.problems import bridge
from femupdate.problem.case_model import build_structure
from femupdate.simulate import prepare

DT = 1.0 / bridge.SAMPLE_RATE
PIERS = [2, 4, 6]


@pytest.fixture(scope="module")
def viscous() -> System:
    return build_structure(Model.model_validate(bridge.viscous_model())).assemble(viscous_values())


@pytest.fixture(scope="module")
def exact(viscous, base_motion) -> np.ndarray:
    return prepare(viscous, DT, method="exact", outputs=PIERS).run(base_motion).displacement


def _run(system: System, ag: np.ndarray, method: str, substeps: int) -> np.ndarray:
    sim = prepare(system, DT, method=method, substeps=substeps, outputs=PIERS)
    return sim.run(ag).displacement


def _rel_l2(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def test_dofs_are_the_papers(viscous):
    assert [viscous.dof_labels[i] for i in PIERS] == ["P1.uy", "P2.uy", "P3.uy"]


def test_frequencies_near_the_papers(viscous):
    freqs, _ = natural_frequencies(viscous, 4)
    np.testing.assert_allclose(freqs, bridge.PAPER_FREQUENCIES_HZ, rtol=0.02)


def test_mass_is_deck_plus_added_masses(viscous):
    b, t = bridge.SECTION_B, bridge.SECTION_T
    deck = 7850.0 * (b * b - (b - 2 * t) ** 2) * 4 * bridge.SPAN
    r = viscous.r
    assert r @ viscous.M @ r == pytest.approx(deck + 5 * bridge.ADDED_MASS, rel=1e-12)


@pytest.mark.parametrize(("method", "substeps", "tol"), [
    ("central_difference", 10, 1e-3),  # measured 2.0e-4
    ("nonlinear", 10, 1e-3),
    ("newmark", 10, 1e-3),  # measured 4.0e-4
    ("newmark", 1, 0.1),  # measured 4 %: period elongation of the 25-35 Hz modes
])
def test_integrators_agree_with_exact(method, substeps, tol, viscous, exact, base_motion):
    assert _rel_l2(_run(viscous, base_motion, method, substeps), exact) < tol


def test_nonlinear_on_the_linear_bridge_is_central_differences(viscous, base_motion):
    cd = _run(viscous, base_motion, "central_difference", 10)
    np.testing.assert_allclose(_run(viscous, base_motion, "nonlinear", 10), cd, rtol=0,
                               atol=1e-12 * np.abs(cd).max())


@pytest.mark.parametrize(("method", "coarse", "fine"), [
    ("central_difference", 10, 20),
    ("newmark", 1, 10),
])
def test_second_order_convergence(method, coarse, fine, viscous, exact, base_motion):
    """Errors against the exact solution fall as h²: by (fine/coarse)² within 15 %."""
    e_coarse = _rel_l2(_run(viscous, base_motion, method, coarse), exact)
    e_fine = _rel_l2(_run(viscous, base_motion, method, fine), exact)
    assert e_coarse / e_fine == pytest.approx((fine / coarse) ** 2, rel=0.15)


def test_friction_bridge_that_never_slips_is_linear(base_motion):
    """With f_u far above any force, the friction bridge is the linear bridge with the stuck
    stiffness K + B^T diag(k_r) B: the nonlinear integrator equals central differences on it."""
    values = {k: v for k, v in viscous_values().items() if k in ("E", "kp1", "kp2", "kp3", "kp4")}
    values |= {k: (1e12 if k.startswith("fu") else v) for k, v in DEFAULT_FRICTION_VALUES.items()}
    frictional = build_structure(Model.model_validate(bridge.friction_model())).assemble(values)
    stuck = System(M=frictional.M, C=frictional.C, K=initial_stiffness(frictional),
                   r=frictional.r)
    response = prepare(frictional, DT, method="nonlinear", substeps=10,
                       outputs=PIERS).run(base_motion)
    assert np.all(response.slip == 0.0)
    linear = _run(stuck, base_motion, "central_difference", 10)
    # same recurrence, the stuck forces added separately: rounding only (measured 1e-9)
    np.testing.assert_allclose(response.displacement, linear, rtol=0,
                               atol=1e-7 * np.abs(linear).max())
    exact = _run(stuck, base_motion, "exact", 1)
    assert _rel_l2(response.displacement, exact) < 3e-3  # measured 1.1e-3 (undamped, stiffer)

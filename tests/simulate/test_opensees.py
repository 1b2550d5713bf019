"""femupdate against OpenSeesPy on the paper's bridge: matrices, frequencies, time histories.

The OpenSees model is built from the same ``[model]`` table (benchmarks/opensees.py). Both codes
integrate the same equations with the same schemes, so they agree to rounding; the tolerances
below are far tighter than the 0.5 % (frequencies) and 1e-3 (time histories) of the brief, and
still far above the measured differences (about 1e-12 to 1e-10), so they test the model, not
the rounding.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

from femupdate.case import Model
from femupdate.errors import ConfigError, MissingDependencyError, ModelError
from femupdate.model.modes import initial_stiffness, natural_frequencies
from femupdate.paper.bench.opensees import OpenSeesPeer, import_opensees
from femupdate.paper.bench.simulate import DEFAULT_FRICTION_VALUES, viscous_values
from femupdate.paper.problems import bridge
from femupdate.problem.case_model import build_structure
from femupdate.simulate import prepare

DT = 1.0 / bridge.SAMPLE_RATE
PIERS = [2, 4, 6]  # P1.uy, P2.uy, P3.uy


def _opensees_or_skip():
    try:
        return import_opensees()
    except MissingDependencyError as exc:
        pytest.skip(f"openseespy is not installed or does not import here: {exc}")


def _friction_values() -> dict[str, float]:
    values = {k: v for k, v in viscous_values().items() if k in ("E", "kp1", "kp2", "kp3", "kp4")}
    return values | DEFAULT_FRICTION_VALUES


@pytest.fixture(scope="module")
def viscous_peer() -> OpenSeesPeer:
    ops = _opensees_or_skip()
    return OpenSeesPeer(Model.model_validate(bridge.viscous_model()), viscous_values(), ops=ops)


@pytest.fixture(scope="module")
def friction_peer() -> OpenSeesPeer:
    ops = _opensees_or_skip()
    return OpenSeesPeer(Model.model_validate(bridge.friction_model()), _friction_values(),
                        ops=ops)


def _rel_l2(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


# ---------------------------------------------------------------------------- import


def test_missing_openseespy_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "openseespy", None)  # makes the import fail
    with pytest.raises(MissingDependencyError, match=r"femupdate\[opensees\]"):
        import_opensees.__wrapped__()


def test_import_opensees_gives_the_interpreter():
    ops = _opensees_or_skip()
    assert callable(ops.eigen) and callable(ops.analyze)


# ---------------------------------------------------------------------------- the model


@pytest.mark.parametrize("which", ["viscous", "friction"])
def test_opensees_assembles_our_matrices(which, viscous_peer, friction_peer):
    peer = viscous_peer if which == "viscous" else friction_peer
    M, C, K = peer.matrices()
    system = peer.system
    for name, theirs, ours in (("M", M, system.M), ("C", C, system.C),
                               ("K", K, initial_stiffness(system))):
        scale = np.abs(ours).max()
        assert np.abs(theirs - ours).max() <= 1e-12 * scale, name


def test_bridge_mass_is_deck_plus_added_masses(viscous_peer):
    """The total translational mass OpenSees assembles: r^T M r = rho A L + 5 x 48 kg."""
    b, t = bridge.SECTION_B, bridge.SECTION_T
    deck = 7850.0 * (b * b - (b - 2 * t) ** 2) * 4 * bridge.SPAN
    M, _, _ = viscous_peer.matrices()
    r = viscous_peer.system.r
    assert r @ M @ r == pytest.approx(deck + 5 * bridge.ADDED_MASS, rel=1e-12)


@pytest.mark.parametrize("which", ["viscous", "friction"])
def test_frequencies_agree(which, viscous_peer, friction_peer):
    peer = viscous_peer if which == "viscous" else friction_peer
    theirs = peer.frequencies(4)
    ours, _ = natural_frequencies(peer.system, 4)
    np.testing.assert_allclose(theirs, ours, rtol=1e-8)  # brief: 0.5 %


def test_quasi_static_response(viscous_peer):
    """A constant a_g over one long Newmark step: the (nearly) static response.

    From rest with zero initial acceleration (OpenSees's start), one average-acceleration step
    of length h gives exactly ``u1 = (K + 2C/h + 4M/h²)⁻¹ (-p a_g)``; at h = 10 s that is the
    static response to 1e-3. With the nodal load ``p = M r``; OpenSees's UniformExcitation
    counts the beams' mass twice, ``p = (M + M_beam) r``: if that check fails, OpenSees has
    fixed it.
    """
    system = viscous_peer.system
    h = 10.0
    ag = np.ones(2)
    step = system.K + 2.0 * system.C / h + 4.0 * system.M / h**2
    expected = np.linalg.solve(step, -system.M @ system.r)
    nodal = viscous_peer.run(ag, h, method="newmark")[-1]
    np.testing.assert_allclose(nodal, expected, rtol=1e-9, atol=1e-12 * np.abs(expected).max())
    table = bridge.viscous_model()
    for mass in table["masses"]:
        mass["m"] = 0.0
    m_beam = build_structure(Model.model_validate(table)).assemble(viscous_values()).M
    doubled = np.linalg.solve(step, -(system.M + m_beam) @ system.r)
    uniform = viscous_peer.run(ag, h, method="newmark", excitation="uniform")[-1]
    np.testing.assert_allclose(uniform, doubled, rtol=1e-9, atol=1e-12 * np.abs(doubled).max())


# ---------------------------------------------------------------------------- time histories


@pytest.mark.parametrize(("method", "substeps"), [("newmark", 1), ("central_difference", 10)])
def test_viscous_time_history_same_integrator(method, substeps, viscous_peer, base_motion):
    assert base_motion[0] == 0.0  # both codes start from rest with a consistent state
    theirs = viscous_peer.run(base_motion, DT, method=method, substeps=substeps, outputs=PIERS)
    ours = prepare(viscous_peer.system, DT, method=method, substeps=substeps,
                   outputs=PIERS).run(base_motion).displacement
    assert _rel_l2(theirs, ours) < 1e-8  # measured 7e-12 (Newmark), 8e-11 (CD); brief: 1e-3


def test_friction_time_history(friction_peer, base_motion):
    """ElasticPP in OpenSees central differences vs our nonlinear integrator, both at dt/10."""
    ag = 2.0 * base_motion  # peak 4 m/s²: every damper slips
    ours = prepare(friction_peer.system, DT, method="nonlinear", substeps=10,
                   outputs=PIERS).run(ag)
    assert np.all(np.ptp(ours.slip, axis=0) > 0.0), "every elasto-slip element must slip"
    theirs = friction_peer.run(ag, DT, method="central_difference", substeps=10, outputs=PIERS)
    assert _rel_l2(theirs, ours.displacement) < 1e-8  # measured about 1e-10


def test_runs_repeat_and_survive_another_model(viscous_peer, friction_peer, base_motion):
    ag = base_motion[:500]
    first = viscous_peer.run(ag, DT, outputs=PIERS)
    friction_peer.build()  # wipes the viscous model from OpenSees's single domain
    again = viscous_peer.run(ag, DT, outputs=PIERS)
    np.testing.assert_array_equal(again, first)


# ---------------------------------------------------------------------------- errors


def test_unsupported_model_is_refused():
    ops = _opensees_or_skip()
    table = bridge.viscous_model() | {"rayleigh": {"alpha": 0.1}}
    with pytest.raises(ModelError, match="rayleigh"):
        OpenSeesPeer(Model.model_validate(table), viscous_values(), ops=ops)


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"method": "exact"}, "method"),
    ({"substeps": 0}, "substeps"),
    ({"excitation": "table"}, "excitation"),
    ({"outputs": [10]}, "outputs"),
])
def test_bad_run_options(kwargs, match, viscous_peer):
    with pytest.raises(ConfigError, match=match):
        viscous_peer.run(np.zeros(10), DT, **kwargs)

"""Baber–Wen degradation of the Bouc–Wen element (δ_A, δ_ν, δ_η): zero rates leave the law
unchanged, the loop follows OpenSees's degrading BoucWen material, the energy is the work of
the hysteretic force, the update's derivative is exact, and bad rates are refused."""

from __future__ import annotations

import numpy as np
import pytest

from femupdate.errors import MissingDependencyError, ModelError
from femupdate.model.hysteresis import (
    MAX_DEGRADING_PARTS,
    bouc_wen_degrading_parts,
    bouc_wen_degrading_update,
    bouc_wen_degrading_update_tangent,
    bouc_wen_force,
    bouc_wen_history,
    bouc_wen_loop,
    bouc_wen_step_limit,
    bouc_wen_update,
    check_bouc_wen_parameters,
)
from femupdate.model.structure import Structure
from femupdate.model.system import BoucWenElements

# k, alpha, A, beta, gamma, n: z_u = 29 mm, yield near 26 N (as tests/model/test_hysteresis.py)
LAW = (1e4, 0.1, 1.0, 150.0, 50.0, 1.5)
# delta_a, delta_nu, delta_eta in 1/J: the history below dissipates about 4 J, so A falls by a
# fifth, ν rises by 40 % and η by a fifth (the peak force drops from 217 N to 156 N)
RATES = (0.05, 0.1, 0.05)
C = (1.0 - LAW[1]) * LAW[0]  # (1 − α) k, the slope of de/dy per unit z


def history(count: int) -> np.ndarray:
    """Growing cycles from rest: 4.4 cycles to ±0.026 m (0.9 z_u … 9 z_u)."""
    t = np.linspace(0.0, 4.0, count + 1)
    return 0.02 * (0.3 + t / 4.0) * np.sin(2.0 * np.pi * 1.1 * t)


def test_zero_rates_are_the_undegraded_law_bit_for_bit() -> None:
    """δ = 0 runs the undegraded update: the loop equals a step-by-step loop of
    ``bouc_wen_update`` bit for bit, and a six-column table is completed with zero rates."""
    y = history(2000)
    k, alpha, A, beta, gamma, n = LAW
    dy_max = float(bouc_wen_step_limit(A, beta, gamma, n))
    z = np.zeros_like(y)
    for i in range(1, y.size):
        z[i] = bouc_wen_update(z[i - 1], y[i] - y[i - 1], A, beta, gamma, n, dy_max)
    force = np.array([bouc_wen_force(y[i], z[i], k, alpha) for i in range(y.size)])
    ours, z_ours = bouc_wen_loop(y, *LAW, 0.0, 0.0, 0.0)
    assert np.array_equal(z_ours, z) and np.array_equal(ours, force)
    elements = BoucWenElements(np.array([0]), np.array([-1]), np.array([LAW]))
    assert elements.table.shape == (1, 9) and not elements.table[0, 6:].any()


def test_degradation_lowers_the_loop() -> None:
    y = history(4000)
    plain, _ = bouc_wen_loop(y, *LAW)
    degraded, _ = bouc_wen_loop(y, *LAW, *RATES)
    # the first quarter cycle dissipates little: the loops start together
    early = slice(0, 200)
    np.testing.assert_allclose(degraded[early], plain[early], rtol=0.02, atol=1e-6)
    assert np.abs(degraded[-1000:]).max() < 0.8 * np.abs(plain[-1000:]).max()
    for i, rate in enumerate(RATES):  # each rate alone weakens the loop
        rates = np.zeros(3)
        rates[i] = rate
        alone, _ = bouc_wen_loop(y, *LAW, *rates)
        assert np.abs(alone[-1000:]).max() < 0.97 * np.abs(plain[-1000:]).max()


def _opensees_stress(ops, y: np.ndarray, rates: tuple[float, float, float]) -> np.ndarray:
    k, alpha, A, beta, gamma, n = LAW
    ops.wipe()
    # argument order: tag alpha ko n gamma beta Ao deltaA deltaNu deltaEta
    ops.uniaxialMaterial("BoucWen", 1, alpha, k, n, gamma, beta, A, *rates)
    ops.testUniaxialMaterial(1)
    stress = []
    for value in y:
        ops.setStrain(float(value))
        stress.append(ops.getStress())
    ops.wipe()
    return np.array(stress)


@pytest.mark.parametrize("rates", [RATES, (0.1, 0.0, 0.0), (0.0, 0.2, 0.0), (0.0, 0.0, 0.1)])
def test_degrading_loop_agrees_with_opensees_boucwen(rates: tuple[float, float, float]) -> None:
    """OpenSees's BoucWen material with δA, δν, δη under the strain history: the stress
    histories agree to NMSE 5.1e-6 at 8,000 increments (rates together; OpenSees's backward
    Euler step is first order, so the NMSE falls 16× per 4× increments: 8.1e-5 at 2,000)."""
    from femupdate.paper.bench.opensees import import_opensees

    try:
        ops = import_opensees()
    except MissingDependencyError as exc:
        pytest.skip(f"openseespy is not installed or does not import here: {exc}")
    nmse = []
    for count in (2000, 8000):
        y = history(count)
        theirs = _opensees_stress(ops, y, rates)
        ours, _ = bouc_wen_loop(y, *LAW, *rates)
        nmse.append(float(np.mean((ours - theirs) ** 2) / np.mean(theirs**2)))
    assert nmse[1] <= 1e-4, nmse
    assert 8.0 < nmse[0] / nmse[1] < 32.0, nmse  # first order in the increment
    plain, _ = bouc_wen_loop(history(8000), *LAW)
    assert np.mean((plain - theirs) ** 2) / np.mean(theirs**2) > 100.0 * nmse[1]


def test_energy_on_virgin_loading_is_the_closed_form() -> None:
    """n = 1, loading from rest: z = z_u (1 − exp(−(β + γ) y)), so
    e = (1 − α) k z_u (y − (1 − exp(−(β + γ) y)) / (β + γ))."""
    k, alpha, A, beta, gamma = 1e4, 0.2, 1.0, 300.0, 100.0
    y = np.linspace(0.0, 0.02, 2001)  # to 8 z_u; Runge–Kutta parts of 0.004 / (β + γ)
    _, z, e = bouc_wen_history(y, k, alpha, A, beta, gamma, 1.0)
    z_u, rate = A / (beta + gamma), beta + gamma
    np.testing.assert_allclose(z, z_u * -np.expm1(-rate * y), rtol=1e-9, atol=1e-15)
    exact = (1.0 - alpha) * k * z_u * (y + np.expm1(-rate * y) / rate)
    np.testing.assert_allclose(e, exact, rtol=1e-8, atol=1e-15)


def test_energy_is_the_work_of_the_hysteretic_force() -> None:
    """e is ∫ (1 − α) k z dy along the history (the trapezoid rule on a fine history agrees to
    its own O(h²) error), and over a closed cycle it grows by the loop's area ∮ f dy (the
    elastic part α k y does no work)."""
    y = history(40000)
    force, z, e = bouc_wen_history(y, *LAW, *RATES)
    work = np.concatenate([[0.0], np.cumsum(0.5 * C * (z[1:] + z[:-1]) * np.diff(y))])
    np.testing.assert_allclose(e, work, rtol=0, atol=1e-6 * e[-1])
    # a closed cycle at the end: from one upward zero crossing of y to the next
    ups = np.flatnonzero((y[:-1] < 0.0) & (y[1:] >= 0.0))
    a, b = ups[-2], ups[-1]
    cycle = slice(a, b + 1)
    area = np.trapezoid(force[cycle], y[cycle])
    # the cycle is not quite closed (the amplitude grows): the elastic work of the mismatch
    elastic = LAW[1] * LAW[0] * 0.5 * (y[b] ** 2 - y[a] ** 2)
    assert e[b] - e[a] == pytest.approx(area - elastic, rel=1e-5)
    assert area > 0.0


def test_heavy_degradation_stays_finite_and_bounded() -> None:
    """Rates that drain A(e) below zero within the history: the element loses its hysteretic
    stiffness; the update stays finite, and the parts per increment never exceed the cap."""
    y = history(2000)
    force, z, e = bouc_wen_history(y, *LAW, 5.0, 5.0, 0.0)
    assert np.all(np.isfinite(force)) and np.all(np.isfinite(z)) and np.all(np.isfinite(e))
    assert 1.0 - 5.0 * e.max() < 0.0  # A(e) went below zero
    z_u = (LAW[2] / (LAW[3] + LAW[4])) ** (1.0 / LAW[5])
    assert np.abs(z).max() <= 1.0001 * z_u
    # a sharp law far degraded (ν = 51, n = 0.2: z_u shrinks 51^5-fold): one increment of
    # 10 z_u would need 1e10 parts; it gets the cap's, and ends finite
    k, A, beta, gamma, n = 1e4, 1.0, 0.5, 0.5, 0.2
    dy_max = float(bouc_wen_step_limit(A, beta, gamma, n))
    args = (A, beta, gamma, n, 0.0, 1.0, 0.0, k, dy_max)
    assert bouc_wen_degrading_parts(0.0, 50.0, 10.0, *args) == MAX_DEGRADING_PARTS
    assert bouc_wen_degrading_parts(0.0, 0.0, 10.0, *args) < MAX_DEGRADING_PARTS
    assert np.all(np.isfinite(bouc_wen_degrading_update(0.0, 50.0, 10.0, *args)))


@pytest.mark.parametrize("n", [1.0, 1.5, 2.0, 5.0])
def test_degrading_tangent_is_the_derivative_of_the_update(n: float) -> None:
    """∂z/∂dy of the degrading update, carried through the stages with e, against central
    differences; its z and e are the update's (same parts)."""
    k, alpha, A = 4000.0, 0.1, 1.0
    beta, gamma = 0.75e3**n, 0.25e3**n  # z_u near 1 mm
    c = (1.0 - alpha) * k
    rates = (30.0, 60.0, 20.0)  # 1/J; (1 − α) k z_u² is 3.6 mJ
    dy_max = float(bouc_wen_step_limit(A, beta, gamma, n))
    for z, e, dy in ((0.0, 0.0, 4e-4), (6e-4, 0.004, 3e-4), (6e-4, 0.01, -8e-4),
                     (-9e-4, 0.002, 2e-4)):
        parts = bouc_wen_degrading_parts(z, e, dy, A, beta, gamma, n, *rates, c, dy_max)
        zn, en, s = bouc_wen_degrading_update_tangent(z, e, dy, A, beta, gamma, n, *rates, c,
                                                      parts)
        z_ref, e_ref = bouc_wen_degrading_update(z, e, dy, A, beta, gamma, n, *rates, c, dy_max)
        assert zn == pytest.approx(z_ref, rel=1e-14, abs=1e-20)
        assert en == pytest.approx(e_ref, rel=1e-14, abs=1e-20)
        eps = 1e-9
        up, down = (bouc_wen_degrading_update_tangent(z, e, dy + h, A, beta, gamma, n, *rates,
                                                      c, parts)[0] for h in (eps, -eps))
        assert s == pytest.approx((up - down) / (2 * eps), rel=1e-5, abs=1e-8)
        # the degradation matters to the derivative: the undegraded law's differs
        plain = bouc_wen_degrading_update_tangent(z, e, dy, A, beta, gamma, n, 0.0, 0.0, 0.0,
                                                  c, parts)[2]
        assert abs(plain - s) > 1e-3 * abs(s)


@pytest.mark.parametrize(("column", "value", "words"), [
    (6, -0.1, "delta_a = -0.1 is out of range; allowed >= 0 and finite"),
    (7, np.inf, "delta_nu = inf is out of range; allowed >= 0"),
    (8, np.nan, "delta_eta = nan is out of range; allowed >= 0"),
])
def test_bad_rates_are_refused(column: int, value: float, words: str) -> None:
    table = np.array([[*LAW, *RATES]])
    table[0, column] = value
    with pytest.raises(ModelError, match=words):
        check_bouc_wen_parameters(table, ("brace",))
    with pytest.raises(ModelError, match="bouc_wen 'brace': " + words.split(" =")[0]):
        check_bouc_wen_parameters(table, ("brace",))


def test_structure_api_takes_the_rates() -> None:
    s = Structure(dofs_per_node=1)
    s.add_node("F1", x=0.0, y=1.0)
    s.add_mass("F1", m=1.0)
    k, alpha, A, beta, gamma, n = LAW
    s.add_bouc_wen("F1", "ux", k, alpha=alpha, A=A, beta=beta, gamma=gamma, n=n,
                   delta_a=RATES[0], delta_nu="dnu", delta_eta=RATES[2], name="brace")
    system = s.assemble({"dnu": 0.3})
    np.testing.assert_array_equal(system.bouc_wen.table, [[*LAW, RATES[0], 0.3, RATES[2]]])
    with pytest.raises(ModelError, match="delta_nu"):
        s.assemble({"dnu": -0.3})
    bad = Structure(dofs_per_node=1)
    bad.add_node("F1", x=0.0, y=1.0)
    with pytest.raises(ModelError, match="delta_eta"):
        bad.add_bouc_wen("F1", "ux", k, beta=beta, gamma=gamma, delta_eta=-1.0)

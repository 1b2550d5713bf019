"""The Bouc–Wen element: its loop against an independent solution and OpenSees, its place in
the structure, the simulator and ``modes``, and its bad parameters."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from femupdate.errors import MissingDependencyError, ModelError
from femupdate.model.hysteresis import (
    bouc_wen_loop,
    bouc_wen_step_limit,
    check_bouc_wen_parameters,
)
from femupdate.model.modes import natural_frequencies
from femupdate.model.structure import Structure, shear_building
from femupdate.simulate import simulate

# k, alpha, A, beta, gamma, n: z_u = (1 / 200)^(1/1.5) = 29 mm, yield near 26 N
LAW = (1e4, 0.1, 1.0, 150.0, 50.0, 1.5)
DURATION = 4.0
OMEGA = 2.0 * np.pi * 1.1  # peaks fall between samples for every step below


def history(t: np.ndarray) -> np.ndarray:
    """A growing sine from rest: loops of increasing size, yielding from the second cycle."""
    return 0.02 * (0.3 + t / DURATION) * np.sin(OMEGA * t)


def history_rate(t: np.ndarray) -> np.ndarray:
    return 0.02 * (np.sin(OMEGA * t) / DURATION + (0.3 + t / DURATION) * OMEGA
                   * np.cos(OMEGA * t))


def reference_z(t: np.ndarray, law: tuple[float, ...] = LAW) -> np.ndarray:
    """z(t) of ż = A u̇ − β |u̇| |z|^(n−1) z − γ u̇ |z|^n by scipy (DOP853, rtol 1e-10)."""
    _, _, A, beta, gamma, n = law

    def rate(time: float, z: np.ndarray) -> list[float]:
        v = history_rate(time)
        return [(A - (beta * np.sign(v * z[0]) + gamma) * abs(z[0]) ** n) * v]

    sol = solve_ivp(rate, (0.0, DURATION), [0.0], method="DOP853", rtol=1e-10, atol=1e-14,
                    dense_output=True, max_step=0.01)
    assert sol.success
    return sol.sol(t)[0]


def _force_scale(law: tuple[float, ...] = LAW) -> float:
    k, alpha, A, beta, gamma, n = law
    return (1.0 - alpha) * k * (A / (beta + gamma)) ** (1.0 / n)


def loop_errors(steps: list[int]) -> np.ndarray:
    """Largest force error over the history / the yield force, per number of steps."""
    k, alpha = LAW[:2]
    errors = []
    for count in steps:
        t = np.linspace(0.0, DURATION, count + 1)
        y = history(t)
        force, _ = bouc_wen_loop(y, *LAW)
        exact = k * (alpha * y + (1.0 - alpha) * reference_z(t))
        errors.append(np.max(np.abs(force - exact)) / _force_scale())
    return np.array(errors)


def test_loop_converges_at_second_order_to_solve_ivp() -> None:
    """Between samples the deformation is linear: the peaks it cuts cost O(h²), the
    Runge–Kutta update elsewhere O(h⁴). Measured: 9.8e-4 (200 steps) … 2.4e-6 (3,200)."""
    steps = [200, 400, 800, 1600, 3200]
    errors = loop_errors(steps)
    order = -np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert 1.7 < order < 2.6, (errors, order)
    assert errors[-1] < 1e-5


def test_loop_agrees_with_opensees_boucwen_at_its_first_order() -> None:
    """OpenSees's BoucWen material takes a backward-Euler step in z per strain increment
    (first order): its distance to femupdate halves with the step, and both approach the
    solve_ivp solution."""
    from femupdate.paper.bench.opensees import import_opensees

    try:
        ops = import_opensees()
    except MissingDependencyError as exc:
        pytest.skip(f"openseespy is not installed or does not import here: {exc}")
    k, alpha, A, beta, gamma, n = LAW
    gaps = []
    steps = [400, 800, 1600, 3200]
    for count in steps:
        y = history(np.linspace(0.0, DURATION, count + 1))
        ops.wipe()
        # argument order: tag alpha ko n gamma beta Ao deltaA deltaNu deltaEta
        ops.uniaxialMaterial("BoucWen", 1, alpha, k, n, gamma, beta, A, 0.0, 0.0, 0.0)
        ops.testUniaxialMaterial(1)
        theirs = []
        for value in y:
            ops.setStrain(float(value))
            theirs.append(ops.getStress())
        ops.wipe()
        ours, _ = bouc_wen_loop(y, *LAW)
        gaps.append(np.max(np.abs(ours - np.array(theirs))) / _force_scale())
    order = -np.polyfit(np.log(steps), np.log(gaps), 1)[0]
    assert 0.9 < order < 1.2, (gaps, order)
    assert gaps[-1] < 2e-3


def test_loop_saturates_at_the_ultimate_z_and_is_odd() -> None:
    _, _, A, beta, gamma, n = LAW
    y = np.linspace(0.0, 0.5, 2001)  # 17 × z_u: fully yielded
    force, z = bouc_wen_loop(y, *LAW)
    z_u = (A / (beta + gamma)) ** (1.0 / n)
    assert abs(z[-1] - z_u) < 1e-9 * z_u
    neg_force, _ = bouc_wen_loop(-y, *LAW)
    np.testing.assert_allclose(neg_force, -force, rtol=0, atol=1e-12 * np.abs(force).max())


def test_large_increments_stay_stable_for_a_sharp_law() -> None:
    """n = 20 (nearly elastic-perfectly plastic): one increment of 10 z_u is cut into parts."""
    law = (1e4, 0.0, 1.0, 0.5, 0.5, 20.0)
    _, z = bouc_wen_loop(np.array([0.0, 10.0, -10.0]), *law)
    np.testing.assert_allclose(z, [0.0, 1.0, -1.0], atol=1e-6)


@pytest.mark.parametrize(("column", "value", "words"), [
    (5, 0.0, "n = 0.0 is out of range; allowed > 0"),
    (5, -1.0, "n = -1.0 is out of range"),
    (0, 0.0, "k = 0.0 is out of range; allowed > 0"),
    (1, 1.5, "alpha = 1.5 is out of range; allowed in [0, 1]"),
    (2, 0.0, "A = 0.0 is out of range"),
    (3, -10.0, "beta = -10.0 is out of range; allowed > 0"),
    (4, -150.0, "gamma = -150.0 with beta = 150.0 gives no bounded hysteresis loop; allowed "
                "-beta < gamma <= beta"),
    (4, 200.0, "gamma = 200.0 with beta = 150.0"),
])
def test_parameters_without_hysteresis_are_refused(column: int, value: float,
                                                    words: str) -> None:
    table = np.array([LAW])
    table[0, column] = value
    with pytest.raises(ModelError, match="bouc_wen 'b1': " + words.replace("[", r"\[")
                       .replace("(", r"\(").replace("+", r"\+")):
        check_bouc_wen_parameters(table, ("b1",))
    s = Structure(dofs_per_node=1)
    s.add_node("F1", x=0.0)
    s.add_mass("F1", m=1.0)
    names = ("k", "alpha", "A", "beta", "gamma", "n")
    with pytest.raises(ModelError) as info:
        s.add_bouc_wen("F1", "ux", **dict(zip(names, table[0], strict=True)), name="b1")
    assert "\n" not in str(info.value) and names[column] in str(info.value)


@pytest.mark.parametrize(("beta", "n"), [(2000.0, 0.01), (1e-6, 0.01), (0.3, 0.01),
                                         (1e5, 0.1)])
def test_a_small_n_whose_z_u_is_not_representable_is_refused(beta: float, n: float) -> None:
    # Issue 33: n = 0.01 (inside (0, 100]) with beta + gamma = 2500 made z_u underflow to 0 and
    # the compiled kernel divide by zero. Its neighbours: z_u overflowing (beta + gamma small),
    # or tiny without underflowing (a step would need ~1e26 Runge–Kutta parts).
    table = np.array([[1e4, 0.0, 1.0, beta, beta / 4.0, n]])
    with pytest.raises(ModelError, match=r"bouc_wen 'b1': z_u = \(A / \(beta \+ gamma\)\)"
                       r"\^\(1/n\) = 1e[+-]\d+ .* is out of range; allowed z_u from 1e-09"):
        check_bouc_wen_parameters(table, ("b1",))


def test_a_small_n_inside_the_range_simulates_with_finite_steps() -> None:
    # n = 0.01 with A/(β + γ) = 1.1: z_u = 1.1^100 = 1.4e4, z_u^(n−1) without overflow.
    assert 0.0 < float(bouc_wen_step_limit(1.0, 0.5, 0.4, 0.01)) < np.inf
    s = _sdof(k=100.0, beta=0.5, gamma=0.4, n=0.01)
    response = simulate(s.assemble(), 0.005, ag=_record(400), method="nonlinear", substeps=8)
    assert np.all(np.isfinite(response.displacement))


def test_parameter_values_are_checked_at_assembly() -> None:
    s = Structure(dofs_per_node=1)
    s.add_node("F1", x=0.0)
    s.add_mass("F1", m=1.0)
    s.add_bouc_wen("F1", "ux", k=1e4, beta="b", gamma="g", name="brace")
    assert s.assemble({"b": 100.0, "g": 20.0}).n_bouc_wen == 1
    with pytest.raises(ModelError, match=r"brace.*gamma = 200.0 with beta = 100.0"):
        s.assemble({"b": 100.0, "g": 200.0})


# ----------------------------------------------------------------------------- in a system


def _sdof(**law: float) -> Structure:
    s = Structure(dofs_per_node=1)
    s.add_node("F1", x=0.0)
    s.add_mass("F1", m=1.0)
    s.add_damper("F1", "ux", 0.5)
    s.add_bouc_wen("F1", "ux", **law)
    return s


def _record(count: int = 2000, dt: float = 0.005) -> np.ndarray:
    t = np.arange(count) * dt
    return 3.0 * np.sin(2.0 * np.pi * 1.3 * t) * np.exp(-0.3 * t)


def test_alpha_one_is_a_linear_spring() -> None:
    """α = 1: the force is k y whatever z does; the same bits path as a spring is not
    expected (the force enters through H), the same response to rounding is."""
    dt = 0.005
    ag = _record()
    bw = simulate(_sdof(k=400.0, alpha=1.0, beta=100.0, gamma=50.0).assemble(), dt, ag=ag,
                  method="nonlinear", substeps=4)
    s = Structure(dofs_per_node=1)
    s.add_node("F1", x=0.0)
    s.add_mass("F1", m=1.0)
    s.add_damper("F1", "ux", 0.5)
    s.add_spring("F1", "ux", 400.0)
    linear = simulate(s.assemble(), dt, ag=ag, method="central_difference", substeps=4)
    scale = np.abs(linear.displacement).max()
    np.testing.assert_allclose(bw.displacement, linear.displacement, rtol=0, atol=1e-12 * scale)


def test_physical_and_modal_kernels_agree() -> None:
    """A dashpot between floors (non-proportional damping) sends the simulator to its
    physical-coordinate kernel; with the dashpot to ground the modal one runs."""
    dt = 0.005
    ag = _record()
    law = {"k": 800.0, "alpha": 0.1, "beta": 4000.0, "gamma": 2000.0, "n": 2.0}
    responses = []
    for proportional in (True, False):
        s = shear_building([1.0, 1.0], [300.0, 300.0],
                           bouc_wen=[law, law])
        if not proportional:
            s.add_damper("F2", "ux", 1e-9, node2="F1")  # negligible, but couples the modes
        sim_system = s.assemble()
        responses.append(simulate(sim_system, dt, ag=ag, method="nonlinear", substeps=8))
    from femupdate.simulate import prepare

    assert prepare(shear_building([1.0, 1.0], [300.0, 300.0], bouc_wen=[law, law]).assemble(),
                   dt, method="nonlinear", substeps=8).modal
    a, b = responses
    assert np.abs(a.hysteretic_z).max() > 0.5 * (1.0 / 6000.0) ** 0.5  # it yields
    np.testing.assert_allclose(a.displacement, b.displacement, rtol=0,
                               atol=1e-8 * np.abs(a.displacement).max())
    np.testing.assert_allclose(a.hysteretic_force, b.hysteretic_force, rtol=0,
                               atol=1e-8 * np.abs(a.hysteretic_force).max())


def test_element_force_follows_the_law_along_the_simulated_deformation() -> None:
    """The forces the simulator reports are the law driven through its own displacements."""
    dt = 0.005
    law = {"k": 400.0, "alpha": 0.2, "A": 1.0, "beta": 100.0, "gamma": 50.0, "n": 1.5}
    r = simulate(_sdof(**law).assemble(), dt, ag=_record(), method="nonlinear", substeps=1)
    force, z = bouc_wen_loop(r.displacement[:, 0], *law.values())
    np.testing.assert_allclose(r.hysteretic_z[:, 0], z, rtol=0, atol=1e-14)
    np.testing.assert_allclose(r.hysteretic_force[:, 0], force, rtol=0, atol=1e-11)


def test_modes_use_the_initial_tangent() -> None:
    k, alpha, A = 400.0, 0.2, 0.7
    s = _sdof(k=k, alpha=alpha, A=A, beta=100.0, gamma=50.0)
    (f,), _ = natural_frequencies(s.assemble())
    assert f == pytest.approx(np.sqrt(k * (alpha + (1 - alpha) * A)) / (2 * np.pi), rel=1e-12)


def test_unstable_step_is_refused_with_the_largest_tangent() -> None:
    from femupdate.errors import SimulationError

    s = _sdof(k=4e6, alpha=0.0, beta=100.0, gamma=0.0)  # unloading tangent 2 k
    with pytest.raises(SimulationError, match="substeps"):
        simulate(s.assemble(), 0.005, ag=_record(200), method="nonlinear", substeps=1)


def _cycle_work(law: tuple[float, ...], amplitude: float) -> float:
    """∮ f dy over the second of two full cycles of ±amplitude, from rest."""
    legs = [np.linspace(0.0, amplitude, 2001)]
    for _ in range(2):
        legs += [np.linspace(amplitude, -amplitude, 4001)[1:],
                 np.linspace(-amplitude, amplitude, 4001)[1:]]
    y = np.concatenate(legs)
    force, _ = bouc_wen_loop(y, *law)
    last = slice(-8001, None)
    return float(np.sum(0.5 * (force[last][1:] + force[last][:-1]) * np.diff(y[last])))


@pytest.mark.parametrize("gamma", [-140.0, 0.0, 50.0, 150.0])
def test_a_closed_cycle_dissipates_energy(gamma: float) -> None:
    assert _cycle_work((1e4, 0.0, 1.0, 150.0, gamma, 1.5), 0.05) > 0.0


def test_a_sharp_law_dissipates_the_elastic_plastic_loop() -> None:
    """n = 25, β = γ: nearly elastic-perfectly plastic, z_u = 10 mm, f_y = 100 N; a cycle of
    ±50 mm encloses 4 f_y (a − z_u) = 16 J."""
    law = (1e4, 0.0, 1.0, 0.5e50, 0.5e50, 25.0)
    assert _cycle_work(law, 0.05) == pytest.approx(16.0, rel=2e-3)  # measured 15.995 J


def test_linear_methods_refuse_bouc_wen_systems() -> None:
    from femupdate.errors import SimulationError

    system = _sdof(k=400.0, beta=100.0, gamma=50.0).assemble()
    for method in ("exact", "central_difference", "newmark"):
        with pytest.raises(SimulationError, match="1 Bouc–Wen elements: use method='nonlinear'"):
            simulate(system, 0.01, ag=_record(50), method=method)

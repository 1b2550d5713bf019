"""Craig–Bampton reduction of nonlinear models: exact with every interior mode, convergent as
the cut-off rises on a beam with a friction damper, and the same integrator's result."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.signal as ss

from femupdate.errors import ConfigError
from femupdate.model import Structure
from femupdate.paper.bench.friction_beam import ELEMENTS, TRUTH, friction_beam_case
from femupdate.simulate import prepare
from femupdate.simulate.craig_bampton import craig_bampton, nonlinear_dofs

DT = 0.005


def friction_beam(friction: bool = True) -> Structure:
    """A 30 m steel beam on end springs and a pier spring, a friction damper at mid-span."""
    s = Structure(dofs_per_node=2)
    for i in range(ELEMENTS + 1):
        s.add_node(f"N{i}", x=30.0 * i / ELEMENTS)
    for i in range(ELEMENTS):
        s.add_beam(f"N{i}", f"N{i + 1}", E=2.1e11, A=0.01, I=2e-4, rho=7850.0)
    s.add_spring("N0", "uy", 1e8)
    s.add_spring(f"N{ELEMENTS}", "uy", 1e8)
    s.add_spring(f"N{ELEMENTS // 3}", "uy", 5e6)
    if friction:
        s.add_friction(f"N{ELEMENTS // 2}", "uy", k_r=2e6, f_u=2e3)
    s.set_rayleigh(0.2, 1e-5)
    return s


def ground_motion(n: int = 2000) -> np.ndarray:
    noise = np.random.default_rng(0).standard_normal(n)
    return 3.0 * ss.sosfiltfilt(ss.butter(4, 20.0, fs=1 / DT, output="sos"), noise)


def test_every_interior_mode_kept_gives_the_full_model_frequencies() -> None:
    system = friction_beam(friction=False).assemble(direction="y")
    outputs = [5, 40]
    reduced, position = craig_bampton(system, outputs, n_modes=system.n_dof - 2)
    assert reduced.n_dof == system.n_dof and list(position[outputs]) == [0, 1]
    full = sla.eigh(system.K, system.M, eigvals_only=True)
    mine = sla.eigh(reduced.K, reduced.M, eigvals_only=True)
    np.testing.assert_allclose(mine, full, rtol=1e-9)


def test_friction_beam_converges_to_the_full_nonlinear_response() -> None:
    """The same central differences (200 substeps) on the full model (122 DOFs) and on its
    reduction: the error falls as the interior's modes reach higher (interior modes up to
    80, 160, 320 Hz for a band of 20 Hz: stick–slip excites far above it)."""
    s = friction_beam()
    system = s.assemble(direction="y")
    outputs = [s.dof_index(f"N{ELEMENTS // 2}", "uy"), s.dof_index(f"N{ELEMENTS // 4}", "uy")]
    ag = ground_motion()
    full = prepare(system, DT, method="nonlinear", outputs=outputs, substeps=200).run(ag)
    assert np.abs(full.slip).max() > 1e-3  # the damper slips: the response is nonlinear
    errors = []
    for cutoff in (80.0, 160.0, 320.0):
        reduced, position = craig_bampton(system, np.union1d(nonlinear_dofs(system), outputs),
                                          cutoff_hz=cutoff)
        r = prepare(reduced, DT, method="nonlinear", outputs=position[outputs],
                    substeps=200).run(ag)
        errors.append(np.sum((r.displacement - full.displacement) ** 2)
                      / np.sum(full.displacement ** 2))
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 1e-4
    assert reduced.n_dof < system.n_dof / 5


def test_a_nonlinear_element_off_the_boundary_is_refused() -> None:
    s = friction_beam()
    system = s.assemble(direction="y")
    with pytest.raises(ConfigError, match=r"nonlinear elements act on interior DOFs N30\.uy"):
        craig_bampton(system, [3], cutoff_hz=100.0)
    with pytest.raises(ConfigError, match="boundary DOFs must be 0 to"):
        craig_bampton(system, [system.n_dof], cutoff_hz=100.0)


def test_a_friction_case_on_the_reduced_path(tmp_path) -> None:
    """``method = "reduced"`` with friction: Craig–Bampton with the damper's DOF kept, φ at the
    truth on the full model's records is the truncation error the summary reports, and φ
    away from the truth is far above it."""
    from femupdate.problem.reduced_path import (
        describe_simulation,
        simulation_record,
        trial_truncation,
    )
    from femupdate.problem.update import UpdateProblem
    from femupdate.trials.experiment import load_experiment
    from femupdate.trials.virtual import virtual_experiment

    truth = TRUTH
    virtual_experiment(friction_beam_case(tmp_path, "nonlinear"), truth, tmp_path, seed=1, snr=0.0,
                       offset=0.0, drift=0.0, duration=4.0, rate=200.0, length_scale=1.0)
    case = friction_beam_case(tmp_path, "reduced")
    problem = UpdateProblem(case, load_experiment(case))
    from femupdate.errors import FemupdateWarning

    with pytest.warns(FemupdateWarning, match="truncation error is"):  # 6e-5 at the nominal
        record = simulation_record(problem)
    assert record["against"] == f"the full model ({system_dofs(case)} DOFs, nonlinear)"
    assert record["n_modes"] < system_dofs(case) / 2  # 2 boundary DOFs, modes to 1.6 kHz
    assert "Craig–Bampton" in describe_simulation(record)
    at_truth = problem(truth)
    assert at_truth == pytest.approx(
        trial_truncation(problem.fitted[0], truth)["truncation_error"], rel=1e-6)
    assert at_truth < 1e-5
    assert problem({"k_pier": 5.5e6, "f_u": 2e3}) > 100 * at_truth


def system_dofs(case) -> int:
    from femupdate.problem.case_model import CaseModel

    return CaseModel(case).structure.n_dof

"""Which simulation path a case takes, decided from its fields alone (no model is built).

A linear model of femupdate's own with at least :data:`REDUCED_MIN_DOF` free DOFs, or one whose
masses leave DOFs without inertia, takes the reduced path when ``[simulation] method`` is not
given (:func:`reduced_by_default`); ``[simulation] cutoff_factor`` and ``n_modes`` belong to
that path only (:func:`simulation_issues`). The path itself, which builds and simulates the
model, is :mod:`femupdate.problem.reduced_path`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from femupdate.case.model_sections import Model
    from femupdate.case.schema import Case

__all__ = ["REDUCED_MIN_DOF", "leaves_dofs_without_mass", "model_dof_count",
           "reduced_by_default", "simulation_issues"]

#: Without ``[simulation] method``, a linear model of at least this many DOFs takes the reduced
#: path. Measured through a case (``UpdateProblem`` φ of the shear building of
#: examples/large/make_case.py, 5,000 samples at 100 Hz, 3 acceleration sensors, 25–29 modes
#: kept: ``python benchmarks/reduced_case.py``, two runs, one BLAS thread, load average 8–10
#: on 2 cores), compiled full exact against reduced, medians of 7 points: 3.7 / 3.5 ms against
#: 3.8 / 7.5 ms at 50 DOFs, 23 / 22 against 4.3 / 4.1 ms at 100, 117 / 115 against 11 / 11 ms
#: at 200, 521 / 344 against 12 / 12 ms at 400. The paths cross between 50 and 100 DOFs.
REDUCED_MIN_DOF = 100


def model_dof_count(model: Model) -> int | None:
    """The free DOFs of ``[model]`` without building it (None for an external model): a shear
    building's floors, else nodes × DOFs per node less the fixed ones."""
    if model.external is not None:
        return None
    if model.shear_building is not None:
        return len(model.shear_building.masses)
    fixed = model.fixed_dofs()
    following = sum(1 for floor in model.diaphragms for node in floor.nodes
                    for dof in ("ux", "uy", "rz") if (node, dof) not in fixed)
    return len(model.nodes) * model.dofs_per_node - len(fixed) - following


def leaves_dofs_without_mass(model: Model) -> bool:
    """Whether ``[model]`` says that some DOFs carry no mass: rigid diaphragms (a building's
    floors) or masses on chosen DOFs. The full paths integrate ``M⁻¹``; the reduced path
    condenses such DOFs (exact when they have no mass)."""
    return bool(model.diaphragms) or any(mass.dofs is not None for mass in model.masses)


def reduced_by_default(model: Model) -> bool:
    """Whether a case without ``[simulation] method`` takes the reduced path: a linear model
    of femupdate's own with at least :data:`REDUCED_MIN_DOF` DOFs, or one that
    :func:`leaves_dofs_without_mass`."""
    if model.has_nonlinear:
        return False
    n = model_dof_count(model)
    return n is not None and (n >= REDUCED_MIN_DOF or leaves_dofs_without_mass(model))


def simulation_issues(case: Case) -> list[tuple[str, str, str]]:
    """``[simulation] cutoff_factor`` and ``n_modes``: only with the reduced path, one of them,
    and no more modes than the model has DOFs."""
    sim = case.simulation
    method = case.simulation_method
    issues = []
    for name in ("cutoff_factor", "n_modes"):
        if getattr(sim, name) is not None and method != "reduced":
            issues.append((f"simulation.{name}", f"got {getattr(sim, name)!r} but the "
                           f"simulation method is {method!r}",
                           "only with method = \"reduced\" (or leave it out)"))
    implicit_possible = sim.method == "implicit" or (sim.method is None
                                                     and case.model.has_nonlinear
                                                     and method == "nonlinear")
    if sim.hht_alpha is not None and not implicit_possible:
        issues.append(("simulation.hht_alpha", f"got {sim.hht_alpha!r} but the simulation "
                       f"method is {method!r}", "only with method = \"implicit\", or without "
                       "a method on a model with friction or Bouc–Wen elements (where the "
                       "implicit scheme may be chosen)"))
    if sim.cutoff_factor is not None and sim.n_modes is not None:
        issues.append(("simulation.n_modes", "given with cutoff_factor: the modes are either "
                       "counted or cut at a frequency", "one of n_modes and cutoff_factor"))
    n = model_dof_count(case.model)
    if sim.n_modes is not None and n is not None and sim.n_modes > n:
        issues.append(("simulation.n_modes", f"got {sim.n_modes} but the model has {n} DOFs",
                       f"1 to {n}"))
    return issues

"""The one adapter from a case to its model: structure, output DOFs and prepared simulator.

``CaseModel(case)`` builds the structure of ``[model]`` once (its topology and DOF map) and
knows the case's integrator, substeps, excitation direction and output DOFs; per evaluation it
assembles the system at parameter values and simulates it under a base motion. The update
problem, virtual experiments, ``femupdate modes`` and the report all go through it.

The integrator of a nonlinear model without ``[simulation] method`` is chosen here, once per
sample interval, at the case's nominal point (:func:`choose_integrator`): central differences
where they are stable with room at the case's substeps, else the implicit scheme. The choice
is then held for every parameter value, so that φ stays one function over the search.

It sits below the trials in the layers (``tests/test_architecture.py``): virtual experiments
simulate a case's model, and the update problem above reads the trials. The case package
(schema and validation) never imports it.
"""

from __future__ import annotations

import copy
import dataclasses
import typing
from collections.abc import Mapping, Sequence

import numpy as np

from femupdate.case.expressions import FieldValues
from femupdate.case.model_sections import Model, storey_values
from femupdate.case.schema import Case, OutputChannel
from femupdate.errors import ConfigError, DataError
from femupdate.problem.reduced_path import ReducedPath
from femupdate.simulate.response import Response

if typing.TYPE_CHECKING:
    from femupdate.external.protocol import ExternalModel
    from femupdate.model.structure import Structure
    from femupdate.model.system import System
    from femupdate.simulate import Simulator


def build_structure(model: Model) -> Structure:
    """The ``femupdate.model.Structure`` described by ``[model]``.

    Numbers that name a parameter stay names: ``structure.assemble(values,
    direction=model.excitation_direction)`` substitutes them; fields that are expressions of
    parameters (``"0.5 * beta"``) are computed from ``values`` (``structure.derive``).
    Elements without a ``name`` are named by their place in the case file
    (``"model.springs[2]"``), so the model's own error messages point into the file.

    Parameters
    ----------
    model : Model
        ``case.model`` of a validated case.

    Returns
    -------
    Structure
        With its topology built (DOF map checked).
    """
    from femupdate.model.structure import Structure, shear_building

    if model.shear_building is not None:
        sb = model.shear_building
        n = len(sb.masses)
        structure = shear_building(
            sb.masses, sb.stiffnesses, sb.dampers,
            frictions=None if sb.frictions is None else storey_values(sb.frictions, n),
            bouc_wen=None if sb.bouc_wen is None else storey_values(sb.bouc_wen, n))
    else:
        structure = Structure(dofs_per_node=model.dofs_per_node)
        for node in model.nodes:
            structure.add_node(node.name, x=node.x, y=node.y, z=node.z)
        for i, beam in enumerate(model.beams):
            structure.add_beam(
                beam.nodes[0], beam.nodes[1], E=beam.E, A=beam.A, I=beam.I, rho=beam.rho,
                G=beam.G, nu=beam.nu, kappa=beam.kappa, mass_per_length=beam.mass_per_length,
                rotary_inertia=beam.rotary_inertia, name=beam.name or f"model.beams[{i}]",
                Iy=beam.Iy, Iz=beam.Iz, J=beam.J, vecxz=beam.vecxz,
                shear_deformation=beam.shear_deformation,
                torsional_inertia=beam.torsional_inertia)
        for i, spring in enumerate(model.springs):
            structure.add_spring(spring.node, spring.dof, spring.k, node2=spring.node2,
                                 dof2=spring.dof2, name=spring.name or f"model.springs[{i}]")
        for i, damper in enumerate(model.dampers):
            structure.add_damper(damper.node, damper.dof, damper.c, node2=damper.node2,
                                 dof2=damper.dof2, name=damper.name or f"model.dampers[{i}]")
        for i, fr in enumerate(model.frictions):
            structure.add_friction(fr.node, fr.dof, fr.k_r, fr.f_u, node2=fr.node2,
                                   dof2=fr.dof2, name=fr.name or f"model.frictions[{i}]")
        for i, bw in enumerate(model.bouc_wen):
            structure.add_bouc_wen(bw.node, bw.dof, bw.k, alpha=bw.alpha, A=bw.A, beta=bw.beta,
                                   gamma=bw.gamma, n=bw.n, delta_a=bw.delta_a,
                                   delta_nu=bw.delta_nu, delta_eta=bw.delta_eta, node2=bw.node2,
                                   dof2=bw.dof2, name=bw.name or f"model.bouc_wen[{i}]")
        for i, mass in enumerate(model.masses):
            structure.add_mass(mass.node, m=mass.m, J=mass.J, name=f"model.masses[{i}]",
                               dofs=mass.dofs)
        for support in model.supports:
            structure.fix(support.node, *support.dofs)
        for floor in model.diaphragms:
            structure.add_diaphragm(floor.master, floor.nodes)
    if model.rayleigh is not None:
        structure.set_rayleigh(alpha=model.rayleigh.alpha, beta=model.rayleigh.beta,
                               bouc_wen=model.rayleigh.bouc_wen)
    derived = FieldValues(structure.parameters)
    if derived:  # fields that are expressions: assembled from the case's parameter values
        structure.derive = derived
    structure.influence_vector(model.excitation_direction)  # builds and checks the topology
    return structure


def check_base_motion_moves_mass(structure: Structure, case: Case, direction: str) -> None:
    """ModelError when the base motion along ``direction`` loads no mass (p = M r = 0 at the
    parameters' nominal values): every response would be zero, and ``synth`` wrote all-zero
    channels (a building excited along y, its masses all on ux)."""
    from femupdate.errors import ModelError

    nominal = {p.name: p.nominal_value for p in case.parameters}
    # sparse: no positive-definite check of M (DOFs without mass are condensed on the
    # reduced path), and no n² array for a large model
    load = structure.assemble(nominal, direction=direction, sparse=True).seismic_load
    if not np.any(np.asarray(load)):
        raise ModelError(f"{case.label}: model: the base motion along {direction} moves no mass "
                         f"(no mass acts on a u{direction} DOF that is free): every response "
                         f"would be zero (allowed: masses whose dofs include u{direction}, or "
                         "[model] direction along the masses' DOFs)")


@dataclasses.dataclass(frozen=True)
class IntegratorChoice:
    """The integrator chosen for a nonlinear model without ``[simulation] method``.

    Attributes
    ----------
    method : str
        ``"nonlinear"`` (central differences) or ``"implicit"`` (HHT-α, α = 0).
    substeps : int
        The case's substeps per sample.
    explicit_substeps : int or None
        The substeps central differences would need at the nominal point with the room of
        :data:`femupdate.simulate.EXPLICIT_MARGIN` (None: the nominal system could not be
        assembled, and central differences were kept).
    stable_substeps : int or None
        The substeps at which central differences are stable at all there.
    reason : str
        Why, in words (printed by ``femupdate run``).
    """

    method: str
    substeps: int
    explicit_substeps: int | None
    stable_substeps: int | None
    reason: str


def choose_integrator(system: System | None, dt: float, substeps: int,
                      why_not: str | None = None) -> IntegratorChoice:
    """The default integrator of a nonlinear model, from its ``system`` at the nominal point
    (:func:`femupdate.simulate.nonlinear_method`), sampled every ``dt`` with ``substeps``.

    ``system`` None (``why_not`` says why it could not be assembled): central differences,
    whose own check of the step then speaks at the first simulation.
    """
    from femupdate.simulate import EXPLICIT_MARGIN, explicit_substeps, nonlinear_method

    if system is None:
        return IntegratorChoice("nonlinear", substeps, None, None,
                                f"central differences kept: the nominal point could not be "
                                f"assembled to choose ({why_not})")
    method = nonlinear_method(system, dt, substeps)
    needed = explicit_substeps(system, dt)
    stable = explicit_substeps(system, dt, limit=2.0)
    room = f"h·ω_max < {EXPLICIT_MARGIN:g}, half the stability limit"
    if method == "nonlinear":
        reason = (f"central differences need {needed:,} substep{'s' * (needed > 1)} per "
                  f"sample at the nominal point ({room}); the case has {substeps:,}")
    else:
        reason = (f"central differences would need {needed:,} substeps per sample at the "
                  f"nominal point ({room}; stable from {stable:,}); the case has "
                  f"{substeps:,} ([simulation] method = \"nonlinear\" keeps them)")
    return IntegratorChoice(method, substeps, needed, stable, reason)


class CaseModel:
    """The structure of a case with its integrator and outputs (picklable).

    Parameters
    ----------
    case : Case
        A validated case.
    channels : sequence of OutputChannel, optional
        The output channels (a trial's); default the ``[data]`` outputs, if any.
    dt : float, optional
        The sample interval of the records simulated (a trial's): a nonlinear model without
        ``[simulation] method`` gets its integrator now (``method``); without ``dt``, at its
        first simulation at each interval (:meth:`method_for`).

    Attributes
    ----------
    structure : Structure
    direction : str
        Direction of the base motion.
    method : str
        Integrator: ``case.simulation_method``, or the one chosen at ``dt``.
    choices : dict of float to IntegratorChoice
        The integrators chosen (by sample interval) for a nonlinear model without
        ``[simulation] method``; empty otherwise.
    substeps : int
        Integration steps per sample (1 for the exact method, which needs none).
    outputs : ndarray of int64
        Free-DOF indices of the case's output channels (empty without ``[data]``).
    influence : ndarray
        The influence vector at the outputs: what a unit base motion moves them by (0 with
        support groups: their channels are absolute unless ``relative_to`` says otherwise).
    groups : tuple of str
        The support groups' names (``[[model.support_groups]]``; empty: one table record), the
        order of the columns of a multi-support input.
    reference : ndarray (n_outputs, n_groups)
        With support groups: 1 where an output channel's record is relative to a group's
        motion (``relative_to``, along the group's direction), else 0.
    """

    def __init__(self, case: Case, channels: Sequence[OutputChannel] | None = None, *,
                 dt: float | None = None) -> None:
        self.choices: dict[float, IntegratorChoice] = {}
        self._chooses = False
        if channels is None:
            channels = case.data.outputs if case.data is not None else []
        self._label = case.label
        self.reduced: ReducedPath | None = None
        self.groups: tuple[str, ...] = ()  # an external model takes one table record
        #: The directions of a base motion with several components (``[[data.components]]``
        #: or an input's ``angle``), the columns of its input; empty: one record.
        self.components: tuple[str, ...] = ()
        self._component_loads: np.ndarray | None = None  # when the mass is constant
        self.reference = np.zeros((len(channels), 0))
        self.external = external_model(case, channels)
        if self.external is not None:
            self.structure = None
            self.influence = np.asarray(self.external.influence, dtype=float)
            self.outputs = np.arange(len(channels), dtype=np.int64)
            return
        self.structure = build_structure(case.model)
        self.components = case.data.base_directions if case.data is not None else ()
        self.direction = (self.components[0] if self.components
                          else case.model.excitation_direction)
        model = case.model
        self.groups = tuple(g.name for g in model.support_groups)
        #: The support DOFs (node, dof) the groups move, and each group's labels of them.
        self._supports = [(node, model.group_dof(g)) for g in model.support_groups
                          for node in g.nodes]
        self._group_labels = [[f"{node}.{model.group_dof(g)}" for node in g.nodes]
                              for g in model.support_groups]
        self.reference = np.array(
            [[float(c.relative_to == g.name and c.dof == model.group_dof(g))
              for g in model.support_groups] for c in channels]).reshape(len(channels),
                                                                         len(self.groups))
        self.method = case.simulation_method
        self.substeps = 1 if self.method in ("exact", "reduced") else case.preprocess.substeps
        #: A nonlinear model without [simulation] method: its integrator is chosen at the
        #: nominal point (choose_integrator), per sample interval.
        self._chooses = self.method == "nonlinear" and case.simulation.method is None
        #: HHT α of the implicit scheme ([simulation] hht_alpha; 0: average acceleration).
        self.hht_alpha = case.simulation.hht_alpha or 0.0
        self._nominal = case.nominal()
        #: The reduced path's settings and warm start (None on the other paths).
        self.reduced = (ReducedPath(case, self.structure, self.direction)
                        if self.method == "reduced" else None)
        self.outputs = np.array([self.structure.dof_index(c.node, c.dof) for c in channels],
                                dtype=np.int64)
        self.influence = self.structure.influence_vector(self.direction)[self.outputs]
        #: (n_outputs, k): each component's rigid translation at the outputs.
        self.component_influence = np.column_stack(
            [self.structure.influence_vector(d)[self.outputs] for d in self.components]
        ) if self.components else np.zeros((self.outputs.size, 0))
        if self.groups:
            self.influence = np.zeros_like(self.influence)
        else:  # multi-support cases move their supports, group by group
            for direction in self.components or (self.direction,):
                check_base_motion_moves_mass(self.structure, case, direction)
        from femupdate.case.model3d import check_not_mechanism

        check_not_mechanism(self.structure, {p.name: p.nominal_value for p in
                                             case.parameters}, self.direction, case.label)
        if dt is not None:
            self.method = self.method_for(dt)

    def method_for(self, dt: float) -> str:
        """The integrator at sample interval ``dt``: the case's, or for a nonlinear model
        without ``[simulation] method`` the one chosen at the nominal point (once per ``dt``,
        then held: :attr:`choices`)."""
        if not self._chooses:
            return self.method
        key = float(dt)
        choice = self.choices.get(key)
        if choice is None:
            from femupdate.errors import FemupdateError

            try:
                system, why = self.system(self._nominal), None
            except (FemupdateError, np.linalg.LinAlgError) as exc:
                system, why = None, str(exc)
            choice = self.choices[key] = choose_integrator(system, key, self.substeps, why)
        return choice.method

    def with_substeps(self, substeps: int) -> CaseModel:
        """This model with ``substeps`` integration steps per sample and the same integrator
        (a step-halving check: :func:`femupdate.problem.reduced_path.step_halving`)."""
        if self.reduced is not None or self.structure is None or self.method == "exact":
            raise ConfigError(f"{self._label}: substeps: the {self.method} path takes none "
                              "(allowed: a time-stepping integrator)")
        other = copy.copy(self)
        other.substeps = int(substeps)
        other.choices = dict(self.choices)  # the integrators chosen stay: only the step changes
        return other

    def _builtin(self, what: str) -> Structure:
        if self.structure is None:
            raise ConfigError(f"{self._label}: {what} needs femupdate's own model; this case's "
                              "model is external ([model.python] or [model.opensees])")
        return self.structure

    def system(self, values: Mapping[str, float]) -> System:
        """The assembled equations of motion at physical parameter ``values``."""
        return self._builtin("the assembled system").assemble(values, direction=self.direction)

    def simulator(self, values: Mapping[str, float], dt: float) -> Simulator:
        """The case's integrator prepared for the system at ``values`` and sample interval
        ``dt``, with the output DOFs."""
        from femupdate.simulate import prepare

        self._builtin("simulating the model")
        if self.outputs.size == 0:
            raise ConfigError(f"{self._label}: the case has no [data] outputs: nothing to "
                              "simulate at")
        if self.reduced is not None:  # sparse, on the lowest modes
            return self.reduced.simulator(values, dt, self.outputs)
        method = self.method_for(dt)
        return prepare(self.system(values), dt, method=method, outputs=self.outputs,
                       substeps=self.substeps,
                       hht_alpha=self.hht_alpha if method == "implicit" else 0.0)

    def simulate(self, values: Mapping[str, float], ag: np.ndarray, dt: float) -> Response:
        """Response at the output DOFs to the base acceleration ``ag`` sampled every ``dt``.

        With support groups ``ag`` holds a column per group (in ``groups`` order) and the
        response is the total one: absolute displacement, velocity and acceleration
        (:meth:`support_response`).
        """
        if self.groups:
            return self.support_response(values, ag, dt)
        if self.components:
            return self.components_response(values, ag, dt)
        return self.simulator(values, dt).run(ag)

    def components_response(self, values: Mapping[str, float], ag: np.ndarray,
                            dt: float) -> Response:
        """Response at the output DOFs to a uniform base motion with several components,
        ``ag`` (n_samples, k) a column per direction of ``components``
        (:mod:`femupdate.simulate.components`): relative displacement and velocity, absolute
        acceleration, on the case's integrator."""
        from femupdate.simulate.components import components_response

        return components_response(self.simulator(values, dt), ag,
                                   self.component_loads(values), self.component_influence)

    def component_loads(self, values: Mapping[str, float]) -> np.ndarray:
        """``p_c`` of each direction of ``components`` (n_dof, k), the base motion's loads at
        ``values``; assembled once when no parameter changes the mass (they depend on M
        alone), else at every call."""
        structure = self._builtin("a base motion with several components")
        if self._component_loads is not None:
            return self._component_loads
        sparse = self.reduced is not None
        loads = np.column_stack([np.asarray(structure.assemble(
            values, direction=d, sparse=sparse).seismic_load, dtype=float)
            for d in self.components])
        if structure.mass_is_constant:
            loads.setflags(write=False)
            self._component_loads = loads
        return loads

    def base_share(self, ag: np.ndarray) -> np.ndarray:
        """The base motion's share of each output's absolute acceleration as recorded,
        (n_samples, n_outputs): ``r a_g`` at the outputs for one record, ``Σ_c r_c a_c`` for
        several components, a support group's motion for ``relative_to`` channels."""
        if self.groups:
            return np.asarray(self.recorded_share(ag))
        if self.components:
            return np.asarray(ag, dtype=float) @ self.component_influence.T
        return np.outer(ag, self.influence)

    def recorded_share(self, ag: np.ndarray, dt: float | None = None) -> np.ndarray | float:
        """What the support groups' accelerations ``ag`` (n_samples, n_groups) add to each
        output channel as recorded (``relative_to``: the group's motion, else 0), (n, k); with
        ``dt``, of the displacements integrated from them. 0.0 without support groups."""
        if not self.groups:
            return 0.0
        if dt is not None:
            from femupdate.simulate.multisupport import integrate_record

            ag = integrate_record(np.asarray(ag, dtype=float), dt)[1]
        return np.asarray(ag, dtype=float) @ self.reference.T

    def support_response(self, values: Mapping[str, float], acceleration: np.ndarray,
                         dt: float) -> Response:
        """Absolute response at the output DOFs to the support groups' accelerations
        ``acceleration`` (n_samples, n_groups), by the pseudo-static split of
        :mod:`femupdate.simulate.multisupport`.

        The supports' velocities and displacements are integrated from their accelerations
        (linear between samples; by Newmark's average-acceleration relations for
        ``method = "newmark"``, so that the scheme sees support motions of its own family).
        """
        from femupdate.simulate.multisupport import (
            SupportCoupling,
            integrate_record,
            multi_support_response,
        )

        structure = self._builtin("multi-support excitation")
        if self.outputs.size == 0:
            raise ConfigError(f"{self._label}: the case has no [data] outputs: nothing to "
                              "simulate at")
        acc = np.asarray(acceleration, dtype=float)
        if acc.ndim != 2 or acc.shape[1] != len(self.groups):
            raise DataError(f"{self._label}: support accelerations of shape {acc.shape}; "
                            f"expected (n_samples, {len(self.groups)}), a column per support "
                            f"group ({', '.join(self.groups)})")
        system = self.system(values)
        k_fs, m_fs, c_fs = structure.support_coupling(values, self._supports)
        coupling = SupportCoupling(system, tuple(f"{n}.{d}" for n, d in self._supports),
                                   k_fs, m_fs, c_fs)
        velocity, displacement = integrate_record(
            acc, dt, "newmark" if self.method == "newmark" else "exact")
        resp = multi_support_response(coupling, self._group_labels, acc, dt, method=self.method,
                                      substeps=self.substeps, velocity=velocity,
                                      displacement=displacement, outputs=self.outputs)
        return Response(resp.t, resp.total, resp.total_velocity, resp.acceleration,
                        diverged=resp.diverged)


def external_model(case: Case, channels: Sequence[OutputChannel]) -> ExternalModel | None:
    """The adapter of the case's ``[model.python]`` or ``[model.opensees]`` (None: femupdate's
    own model). Relative paths start from the case file's folder."""
    section = case.model.external
    if section is None:
        return None
    from femupdate.external.opensees_model import OpenSeesModel
    from femupdate.external.python_model import PythonModel

    base = case.source.parent if case.source is not None else None
    labels = [c.label for c in channels]
    if case.model.python is not None:
        py = case.model.python
        return PythonModel(py.function, labels, quantity=py.quantity, frequencies=py.frequencies,
                           influence=py.influence, base_dir=base, field="model.python")
    ops = case.model.opensees
    assert ops is not None
    return OpenSeesModel(ops.build, ops.outputs, quantity=ops.quantity, direction=ops.direction,
                         excitation=ops.excitation, substeps=case.preprocess.substeps,
                         algorithm=ops.algorithm, tolerance=ops.tolerance,
                         max_iterations=ops.max_iterations, system=ops.system,
                         constraints=ops.constraints, n_modes=ops.n_modes,
                         eigen_solver=ops.eigen_solver, check_base_load=ops.check_base_load,
                         base_dir=base, field="model.opensees")

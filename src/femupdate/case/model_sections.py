"""The ``[model]`` sections of a case file: nodes, beams, springs, dampers, friction elements,
Bouc–Wen elements, masses, supports, Rayleigh damping, or a shear building (with friction and
Bouc–Wen elements per storey). Any number may name a parameter.
"""

from __future__ import annotations

import typing
from typing import Annotated, Literal

from pydantic import Field, PlainValidator, WithJsonSchema, model_validator
from pydantic_core import PydanticCustomError

from femupdate.case.checks import model_issues
from femupdate.case.fields import (
    DOF_NAMES,
    Area,
    BoucWenA,
    BoucWenDegradation,
    BoucWenExponent,
    BoucWenGamma,
    BoucWenShape,
    Coordinate,
    DampingCoefficient,
    Density,
    DofName,
    ElementName,
    InitialStiffness,
    MassPerLength,
    Modulus,
    NodalMass,
    NodeName,
    Poisson,
    PositiveModulus,
    RayleighAlpha,
    RayleighBeta,
    RotaryInertia,
    SecondMoment,
    Section,
    ShearFactor,
    SlipForce,
    Stiffness,
    StiffnessRatio,
    find_range,
    format_value,
    integer_field,
    number_field,
    text_field,
)
from femupdate.case.issues import Issue, raise_issues
from femupdate.case.model3d import Vector3

# ----------------------------------------------------------------------------- [model]


class Node(Section):
    """``[[model.nodes]]``: a node in the plane of the model (in space, with ``z`` vertical,
    for ``dofs_per_node = 6``)."""

    name: NodeName
    x: Coordinate
    y: Coordinate = 0.0
    z: Coordinate = 0.0


class Beam(Section):
    """``[[model.beams]]``: a Timoshenko beam between two nodes (bending and shear;
    ``shear_deformation = false``: Euler–Bernoulli); ``I`` for planar models, ``Iy``, ``Iz``,
    ``J`` and ``vecxz`` for 3-D frames (``model3d``)."""

    nodes: Annotated[list[NodeName], Field(min_length=2, max_length=2)]
    E: Modulus
    G: PositiveModulus | None = None
    nu: Poisson | None = None
    A: Area
    I: SecondMoment | None = None  # noqa: E741 (the usual symbol of the second moment of area)
    Iy: SecondMoment | None = None
    Iz: SecondMoment | None = None
    J: SecondMoment | None = None
    vecxz: Vector3 | None = None
    rho: Density = 0.0
    kappa: ShearFactor = 5.0 / 6.0
    mass_per_length: MassPerLength = 0.0
    rotary_inertia: bool = True
    torsional_inertia: bool | None = None
    shear_deformation: bool = True
    name: ElementName | None = None

    @model_validator(mode="after")
    def _check(self) -> Beam:
        issues: list[Issue] = []
        if self.nodes[0] == self.nodes[1]:
            issues.append(("nodes", f"both ends are node {self.nodes[0]!r}",
                           "two different nodes"))
        if self.G is not None and self.nu is not None:
            issues.append(("nu", f"both G = {format_value(self.G)} and nu = "
                           f"{format_value(self.nu)} are given",
                           "G or nu, not both (neither: no shear deformation)"))
        raise_issues(issues)
        return self


class _Link(Section):
    """An element at one DOF, to the base (ground), or between two DOFs."""

    node: NodeName
    dof: DofName
    node2: NodeName | None = None
    dof2: DofName | None = None
    name: ElementName | None = None

    @model_validator(mode="after")
    def _check(self) -> _Link:
        if self.dof2 is not None and self.node2 is None:
            raise_issues([("dof2", f"dof2 = {self.dof2!r} without node2",
                            "node2 with dof2 (between two DOFs), or neither (to the base)")])
        if self.node2 == self.node and self.second_dof == self.dof:
            raise_issues([("node2", f"connects {self.node}.{self.dof} to itself",
                            "two different DOFs, or no node2 (to the base)")])
        return self

    @property
    def second_dof(self) -> str | None:
        """The DOF at ``node2`` (``dof2``, default the same as ``dof``), None to the base."""
        if self.node2 is None:
            return None
        return self.dof2 if self.dof2 is not None else self.dof


class Spring(_Link):
    """``[[model.springs]]``: a linear spring."""

    k: Stiffness


class Damper(_Link):
    """``[[model.dampers]]``: a linear viscous damper."""

    c: DampingCoefficient


class Friction(_Link):
    """``[[model.frictions]]``: an elasto-slip (Jenkins) damper: spring k_r, slider f_u."""

    k_r: Stiffness
    f_u: SlipForce


def _gamma_issue(beta: float | str, gamma: float | str, where: str = "gamma") -> list[Issue]:
    """(β, γ) must satisfy −β < γ ≤ β when both are numbers (parameters: at assembly)."""
    if isinstance(beta, str) or isinstance(gamma, str) or -beta < gamma <= beta:
        return []
    return [(where, f"gamma = {format_value(gamma)} with beta = {format_value(beta)} gives no "
             "bounded hysteresis loop", f"-beta < gamma <= beta, i.e. in "
             f"({format_value(-beta)}, {format_value(beta)}]")]


def _ultimate_issue(A: float | str, beta: float | str, gamma: float | str, n: float | str,
                    where: str = "n") -> list[Issue]:
    """z_u = (A/(β+γ))^(1/n) within its range when all four are numbers and (β, γ) valid
    (parameters: at assembly)."""
    values = (A, beta, gamma, n)
    if any(isinstance(v, str) for v in values) or _gamma_issue(beta, gamma):
        return []
    from femupdate.model.hysteresis import ultimate_deformation_issue  # numba: when needed

    issue = ultimate_deformation_issue(*(float(v) for v in values))  # type: ignore[arg-type]
    return [] if issue is None else [(where, *issue)]


class BoucWen(_Link):
    """``[[model.bouc_wen]]``: a Bouc–Wen hysteretic element, force α k y + (1 − α) k z with
    ż = (A(e) ẏ − ν(e) (β |ẏ| |z|^(n−1) z + γ ẏ |z|^n)) / η(e), A(e) = A − δ_A e,
    ν(e) = 1 + δ_ν e, η(e) = 1 + δ_η e, e = ∫ (1 − α) k z dy (Baber–Wen degradation; the
    rates default to 0: none)."""

    k: InitialStiffness
    alpha: StiffnessRatio = 0.0
    A: BoucWenA = 1.0
    beta: BoucWenShape
    gamma: BoucWenGamma
    n: BoucWenExponent = 1.0
    delta_a: BoucWenDegradation = 0.0
    delta_nu: BoucWenDegradation = 0.0
    delta_eta: BoucWenDegradation = 0.0

    @model_validator(mode="after")
    def _check_shape(self) -> BoucWen:
        raise_issues(_gamma_issue(self.beta, self.gamma)
                     or _ultimate_issue(self.A, self.beta, self.gamma, self.n))
        return self


class Mass(Section):
    """``[[model.masses]]``: a lumped mass on the node's translations and a rotary inertia
    ``J`` (on ``rz``; on each of ``rx``, ``ry``, ``rz`` of a 3-D frame); ``dofs`` names the
    DOFs that carry them (default all: ``["ux", "uy"]`` for a building's floor mass)."""

    node: NodeName
    m: NodalMass
    J: RotaryInertia = 0.0
    dofs: Annotated[list[DofName], Field(min_length=1, max_length=6)] | None = None

    @model_validator(mode="after")
    def _check_dofs(self) -> Mass:
        if self.dofs is not None:
            raise_issues(mass_dofs_issues(self.m, self.J, self.dofs))
        return self


def mass_dofs_issues(m: float | str, J: float | str, dofs: list[str]) -> list[Issue]:
    """A mass's ``dofs`` must carry what it gives: ``m`` (non-zero) a translation, ``J`` a
    rotation, each DOF once. (``{m = 400, dofs = ["rx"]}`` dropped its 400 kg unsaid.)"""
    repeated = sorted({d for d in dofs if dofs.count(d) > 1})
    if repeated:
        return [("dofs", f"names {', '.join(repeated)} more than once", "each DOF once")]
    issues: list[Issue] = []
    for value, what, kind, letter in ((m, "m", "translation", "u"), (J, "J", "rotation", "r")):
        if value != 0.0 and not any(d.startswith(letter) for d in dofs):
            issues.append(("dofs", f"{dofs} names no {kind}, so {what} = {value!r} would act on "
                           "nothing", f"dofs with at least one {kind} "
                           f"({'ux, uy, uz' if letter == 'u' else 'rx, ry, rz'}) for {what}, "
                           f"or {what} = 0"))
    return issues


class Diaphragm(Section):
    """``[[model.diaphragms]]`` (3-D frames): a floor rigid in its horizontal plane, its
    ``nodes`` following ``master`` in ux, uy and rz."""

    master: NodeName
    nodes: Annotated[list[NodeName], Field(min_length=1, max_length=100_000)]


class Support(Section):
    """``[[model.supports]]``: DOFs fixed to the base (they move with the table)."""

    node: NodeName
    dofs: Annotated[list[DofName], Field(min_length=1, max_length=6)]

    @model_validator(mode="after")
    def _check(self) -> Support:
        raise_issues([(f"dofs[{i}]", f"{dof!r} is listed twice", "each DOF once")
                       for i, dof in enumerate(self.dofs) if dof in self.dofs[:i]])
        return self


class SupportGroup(Section):
    """``[[model.support_groups]]``: supports that follow a record of their own (multi-support
    excitation): the translation along ``direction`` (default the model's) of each of
    ``nodes``, fixed by ``[[model.supports]]``, moves with the acceleration read from the
    group's input channel ``[data.inputs.<name>]``. Fixed DOFs in no group stay still."""

    name: ElementName
    nodes: Annotated[list[NodeName], Field(max_length=100_000)]
    direction: Literal["x", "y", "z"] | None = None


class Rayleigh(Section):
    """``[model.rayleigh]``: damping ``C += alpha M + beta K₀``, ``K₀`` with the Bouc–Wen
    elements' initial stiffness unless ``bouc_wen = false``; friction sliders are never in it
    (their stuck stiffness is the stick-slip model's penalty, not a structural stiffness)."""

    alpha: RayleighAlpha = 0.0
    beta: RayleighBeta = 0.0
    bouc_wen: bool = True


def _per_storey(value: typing.Any) -> typing.Any:
    """A list of values, one per storey, or one value for every storey (``value``'s range)."""
    rng = find_range(value)
    assert rng is not None

    def check(given: typing.Any) -> typing.Any:
        if not isinstance(given, list):
            return rng(given)
        if not 1 <= len(given) <= 1000:
            raise PydanticCustomError("storey_count", "got {got} values",
                                      {"got": len(given), "allowed": "1 to 1000 values, one "
                                       "per storey, or one value for every storey"})
        out = []
        for i, item in enumerate(given):
            try:
                out.append(rng(item))
            except PydanticCustomError as exc:
                raise PydanticCustomError(exc.type, f"storey {i + 1}: " + exc.message_template,
                                          exc.context) from None
        return out

    schema = rng.json_schema()
    return Annotated[list[value] | value, PlainValidator(check),
                     WithJsonSchema({"anyOf": [{"type": "array", "items": schema}, schema]}),
                     rng]


class StoreyFrictions(Section):
    """``[model.shear_building.frictions]``: an elasto-slip element in every storey."""

    k_r: _per_storey(Stiffness)
    f_u: _per_storey(SlipForce)


class StoreyBoucWen(Section):
    """``[model.shear_building.bouc_wen]``: a Bouc–Wen element in every storey."""

    k: _per_storey(InitialStiffness)
    alpha: _per_storey(StiffnessRatio) = 0.0
    A: _per_storey(BoucWenA) = 1.0
    beta: _per_storey(BoucWenShape)
    gamma: _per_storey(BoucWenGamma)
    n: _per_storey(BoucWenExponent) = 1.0
    delta_a: _per_storey(BoucWenDegradation) = 0.0
    delta_nu: _per_storey(BoucWenDegradation) = 0.0
    delta_eta: _per_storey(BoucWenDegradation) = 0.0


def storey_values(section: Section, n: int) -> list[dict[str, float | str]]:
    """The fields of a per-storey section as one dict per storey (single values repeated)."""
    return [{key: (value[i] if isinstance(value, list) else value)
             for key, value in section} for i in range(n)]


class ShearBuilding(Section):
    """``[model.shear_building]``: storeys on a shake table, storey 1 at the bottom; viscous
    dampers, friction and Bouc–Wen elements per storey."""

    masses: Annotated[list[NodalMass], Field(min_length=1, max_length=1000)]
    stiffnesses: Annotated[list[Stiffness], Field(min_length=1, max_length=1000)]
    dampers: Annotated[list[DampingCoefficient], Field(min_length=1, max_length=1000)] | None = None
    frictions: StoreyFrictions | None = None
    bouc_wen: StoreyBoucWen | None = None

    @model_validator(mode="after")
    def _check(self) -> ShearBuilding:
        n = len(self.masses)
        issues = [(key, f"has {len(values)} values but masses has {n}",
                   f"{n} values, one per storey")
                  for key, values in (("stiffnesses", self.stiffnesses),
                                      ("dampers", self.dampers or self.masses))
                  if len(values) != n]
        for name in ("frictions", "bouc_wen"):
            section = getattr(self, name)
            for key, values in section or ():
                if isinstance(values, list) and len(values) != n:
                    issues.append((f"{name}.{key}", f"has {len(values)} values but masses has "
                                   f"{n}", f"{n} values, one per storey, or one value for "
                                   "every storey"))
        bw = self.bouc_wen
        if bw is not None and not issues:
            storeys = storey_values(bw, n)
            if any(isinstance(getattr(bw, key), list) for key in ("A", "beta", "gamma", "n")):
                for i, storey in enumerate(storeys):
                    issues += _gamma_issue(storey["beta"], storey["gamma"],
                                           f"bouc_wen.gamma (storey {i + 1})")
                    issues += _ultimate_issue(storey["A"], storey["beta"], storey["gamma"],
                                              storey["n"], f"bouc_wen.n (storey {i + 1})")
            else:
                issues += _gamma_issue(bw.beta, bw.gamma, "bouc_wen.gamma")
                issues += _ultimate_issue(bw.A, bw.beta, bw.gamma, bw.n, "bouc_wen.n")
        raise_issues(issues)
        return self

    @property
    def floors(self) -> tuple[str, ...]:
        """Node names of the floors: ``"F1"`` (above storey 1) to ``"Fn"`` (the roof)."""
        return tuple(f"F{i + 1}" for i in range(len(self.masses)))



CodeReference = text_field(4096, 1)
Timeout = number_field("s", gt=0.0, le=1e6)


class PythonModelSection(Section):
    """``[model.python]``: the user's Python function as the model.

    ``function(values, ag, dt)`` returns the predicted channels, one column per
    ``[[data.outputs]]`` in order: absolute accelerations (m/s²) or displacements relative to
    the base (m), by ``quantity``.
    """

    function: CodeReference
    frequencies: CodeReference | None = None
    quantity: Literal["acceleration", "displacement"] = "acceleration"
    influence: Annotated[list[number_field(ge=-1e3, le=1e3)],
                         Field(min_length=1, max_length=10_000)] | None = None
    timeout: Timeout | None = None
    isolate: bool = True


class OpenSeesSection(Section):
    """``[model.opensees]``: an OpenSeesPy model built by the user's code, analysed by
    femupdate under the measured base motion."""

    build: CodeReference
    outputs: Annotated[list[Annotated[list[integer_field(ge=1, le=10**9)],
                                      Field(min_length=2, max_length=2)]],
                       Field(min_length=1, max_length=10_000)]
    quantity: Literal["acceleration", "displacement"] = "acceleration"
    direction: integer_field(ge=1, le=6) = 1
    excitation: Literal["uniform", "nodal"] = "uniform"
    algorithm: Literal["newton", "linear"] = "newton"
    tolerance: number_field(gt=0.0, lt=1.0) = 1e-10
    max_iterations: integer_field(ge=1, le=10_000) = 25
    system: text_field(64, 1) = "BandGeneral"
    constraints: text_field(64, 1) = "Plain"
    n_modes: integer_field(ge=1, le=10_000) = 6
    eigen_solver: Literal["-genBandArpack", "-fullGenLapack", "-symmBandLapack"] = (
        "-genBandArpack")
    check_base_load: bool = True
    timeout: Timeout | None = None
    isolate: bool = True


class Model(Section):
    """``[model]``: the finite element model, or an external one (``[model.python]``,
    ``[model.opensees]``)."""

    dofs_per_node: Literal[2, 3, 6] = 2
    direction: Literal["x", "y"] | None = None
    rayleigh: Rayleigh | None = None
    nodes: list[Node] = Field(default_factory=list)
    beams: list[Beam] = Field(default_factory=list)
    springs: list[Spring] = Field(default_factory=list)
    dampers: list[Damper] = Field(default_factory=list)
    frictions: list[Friction] = Field(default_factory=list)
    bouc_wen: list[BoucWen] = Field(default_factory=list)
    masses: list[Mass] = Field(default_factory=list)
    supports: list[Support] = Field(default_factory=list)
    diaphragms: list[Diaphragm] = Field(default_factory=list)
    support_groups: list[SupportGroup] = Field(default_factory=list)
    shear_building: ShearBuilding | None = None
    python: PythonModelSection | None = None
    opensees: OpenSeesSection | None = None

    @model_validator(mode="after")
    def _check(self) -> Model:
        raise_issues(model_issues(self))
        return self

    @property
    def external(self) -> PythonModelSection | OpenSeesSection | None:
        """The external model's section, or None for femupdate's own."""
        return self.python or self.opensees

    @property
    def has_friction(self) -> bool:
        return bool(self.frictions) or (self.shear_building is not None
                                        and self.shear_building.frictions is not None)

    @property
    def has_bouc_wen(self) -> bool:
        """Bouc–Wen elements, given one by one or per storey."""
        return bool(self.bouc_wen) or (self.shear_building is not None
                                       and self.shear_building.bouc_wen is not None)

    @property
    def has_nonlinear(self) -> bool:
        """Friction or Bouc–Wen elements (the model needs the nonlinear integrator)."""
        return self.has_friction or bool(self.bouc_wen) or (
            self.shear_building is not None and self.shear_building.bouc_wen is not None)

    @property
    def excitation_direction(self) -> str:
        """Direction of the base motion: ``direction``, or "x" for a shear building, a plane
        frame and a 3-D frame, "y" (transverse) for a 2-DOF/node model."""
        if self.direction is not None:
            return self.direction
        return "y" if self.shear_building is None and self.dofs_per_node == 2 else "x"

    def group_dof(self, group: SupportGroup) -> str:
        """The DOF a support group moves: ``"u" + direction`` (default the model's)."""
        return "u" + (group.direction or self.excitation_direction)

    def dof_names(self) -> tuple[str, ...]:
        """DOF names of a node of this model (a shear building's floors: ``("ux",)``)."""
        return ("ux",) if self.shear_building is not None else DOF_NAMES[self.dofs_per_node]

    def node_names(self) -> tuple[str, ...]:
        if self.external is not None:
            return ()
        if self.shear_building is not None:
            return self.shear_building.floors
        return tuple(node.name for node in self.nodes)

    def fixed_dofs(self) -> dict[tuple[str, str], str]:
        """``(node, dof) -> path of the support`` for every fixed DOF."""
        return {(s.node, dof): f"model.supports[{i}]"
                for i, s in reversed(list(enumerate(self.supports))) for dof in s.dofs}

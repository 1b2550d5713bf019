"""A structure of nodes and elements, assembled into a ``System`` for given parameters.

The structure is described once (nodes, beams, springs, dampers, friction and Bouc–Wen
elements, masses, supports, rigid diaphragms); any numeric property may be a number or the name
of a parameter. The topology (DOF map, scatter indices) is built once, lazily, and ``assemble``
then only evaluates the element matrices of all elements of a kind together and scatters them
with precomputed flat indices, which keeps re-assembly for new parameter values cheap (it runs
once per evaluation of the objective in model updating).

The class holds the description and orchestrates; the work is done by pure functions, one
module per job:

- :mod:`~femupdate.model.properties`: numbers or parameter names, their ranges, their values;
- :mod:`~femupdate.model.description`: the checks of a beam's geometry and a mass's DOFs;
- :mod:`~femupdate.model.topology`: DOF numbering and the scatter plan (``_build``'s steps);
- :mod:`~femupdate.model.matrices`: ``M``, ``K`` and ``C`` (dampers, Rayleigh), diaphragms;
- :mod:`~femupdate.model.nonlinear_elements`: the friction and Bouc–Wen elements;
- :mod:`~femupdate.model.excitation`: influence vector, seismic load, support coupling.

Why this file is long (about 750 lines): what is left is the class's public surface. The
description methods (``add_*``, ``fix``, ``set_rayleigh``, with their parameter documentation
and the checks that name the element in the message) are two thirds of it; each is a few lines
over the helpers above, and splitting them from the class would only move its documentation.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike

from femupdate.errors import ModelError
from femupdate.model.description import beam_options, check_mass_dofs
from femupdate.model.diaphragm import diaphragm_constraint
from femupdate.model.elements import check_value
from femupdate.model.excitation import coupling_blocks, rigid_translation, seismic_vector
from femupdate.model.hysteresis import BOUC_WEN_PARAMETERS, check_bouc_wen_parameters
from femupdate.model.matrices import bouc_wen_rayleigh, constrained_system, structure_matrices
from femupdate.model.nonlinear_elements import bouc_wen_elements, friction_elements
from femupdate.model.properties import (
    BEAM_SPECS,
    BOUC_WEN_SPECS,
    NONNEG,
    Prop,
    Record,
    Spec,
    Value,
    check_property,
    parameter_names,
    parameter_vector,
    property_over,
)
from femupdate.model.system import System
from femupdate.model.topology import (
    Topology,
    beam_plan,
    link_dofs,
    lumped_mass_plan,
    mass_is_constant,
    number_dofs,
    odd_link_dofs,
    records_by_kind,
    scatter_plan,
)

__all__ = ["DOF_NAMES", "Structure", "Value", "shear_building"]

#: DOF names of a node for each ``dofs_per_node``.
DOF_NAMES: dict[int, tuple[str, ...]] = {1: ("ux",), 2: ("uy", "rz"), 3: ("ux", "uy", "rz"),
                                         6: ("ux", "uy", "uz", "rx", "ry", "rz")}

_INF = math.inf

class Structure:
    """A planar structure of nodes and elements.

    Parameters
    ----------
    dofs_per_node : {1, 2, 3}
        1: ``(ux,)`` (springs, dampers and masses only, e.g. shear buildings);
        2: ``(uy, rz)``, beams along the x axis bending in the plane (the paper's bridge deck);
        3: ``(ux, uy, rz)``, plane frames;
        6: ``(ux, uy, uz, rx, ry, rz)``, 3-D frames (docs/frames-3d.md).

    Examples
    --------
    >>> s = Structure(dofs_per_node=2)
    >>> s.add_node("A", x=0.0); s.add_node("B", x=2.0)
    >>> s.add_beam("A", "B", E="E", A=1e-3, I=1e-6, rho=7850.0)
    'beam1'
    >>> s.fix("A")
    >>> system = s.assemble({"E": 2.1e11})
    """

    def __init__(self, dofs_per_node: int = 2) -> None:
        if dofs_per_node not in DOF_NAMES:
            raise ModelError(f"dofs_per_node = {dofs_per_node!r}; allowed 1, 2, 3 or 6")
        self.dofs_per_node: int = dofs_per_node
        self._node_index: dict[str, int] = {}
        self._xy: list[tuple[float, float]] = []
        self._z: list[float] = []  # heights, 3-D frames (dofs_per_node=6) only
        self._records: list[Record] = []
        self._element_names: set[str] = set()
        self._fixed: set[int] = set()
        self._followers: dict[int, int] = {}  # node → master node of its rigid diaphragm
        self._topology: Topology | None = None
        self._parameters: tuple[str, ...] | None = None
        #: Maps a caller's named parameter values to the structure's own (its string
        #: properties: a case's derived fields, femupdate.case.expressions.FieldValues);
        #: None: the same names.
        self.derive: Callable[[Mapping[str, float]], Mapping[str, float]] | None = None
        # support_coupling's twins with supports released, for the topology they were made of
        self._released: dict[tuple[int, ...], tuple[Topology, Structure]] = {}

    # ------------------------------------------------------------------ description

    @property
    def dof_names(self) -> tuple[str, ...]:
        """Names of the DOFs of every node, e.g. ``("uy", "rz")``."""
        return DOF_NAMES[self.dofs_per_node]

    @property
    def nodes(self) -> tuple[str, ...]:
        """Node names in the order added."""
        return tuple(self._node_index)

    @property
    def parameters(self) -> tuple[str, ...]:
        """Parameter names used by the elements, in first-use order."""
        if self._parameters is None:
            self._parameters = parameter_names(self._records)
        return self._parameters

    def add_node(self, name: str, x: float, y: float = 0.0, z: float = 0.0) -> None:
        """Add a node at ``(x, y)`` (``(x, y, z)`` with ``dofs_per_node=6``)."""
        if not isinstance(name, str) or not name:
            raise ModelError(f"node name must be a non-empty string, got {name!r}")
        if name in self._node_index:
            raise ModelError(f"duplicate node {name!r}; node names must be unique")
        x = check_value(f"node {name!r}", "x", x, -_INF)
        y = check_value(f"node {name!r}", "y", y, -_INF)
        z = check_value(f"node {name!r}", "z", z, -_INF)
        if z != 0.0 and self.dofs_per_node != 6:
            raise ModelError(f"node {name!r}: z = {z!r} needs dofs_per_node=6 (3-D frames)")
        self._node_index[name] = len(self._xy)
        self._xy.append((x, y))
        self._z.append(z)
        self._topology = None

    def add_beam(
        self,
        node1: str,
        node2: str,
        *,
        E: Value,
        A: Value,
        I: Value | None = None,  # noqa: E741
        rho: Value = 0.0,
        G: Value | None = None,
        nu: Value | None = None,
        kappa: Value = 5 / 6,
        mass_per_length: Value = 0.0,
        rotary_inertia: bool = True,
        name: str | None = None,
        Iy: Value | None = None,
        Iz: Value | None = None,
        J: Value | None = None,
        vecxz: Sequence[float] | None = None,
        shear_deformation: bool = True,
        torsional_inertia: bool | None = None,
    ) -> str:
        """Add a Timoshenko beam (``dofs_per_node`` 2: along x; 3: any direction in the plane;
        6: a 3-D beam-column, :mod:`femupdate.model.elements3d`).

        With ``dofs_per_node=6`` give ``Iy``, ``Iz``, ``J`` and ``vecxz`` instead of ``I`` (the
        shear areas are both ``κA``, the torsional inertia ``ρJ``) and ``G`` or ``nu``.

        Parameters
        ----------
        node1, node2 : str
            End nodes.
        E : float or str
            Young's modulus (≥ 0).
        A, I : float or str
            Cross-section area and second moment of area (> 0).
        rho : float or str
            Density (≥ 0); translational ``ρA`` and, if ``rotary_inertia``, rotary ``ρI``.
        G, nu : float or str, optional
            Shear modulus (> 0) or Poisson's ratio (-1 < ν ≤ 0.5, ``G = E / 2(1 + ν)``), at most
            one; with neither, the beam is rigid in shear (Euler–Bernoulli).
        kappa : float or str
            Shear-area factor (> 0), default 5/6.
        mass_per_length : float or str
            Non-structural mass per unit length (≥ 0), e.g. added masses spread along a deck;
            translational inertia only.
        rotary_inertia : bool
            Include the rotary inertia ``ρI`` (3-D: ``ρIy``, ``ρIz`` of the bending rotations
            and, unless ``torsional_inertia`` says otherwise, ``ρJ`` of the twist).
        name : str, optional
            Element name (default ``"beam<k>"``).
        shear_deformation : bool
            ``False``: no shear deformation (Euler–Bernoulli bending) even with ``G`` or ``nu``
            given, which a 3-D beam needs for its torsional stiffness ``G J``.
        torsional_inertia : bool, optional
            3-D beams: include the torsional inertia ``ρJ`` (default: as ``rotary_inertia``);
            ``rotary_inertia=False, torsional_inertia=True`` drops the bending rotations'
            inertia only (OpenSees's ``elasticBeamColumn`` with ``-cMass``).

        Returns
        -------
        str
            The element name.
        """
        name = self._new_name(name, "beam")
        label = f"beam {name!r}"
        if self.dofs_per_node == 1:
            raise ModelError(f"{label}: beams need rotations; use dofs_per_node=2 or 3")
        n1, n2 = self._node(node1, label), self._node(node2, label)
        options, extra = beam_options(label, self.dofs_per_node, (node1, node2), self._xyz(n1),
                                      self._xyz(n2), I=I, Iy=Iy, Iz=Iz, J=J, vecxz=vecxz, G=G,
                                      nu=nu, rotary_inertia=rotary_inertia,
                                      shear_deformation=shear_deformation,
                                      torsional_inertia=torsional_inertia)
        raw: dict[str, Value] = {
            "E": E,
            "A": A,
            "I": 1.0 if I is None else I,
            "rho": rho,
            "kappa": kappa,
            "mass_per_length": mass_per_length,
        }
        if G is not None:
            raw["G"] = G
        if nu is not None:
            raw["nu"] = nu
        raw.update(extra)
        props = {k: check_property(v, label, k, BEAM_SPECS[k]) for k, v in raw.items()}
        self._add(Record("beam", name, props, nodes=(n1, n2), options=options))
        return name

    def add_spring(
        self,
        node: str,
        dof: str,
        k: Value,
        *,
        node2: str | None = None,
        dof2: str | None = None,
        name: str | None = None,
    ) -> str:
        """Add a linear spring (``k ≥ 0``) from ``node.dof`` to ground or to ``node2.dof2``.

        ``dof2`` defaults to ``dof``. A spring to a fixed DOF acts as a spring to ground.
        """
        return self._add_link("spring", node, dof, node2, dof2, name, {"k": k})

    def add_damper(
        self,
        node: str,
        dof: str,
        c: Value,
        *,
        node2: str | None = None,
        dof2: str | None = None,
        name: str | None = None,
    ) -> str:
        """Add a linear viscous damper (``c ≥ 0``), to ground or between two DOFs."""
        return self._add_link("damper", node, dof, node2, dof2, name, {"c": c})

    def add_friction(
        self,
        node: str,
        dof: str,
        k_r: Value,
        f_u: Value,
        *,
        node2: str | None = None,
        dof2: str | None = None,
        name: str | None = None,
    ) -> str:
        """Add an elasto-slip element: spring ``k_r ≥ 0`` in series with a slider ``f_u ≥ 0``."""
        return self._add_link("friction", node, dof, node2, dof2, name, {"k_r": k_r, "f_u": f_u})

    def add_bouc_wen(
        self,
        node: str,
        dof: str,
        k: Value,
        *,
        alpha: Value = 0.0,
        A: Value = 1.0,
        beta: Value,
        gamma: Value,
        n: Value = 1.0,
        delta_a: Value = 0.0,
        delta_nu: Value = 0.0,
        delta_eta: Value = 0.0,
        node2: str | None = None,
        dof2: str | None = None,
        name: str | None = None,
    ) -> str:
        """Add a Bouc–Wen hysteretic element (:mod:`femupdate.model.hysteresis`).

        Force ``α k y + (1 − α) k z`` with ``ż = A ẏ − β |ẏ| |z|^(n−1) z − γ ẏ |z|^n``, ``y``
        the deformation of ``node.dof`` (minus ``node2.dof2``, or to ground); with Baber and
        Wen's degradation ``ż = (A(e) ẏ − ν(e) (β |ẏ| |z|^(n−1) z + γ ẏ |z|^n)) / η(e)``,
        ``A(e) = A − δ_A e``, ``ν(e) = 1 + δ_ν e``, ``η(e) = 1 + δ_η e``, ``e = ∫ (1 − α) k z dy``.

        Parameters
        ----------
        k : float or str
            Initial stiffness (``> 0``; for ``A = 1``).
        alpha : float or str
            Post-yield to initial stiffness ratio, in ``[0, 1]``.
        A, beta, gamma, n : float or str
            ``A > 0``, ``β > 0``, ``−β < γ ≤ β`` (checked at assembly), ``n > 0``.
        delta_a, delta_nu, delta_eta : float or str
            Degradation rates ``≥ 0`` per unit of hysteretic energy (1/J); 0 (the default):
            none.
        """
        props = {"k": k, "alpha": alpha, "A": A, "beta": beta, "gamma": gamma, "n": n,
                 "delta_a": delta_a, "delta_nu": delta_nu, "delta_eta": delta_eta}
        values = [props[key] for key in BOUC_WEN_PARAMETERS]
        if all(isinstance(v, int | float) for v in values):  # constants: say now, not later
            check_bouc_wen_parameters(np.array([values], dtype=float),
                                      (name or f"bouc_wen at {node}.{dof}",))
        return self._add_link("bouc_wen", node, dof, node2, dof2, name, props,
                              specs=BOUC_WEN_SPECS)

    def add_mass(
        self, node: str, m: Value = 0.0, J: Value = 0.0, *, name: str | None = None,
        dofs: Sequence[str] | None = None,
    ) -> str:
        """Add a lumped mass ``m`` on every translation of ``node`` and rotary inertia ``J``.

        ``dofs`` (optional) names the DOFs that carry them, e.g. ``("ux", "uy", "rz")`` for a
        building's floor mass, which moves horizontally and twists about the vertical: ``m``
        on the translations among them, ``J`` on the rotations. A DOF without any mass has no
        mode of its own; the reduced path condenses it (:mod:`femupdate.model.sparse`).
        """
        name = self._new_name(name, "mass")
        label = f"mass {name!r}"
        n = self._node(node, label)
        if self.dofs_per_node == 1 and not (isinstance(J, int | float) and J == 0):
            raise ModelError(
                f"{label}: J = {J!r} needs a rotational DOF; this structure has ux only"
            )
        carried = tuple(range(self.dofs_per_node)) if dofs is None else tuple(
            self._dof(d, label) for d in dofs)
        if not carried:
            raise ModelError(f"{label}: dofs = []; name at least one of {self.dof_names}")
        if len(set(carried)) < len(carried):
            raise ModelError(f"{label}: dofs = {list(dofs or ())} names a DOF more than once")
        props = {"m": check_property(m, label, "m", NONNEG),
                 "J": check_property(J, label, "J", NONNEG)}
        check_mass_dofs(label, [self.dof_names[d] for d in carried], props, dofs is not None)
        self._add(Record("mass", name, props, nodes=(n,), options={"dofs": carried}))
        return name

    def add_diaphragm(self, master: str, nodes: Sequence[str]) -> None:
        """Make a floor rigid in its horizontal plane (3-D frames): ``nodes`` follow
        ``master`` in ux, uy and rz (:mod:`femupdate.model.diaphragm`).

        The nodes must lie at the master's height ``z``; a node belongs to one diaphragm.
        Their DOFs ux, uy, rz leave the model (``dof_index`` refuses them); loads, sensors and
        friction or Bouc–Wen elements go on the master.
        """
        label = f"diaphragm of {master!r}"
        if self.dofs_per_node != 6:
            raise ModelError(f"{label}: rigid diaphragms need a 3-D frame (dofs_per_node = 6); "
                             f"this structure has {self.dofs_per_node}")
        m = self._node(master, label)
        if m in self._followers:
            raise ModelError(f"{label}: {master!r} already follows another diaphragm's master")
        if not nodes:
            raise ModelError(f"{label}: nodes = []; name the floor's other nodes")
        for node in nodes:
            s = self._node(node, label)
            if s == m:
                raise ModelError(f"{label}: the master cannot be one of its own nodes")
            if s in self._followers or s in self._followers.values():
                raise ModelError(f"{label}: node {node!r} is already in a diaphragm")
            dz = self._z[s] - self._z[m]
            if abs(dz) > 1e-9 * max(1.0, abs(self._z[m])):
                raise ModelError(f"{label}: node {node!r} is at z = {self._z[s]!r}, not at the "
                                 f"master's z = {self._z[m]!r}")
        for node in nodes:
            self._followers[self._node_index[node]] = m
        self._topology = None

    def fix(self, node: str, *dofs: str) -> None:
        """Fix (support) the given DOFs of ``node``; all of them when none is given."""
        n = self._node(node, "fix")
        names = dofs or self.dof_names
        for d in names:
            self._fixed.add(n * self.dofs_per_node + self._dof(d, f"fix({node!r})"))
        self._topology = None

    def set_rayleigh(self, alpha: Value = 0.0, beta: Value = 0.0, *,
                     bouc_wen: bool = True) -> None:
        """Add (or replace) Rayleigh damping ``C += α M + β K₀``.

        ``K₀`` is ``K`` of the linear elements plus, with ``bouc_wen`` (the default, as
        OpenSees's ``rayleigh`` with ``betaKinit`` on links with ``-doRayleigh 1``), the
        Bouc–Wen elements' initial stiffness ``k (α + (1 − α) A)``
        (:mod:`femupdate.model.links`). Friction sliders are never in it: their stuck stiffness
        ``k_r`` is a penalty of the stick-slip model, not a structural stiffness.
        """
        props = {
            "alpha": check_property(alpha, "Rayleigh damping", "alpha", NONNEG),
            "beta": check_property(beta, "Rayleigh damping", "beta", NONNEG),
        }
        self._records = [r for r in self._records if r.kind != "rayleigh"]
        self._add(Record("rayleigh", "rayleigh", props, options={"bouc_wen": bool(bouc_wen)}))

    # ------------------------------------------------------------------ DOFs and loads

    @property
    def n_dof(self) -> int:
        """Number of free DOFs (those that follow a diaphragm's master left out)."""
        topo = self._topo()
        return topo.n if topo.diaphragms is None else topo.diaphragms.n

    @property
    def dof_labels(self) -> tuple[str, ...]:
        """Label of every free DOF, ``"node.dof"``."""
        topo = self._topo()
        return topo.labels if topo.diaphragms is None else topo.diaphragms.labels

    def dof_index(self, node: str, dof: str) -> int:
        """Index of ``node.dof`` among the free DOFs (``ModelError`` if unknown or fixed)."""
        g = self._node(node, "dof_index") * self.dofs_per_node + self._dof(dof, "dof_index")
        i = int(self._topo().free[g])
        if i < 0:
            raise ModelError(f"DOF {node}.{dof} is fixed; it has no free-DOF index")
        floors = self._topo().diaphragms
        if floors is not None:
            if floors.index[i] < 0:
                raise ModelError(
                    f"DOF {node}.{dof} follows the rigid diaphragm of {floors.followed[i]!r} "
                    "(ux, uy, rz of its nodes are the master's); use the master node's DOF")
            i = int(floors.index[i])
        return i

    def force_vector(self, node: str, dof: str) -> np.ndarray:
        """Unit load on ``node.dof``, as a vector over the free DOFs."""
        f = np.zeros(self.n_dof)
        f[self.dof_index(node, dof)] = 1.0
        return f

    def nonlinear_elements(self) -> list[str]:
        """The names of the friction and Bouc–Wen elements (none: the model is linear in its
        base motion)."""
        return [r.name for r in self._records if r.kind in ("friction", "bouc_wen")]

    def influence_vector(self, direction: str | None = None) -> np.ndarray:
        """Rigid-body displacement of the free DOFs for a unit base displacement.

        1 on the translations along ``direction`` (``"x"`` or ``"y"``), 0 elsewhere.
        """
        topo = self._topo()
        r = self._rigid(direction)[topo.free >= 0]
        return r if topo.diaphragms is None else r[topo.diaphragms.kept]

    # ------------------------------------------------------------------ assembly

    def assemble(
        self, values: Mapping[str, float] | ArrayLike | None = None, direction: str | None = None,
        *, sparse: bool = False,
    ) -> System:
        """Assemble the free-DOF matrices for the given parameter values.

        Parameters
        ----------
        values : mapping or array_like, optional
            ``{name: value}`` for every parameter in ``parameters`` (no others), or an array in
            the order of ``parameters``.
        direction : {"x", "y"}, optional
            Base-excitation direction for the influence vector ``r``; default the only
            translation for ``dofs_per_node`` 1 (``x``) and 2 (``y``), ``x`` for frames.

        sparse : bool
            Assemble ``M``, ``C``, ``K`` as ``scipy.sparse`` CSR matrices (large models, for
            :mod:`femupdate.simulate.reduced`); the dense integrators need the default.

        Returns
        -------
        System
            ``M`` is checked positive definite (``ModelError`` naming DOFs without inertia).
        """
        topo = self._topo()
        rigid = self._rigid(direction)
        r = rigid[topo.free >= 0]
        if isinstance(values, Mapping) and self.derive is not None:
            values = self.derive(values)
        p = parameter_vector(self.parameters, values)
        m, c, k, beam_m = structure_matrices(topo, p, self.dofs_per_node, sparse)
        friction = friction_elements(topo, p)
        bouc_wen = bouc_wen_elements(topo, p)
        link_damping = bouc_wen_rayleigh(topo, p, bouc_wen, sparse)  # β K₀ of the Bouc–Wen links
        if link_damping is not None:
            c = c + link_damping
        # consistent beam mass couples the moving supports to free DOFs
        seismic = seismic_vector(m, r, rigid, topo.beam_coupling, beam_m, topo.n)
        if topo.diaphragms is not None:
            return constrained_system(topo, m, c, k, r, friction, bouc_wen, seismic, sparse)
        return System(M=m, C=c, K=k, r=r, friction=friction, dof_labels=topo.labels,
                      seismic=seismic, bouc_wen=bouc_wen)

    def support_coupling(
        self, values: Mapping[str, float] | ArrayLike | None, supports: Sequence[tuple[str, str]],
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``K_fs``, ``M_fs``, ``C_fs``: how the motion of fixed DOFs loads the free DOFs.

        The blocks (n_free × n_supports, rows in ``dof_labels`` order, columns in the order of
        ``supports``) of the matrices of the same structure with those DOFs released, assembled
        at ``values``: what :mod:`femupdate.simulate.multisupport` needs to move supports with
        records of their own.

        Parameters
        ----------
        values : mapping or array_like
            As for :meth:`assemble`.
        supports : sequence of (node, dof)
            Fixed DOFs, e.g. ``[("A", "uy"), ("C", "uy")]``.
        """
        topo = self._topo()
        dpn = self.dofs_per_node
        key = tuple(self._node(node, "support_coupling") * dpn
                    + self._dof(dof, "support_coupling") for node, dof in supports)
        loose = [f"{node}.{dof}" for (node, dof), g in zip(supports, key, strict=True)
                 if topo.free[g] >= 0]
        if loose:
            raise ModelError(f"support_coupling: {', '.join(loose)} not fixed; only fixed DOFs "
                             "move as supports")
        cached = self._released.get(key)
        if cached is None or cached[0] is not topo:
            twin = Structure(dpn)
            twin._node_index, twin._xy, twin._z = dict(self._node_index), list(self._xy), list(
                self._z)
            twin._records, twin._element_names = list(self._records), set(self._element_names)
            twin._fixed = self._fixed - set(key)
            twin._followers = dict(self._followers)
            twin.derive = self.derive
            cached = self._released[key] = (topo, twin)
        twin = cached[1]
        # sparse: the released DOFs may carry no mass (a support node without beam mass)
        return coupling_blocks(twin.assemble(values, sparse=True), supports, self.dof_labels)

    def seismic_load(
        self, values: Mapping[str, float] | ArrayLike | None = None, direction: str | None = None
    ) -> np.ndarray:
        """The vector ``p`` of the base-excitation load ``-p a_g(t)`` on the free DOFs.

        ``p = M_ff r_f + M_fc r_c``: besides ``M r`` it includes the inertia that consistent
        beam masses couple from moving supports (fixed DOFs) into the free DOFs. Equal to
        ``M r`` when no beam mass touches a fixed DOF (e.g. the paper's bridge, supported on
        springs).
        """
        return self.assemble(values, direction).seismic_load

    # ------------------------------------------------------------------ internals

    def _new_name(self, name: str | None, kind: str) -> str:
        if name is None:
            k = 1
            while f"{kind}{k}" in self._element_names:
                k += 1
            name = f"{kind}{k}"
        if not isinstance(name, str) or not name:
            raise ModelError(f"{kind} name must be a non-empty string, got {name!r}")
        if name in self._element_names:
            raise ModelError(f"duplicate element name {name!r}")
        return name

    def _add(self, rec: Record) -> None:
        self._records.append(rec)
        if rec.kind != "rayleigh":
            self._element_names.add(rec.name)
        self._topology = None
        self._parameters = None

    def _node(self, node: str, where: str) -> int:
        try:
            return self._node_index[node]
        except (KeyError, TypeError):
            known = ", ".join(self._node_index) or "none yet"
            raise ModelError(f"{where}: unknown node {node!r}; known nodes: {known}") from None

    def _dof(self, dof: str, where: str) -> int:
        try:
            return self.dof_names.index(dof)
        except ValueError:
            raise ModelError(
                f"{where}: unknown DOF {dof!r}; with dofs_per_node={self.dofs_per_node} the DOFs "
                f"are {self.dof_names}"
            ) from None

    def _add_link(
        self,
        kind: str,
        node: str,
        dof: str,
        node2: str | None,
        dof2: str | None,
        name: str | None,
        raw: dict[str, Value],
        specs: Mapping[str, Spec] | None = None,
    ) -> str:
        name = self._new_name(name, kind)
        label = f"{kind} {name!r}"
        n1, d1 = self._node(node, label), self._dof(dof, label)
        if node2 is None:
            if dof2 is not None:
                raise ModelError(f"{label}: dof2 = {dof2!r} given without node2")
            n2, d2 = -1, -1
        else:
            n2, d2 = self._node(node2, label), self._dof(dof if dof2 is None else dof2, label)
            if (n1, d1) == (n2, d2):
                raise ModelError(f"{label}: connects {node}.{dof} to itself")
        props = {k: check_property(v, label, k, NONNEG if specs is None else specs[k])
                 for k, v in raw.items()}
        self._add(Record(kind, name, props, nodes=(n1, n2), dofs=(d1, d2)))
        return name

    def _xyz(self, node: int) -> tuple[float, float, float]:
        return (*self._xy[node], self._z[node])

    @property
    def mass_is_constant(self) -> bool:
        """Whether no parameter changes the mass matrix (nor the base motion's load ``p``)."""
        return bool(self._topo().mass_const)

    def _rigid(self, direction: str | None) -> np.ndarray:
        """Rigid base translation over all global DOFs (fixed ones included)."""
        return rigid_translation(self._topo().dof_names, self.dof_names, self.dofs_per_node,
                                 direction)

    def _topo(self) -> Topology:
        if self._topology is None:
            self._topology = self._build()
        return self._topology

    def _prop(self, recs: Sequence[Record], kind: str, what: str, spec: Spec,
              default: float = 0.0) -> Prop:
        return property_over(recs, kind, what, spec, self.parameters, default)

    def _build(self) -> Topology:
        """The numbering and scatter plan of the elements, made once per topology.

        The steps (:mod:`femupdate.model.topology`), in order:

        1. number the free DOFs (fixed ones -1) and label them ``"node.dof"``;
        2. group the element records by kind;
        3. the beams: global DOFs, lengths, global→local rotations, scatter targets, and the
           coupling of their free rows to fixed columns (the inertia moving supports carry);
        4. the links: the DOF pairs of springs and dampers, and of friction and Bouc–Wen
           elements with a fixed first end swapped (their laws are odd);
        5. the lumped masses' diagonal targets;
        6. every property over its elements (constants, and where parameters go), Rayleigh
           damping, and whether the mass matrix is constant (then assembled once);
        7. the rigid diaphragms' elimination of the follower DOFs, if any.

        The assembly then only evaluates the element formulas at the parameter values and
        scatters them by this plan. Errors (no nodes, nothing free, a link between fixed DOFs,
        a diaphragm that cannot be made) raise ``ModelError`` here, on first use.
        """
        dpn, names = self.dofs_per_node, self.nodes
        points = [self._xyz(i) for i in range(len(self._xy))]
        dofs = number_dofs(len(points), dpn, self._fixed, names, self.dof_names)
        n, free = dofs.n, dofs.free
        by_kind = records_by_kind(self._records)
        beams = by_kind.get("beam", [])
        beam = beam_plan(beams, points, dpn, dofs)
        springs, dampers = by_kind.get("spring", []), by_kind.get("damper", [])
        frictions, bouc_wens = by_kind.get("friction", []), by_kind.get("bouc_wen", [])
        spring_target, spring_keep = scatter_plan(
            link_dofs(springs, free, dpn, names, self.dof_names), n)
        damper_target, damper_keep = scatter_plan(
            link_dofs(dampers, free, dpn, names, self.dof_names), n)
        fr = odd_link_dofs(link_dofs(frictions, free, dpn, names, self.dof_names))
        bw = odd_link_dofs(link_dofs(bouc_wens, free, dpn, names, self.dof_names))
        masses = by_kind.get("mass", [])
        m_target, m_owner, j_target, j_owner = lumped_mass_plan(masses, free, dpn, n,
                                                                self.dof_names)

        mass_m = self._prop(masses, "mass", "m", NONNEG)
        mass_J = self._prop(masses, "mass", "J", NONNEG)
        beam_props = {what: self._prop(beams, "beam", what, spec,
                                       default=1.0 if what in ("G", "kappa") else 0.0)
                      for what, spec in BEAM_SPECS.items()}
        beam_shear = np.array([rec.options["shear"] for rec in beams], dtype=np.int64)
        ray = by_kind.get("rayleigh", [])
        rayleigh = None
        if ray:
            rayleigh = (self._prop(ray, "Rayleigh damping", "alpha", NONNEG),
                        self._prop(ray, "Rayleigh damping", "beta", NONNEG))

        diaphragms = None
        if self._followers:
            diaphragms = diaphragm_constraint(self._followers, points, free, names, dofs.labels)
            for ends, kind in ((fr, "friction element"), (bw, "Bouc–Wen element")):
                diaphragms.reindex(ends.reshape(-1), f"a {kind}")
        return Topology(
            n=n,
            labels=dofs.labels,
            free=free,
            dof_names=np.array(dofs.dof_names),
            beam_props=beam_props,
            beam_L=beam.length,
            beam_shear=beam_shear,
            beam_rotary=np.array([float(rec.options["rotary"]) for rec in beams]),
            beam_T=beam.T,
            beam_target=beam.target,
            beam_keep=beam.keep,
            beam_coupling=beam.coupling,
            spring_k=self._prop(springs, "spring", "k", NONNEG),
            spring_target=spring_target,
            spring_keep=spring_keep,
            damper_c=self._prop(dampers, "damper", "c", NONNEG),
            damper_target=damper_target,
            damper_keep=damper_keep,
            friction_i=fr[:, 0].copy(),
            friction_j=fr[:, 1].copy(),
            friction_kr=self._prop(frictions, "friction", "k_r", NONNEG),
            friction_fu=self._prop(frictions, "friction", "f_u", NONNEG),
            mass_m=mass_m,
            mass_J=mass_J,
            mass_m_target=m_target,
            mass_m_owner=m_owner,
            mass_J_target=j_target,
            mass_J_owner=j_owner,
            rayleigh=rayleigh,
            mass_const=mass_is_constant(beam_props, beam_shear, mass_m, mass_J),
            bouc_wen_i=bw[:, 0].copy(),
            bouc_wen_j=bw[:, 1].copy(),
            bouc_wen_props=tuple(self._prop(bouc_wens, "bouc_wen", what, BOUC_WEN_SPECS[what])
                                 for what in BOUC_WEN_PARAMETERS),
            diaphragms=diaphragms,
            rayleigh_bouc_wen=bool(ray[0].options.get("bouc_wen", True)) if ray else True,
            beam_shear_off=np.array([bool(rec.options["shear_off"]) for rec in beams], bool),
            beam_torsion=np.array([bool(rec.options["torsion"]) for rec in beams], bool),
        )


def shear_building(
    masses: Sequence[Value],
    stiffnesses: Sequence[Value],
    dampers: Sequence[Value] | None = None,
    *,
    frictions: Sequence[Mapping[str, Value]] | None = None,
    bouc_wen: Sequence[Mapping[str, Value]] | None = None,
) -> Structure:
    """A shear building: one horizontal DOF per storey, storey springs between floors.

    Floors are nodes ``"F1"`` (lowest) … ``"Fn"`` with DOF ``ux``; storey ``i`` has a spring
    ``"k<i>"`` (and a damper ``"c<i>"``, an elasto-slip element ``"f<i>"``, a Bouc–Wen element
    ``"bw<i>"``) between floor ``i`` and the floor below (the ground for ``i = 1``), and floor
    ``i`` a mass ``"m<i>"``. Any value may be a parameter name.

    Parameters
    ----------
    masses, stiffnesses : sequence of float or str
        Floor masses and storey stiffnesses, bottom up, of equal length.
    dampers : sequence of float or str, optional
        Storey viscous damping coefficients, same length.
    frictions : sequence of mapping, optional
        Per storey ``{"k_r": ..., "f_u": ...}`` (:meth:`Structure.add_friction`), same length.
    bouc_wen : sequence of mapping, optional
        Per storey ``{"k", "alpha", "A", "beta", "gamma", "n"}`` and optionally the
        degradation rates ``delta_a``, ``delta_nu``, ``delta_eta``
        (:meth:`Structure.add_bouc_wen`; ``alpha``, ``A`` and ``n`` may be left out), same
        length.
    """
    n = len(masses)
    if n == 0:
        raise ModelError("shear_building: masses is empty; give one mass per storey")
    if len(stiffnesses) != n:
        raise ModelError(
            f"shear_building: {len(stiffnesses)} stiffnesses for {n} masses; give one per storey"
        )
    for what, given in (("dampers", dampers), ("frictions", frictions),
                        ("bouc_wen", bouc_wen)):
        if given is not None and len(given) != n:
            raise ModelError(
                f"shear_building: {len(given)} {what} for {n} masses; give one per storey"
            )
    s = Structure(dofs_per_node=1)
    for i in range(1, n + 1):
        s.add_node(f"F{i}", x=0.0, y=float(i))
        s.add_mass(f"F{i}", m=masses[i - 1], name=f"m{i}")
    for i in range(1, n + 1):
        below = {} if i == 1 else {"node2": f"F{i - 1}"}
        s.add_spring(f"F{i}", "ux", stiffnesses[i - 1], name=f"k{i}", **below)
        if dampers is not None:
            s.add_damper(f"F{i}", "ux", dampers[i - 1], name=f"c{i}", **below)
        if frictions is not None:
            fr = frictions[i - 1]
            s.add_friction(f"F{i}", "ux", fr["k_r"], fr["f_u"], name=f"f{i}", **below)
        if bouc_wen is not None:
            s.add_bouc_wen(f"F{i}", "ux", name=f"bw{i}", **below, **bouc_wen[i - 1])
    return s

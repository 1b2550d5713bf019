"""A planar structure of nodes and elements, assembled into a ``System`` for given parameters.

The structure is described once (nodes, beams, springs, dampers, friction and Bouc–Wen
elements, masses, supports); any numeric property may be a number or the name of a parameter.
The topology (DOF map, scatter indices) is built once, lazily, and ``assemble`` then only
evaluates the element matrices of all elements of a kind together and scatters them with
precomputed flat indices, which keeps re-assembly for new parameter values cheap (it runs once
per evaluation of the objective in model updating).

Why this file is long (about 900 lines): it is one class on purpose. The description methods
(``add_*``, with their checks and messages, half of the file) and the compiled topology and
assembly share the element records and their scatter indices; split in two, each half would
reach into the other's private state.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike

from femupdate.errors import ModelError
from femupdate.model.diaphragm import Diaphragms, diaphragm_constraint
from femupdate.model.elements import (
    _range_text,
    beam_mass,
    beam_stiffness,
    check_value,
    frame_mass,
    frame_rotation,
    frame_stiffness,
    spring_matrix,
)
from femupdate.model.elements3d import frame3d_mass, frame3d_rotation, frame3d_stiffness
from femupdate.model.hysteresis import BOUC_WEN_PARAMETERS, check_bouc_wen_parameters
from femupdate.model.modes import check_mass_matrix
from femupdate.model.sparse import SparsePattern, check_sparse_mass, scatter_sparse
from femupdate.model.system import BoucWenElements, FrictionElements, System

__all__ = ["DOF_NAMES", "Structure", "shear_building"]

#: DOF names of a node for each ``dofs_per_node``.
DOF_NAMES: dict[int, tuple[str, ...]] = {1: ("ux",), 2: ("uy", "rz"), 3: ("ux", "uy", "rz"),
                                         6: ("ux", "uy", "uz", "rx", "ry", "rz")}

#: Default base-excitation direction for each ``dofs_per_node``.
_DEFAULT_DIRECTION = {1: "x", 2: "y", 3: "x", 6: "x"}

Value = float | str
"""A numeric property: a number, or the name of a parameter given at assembly."""

_INF = math.inf


@dataclass(frozen=True)
class _Spec:
    """Allowed range of a property: ``[low, high]``, or ``(low, high]`` when ``low_open``."""

    low: float = 0.0
    high: float = _INF
    low_open: bool = False


_NONNEG = _Spec()
_POSITIVE = _Spec(low_open=True)

_BEAM_SPECS = {
    "E": _NONNEG,
    "A": _POSITIVE,
    "I": _POSITIVE,
    "rho": _NONNEG,
    "G": _POSITIVE,
    "nu": _Spec(-1.0, 0.5, low_open=True),
    "kappa": _POSITIVE,
    "mass_per_length": _NONNEG,
    # 3-D beams (dofs_per_node=6), femupdate.model.elements3d
    "Iy": _POSITIVE,
    "Iz": _POSITIVE,
    "J": _POSITIVE,
}

# Bouc–Wen properties one by one; the admissible (β, γ) pairs are checked at assembly.
_BOUC_WEN_SPECS = {
    "k": _POSITIVE,
    "alpha": _Spec(0.0, 1.0),
    "A": _POSITIVE,
    "beta": _POSITIVE,
    "gamma": _Spec(-_INF),
    "n": _POSITIVE,
}

# Beam properties the mass matrix depends on (besides E, through Φ, when G is given).
_MASS_PROPS = ("A", "I", "rho", "G", "nu", "kappa", "mass_per_length", "Iy", "Iz", "J")


@dataclass(frozen=True)
class _Record:
    """One element as described by the user: its kind, name, where it acts and its properties."""

    kind: str  # "beam", "spring", "damper", "friction", "bouc_wen", "mass", "rayleigh"
    name: str
    props: dict[str, Value]
    nodes: tuple[int, ...] = ()
    dofs: tuple[int, ...] = ()  # local DOF index per node (links only)
    options: dict[str, object] = field(default_factory=dict)


@dataclass(frozen=True)
class _Prop:
    """One property over all elements of a kind: constants, and where parameters go."""

    what: str
    kind: str
    names: tuple[str, ...]
    const: np.ndarray
    pidx: np.ndarray  # parameter index per element, -1 for a constant
    spec: _Spec
    params: tuple[str, ...]
    where: np.ndarray  # elements whose value is a parameter

    @property
    def is_const(self) -> bool:
        return self.where.size == 0

    def evaluate(self, p: np.ndarray) -> np.ndarray:
        """Values for parameter vector ``p``; parameter values outside the range raise."""
        where = self.where
        if where.size == 0:
            return self.const
        vp = p[self.pidx[where]]
        s = self.spec
        ok = (vp > s.low if s.low_open else vp >= s.low) & (vp <= s.high)
        if not ok.all():
            e = int(where[np.argmin(ok)])
            v = float(p[self.pidx[e]])
            raise ModelError(
                f"{self.kind} {self.names[e]!r}: {self.what} = {v!r} (parameter "
                f"{self.params[self.pidx[e]]!r}) is out of range; allowed "
                f"{_range_text(s.low, s.high, s.low_open)}"
            )
        v = self.const.copy()
        v[where] = vp
        return v


def _beam3d_options(label: str, dpn: int, xyz1: tuple[float, float, float],
                    xyz2: tuple[float, float, float], I: Value | None,  # noqa: E741
                    Iy: Value | None, Iz: Value | None, J: Value | None,
                    vecxz: Sequence[float] | None, shear: int) -> dict[str, object]:
    """The 3-D beam's extra properties and options (checks which of I / Iy, Iz, J, vecxz)."""
    given3d = {k: v for k, v in (("Iy", Iy), ("Iz", Iz), ("J", J)) if v is not None}
    if dpn != 6:
        if given3d or vecxz is not None:
            raise ModelError(f"{label}: Iy, Iz, J and vecxz are for dofs_per_node=6; give I")
        if I is None:
            raise ModelError(f"{label}: I (second moment of area) is missing")
        return {"options": {}}
    if I is not None:
        raise ModelError(f"{label}: with dofs_per_node=6 give Iy, Iz and J, not I")
    missing = [k for k in ("Iy", "Iz", "J") if k not in given3d] + (
        ["vecxz"] if vecxz is None else [])
    if missing:
        raise ModelError(f"{label}: {', '.join(missing)} missing; a 3-D beam needs Iy, Iz, J "
                         "and vecxz")
    if shear == 0:
        raise ModelError(f"{label}: give G or nu (a 3-D beam needs its torsional stiffness)")
    vec = np.asarray(vecxz, dtype=float)
    if vec.shape != (3,) or not np.all(np.isfinite(vec)):
        raise ModelError(f"{label}: vecxz = {vecxz!r}; give three finite numbers")
    try:
        frame3d_rotation(xyz1, xyz2, vec)
    except ModelError as exc:
        raise ModelError(f"{label}: {str(exc).removeprefix('3-D beam: ')}") from None
    return {"options": {"vecxz": vec}, **given3d}


def _shear_modulus(E: np.ndarray, bp: Mapping[str, np.ndarray], shear: np.ndarray
                   ) -> np.ndarray:
    """``G`` per beam: given (1), from ``nu`` (2), or infinite (0)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        from_nu = E / (2.0 * (1.0 + bp["nu"]))
    return np.where(shear == 1, bp["G"], np.where(shear == 2, from_nu, _INF))


def _scatter(dof_map: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Flat targets in an ``n × n`` matrix and the kept entries of an element stack.

    ``dof_map`` (n_e, d) holds free-DOF indices, -1 for fixed DOFs and ground, whose rows and
    columns are dropped.
    """
    rows = dof_map[:, :, None]
    cols = dof_map[:, None, :]
    keep = ((rows >= 0) & (cols >= 0)).ravel()
    target = (rows * n + cols).ravel()[keep]
    return target, np.flatnonzero(keep)


@dataclass(frozen=True)
class _Topology:
    n: int
    labels: tuple[str, ...]
    free: np.ndarray  # free index per global DOF, -1 where fixed
    dof_names: np.ndarray  # DOF name per global DOF (str array)
    # beams
    beam_props: dict[str, _Prop]
    beam_L: np.ndarray
    beam_shear: np.ndarray  # 0 rigid in shear, 1 G given, 2 nu given
    beam_rotary: np.ndarray  # 1.0 with rotary inertia, else 0.0
    beam_T: np.ndarray | None  # (n_b, d, d) global→local, None when identity
    beam_target: np.ndarray
    beam_keep: np.ndarray
    beam_coupling: tuple[np.ndarray, np.ndarray, np.ndarray]  # row, keep, global column
    # links
    spring_k: _Prop
    spring_target: np.ndarray
    spring_keep: np.ndarray
    damper_c: _Prop
    damper_target: np.ndarray
    damper_keep: np.ndarray
    friction_i: np.ndarray
    friction_j: np.ndarray
    friction_kr: _Prop
    friction_fu: _Prop
    # lumped masses: flat diagonal targets and the owning element of each
    mass_m: _Prop
    mass_J: _Prop
    mass_m_target: np.ndarray
    mass_m_owner: np.ndarray
    mass_J_target: np.ndarray
    mass_J_owner: np.ndarray
    rayleigh: tuple[_Prop, _Prop] | None
    mass_const: bool  # no parameter changes M: it is assembled and checked once
    cache: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    # the CSR structure of the sparse K and C (their targets never change)
    patterns: dict[str, SparsePattern] = field(default_factory=dict)
    # Bouc–Wen elements: end DOFs and their six properties (BOUC_WEN_PARAMETERS)
    bouc_wen_i: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    bouc_wen_j: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    bouc_wen_props: tuple[_Prop, ...] = ()
    # rigid floor diaphragms (3-D frames): the elimination of the follower DOFs, or None
    diaphragms: Diaphragms | None = None


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
        self._records: list[_Record] = []
        self._element_names: set[str] = set()
        self._fixed: set[int] = set()
        self._followers: dict[int, int] = {}  # node → master node of its rigid diaphragm
        self._topology: _Topology | None = None
        self._parameters: tuple[str, ...] | None = None
        #: Maps a caller's named parameter values to the structure's own (its string
        #: properties: a case's derived fields, femupdate.case.expressions.FieldValues);
        #: None: the same names.
        self.derive: Callable[[Mapping[str, float]], Mapping[str, float]] | None = None
        # support_coupling's twins with supports released, for the topology they were made of
        self._released: dict[tuple[int, ...], tuple[_Topology, Structure]] = {}

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
            seen: dict[str, None] = {}
            for rec in self._records:
                for v in rec.props.values():
                    if isinstance(v, str):
                        seen.setdefault(v, None)
            self._parameters = tuple(seen)
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
            Include the rotary inertia ``ρI``.
        name : str, optional
            Element name (default ``"beam<k>"``).

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
        (x1, y1), (x2, y2) = self._xy[n1], self._xy[n2]
        length = math.hypot(x2 - x1, y2 - y1, self._z[n2] - self._z[n1])
        if not length > 0.0:
            raise ModelError(
                f"{label}: length = {length!r} between nodes {node1!r} and {node2!r}; "
                "allowed > 0 (the nodes coincide)"
            )
        if self.dofs_per_node == 2 and abs(y2 - y1) > 1e-9 * length:
            raise ModelError(
                f"{label}: with dofs_per_node=2 beams must lie along the x axis; nodes "
                f"{node1!r} and {node2!r} differ in y by {y2 - y1!r}. Use dofs_per_node=3"
            )
        if G is not None and nu is not None:
            raise ModelError(f"{label}: give G or nu, not both")
        shear = 0 if G is None and nu is None else (1 if G is not None else 2)
        options: dict[str, object] = {"shear": shear, "rotary": bool(rotary_inertia)}
        extra = _beam3d_options(label, self.dofs_per_node, self._xyz(n1), self._xyz(n2),
                                I, Iy, Iz, J, vecxz, shear)
        options.update(extra.pop("options"))  # type: ignore[arg-type]
        raw = {
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
        raw.update(extra)  # type: ignore[arg-type]
        props = {k: self._value(v, label, k, _BEAM_SPECS[k]) for k, v in raw.items()}
        self._add(_Record("beam", name, props, nodes=(n1, n2), options=options))
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
        node2: str | None = None,
        dof2: str | None = None,
        name: str | None = None,
    ) -> str:
        """Add a Bouc–Wen hysteretic element (:mod:`femupdate.model.hysteresis`).

        Force ``α k y + (1 − α) k z`` with ``ż = A ẏ − β |ẏ| |z|^(n−1) z − γ ẏ |z|^n``, ``y``
        the deformation of ``node.dof`` (minus ``node2.dof2``, or to ground).

        Parameters
        ----------
        k : float or str
            Initial stiffness (``> 0``; for ``A = 1``).
        alpha : float or str
            Post-yield to initial stiffness ratio, in ``[0, 1]``.
        A, beta, gamma, n : float or str
            ``A > 0``, ``β > 0``, ``−β < γ ≤ β`` (checked at assembly), ``n > 0``.
        """
        props = {"k": k, "alpha": alpha, "A": A, "beta": beta, "gamma": gamma, "n": n}
        values = [props[key] for key in BOUC_WEN_PARAMETERS]
        if all(isinstance(v, int | float) for v in values):  # constants: say now, not later
            check_bouc_wen_parameters(np.array([values], dtype=float),
                                      (name or f"bouc_wen at {node}.{dof}",))
        return self._add_link("bouc_wen", node, dof, node2, dof2, name, props,
                              specs=_BOUC_WEN_SPECS)

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
        props = {"m": self._value(m, label, "m", _NONNEG), "J": self._value(J, label, "J", _NONNEG)}
        names = [self.dof_names[d] for d in carried]
        for what, letter, kind in (("m", "u", "translation"), ("J", "r", "rotation")):
            # A mass whose DOFs cannot carry it was dropped without a word.
            if props[what] != 0.0 and dofs is not None and not any(
                    d.startswith(letter) for d in names):
                raise ModelError(f"{label}: dofs = {names} names no {kind}, so {what} = "
                                 f"{props[what]!r} would act on nothing; name a {kind} in "
                                 f"dofs, or give {what} = 0")
        self._add(_Record("mass", name, props, nodes=(n,), options={"dofs": carried}))
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

    def set_rayleigh(self, alpha: Value = 0.0, beta: Value = 0.0) -> None:
        """Add (or replace) Rayleigh damping ``C += α M + β K`` (``K`` without friction)."""
        props = {
            "alpha": self._value(alpha, "Rayleigh damping", "alpha", _NONNEG),
            "beta": self._value(beta, "Rayleigh damping", "beta", _NONNEG),
        }
        self._records = [r for r in self._records if r.kind != "rayleigh"]
        self._add(_Record("rayleigh", "rayleigh", props))

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
        p = self._parameter_vector(values)
        m, c, k, friction, beam_m = self._matrices(p, sparse)
        bouc_wen = self._bouc_wen(p)
        seismic = None
        rows, keep, gcols = topo.beam_coupling
        if rows.size:  # consistent beam mass couples the moving supports to free DOFs
            seismic = m @ r + np.bincount(
                rows, weights=beam_m.reshape(-1)[keep] * rigid[gcols], minlength=topo.n
            )
        if topo.diaphragms is not None:
            return _constrained(topo, m, c, k, r, friction, bouc_wen, seismic, sparse)
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
        sys = twin.assemble(values, sparse=True)
        index = {label: i for i, label in enumerate(sys.dof_labels)}
        cols = [index[f"{node}.{dof}"] for node, dof in supports]
        rows = [index[label] for label in self.dof_labels]
        return tuple(sp.csr_matrix(mat)[rows][:, cols].toarray()  # type: ignore[return-value]
                     for mat in (sys.K, sys.M, sys.C))

    def _bouc_wen(self, p: np.ndarray) -> BoucWenElements | None:
        """The Bouc–Wen elements at parameter vector ``p`` (None without any)."""
        topo = self._topo()
        if not topo.bouc_wen_i.size:
            return None
        table = np.column_stack([prop.evaluate(p) for prop in topo.bouc_wen_props])
        names = topo.bouc_wen_props[0].names
        check_bouc_wen_parameters(table, names)
        return BoucWenElements(dof_i=topo.bouc_wen_i.copy(), dof_j=topo.bouc_wen_j.copy(),
                               table=table, names=names)

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

    def _matrices(
        self, p: np.ndarray, sparse: bool = False
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, FrictionElements | None, np.ndarray]:
        """M, C, K (dense, or CSR if ``sparse``), friction and the stack of beam mass matrices."""
        topo = self._topo()
        n = topo.n
        nn = n * n

        def accumulate(target: np.ndarray, weights: np.ndarray, key: str = "") -> np.ndarray:
            if sparse:  # flat targets row·n + col summed into CSR (duplicates add up)
                if not key:
                    return scatter_sparse(target, weights, n)
                pattern = topo.patterns.get(key)
                if pattern is None:
                    pattern = topo.patterns[key] = SparsePattern.of(target, n)
                return pattern.matrix(weights)
            return np.bincount(target, weights=weights, minlength=nn).reshape(n, n)

        bp = {key: prop.evaluate(p) for key, prop in topo.beam_props.items()}
        L = topo.beam_L
        E, A, I = bp["E"], bp["A"], bp["I"]  # noqa: E741
        # Φ = 12 E I / (κ G A L²); with ν given, E/G = 2(1 + ν) so Φ stays finite at E = 0.
        flex = np.where(
            topo.beam_shear == 1,
            12.0 * E / bp["G"],
            np.where(topo.beam_shear == 2, 24.0 * (1.0 + bp["nu"]), 0.0),
        )
        phi = flex * I / (bp["kappa"] * A * L * L)
        frame = self.dofs_per_node == 3
        if self.dofs_per_node == 6:
            g = _shear_modulus(E, bp, topo.beam_shear)
            kb = frame3d_stiffness(E, g, A, bp["Iy"], bp["Iz"], bp["J"], bp["kappa"] * A,
                                   bp["kappa"] * A, L).reshape(L.size, 12, 12)
        elif frame:
            kb = frame_stiffness(E * A, E * I, L, phi)
        else:
            kb = beam_stiffness(E * I, L, phi)
        if topo.beam_T is not None:
            kb = np.swapaxes(topo.beam_T, 1, 2) @ kb @ topo.beam_T
        mass_key = "mass_sparse" if sparse else "mass"
        cached = topo.cache.get(mass_key)
        if cached is not None:
            m, mb = cached[0].copy(), cached[1]
        else:
            mu = bp["rho"] * A + bp["mass_per_length"]
            rho_i = bp["rho"] * I * topo.beam_rotary
            if self.dofs_per_node == 6:
                g = _shear_modulus(E, bp, topo.beam_shear)
                mb = np.array([
                    frame3d_mass(mu[e], bp["rho"][e], E[e], g[e], A[e], bp["Iy"][e], bp["Iz"][e],
                                 bp["kappa"][e] * A[e], bp["kappa"][e] * A[e], L[e],
                                 Ip=bp["J"][e], rotary_inertia=bool(topo.beam_rotary[e]))
                    for e in range(L.size)]).reshape(L.size, 12, 12)
            elif frame:
                mb = frame_mass(mu, rho_i, L, phi)
            else:
                mb = beam_mass(mu, rho_i, L, phi)
            if topo.beam_T is not None:
                mb = np.swapaxes(topo.beam_T, 1, 2) @ mb @ topo.beam_T
            mm, mj = topo.mass_m.evaluate(p), topo.mass_J.evaluate(p)
            m = accumulate(
                np.concatenate([topo.beam_target, topo.mass_m_target, topo.mass_J_target]),
                np.concatenate(
                    [mb.reshape(-1)[topo.beam_keep], mm[topo.mass_m_owner], mj[topo.mass_J_owner]]
                ),
            )
            if topo.diaphragms is None:
                _check_mass(m, topo.labels, sparse)
            if topo.mass_const:
                topo.cache[mass_key] = (m.copy(), mb)

        ks = spring_matrix(topo.spring_k.evaluate(p))
        k = accumulate(
            np.concatenate([topo.beam_target, topo.spring_target]),
            np.concatenate([kb.reshape(-1)[topo.beam_keep], ks.reshape(-1)[topo.spring_keep]]),
            "K",
        )
        cs = spring_matrix(topo.damper_c.evaluate(p))
        c = accumulate(topo.damper_target, cs.reshape(-1)[topo.damper_keep], "C")
        if topo.rayleigh is not None:
            alpha, beta = (float(prop.evaluate(p)[0]) for prop in topo.rayleigh)
            c = c + alpha * m + beta * k
        friction = None
        if topo.friction_i.size:
            friction = FrictionElements(
                dof_i=topo.friction_i.copy(),
                dof_j=topo.friction_j.copy(),
                k_r=topo.friction_kr.evaluate(p).copy(),
                f_u=topo.friction_fu.evaluate(p).copy(),
            )
        return m, c, k, friction, mb

    def _parameter_vector(self, values: Mapping[str, float] | ArrayLike | None) -> np.ndarray:
        names = self.parameters
        if values is None:
            values = {}
        if isinstance(values, Mapping) and self.derive is not None:
            values = self.derive(values)
        if isinstance(values, Mapping):
            unknown = [key for key in values if key not in names]
            if unknown:
                raise ModelError(
                    f"unknown parameter(s) {', '.join(map(repr, unknown))}; this structure "
                    f"uses {names}"
                )
            missing = [key for key in names if key not in values]
            if missing:
                raise ModelError(
                    f"missing value(s) for parameter(s) {', '.join(map(repr, missing))}"
                )
            raw: Sequence[object] = [values[key] for key in names]
        else:
            raw = list(np.atleast_1d(np.asarray(values)))
            if len(raw) != len(names):
                raise ModelError(
                    f"got {len(raw)} parameter values; this structure has {len(names)}: {names}"
                )
        try:
            p = np.array([float(v) for v in raw], dtype=float)  # type: ignore[arg-type]
        except (TypeError, ValueError) as exc:
            raise ModelError(f"parameter values must be numbers: {exc}") from exc
        bad = np.flatnonzero(~np.isfinite(p))
        if bad.size:
            raise ModelError(
                f"parameter {names[bad[0]]!r} = {float(p[bad[0]])!r}; it must be finite"
            )
        return p

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

    def _add(self, rec: _Record) -> None:
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

    @staticmethod
    def _value(v: Value, element: str, what: str, spec: _Spec) -> Value:
        if isinstance(v, str):
            if not v:
                raise ModelError(f"{element}: {what} is an empty parameter name")
            return v
        return check_value(element, what, v, spec.low, spec.high, low_open=spec.low_open)

    def _add_link(
        self,
        kind: str,
        node: str,
        dof: str,
        node2: str | None,
        dof2: str | None,
        name: str | None,
        raw: dict[str, Value],
        specs: Mapping[str, _Spec] | None = None,
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
        props = {k: self._value(v, label, k, _NONNEG if specs is None else specs[k])
                 for k, v in raw.items()}
        self._add(_Record(kind, name, props, nodes=(n1, n2), dofs=(d1, d2)))
        return name

    def _xyz(self, node: int) -> tuple[float, float, float]:
        return (*self._xy[node], self._z[node])

    def _rigid(self, direction: str | None) -> np.ndarray:
        """Rigid base translation over all global DOFs (fixed ones included)."""
        if direction is None:
            direction = _DEFAULT_DIRECTION[self.dofs_per_node]
        name = f"u{direction}"
        if not isinstance(direction, str) or name not in self.dof_names:
            allowed = [d[1] for d in self.dof_names if d.startswith("u")]
            raise ModelError(
                f"direction = {direction!r}; allowed {allowed} for dofs_per_node="
                f"{self.dofs_per_node}"
            )
        return (self._topo().dof_names == name).astype(float)

    def _topo(self) -> _Topology:
        if self._topology is None:
            self._topology = self._build()
        return self._topology

    def _prop(
        self, recs: Sequence[_Record], kind: str, what: str, spec: _Spec, default: float = 0.0
    ) -> _Prop:
        params = self.parameters
        const = np.zeros(len(recs))
        pidx = np.full(len(recs), -1, dtype=np.int64)
        for e, rec in enumerate(recs):
            v = rec.props.get(what, default)
            if isinstance(v, str):
                pidx[e] = params.index(v)
            else:
                const[e] = v
        names = tuple(r.name for r in recs)
        return _Prop(what, kind, names, const, pidx, spec, params, np.flatnonzero(pidx >= 0))

    def _build(self) -> _Topology:
        """The numbering and scatter plan of the elements, made once per topology.

        In order: the free DOFs (fixed ones numbered -1) and their labels; the beams' global
        DOFs, lengths, rotations and the coupling of their free rows to fixed columns (for
        multi-support); the links' (springs, dampers, friction, Bouc–Wen) DOF pairs, an
        element with a fixed first end swapped (the laws are odd); the lumped masses. The
        assembly then only evaluates the element formulas at the parameter values and
        scatters them by this plan.
        """
        dpn = self.dofs_per_node
        n_nodes = len(self._xy)
        if n_nodes == 0:
            raise ModelError("the structure has no nodes; add_node first")
        n_global = n_nodes * dpn
        fixed = np.zeros(n_global, dtype=bool)
        fixed[list(self._fixed)] = True
        free = np.full(n_global, -1, dtype=np.int64)
        free[~fixed] = np.arange(int((~fixed).sum()))
        n = int((~fixed).sum())
        if n == 0:
            raise ModelError("every DOF is fixed; the structure has no free DOF")
        node_names = self.nodes
        dof_names = tuple(d for _ in range(n_nodes) for d in self.dof_names)
        labels = tuple(
            f"{node_names[g // dpn]}.{dof_names[g]}" for g in range(n_global) if not fixed[g]
        )
        by_kind: dict[str, list[_Record]] = {}
        for rec in self._records:
            by_kind.setdefault(rec.kind, []).append(rec)

        # beams
        beams = by_kind.get("beam", [])
        d = 2 * dpn
        beam_t: np.ndarray | None
        gdofs = np.array(
            [[nd * dpn + j for nd in rec.nodes for j in range(dpn)] for rec in beams],
            dtype=np.int64,
        ).reshape(len(beams), d)
        xy = np.column_stack([np.array(self._xy).reshape(-1, 2), self._z])
        delta = xy[[rec.nodes[1] for rec in beams]] - xy[[rec.nodes[0] for rec in beams]]
        delta = delta.reshape(len(beams), 3)
        length = np.sqrt((delta * delta).sum(axis=1))
        cos, sin = delta[:, 0] / length, delta[:, 1] / length
        if dpn == 6:
            beam_t = np.array([frame3d_rotation(self._xyz(rec.nodes[0]), self._xyz(rec.nodes[1]),
                                                rec.options["vecxz"])  # type: ignore[arg-type]
                               for rec in beams]).reshape(len(beams), 12, 12)
        elif dpn == 3:
            beam_t = frame_rotation(cos, sin)
        elif np.all(cos > 0):
            beam_t = None
        else:  # a beam from right to left: its local v is -uy
            beam_t = np.zeros((len(beams), 4, 4))
            beam_t[:, [0, 2], [0, 2]] = np.sign(cos)[:, None]
            beam_t[:, [1, 3], [1, 3]] = 1.0
        fmap = free[gdofs]
        beam_target, beam_keep = _scatter(fmap, n)
        rows = np.broadcast_to(fmap[:, :, None], (len(beams), d, d)).ravel()
        gcols = np.broadcast_to(gdofs[:, None, :], (len(beams), d, d)).ravel()
        coupling = (rows >= 0) & fixed[gcols]
        beam_coupling = (rows[coupling], np.flatnonzero(coupling), gcols[coupling])

        # links: springs, dampers, friction
        def link_map(recs: list[_Record]) -> np.ndarray:
            out = np.full((len(recs), 2), -1, dtype=np.int64)
            for e, rec in enumerate(recs):
                for side in (0, 1):
                    if rec.nodes[side] >= 0:
                        out[e, side] = free[rec.nodes[side] * dpn + rec.dofs[side]]
                if out[e, 0] < 0 and out[e, 1] < 0:
                    ends = [
                        f"{node_names[nd]}.{self.dof_names[dd]}"
                        for nd, dd in zip(rec.nodes, rec.dofs, strict=True)
                        if nd >= 0
                    ]
                    raise ModelError(
                        f"{rec.kind} {rec.name!r} connects only fixed DOFs or ground "
                        f"({', '.join(ends)} fixed); it would have no effect. Remove it or "
                        "free the DOF"
                    )
            return out

        springs, dampers = by_kind.get("spring", []), by_kind.get("damper", [])
        frictions = by_kind.get("friction", [])
        spring_target, spring_keep = _scatter(link_map(springs), n)
        damper_target, damper_keep = _scatter(link_map(dampers), n)
        fr = link_map(frictions)
        # A friction element whose first end is fixed: swap ends (the law is odd, so the sign
        # of the deformation does not matter).
        swap = fr[:, 0] < 0
        fr[swap] = fr[swap][:, ::-1]
        bouc_wens = by_kind.get("bouc_wen", [])
        bw = link_map(bouc_wens)
        swap = bw[:, 0] < 0  # the Bouc–Wen law is odd in (y, z) too
        bw[swap] = bw[swap][:, ::-1]

        # lumped masses
        masses = by_kind.get("mass", [])
        trans = [j for j, name in enumerate(self.dof_names) if name.startswith("u")]
        rot = [j for j, name in enumerate(self.dof_names) if name.startswith("r")]

        def diag(js: list[int]) -> tuple[np.ndarray, np.ndarray]:
            idx = [(free[rec.nodes[0] * dpn + j], e) for e, rec in enumerate(masses) for j in js
                   if j in rec.options.get("dofs", js)]
            idx = [(i, e) for i, e in idx if i >= 0]
            arr = np.array(idx, dtype=np.int64).reshape(-1, 2)
            return arr[:, 0] * (n + 1), arr[:, 1]

        m_target, m_owner = diag(trans)
        j_target, j_owner = diag(rot)

        mass_m = self._prop(masses, "mass", "m", _NONNEG)
        mass_J = self._prop(masses, "mass", "J", _NONNEG)
        beam_props = {
            what: self._prop(
                beams, "beam", what, spec, default=1.0 if what in ("G", "kappa") else 0.0
            )
            for what, spec in _BEAM_SPECS.items()
        }
        beam_shear = np.array([rec.options["shear"] for rec in beams], dtype=np.int64)

        ray = by_kind.get("rayleigh", [])
        rayleigh = None
        if ray:
            rayleigh = (
                self._prop(ray, "Rayleigh damping", "alpha", _NONNEG),
                self._prop(ray, "Rayleigh damping", "beta", _NONNEG),
            )

        mass_const = all(beam_props[w].is_const for w in _MASS_PROPS) and (
            beam_props["E"].is_const or not np.any(beam_props["E"].pidx[beam_shear == 1] >= 0)
        )
        mass_const = mass_const and all(prop.is_const for prop in (mass_m, mass_J))
        diaphragms = None
        if self._followers:
            diaphragms = diaphragm_constraint(self._followers, [self._xyz(i) for i in
                                                                range(n_nodes)],
                                              free, node_names, labels)
            for ends, kind in ((fr, "friction element"), (bw, "Bouc–Wen element")):
                diaphragms.reindex(ends.reshape(-1), f"a {kind}")
        return _Topology(
            n=n,
            labels=labels,
            free=free,
            dof_names=np.array(dof_names),
            beam_props=beam_props,
            beam_L=length,
            beam_shear=beam_shear,
            beam_rotary=np.array([float(rec.options["rotary"]) for rec in beams]),
            beam_T=beam_t,
            beam_target=beam_target,
            beam_keep=beam_keep,
            beam_coupling=beam_coupling,
            spring_k=self._prop(springs, "spring", "k", _NONNEG),
            spring_target=spring_target,
            spring_keep=spring_keep,
            damper_c=self._prop(dampers, "damper", "c", _NONNEG),
            damper_target=damper_target,
            damper_keep=damper_keep,
            friction_i=fr[:, 0].copy(),
            friction_j=fr[:, 1].copy(),
            friction_kr=self._prop(frictions, "friction", "k_r", _NONNEG),
            friction_fu=self._prop(frictions, "friction", "f_u", _NONNEG),
            mass_m=mass_m,
            mass_J=mass_J,
            mass_m_target=m_target,
            mass_m_owner=m_owner,
            mass_J_target=j_target,
            mass_J_owner=j_owner,
            rayleigh=rayleigh,
            mass_const=mass_const,
            bouc_wen_i=bw[:, 0].copy(),
            bouc_wen_j=bw[:, 1].copy(),
            bouc_wen_props=tuple(self._prop(bouc_wens, "bouc_wen", what, _BOUC_WEN_SPECS[what])
                                 for what in BOUC_WEN_PARAMETERS),
            diaphragms=diaphragms,
        )


def _check_mass(m: np.ndarray | sp.spmatrix, labels: Sequence[str], sparse: bool) -> None:
    """Dense ``M``: positive definite (the step-by-step integrators invert it); sparse ``M``
    (the reduced path): DOFs without mass allowed, condensed there."""
    if sparse:
        check_sparse_mass(m, labels, allow_massless=True)
    else:
        check_mass_matrix(m, labels)


def _constrained(topo: _Topology, m: np.ndarray | sp.spmatrix, c: np.ndarray | sp.spmatrix,
                 k: np.ndarray | sp.spmatrix, r: np.ndarray,
                 friction: FrictionElements | None, bouc_wen: BoucWenElements | None,
                 seismic: np.ndarray | None, sparse: bool) -> System:
    """The System on the independent DOFs of a structure with rigid diaphragms."""
    floors = topo.diaphragms
    assert floors is not None
    key = "diaphragm mass sparse" if sparse else "diaphragm mass"
    cached = topo.cache.get(key)
    if cached is not None and topo.mass_const:
        mq = cached[0].copy()
    else:
        mq = floors.transform(m)
        _check_mass(mq, floors.labels, sparse)
        if topo.mass_const:
            topo.cache[key] = (mq.copy(), np.zeros(0))
    if friction is not None:
        friction = FrictionElements(floors.reindex(friction.dof_i, "friction"),
                                    floors.reindex(friction.dof_j, "friction"),
                                    friction.k_r, friction.f_u)
    if bouc_wen is not None:
        bouc_wen = BoucWenElements(floors.reindex(bouc_wen.dof_i, "Bouc–Wen"),
                                   floors.reindex(bouc_wen.dof_j, "Bouc–Wen"),
                                   bouc_wen.table, bouc_wen.names)
    return System(M=mq, C=floors.transform(c), K=floors.transform(k), r=r[floors.kept],
                  friction=friction, dof_labels=floors.labels,
                  seismic=None if seismic is None else floors.T.T @ seismic,
                  bouc_wen=bouc_wen)


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
        Per storey ``{"k", "alpha", "A", "beta", "gamma", "n"}`` (:meth:`Structure.add_bouc_wen`;
        ``alpha``, ``A`` and ``n`` may be left out), same length.
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

"""3-D frames: nodes with six DOFs, Timoshenko beam-columns, springs, masses, supports and rigid
floor diaphragms, assembled into a :class:`~femupdate.model.system.System`.

DOFs of a node: ``(ux, uy, uz, rx, ry, rz)``; ``z`` is vertical (floors lie in ``xy`` planes).

Rigid floor diaphragms. ``add_diaphragm(master, nodes)`` makes the floor rigid in its plane:
each listed node ``s`` follows the master ``m`` as

    ux_s = ux_m - (y_s - y_m) rz_m,   uy_s = uy_m + (x_s - x_m) rz_m,   rz_s = rz_m,

while its ``uz``, ``rx``, ``ry`` stay free. The constraint is applied by a transformation: all
DOFs ``u = T q``, ``q`` the independent DOFs (the slaves' ``ux, uy, rz`` are not in ``q``), and
``K_q = Tᵀ K T``, ``M_q = Tᵀ M T`` (the constrained equations are condensed exactly, as
OpenSees's ``rigidDiaphragm`` with the ``Transformation`` constraint handler does). A dedicated
master node has no stiffness of its own in ``uz, rx, ry``: fix them.

Any numeric property of a beam, mass or spring may be the name of a parameter, given at
``assemble(values)``. Assembly is dense (frames of up to a few hundred DOFs) and re-evaluates
every element: this builder is not on the compiled path of
:class:`~femupdate.model.structure.Structure`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from femupdate.errors import ModelError
from femupdate.model.elements import check_value
from femupdate.model.elements3d import frame3d_element, frame3d_rotation
from femupdate.model.system import System

__all__ = ["DOF_NAMES_3D", "Frame3D", "Frame3DModel", "null_space_dofs"]

#: DOF names of a node of a 3-D frame.
DOF_NAMES_3D: tuple[str, ...] = ("ux", "uy", "uz", "rx", "ry", "rz")
_DPN = 6
_IUX, _IUY, _IRZ = 0, 1, 5

Value = float | str
"""A numeric property: a number, or the name of a parameter given at assembly."""

_BEAM_NUMBERS = ("E", "A", "Iy", "Iz", "J", "G", "nu", "kappa_y", "kappa_z", "rho",
                 "mass_per_length", "Ip")


def _resolve(v: Value | None, values: Mapping[str, float], where: str) -> float | None:
    if not isinstance(v, str):
        return v
    if v not in values:
        raise ModelError(f"{where}: parameter {v!r} has no value; give it in values")
    return float(values[v])


def _beam_numbers(props: Mapping[str, object], values: Mapping[str, float], label: str
                  ) -> dict[str, object]:
    """Beam properties with parameters replaced by their values and ``G`` from ``nu``."""
    out = dict(props)
    for key in _BEAM_NUMBERS:
        out[key] = _resolve(props[key], values, f"{label}: {key}")  # type: ignore[arg-type]
    nu = out.pop("nu")
    if nu is not None:
        nu = check_value(label, "nu", nu, -1.0, 0.5, low_open=True)  # type: ignore[arg-type]
        out["G"] = check_value(label, "E", out["E"]) / (2.0 * (1.0 + nu))  # type: ignore[arg-type]
    return out


@dataclass(frozen=True)
class Frame3DModel:
    """An assembled 3-D frame: the free-DOF system and its coupling to the supports.

    Attributes
    ----------
    system : System
        ``M, C, K`` of the free DOFs; ``r`` and ``seismic`` for a uniform base motion along x.
    support_labels : tuple of str
        The fixed (support) DOFs, e.g. ``"A.ux"``, in the column order of the ``*_fs`` blocks.
    K_fs, M_fs, C_fs : ndarray, shape (n_free, n_support)
        Coupling of the free DOFs to the support DOFs.
    transformation : ndarray, shape (6 n_nodes, n_free + n_support)
        All nodal DOFs from the independent ones (free first, then supports): diaphragm slaves
        are rows of it.
    node_dof_labels : tuple of str
        A label per row of ``transformation`` (``"node.dof"``).
    """

    system: System
    support_labels: tuple[str, ...]
    K_fs: np.ndarray
    M_fs: np.ndarray
    C_fs: np.ndarray
    transformation: np.ndarray
    node_dof_labels: tuple[str, ...]

    def rigid_influence(self, direction: str) -> tuple[np.ndarray, np.ndarray]:
        """Free and support parts of a unit rigid translation along ``"x"``, ``"y"`` or ``"z"``."""
        if direction not in ("x", "y", "z"):
            raise ModelError(f"direction = {direction!r}; allowed 'x', 'y' or 'z'")
        n_f = self.system.n_dof
        g = np.array([lab.endswith(f".u{direction}") for lab in self.node_dof_labels], float)
        q = np.linalg.lstsq(self.transformation, g, rcond=None)[0]
        return q[:n_f], q[n_f:]

    def uniform_system(self, direction: str = "x") -> System:
        """The system for one uniform base motion along ``direction`` (``-p a_g`` load)."""
        r_f, r_s = self.rigid_influence(direction)
        s = self.system
        return System(s.M, s.C, s.K, r_f, dof_labels=s.dof_labels,
                      seismic=s.M @ r_f + self.M_fs @ r_s)


def null_space_dofs(K: np.ndarray, labels: Sequence[str], rtol: float = 1e-10) -> list[str]:
    """Labels of the DOFs taking part in the zero-energy modes of ``K`` (empty if regular).

    ``K`` is scaled by its diagonal first, so that translations and rotations compare.
    """
    d = np.sqrt(np.abs(np.diag(K)))
    d[d == 0.0] = 1.0
    ks = K / d[:, None] / d[None, :]
    w, v = np.linalg.eigh(ks)
    null = v[:, w <= rtol * max(float(np.abs(w).max()), 1e-300)]
    if null.shape[1] == 0:
        return []
    weight = np.abs(null).max(axis=1)
    return [lab for lab, wt in zip(labels, weight, strict=True) if wt > 0.1 * weight.max()]


def _check_axes(xyz1: Sequence[float], xyz2: Sequence[float], vecxz: np.ndarray,
                label: str) -> None:
    try:
        frame3d_rotation(xyz1, xyz2, vecxz)
    except ModelError as exc:
        raise ModelError(f"{label}: {str(exc).removeprefix('3-D beam: ')}") from None


class Frame3D:
    """A 3-D frame of nodes with six DOFs ``(ux, uy, uz, rx, ry, rz)``.

    Examples
    --------
    >>> f = Frame3D()
    >>> f.add_node("A", 0.0, 0.0, 0.0); f.add_node("B", 0.0, 0.0, 3.0)
    >>> f.add_beam("A", "B", E=2e11, nu=0.3, A=1e-2, Iy=1e-5, Iz=2e-5, J=3e-5, rho=7850.0,
    ...            vecxz=(1.0, 0.0, 0.0))
    'beam1'
    >>> f.fix("A")
    >>> model = f.assemble()
    """

    def __init__(self) -> None:
        self._index: dict[str, int] = {}
        self._xyz: list[tuple[float, float, float]] = []
        self._beams: list[tuple[str, int, int, dict[str, object]]] = []
        self._masses: list[tuple[int, tuple[float, ...]]] = []
        self._springs: list[tuple[int, float]] = []
        self._fixed: set[int] = set()
        self._slaves: dict[int, int] = {}  # slave node → master node
        self._rayleigh = (0.0, 0.0)

    @property
    def nodes(self) -> tuple[str, ...]:
        """Node names in the order added."""
        return tuple(self._index)

    def add_node(self, name: str, x: float, y: float = 0.0, z: float = 0.0) -> None:
        """Add a node at ``(x, y, z)``."""
        if not isinstance(name, str) or not name:
            raise ModelError(f"node name must be a non-empty string, got {name!r}")
        if name in self._index:
            raise ModelError(f"duplicate node {name!r}; node names must be unique")
        xyz = tuple(check_value(f"node {name!r}", w, v, -math.inf)
                    for w, v in (("x", x), ("y", y), ("z", z)))
        self._index[name] = len(self._xyz)
        self._xyz.append(xyz)  # type: ignore[arg-type]

    def _node(self, node: str, where: str) -> int:
        try:
            return self._index[node]
        except (KeyError, TypeError):
            raise ModelError(f"{where}: unknown node {node!r}; known nodes: "
                             f"{', '.join(self._index) or 'none yet'}") from None

    def _dof(self, dof: str, where: str) -> int:
        if dof not in DOF_NAMES_3D:
            raise ModelError(f"{where}: unknown DOF {dof!r}; allowed {DOF_NAMES_3D}")
        return DOF_NAMES_3D.index(dof)

    def add_beam(
        self, node1: str, node2: str, *, E: Value, A: Value, Iy: Value, Iz: Value, J: Value,
        vecxz: Sequence[float], G: Value | None = None, nu: Value | None = None,
        kappa_y: Value = 5 / 6, kappa_z: Value = 5 / 6, rho: Value = 0.0,
        mass_per_length: Value = 0.0, Ip: Value | None = None, rotary_inertia: bool = True,
        name: str | None = None, shear_deformation: bool = True,
        torsional_inertia: bool | None = None,
    ) -> str:
        """Add a 3-D Timoshenko beam-column (:mod:`femupdate.model.elements3d`).

        Parameters
        ----------
        node1, node2 : str
            End nodes (local x from node1 to node2).
        E, A, Iy, Iz, J : float or str
            Young's modulus, area, second moments about local y and z, torsion constant. Any
            number here and below may be a parameter name.
        vecxz : sequence of 3 floats
            A vector in the local xz plane (OpenSees ``geomTransf Linear``).
        G, nu : float
            Shear modulus or Poisson's ratio (``G = E / 2(1 + ν)``), exactly one.
        kappa_y, kappa_z : float
            Shear-area factors (``Avy = κy A``, ``Avz = κz A``).
        rho, mass_per_length : float
            Density and non-structural mass per length.
        Ip : float, optional
            Polar moment for the torsional inertia (default ``J``, as OpenSees).
        rotary_inertia : bool
            Include rotary and (unless ``torsional_inertia`` says otherwise) torsional inertia.
        shear_deformation : bool
            ``False``: Euler–Bernoulli bending (no shear deformation), ``G J`` kept.
        torsional_inertia : bool, optional
            Include the torsional inertia ``ρ Ip`` (default: as ``rotary_inertia``).
        """
        k = len(self._beams) + 1
        while name is None and f"beam{k}" in {b[0] for b in self._beams}:
            k += 1
        name = f"beam{k}" if name is None else name
        label = f"3-D beam {name!r}"
        if name in {b[0] for b in self._beams}:
            raise ModelError(f"duplicate element name {name!r}")
        if (G is None) == (nu is None):
            raise ModelError(f"{label}: give exactly one of G and nu (a 3-D frame needs torsion)")
        vec = np.asarray(vecxz, dtype=float)
        if vec.shape != (3,) or not np.all(np.isfinite(vec)):
            raise ModelError(f"{label}: vecxz = {vecxz!r}; give three finite numbers")
        n1, n2 = self._node(node1, label), self._node(node2, label)
        props = dict(E=E, A=A, Iy=Iy, Iz=Iz, J=J, G=G, nu=nu, kappa_y=kappa_y, kappa_z=kappa_z,
                     rho=rho, mass_per_length=mass_per_length, Ip=Ip,
                     rotary_inertia=rotary_inertia, vecxz=vec,
                     shear_deformation=bool(shear_deformation),
                     torsional_inertia=torsional_inertia)
        for key in _BEAM_NUMBERS:
            if props[key] == "":
                raise ModelError(f"{label}: {key} is an empty parameter name")
        if not any(isinstance(props[key], str) for key in _BEAM_NUMBERS):
            # Check now, with the element's own messages.
            frame3d_element(self._xyz[n1], self._xyz[n2], name=name,
                            **_beam_numbers(props, {}, label))  # type: ignore[arg-type]
        else:
            _check_axes(self._xyz[n1], self._xyz[n2], vec, label)
        self._beams.append((name, n1, n2, props))
        return name

    def add_mass(self, node: str, m: Value = 0.0, *, Jx: Value = 0.0, Jy: Value = 0.0,
                 Jz: Value = 0.0) -> None:
        """Add a lumped mass ``m`` on the three translations and rotary inertias ``Jx, Jy, Jz``."""
        label = f"mass at {node!r}"
        n = self._node(node, label)
        vals = tuple(v if isinstance(v, str) else check_value(label, w, v) for w, v in
                     (("m", m), ("m", m), ("m", m), ("Jx", Jx), ("Jy", Jy), ("Jz", Jz)))
        self._masses.append((n, vals))

    def add_spring(self, node: str, dof: str, k: Value) -> None:
        """Add a linear spring ``k ≥ 0`` from ``node.dof`` to the ground."""
        label = f"spring at {node}.{dof}"
        self._springs.append((self._node(node, label) * _DPN + self._dof(dof, label),
                              k if isinstance(k, str) else check_value(label, "k", k)))

    @property
    def parameters(self) -> tuple[str, ...]:
        """Parameter names used by the beams, masses and springs, in first-use order."""
        seen: dict[str, None] = {}
        for _, _, _, props in self._beams:
            for key in _BEAM_NUMBERS:
                if isinstance(props[key], str):
                    seen.setdefault(props[key], None)  # type: ignore[arg-type]
        for _, vals in self._masses:
            for v in vals:
                if isinstance(v, str):
                    seen.setdefault(v, None)
        for _, k in self._springs:
            if isinstance(k, str):
                seen.setdefault(k, None)
        return tuple(seen)

    def fix(self, node: str, *dofs: str) -> None:
        """Fix (support) the given DOFs of ``node``; all six when none is given."""
        n = self._node(node, "fix")
        for d in dofs or DOF_NAMES_3D:
            self._fixed.add(n * _DPN + self._dof(d, f"fix({node!r})"))

    def add_diaphragm(self, master: str, nodes: Sequence[str]) -> None:
        """Make a floor rigid in its (horizontal) plane: ``nodes`` follow ``master`` in ux, uy, rz.

        The nodes must lie at the master's height ``z``; a node can belong to one diaphragm.
        """
        label = f"diaphragm of {master!r}"
        m = self._node(master, label)
        if m in self._slaves:
            raise ModelError(f"{label}: {master!r} already follows another diaphragm's master")
        for node in nodes:
            s = self._node(node, label)
            if s == m:
                raise ModelError(f"{label}: the master cannot be one of its own nodes")
            if s in self._slaves or s in self._slaves.values():
                raise ModelError(f"{label}: node {node!r} is already in a diaphragm")
            dz = self._xyz[s][2] - self._xyz[m][2]
            if abs(dz) > 1e-9 * max(1.0, abs(self._xyz[m][2])):
                raise ModelError(f"{label}: node {node!r} is at z = {self._xyz[s][2]!r}, not at "
                                 f"the master's z = {self._xyz[m][2]!r}")
            self._slaves[s] = m

    def set_rayleigh(self, alpha: float = 0.0, beta: float = 0.0) -> None:
        """Rayleigh damping ``C = α M + β K`` (of the independent DOFs)."""
        self._rayleigh = (check_value("Rayleigh damping", "alpha", alpha),
                          check_value("Rayleigh damping", "beta", beta))

    # ------------------------------------------------------------------ assembly

    def _transformation(self) -> tuple[np.ndarray, list[int]]:
        """``T`` (n_global × n_independent) and the global DOF of each independent column."""
        n_global = len(self._xyz) * _DPN
        dependent = {s * _DPN + j for s in self._slaves for j in (_IUX, _IUY, _IRZ)}
        for g in sorted(dependent & self._fixed):
            raise ModelError(f"diaphragm: {self._label(g)} is both fixed and constrained to its "
                             "master; fix the master instead")
        indep = [g for g in range(n_global) if g not in dependent]
        col = {g: c for c, g in enumerate(indep)}
        t = np.zeros((n_global, len(indep)))
        t[indep, range(len(indep))] = 1.0
        for s, m in self._slaves.items():
            dx = self._xyz[s][0] - self._xyz[m][0]
            dy = self._xyz[s][1] - self._xyz[m][1]
            ux, uy, rz = (col[m * _DPN + j] for j in (_IUX, _IUY, _IRZ))
            t[s * _DPN + _IUX, [ux, rz]] = (1.0, -dy)
            t[s * _DPN + _IUY, [uy, rz]] = (1.0, dx)
            t[s * _DPN + _IRZ, rz] = 1.0
        return t, indep

    def _label(self, g: int) -> str:
        return f"{self.nodes[g // _DPN]}.{DOF_NAMES_3D[g % _DPN]}"

    def assemble(self, values: Mapping[str, float] | None = None) -> Frame3DModel:
        """Assemble ``M``, ``C``, ``K`` of the free DOFs and their coupling to the supports.

        Parameters
        ----------
        values : mapping, optional
            A value for every name in :attr:`parameters`.

        Raises
        ------
        ModelError
            With no node or no free DOF, a parameter without value or out of range, or when the
            frame is a mechanism (singular ``K``): the message names the free DOFs of the
            zero-energy modes.
        """
        values = {} if values is None else values
        if not self._xyz:
            raise ModelError("the 3-D frame has no nodes; add_node first")
        unknown = sorted(set(values) - set(self.parameters))
        if unknown:
            raise ModelError(f"unknown parameter(s) {', '.join(map(repr, unknown))}; this frame "
                             f"uses {self.parameters}")
        n_global = len(self._xyz) * _DPN
        k_g = np.zeros((n_global, n_global))
        m_g = np.zeros((n_global, n_global))
        for name, n1, n2, props in self._beams:
            k_e, m_e = frame3d_element(self._xyz[n1], self._xyz[n2], name=name,
                                       **_beam_numbers(props, values, f"3-D beam {name!r}"))
            idx = np.r_[n1 * _DPN:(n1 + 1) * _DPN, n2 * _DPN:(n2 + 1) * _DPN]
            k_g[np.ix_(idx, idx)] += k_e
            m_g[np.ix_(idx, idx)] += m_e
        for n, raw in self._masses:
            where = f"mass at {self.nodes[n]!r}"
            vals = [check_value(where, w, _resolve(v, values, where))  # type: ignore[arg-type]
                    for w, v in zip(("m", "m", "m", "Jx", "Jy", "Jz"), raw, strict=True)]
            m_g[range(n * _DPN, (n + 1) * _DPN), range(n * _DPN, (n + 1) * _DPN)] += vals
        for g, k in self._springs:
            where = f"spring at {self._label(g)}"
            k_g[g, g] += check_value(where, "k", _resolve(k, values, where))  # type: ignore[arg-type]
        t, indep = self._transformation()
        free = [c for c, g in enumerate(indep) if g not in self._fixed]
        sup = [c for c, g in enumerate(indep) if g in self._fixed]
        if not free:
            raise ModelError("every DOF of the 3-D frame is fixed; it has no free DOF")
        order = free + sup
        t = t[:, order]
        k_q, m_q = t.T @ k_g @ t, t.T @ m_g @ t
        alpha, beta = self._rayleigh
        c_q = alpha * m_q + beta * k_q
        nf = len(free)
        labels = tuple(self._label(indep[c]) for c in free)
        k_ff = k_q[:nf, :nf]
        loose = null_space_dofs(k_ff, labels)
        if loose:
            raise ModelError(f"the 3-D frame is a mechanism (singular stiffness); free DOFs in "
                             f"its zero-energy modes: {', '.join(loose)}. Add supports, "
                             "springs or beams there")
        m_ff = m_q[:nf, :nf]
        if np.any(np.diag(m_ff) <= 0.0) or np.linalg.eigvalsh(m_ff).min() <= 0.0:
            massless = [lab for lab, v in zip(labels, np.diag(m_ff), strict=True) if v <= 0.0]
            raise ModelError("the 3-D frame's mass matrix is not positive definite; DOFs "
                             f"without mass: {', '.join(massless) or 'none (check the masses)'}")
        all_labels = tuple(self._label(g) for g in range(n_global))
        model = Frame3DModel(
            system=System(m_ff, c_q[:nf, :nf], k_ff, np.zeros(nf), dof_labels=labels),
            support_labels=tuple(self._label(indep[c]) for c in sup),
            K_fs=k_q[:nf, nf:], M_fs=m_q[:nf, nf:], C_fs=c_q[:nf, nf:],
            transformation=t, node_dof_labels=all_labels,
        )
        r_f, r_s = model.rigid_influence("x")
        sys_x = System(m_ff, c_q[:nf, :nf], k_ff, r_f, dof_labels=labels,
                       seismic=m_ff @ r_f + model.M_fs @ r_s)
        return Frame3DModel(sys_x, model.support_labels, model.K_fs, model.M_fs, model.C_fs,
                            t, all_labels)

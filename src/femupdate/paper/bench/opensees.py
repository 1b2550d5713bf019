"""OpenSeesPy as a peer: the same structure built in OpenSees, for cross-checks and timing.

femupdate's integrators are checked against closed-form solutions; this module checks them
against an independent, widely used code as well. :class:`OpenSeesPeer` builds a ``[model]``
table (the paper's bridge, or any model of the same kind) in OpenSees so that its equations are
ours, term by term:

- the deck: ``ElasticTimoshenkoBeam`` (2-D) elements with ``-cMass``, whose consistent mass
  (interdependent shape functions, translational and rotary inertia) and stiffness are those of
  :mod:`femupdate.model.elements`, with ``G`` from ``nu`` and ``Avy = κA``; the axial DOF of
  every node is fixed (our nodes have ``(uy, rz)`` only);
- springs: ``zeroLength`` elements with an ``Elastic`` material; viscous dampers: ``Elastic``
  with ``E = 0`` and damping tangent ``eta = c``; elasto-slip dampers: ``ElasticPP`` with
  ``E = k_r`` and yield deformation ``f_u / k_r`` (elastic-perfectly-plastic is exactly the
  Jenkins element); all against fixed ground nodes, or between two nodes;
- lumped masses on the nodes (``m`` on the translations, ``J`` on the rotation).

:meth:`OpenSeesPeer.matrices` reads the assembled ``M``, ``C``, ``K`` back from OpenSees
(``GimmeMCK``): they equal femupdate's to rounding.

The base motion. ``UniformExcitation`` counts the mass of the Timoshenko beams twice in its load
(OpenSeesPy 3.7.1.2, 2-D and 3-D ``ElasticTimoshenkoBeam`` with ``-cMass``; the 2-D
``elasticBeamColumn`` with ``-mass`` does the same): the static response to a constant ``a_g`` is
``K⁻¹ (M + M_beam) r a_g``, 44 % too large on the bridge, while ``M`` itself is right. So the
default excitation (``excitation="nodal"``) applies the load of the relative-motion equations,
``-M r a_g(t)``, as nodal forces in a ``Plain`` pattern, with ``M`` as OpenSees assembled it;
``excitation="uniform"`` runs ``UniformExcitation`` as it is, to show the defect.

Time histories take the base acceleration as a ``Path`` time series (linear between samples, as
in femupdate): Newmark's average acceleration, or central differences, each with ``substeps``
steps per sample, ``Linear`` algorithm with ``-factorOnce`` (the iteration matrix is constant for
both; the elasto-slip forces are explicit in central differences). Both codes start from rest;
OpenSees starts with zero acceleration and ``u_{-1} = u_0``, femupdate with the acceleration of
the equations at ``t = 0``: the two agree when ``a_g(0) = 0`` (an accelerogram starts from zero).

OpenSees has one domain per process: building a peer wipes whatever model was there, and a peer
whose domain was wiped by another is rebuilt before it runs.
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Mapping, Sequence
from types import ModuleType

import numpy as np

from femupdate.case import Model
from femupdate.errors import (
    ConfigError,
    DataError,
    ModelError,
    SimulationError,
)
from femupdate.external.openseespy import OPENSEES_EXTRA, import_opensees
from femupdate.model.system import System
from femupdate.problem.case_model import build_structure

__all__ = ["OPENSEES_EXTRA", "OPENSEES_METHODS", "OpenSeesPeer", "import_opensees"]

#: Integrators of :meth:`OpenSeesPeer.run`, named as femupdate's.
OPENSEES_METHODS: tuple[str, ...] = ("newmark", "central_difference")

_DIRECTION = {"uy": 2, "rz": 3}  # OpenSees DOF numbers of a 2-D node (ux, uy, rz) = (1, 2, 3)
_SERIES_TAG = 1
_PATTERN_TAG = 1
_builds = itertools.count(1)  # build counter: tells a peer whether the domain is still its own
_live_build = [0]


def _resolve(value: float | str, values: Mapping[str, float]) -> float:
    """A model number, or the value of the parameter it names (already checked by assembly)."""
    return float(values[value]) if isinstance(value, str) else float(value)


def _check_supported(model: Model) -> None:
    """Raise ModelError for what the OpenSees translation does not reproduce exactly."""
    problems = []
    if model.shear_building is not None:
        problems.append("model.shear_building (build it with nodes and springs instead)")
    if model.dofs_per_node != 2:
        problems.append(f"dofs_per_node = {model.dofs_per_node} (only 2: uy, rz)")
    if model.excitation_direction != "y":
        problems.append(f"direction = {model.excitation_direction!r} (only 'y')")
    if model.rayleigh is not None:
        problems.append("model.rayleigh")
    if model.bouc_wen:
        problems.append("model.bouc_wen (not translated)")
    if model.supports:
        problems.append("model.supports (the nodal base-motion load covers free DOFs only)")
    for node in model.nodes:
        if node.y != 0.0:
            problems.append(f"node {node.name!r} at y = {node.y} (the deck lies along x, y = 0)")
    for i, beam in enumerate(model.beams):
        label = beam.name or f"model.beams[{i}]"
        if beam.mass_per_length != 0.0:
            problems.append(f"beam {label!r}: mass_per_length (OpenSees adds its rotary inertia)")
        if not beam.rotary_inertia:
            problems.append(f"beam {label!r}: rotary_inertia = false (OpenSees always has it)")
    for kind, links in (("springs", model.springs), ("dampers", model.dampers),
                        ("frictions", model.frictions)):
        for i, link in enumerate(links):
            if link.node2 is not None and link.second_dof != link.dof:
                problems.append(f"model.{kind}[{i}]: {link.dof} to {link.second_dof} "
                                "(zeroLength links equal DOFs only)")
    if problems:
        raise ModelError("the OpenSees peer cannot build this model exactly: "
                         + "; ".join(problems))


class OpenSeesPeer:
    """A ``[model]`` table built in OpenSees, with femupdate's DOF order for its results.

    Parameters
    ----------
    model : femupdate.case.Model
        A validated model with 2 DOFs per node (uy, rz), nodes along x, base motion in y.
    values : mapping of str to float
        Parameter values, as for ``Structure.assemble`` (checked by it).
    ops : module, optional
        ``openseespy.opensees`` (default: :func:`import_opensees`).

    Attributes
    ----------
    system : System
        femupdate's assembly of the same model and values (the reference).
    dof_labels : tuple of str
        Labels of the free DOFs (``"P1.uy"``): the columns of every result.

    Raises
    ------
    ModelError
        For models the translation does not reproduce exactly (names the feature), or values
        out of range.
    MissingDependencyError
        When openseespy is not available.
    """

    def __init__(self, model: Model, values: Mapping[str, float], *,
                 ops: ModuleType | None = None) -> None:
        _check_supported(model)
        self.ops = import_opensees() if ops is None else ops
        self.model = model
        self.values = dict(values)
        self.system: System = build_structure(model).assemble(self.values, direction="y")
        self.dof_labels: tuple[str, ...] = self.system.dof_labels
        self._tags = {node.name: i + 1 for i, node in enumerate(model.nodes)}
        self._dofs = []  # (node tag, OpenSees DOF) of each of our free DOFs
        for label in self.dof_labels:
            node, dof = label.rsplit(".", 1)
            self._dofs.append((self._tags[node], _DIRECTION[dof]))
        self._build_id = 0
        self.build()

    # ------------------------------------------------------------------ the model

    def build(self) -> None:
        """Wipe the OpenSees domain and build this model in it (about 0.15 ms).

        OpenSees's messages go to ``os.devnull`` from here on, for the whole process (it warns
        on stderr at the start of every central-difference run); failures still raise.
        """
        ops, model, values = self.ops, self.model, self.values
        ops.wipe()
        ops.logFile(os.devnull, "-noEcho")  # OpenSees warns on stderr at every CD start
        ops.model("basic", "-ndm", 2, "-ndf", 3)
        n = len(model.nodes)
        for node in model.nodes:
            ops.node(self._tags[node.name], node.x, 0.0)
        for node in model.nodes:
            ops.fix(self._tags[node.name], 1, 0, 0)  # axial DOF: not in the model
        ground: dict[str, int] = {}

        def other_end(link_node2: str | None, node: str) -> int:
            if link_node2 is not None:
                return self._tags[link_node2]
            if node not in ground:  # a fixed node at the same place
                ground[node] = 2 * n + len(ground) + 1
                x = next(nd.x for nd in model.nodes if nd.name == node)
                ops.node(ground[node], x, 0.0)
                ops.fix(ground[node], 1, 1, 1)
            return ground[node]

        ops.geomTransf("Linear", 1)
        for i, beam in enumerate(model.beams):
            E = _resolve(beam.E, values)
            A, I = _resolve(beam.A, values), _resolve(beam.I, values)  # noqa: E741
            if beam.G is not None:
                G = _resolve(beam.G, values)
            elif beam.nu is not None:
                G = E / (2.0 * (1.0 + _resolve(beam.nu, values)))
            else:
                G = 1e300  # rigid in shear: Φ = 0 to rounding
            mu = _resolve(beam.rho, values) * A
            i_node, j_node = (self._tags[nd] for nd in beam.nodes)
            ops.element("ElasticTimoshenkoBeam", i + 1, i_node, j_node, E, G, A, I,
                        _resolve(beam.kappa, values) * A, 1, "-mass", mu, "-cMass")
        tag = len(model.beams) + 1
        links: list[tuple[str, str | None, str, str, list[float]]] = []
        for s in model.springs:
            k = _resolve(s.k, values)
            if k > 0.0:
                links.append((s.node, s.node2, s.dof, "Elastic", [k]))
        for d in model.dampers:
            c = _resolve(d.c, values)
            if c > 0.0:
                links.append((d.node, d.node2, d.dof, "Elastic", [0.0, c]))
        for f in model.frictions:
            k_r, f_u = _resolve(f.k_r, values), _resolve(f.f_u, values)
            if k_r > 0.0 and f_u > 0.0:  # otherwise the element carries no force
                if np.isinf(f_u):
                    links.append((f.node, f.node2, f.dof, "Elastic", [k_r]))
                else:
                    links.append((f.node, f.node2, f.dof, "ElasticPP", [k_r, f_u / k_r]))
        for node, node2, dof, material, args in links:
            ops.uniaxialMaterial(material, tag, *args)
            ops.element("zeroLength", tag, other_end(node2, node), self._tags[node],
                        "-mat", tag, "-dir", _DIRECTION[dof])
            tag += 1
        for mass in model.masses:
            m, J = _resolve(mass.m, values), _resolve(mass.J, values)
            ops.mass(self._tags[mass.node], m, m, J)
        self._build_id = next(_builds)
        _live_build[0] = self._build_id
        r = np.array([1.0 if d == _DIRECTION["uy"] else 0.0 for _, d in self._dofs])
        self._seismic = self._assembled(1.0, 0.0, 0.0) @ r  # p of the load -p a_g(t)

    def _ensure_built(self) -> None:
        if _live_build[0] != self._build_id:
            self.build()

    def _equations(self) -> np.ndarray:
        """OpenSees equation number of each of our free DOFs (after an analysis is set up)."""
        return np.array([self.ops.nodeDOFs(t)[d - 1] for t, d in self._dofs], dtype=np.int64)

    def _assembled(self, m: float, c: float, k: float) -> np.ndarray:
        """``m M + c C + k K`` as OpenSees assembles it (``GimmeMCK``), in our DOF order."""
        ops = self.ops
        ops.wipeAnalysis()
        ops.constraints("Plain")
        ops.numberer("Plain")
        ops.system("FullGeneral")
        ops.algorithm("Linear")
        ops.integrator("GimmeMCK", m, c, k)
        ops.analysis("Transient")
        ops.analyze(1, 0.0)
        a = np.asarray(ops.printA("-ret"), dtype=float)
        eq = self._equations()
        ops.wipeAnalysis()
        size = round(float(np.sqrt(a.size)))
        if np.any(eq < 0) or size != eq.size:
            raise ModelError(f"OpenSees numbered {size} equations for {eq.size} free DOFs")
        return a.reshape(size, size)[np.ix_(eq, eq)]

    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``M``, ``C``, ``K`` as OpenSees assembles them, in femupdate's DOF order.

        ``K`` is the initial tangent (elasto-slip elements stuck).
        """
        self._ensure_built()
        return self._assembled(1.0, 0.0, 0.0), self._assembled(0.0, 1.0, 0.0), \
            self._assembled(0.0, 0.0, 1.0)

    def frequencies(self, n_modes: int | None = None) -> np.ndarray:
        """Undamped natural frequencies (Hz) from OpenSees's ``eigen`` (full LAPACK solver).

        Parameters
        ----------
        n_modes : int, optional
            Number of lowest modes, 1 to the number of free DOFs (default all).
        """
        n = len(self.dof_labels)
        n_modes = n if n_modes is None else n_modes
        if isinstance(n_modes, bool) or not isinstance(n_modes, int) or not 1 <= n_modes <= n:
            raise ConfigError(f"n_modes = {n_modes!r} is out of range; allowed 1 to {n}")
        self._ensure_built()
        self.ops.wipeAnalysis()
        w2 = np.asarray(self.ops.eigen("-fullGenLapack", n_modes), dtype=float)
        return np.sqrt(np.clip(w2, 0.0, None)) / (2.0 * np.pi)

    # ------------------------------------------------------------------ time histories

    def run(self, ag: np.ndarray, dt: float, *, method: str = "newmark", substeps: int = 1,
            outputs: Sequence[int] | None = None, excitation: str = "nodal") -> np.ndarray:
        """Displacements relative to the base under the base acceleration ``ag``, from rest.

        Parameters
        ----------
        ag : ndarray (n_samples,)
            Base acceleration every ``dt``, linear in between (m/s²).
        dt : float
            Sample interval (s), > 0.
        method : {"newmark", "central_difference"}
            Newmark's average acceleration (γ = ½, β = ¼) or central differences.
        substeps : int
            Integration steps per sample, >= 1.
        outputs : sequence of int, optional
            Indices into :attr:`dof_labels` (default all).
        excitation : {"nodal", "uniform"}
            ``"nodal"``: the load ``-M r a_g`` as nodal forces (exact); ``"uniform"``:
            OpenSees's ``UniformExcitation``, which counts the beam mass twice in the load.

        Returns
        -------
        ndarray (n_samples, n_outputs)
            Displacement at every sample, the first one at rest.

        Raises
        ------
        SimulationError
            If OpenSees fails a step or the solution overflows (central differences beyond
            their stable step).
        """
        if method not in OPENSEES_METHODS:
            raise ConfigError(f"method = {method!r} is unknown for OpenSees; choose one of "
                              f"{', '.join(OPENSEES_METHODS)}")
        if excitation not in ("nodal", "uniform"):
            raise ConfigError(f"excitation = {excitation!r}; choose 'nodal' or 'uniform'")
        if isinstance(substeps, bool) or not isinstance(substeps, int) or substeps < 1:
            raise ConfigError(f"substeps = {substeps!r} must be an integer >= 1")
        if not (isinstance(dt, int | float) and np.isfinite(dt) and dt > 0.0):
            raise ConfigError(f"dt = {dt!r} is not allowed; it must be finite and > 0 (s)")
        ag = np.asarray(ag, dtype=float)
        if ag.ndim != 1 or ag.size < 2:
            raise DataError(f"ag has shape {ag.shape}; expected (n_samples,) with n_samples >= 2")
        if not np.all(np.isfinite(ag)):
            raise DataError(f"ag contains NaN or inf at sample {int(np.argmin(np.isfinite(ag)))}")
        n_dof = len(self.dof_labels)
        out = np.arange(n_dof) if outputs is None else np.asarray(outputs, dtype=np.int64)
        if out.ndim != 1 or out.size == 0 or np.any((out < 0) | (out >= n_dof)):
            raise ConfigError(f"outputs = {outputs!r}; allowed DOF indices 0 to {n_dof - 1}")
        self._ensure_built()
        ops = self.ops
        ops.wipeAnalysis()
        ops.reset()
        ops.setTime(0.0)
        # Path returns 0 at and beyond its last point: repeat the last sample once.
        ops.timeSeries("Path", _SERIES_TAG, "-dt", float(dt), "-values",
                       *np.append(ag, ag[-1]).tolist())
        if excitation == "uniform":
            ops.pattern("UniformExcitation", _PATTERN_TAG, 2, "-accel", _SERIES_TAG)
        else:
            ops.pattern("Plain", _PATTERN_TAG, _SERIES_TAG, "-fact", -1.0)
            loads: dict[int, list[float]] = {}
            for (tag, d), p in zip(self._dofs, self._seismic, strict=True):
                loads.setdefault(tag, [0.0, 0.0, 0.0])[d - 1] = float(p)
            for tag, load in loads.items():
                ops.load(tag, *load)
        ops.constraints("Plain")
        ops.numberer("Plain")
        ops.system("BandGeneral")
        ops.algorithm("Linear", "-factorOnce")
        if method == "newmark":
            ops.integrator("Newmark", 0.5, 0.25)
        else:
            ops.integrator("CentralDifference")
        ops.analysis("Transient")
        try:
            disp = _march(ops, [self._dofs[i] for i in out], ag.size, float(dt) / substeps,
                          substeps)
        finally:
            ops.wipeAnalysis()
            ops.remove("loadPattern", _PATTERN_TAG)
            ops.remove("timeSeries", _SERIES_TAG)
            ops.reset()
        if disp is None or not np.all(np.isfinite(disp)):
            raise SimulationError(
                f"OpenSees {method} with {substeps} substeps failed or overflowed; central "
                "differences need h = dt/substeps below 2/ω_max")
        return disp


def _march(ops: ModuleType, dofs: Sequence[tuple[int, int]], n_samples: int, h: float,
           substeps: int) -> np.ndarray | None:
    """Step OpenSees through the samples, reading the displacements; None if a step fails."""
    disp = np.zeros((n_samples, len(dofs)))
    analyze, node_disp = ops.analyze, ops.nodeDisp
    for k in range(1, n_samples):
        if analyze(substeps, h) != 0:
            return None
        row = disp[k]
        for j, (tag, d) in enumerate(dofs):
            row[j] = node_disp(tag, d)
    return disp

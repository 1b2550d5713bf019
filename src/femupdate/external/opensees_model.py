"""A model built in OpenSeesPy by the user's script or function.

The user's code builds the model (nodes, elements, masses, damping) from the parameter values;
femupdate wipes the domain before every build, runs the transient analysis under the base motion
(a ``Path`` time series, linear between samples), records the output DOFs and reads the
natural frequencies from OpenSees's eigen solver.

The base motion is applied one of two ways:

- ``excitation="uniform"``: OpenSees's ``UniformExcitation``. Some elements count their own
  mass twice in its load: ``ElasticTimoshenkoBeam`` (2-D, ``-mass`` with or without
  ``-cMass``) and the 2-D ``elasticBeamColumn`` with ``-mass`` (OpenSeesPy 3.7.1.2). So
  before the first analysis in a process the load is checked: one tiny step under a unit
  step of base acceleration from rest must give every output the relative acceleration
  ``-r`` (``-1`` along the motion); otherwise a ConfigError stops the run and says to use
  ``"nodal"`` (switch the check off with ``check_base_load=False`` when the model has mass
  coupled to supports, where ``-r`` is not expected).
- ``excitation="nodal"``: the load of the relative-motion equations, ``-M r a_g(t)``, as nodal
  forces, ``M`` as OpenSees assembles it (``GimmeMCK``) and ``r`` the unit vector of the
  direction on every free DOF. Exact for any element mass, but mass coupled by elements to
  constrained DOFs (a consistent-mass beam on a fixed node) gets no load.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from types import CodeType, ModuleType
from typing import Any

import numpy as np

from femupdate.errors import ConfigError
from femupdate.external.loader import CodeRef, compile_script, load_function, parse_ref
from femupdate.external.protocol import EvaluationError
from femupdate.external.python_model import check_quantity

__all__ = ["EXCITATIONS", "OpenSeesModel"]

EXCITATIONS: tuple[str, ...] = ("uniform", "nodal")
ALGORITHMS: tuple[str, ...] = ("newton", "linear")
#: Tags of femupdate's time series and load pattern, clear of the user's usual small tags.
_SERIES_TAG = 900_001
_PATTERN_TAG = 900_001
#: Time step of the base-load check: stiffness and damping act by (ω h)², negligible.
_CHECK_STEP = 1e-8
_CHECK_TOL = 1e-3


def _check_outputs(outputs: Sequence[Sequence[int]], field: str) -> tuple[tuple[int, int], ...]:
    allowed = "a list of [node tag, dof] pairs, dof from 1"
    if isinstance(outputs, str) or not isinstance(outputs, Sequence) or not outputs:
        raise ConfigError(f"{field}: got {outputs!r}: no outputs (allowed: {allowed})")
    pairs = []
    for i, pair in enumerate(outputs):
        ok = (isinstance(pair, Sequence) and not isinstance(pair, str) and len(pair) == 2
              and all(isinstance(v, int | np.integer) and not isinstance(v, bool)
                      for v in pair) and pair[1] >= 1)
        if not ok:
            raise ConfigError(f"{field}[{i}]: got {pair!r} (allowed: {allowed})")
        pairs.append((int(pair[0]), int(pair[1])))
    if len(set(pairs)) != len(pairs):
        raise ConfigError(f"{field}: got {pairs!r}: an output repeated (allowed: {allowed}, "
                          "each once)")
    return tuple(pairs)


def _positive_int(value: Any, field: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ConfigError(f"{field}: got {value!r} (allowed: an integer >= 1)")
    return value


def _choice(value: str, field: str, allowed: tuple[str, ...]) -> str:
    if value not in allowed:
        raise ConfigError(f"{field}: got {value!r} (allowed: {', '.join(map(repr, allowed))})")
    return value


class OpenSeesModel:
    """An OpenSeesPy model built by the user's code, analysed by femupdate.

    Parameters
    ----------
    build : str
        ``"package.module:function"`` or ``"path/to/file.py:function"``, called as
        ``function(values)``; or a script ``"path/to/file.py"``, run with the values in its
        global ``params``. It builds the model with ``openseespy.opensees`` (imported as usual;
        femupdate preloads the BLAS its Linux wheel needs) and runs no transient analysis.
    outputs : sequence of (int, int)
        (node tag, DOF number from 1) of each output, as the model knows them.
    quantity : {"acceleration", "displacement"}
        Record absolute accelerations (relative ones plus the base's) or displacements relative
        to the base.
    direction : int
        DOF number of the base motion (1: x, 2: y, ...).
    excitation : {"uniform", "nodal"}
        How the base motion loads the model (see the module notes).
    substeps : int
        Newmark (average acceleration) steps per sample.
    algorithm : {"newton", "linear"}
        ``"newton"`` with a ``NormDispIncr`` test (any model); ``"linear"``: one factorisation
        for the whole analysis (linear models only, several times faster).
    tolerance, max_iterations : float, int
        Of the Newton convergence test.
    system, constraints : str
        OpenSees's ``system`` and ``constraints`` handlers.
    n_modes : int
        Natural frequencies to compute.
    eigen_solver : str
        ``"-genBandArpack"`` (fewer modes than DOFs) or ``"-fullGenLapack"`` (small models).
    check_base_load : bool
        With ``"uniform"``, check the base load once per process (module notes).
    base_dir : path or None
        Folder of a relative file (the case file's folder).
    field : str
        Prefix of the case-file fields in messages.
    """

    def __init__(self, build: str, outputs: Sequence[Sequence[int]], *,
                 quantity: str = "acceleration", direction: int = 1,
                 excitation: str = "uniform", substeps: int = 1, algorithm: str = "newton",
                 tolerance: float = 1e-10, max_iterations: int = 25,
                 system: str = "BandGeneral", constraints: str = "Plain", n_modes: int = 6,
                 eigen_solver: str = "-genBandArpack", check_base_load: bool = True,
                 base_dir: str | Path | None = None, field: str = "model") -> None:
        self.ref: CodeRef = parse_ref(build, field=f"{field}.build", base_dir=base_dir,
                                      script_allowed=True)
        self.outputs_field = f"{field}.outputs"
        self.dofs = _check_outputs(outputs, self.outputs_field)
        self.outputs = tuple(f"{node}.{dof}" for node, dof in self.dofs)
        self.quantity = check_quantity(quantity, f"{field}.quantity")
        self.direction = _positive_int(direction, f"{field}.direction")
        self.excitation = _choice(excitation, f"{field}.excitation", EXCITATIONS)
        self.substeps = _positive_int(substeps, f"{field}.substeps")
        self.algorithm = _choice(algorithm, f"{field}.algorithm", ALGORITHMS)
        if not (isinstance(tolerance, int | float) and 0 < tolerance < 1):
            raise ConfigError(f"{field}.tolerance: got {tolerance!r} (allowed: (0, 1))")
        self.tolerance = float(tolerance)
        self.max_iterations = _positive_int(max_iterations, f"{field}.max_iterations")
        self.system, self.constraints = str(system), str(constraints)
        self.n_modes = _positive_int(n_modes, f"{field}.n_modes")
        self.eigen_solver = _choice(eigen_solver, f"{field}.eigen_solver",
                                    ("-genBandArpack", "-fullGenLapack", "-symmBandLapack"))
        self.check_base_load = bool(check_base_load)
        self._influence = np.array([1.0 if d == self.direction else 0.0 for _, d in self.dofs])
        self._ops: ModuleType | None = None
        self._builder: Callable[[Mapping[str, float]], None] | None = None
        self._checked = False

    @property
    def influence(self) -> np.ndarray:
        return self._influence.copy()

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_ops": None, "_builder": None, "_checked": False}

    def __repr__(self) -> str:
        return f"OpenSeesModel({self.ref.text!r}, outputs={[list(d) for d in self.dofs]!r})"

    # ------------------------------------------------------------------ loading

    def prepare(self) -> None:
        """Import OpenSeesPy (MissingDependencyError naming the extra) and the user's code."""
        if self._builder is not None:
            return
        from femupdate.external.openseespy import import_opensees

        self._ops = import_opensees()  # before the user's module imports openseespy
        if self.ref.function is not None:
            self._builder = load_function(self.ref)
        else:
            self._builder = _script_runner(compile_script(self.ref), self.ref.path)

    def _build(self, values: Mapping[str, float]) -> ModuleType:
        """A fresh domain, built by the user's code."""
        self.prepare()
        ops = self._ops
        assert ops is not None and self._builder is not None
        ops.wipe()
        try:
            self._builder(dict(values))
        except Exception as exc:
            raise EvaluationError(f"building the OpenSees model ({self.ref.text}) raised "
                                  f"{type(exc).__name__}: {exc}") from exc
        ops.wipeAnalysis()
        # OpenSees's own warnings go to the process's stderr, which the worker keeps.
        return ops

    # ------------------------------------------------------------------ frequencies

    def frequencies(self, values: Mapping[str, float]) -> np.ndarray:
        """The ``n_modes`` lowest undamped natural frequencies (Hz) from ``eigen``."""
        ops = self._build(values)
        try:
            w2 = np.asarray(ops.eigen(self.eigen_solver, self.n_modes), dtype=float)
        except Exception as exc:
            raise EvaluationError(f"OpenSees eigen({self.eigen_solver}, {self.n_modes}) "
                                  f"failed: {exc}") from exc
        finally:
            ops.wipe()
        return np.sqrt(np.clip(w2, 0.0, None)) / (2.0 * math.pi)

    # ------------------------------------------------------------------ time history

    def predict(self, values: Mapping[str, float], ag: np.ndarray, dt: float) -> np.ndarray:
        """Absolute accelerations or relative displacements at the outputs, (len(ag), k)."""
        ag = np.asarray(ag, dtype=float)
        if self.excitation == "uniform" and self.check_base_load and not self._checked:
            self._check_uniform_load(values)
        ops = self._build(values)
        try:
            self._check_outputs_exist(ops)
            self._apply_base_motion(ops, ag, dt)
            self._analysis(ops)
            relative = self._march(ops, ag.size, dt)
        finally:
            ops.wipe()
        if self.quantity == "acceleration":
            return relative + np.outer(ag, self._influence)
        return relative

    def _check_outputs_exist(self, ops: ModuleType) -> None:
        tags = set(ops.getNodeTags())
        for node, dof in self.dofs:
            if node not in tags:
                raise ConfigError(f"{self.outputs_field}: got node {node}: the model built by "
                                  f"{self.ref.text} has no such node (allowed: its nodes "
                                  f"{sorted(tags)[:20]})")
            ndf = len(ops.nodeDisp(node))  # nodeDOFs needs an analysis set up
            if dof > ndf:
                raise ConfigError(f"{self.outputs_field}: got DOF {dof} of node {node}, which "
                                  f"has {ndf} (allowed: 1 to {ndf})")

    def _apply_base_motion(self, ops: ModuleType, ag: np.ndarray, dt: float) -> None:
        loads = (_seismic_loads(ops, self.direction, self.constraints)
                 if self.excitation == "nodal" else {})
        ops.setTime(0.0)
        # Path gives 0 past its last point: the last sample is repeated for rounding in time.
        ops.timeSeries("Path", _SERIES_TAG, "-dt", float(dt), "-values",
                       *np.append(ag, ag[-1]).tolist())
        if self.excitation == "uniform":
            ops.pattern("UniformExcitation", _PATTERN_TAG, self.direction, "-accel", _SERIES_TAG)
            return
        ops.pattern("Plain", _PATTERN_TAG, _SERIES_TAG, "-fact", -1.0)
        for node, load in loads.items():
            ops.load(node, *load)

    def _analysis(self, ops: ModuleType) -> None:
        ops.constraints(self.constraints)
        ops.numberer("RCM")
        ops.system(self.system)
        if self.algorithm == "linear":
            ops.algorithm("Linear", "-factorOnce")
        else:
            ops.test("NormDispIncr", self.tolerance, self.max_iterations)
            ops.algorithm("Newton")
        ops.integrator("Newmark", 0.5, 0.25)
        ops.analysis("Transient")

    def _march(self, ops: ModuleType, n_samples: int, dt: float) -> np.ndarray:
        """Relative displacements or accelerations at every sample, the first at rest."""
        out = np.zeros((n_samples, len(self.dofs)))
        read = ops.nodeAccel if self.quantity == "acceleration" else ops.nodeDisp
        analyze, h, substeps = ops.analyze, dt / self.substeps, self.substeps
        for k in range(1, n_samples):
            if analyze(substeps, h) != 0:
                raise EvaluationError(f"OpenSees analysis failed at t = {k * dt:.6g} s (sample "
                                      f"{k} of {n_samples}; algorithm {self.algorithm!r})")
            row = out[k]
            for j, (node, dof) in enumerate(self.dofs):
                row[j] = read(node, dof)
        return out

    def _check_uniform_load(self, values: Mapping[str, float]) -> None:
        """ConfigError if UniformExcitation's load is not ``M r`` at the outputs (see notes)."""
        ops = self._build(values)
        try:
            self._check_outputs_exist(ops)
            ops.setTime(0.0)
            ops.timeSeries("Constant", _SERIES_TAG, "-factor", 1.0)
            ops.pattern("UniformExcitation", _PATTERN_TAG, self.direction, "-accel", _SERIES_TAG)
            ops.constraints(self.constraints)
            ops.numberer("RCM")
            ops.system(self.system)
            ops.algorithm("Linear")
            ops.integrator("Newmark", 0.5, 0.25)
            ops.analysis("Transient")
            if ops.analyze(1, _CHECK_STEP) != 0:
                raise EvaluationError("OpenSees failed the base-load check step")
            acc = np.array([ops.nodeAccel(node, dof) for node, dof in self.dofs])
        finally:
            ops.wipe()
        wrong = np.abs(acc + self._influence) > _CHECK_TOL
        if np.any(wrong):
            j = int(np.argmax(np.abs(acc + self._influence)))
            raise ConfigError(
                f"{self.ref.field}: UniformExcitation loads this model with more (or less) than "
                f"its mass: under a unit base acceleration from rest, output {self.outputs[j]} "
                f"starts with relative acceleration {acc[j]:.6g} instead of "
                f"{-self._influence[j]:g} (elements that count their mass twice, such as "
                "ElasticTimoshenkoBeam with -mass) (allowed: excitation = 'nodal', or the mass "
                "on the nodes; check_base_load = false if mass is coupled to supports)")
        self._checked = True


def _script_runner(code: CodeType, path: Path | None) -> Callable[[Mapping[str, float]], None]:
    """Run a compiled build script with the values in its global ``params``."""

    def run(values: Mapping[str, float]) -> None:
        exec(code, {"__name__": "__femupdate_build__", "__file__": str(path),
                    "params": dict(values)})

    return run


def _free_equations(ops: ModuleType) -> dict[int, list[int]]:
    """Equation number of every DOF of every node (-1 where constrained)."""
    return {int(node): [int(e) for e in ops.nodeDOFs(node)] for node in ops.getNodeTags()}


def _seismic_loads(ops: ModuleType, direction: int, constraints: str) -> dict[int, list[float]]:
    """Nodal loads ``p = M r`` of the base motion, M as OpenSees assembles it."""
    ops.wipeAnalysis()
    ops.constraints(constraints)
    ops.numberer("Plain")
    ops.system("FullGeneral")
    ops.algorithm("Linear")
    ops.integrator("GimmeMCK", 1.0, 0.0, 0.0)
    ops.analysis("Transient")
    # The step assembles M, then solves with it: that fails for massless DOFs (rotations
    # under lumped mass), yet M is assembled and what is needed.
    ops.analyze(1, 0.0)
    a = np.asarray(ops.printA("-ret"), dtype=float)
    equations = _free_equations(ops)
    ops.wipeAnalysis()
    ops.setTime(0.0)
    n = round(math.sqrt(a.size))
    count = 1 + max((e for eqs in equations.values() for e in eqs), default=-1)
    if n * n != a.size or n != count:
        raise EvaluationError(f"OpenSees assembled a mass matrix of {a.size} entries for "
                              f"{count} equations (GimmeMCK)")
    mass = a.reshape(n, n)
    r = np.zeros(n)
    for eqs in equations.values():
        if len(eqs) >= direction and eqs[direction - 1] >= 0:
            r[eqs[direction - 1]] = 1.0
    p = mass @ r
    loads = {}
    for node, eqs in equations.items():
        load = [float(p[e]) if e >= 0 else 0.0 for e in eqs]
        if any(load):
            loads[node] = load
    return loads


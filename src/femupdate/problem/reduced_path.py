"""The reduced (large-model) path of a case: ``[simulation] method = "reduced"``.

A linear model of femupdate's own is simulated on its lowest modes with a static correction
(:class:`femupdate.simulate.reduced.ReducedSimulator`), assembled sparse (no dense n × n matrix)
and with the eigensolver warm-started. What this module decides for a case:

- **The path.** ``method = "reduced"`` asks for it; without a ``method`` a linear model of at
  least :data:`femupdate.case.simulation_path.REDUCED_MIN_DOF` DOFs takes it (below, nothing
  changes: the full exact path).
- **The band.** The case's preprocessing has no low-pass (only a high-pass, resampling and the
  delay band), so the fitted band reaches the Nyquist frequency of the trial's samples (after
  ``resample_hz``): modes are kept up to ``cutoff_factor × fs / 2``.
- **The warm start.** Every evaluation starts the Lanczos iteration from the modes of the
  case's nominal point (computed once per process, deterministically), never from those of
  the previous evaluation: the previous point depends on which worker or thread evaluated
  what, and a start changes φ in its last bits; the nominal modes give the same φ for the same
  point in every process.
- **The truncation error**, once per ``femupdate run``: the reduced prediction against the full
  model's at the nominal point (relative, as φ is), in the console and ``summary.json``.

The same record says, for a nonlinear model on the full path, which integrator ran and, when
``[simulation] method`` is not given, why it was chosen
(:func:`femupdate.problem.case_model.choose_integrator`), with a **step-halving check**: the
prediction at the case's substeps against the one at twice as many, at the nominal point
(:func:`step_halving`, warned about above :data:`STEP_HALVING_WARN`), and a **rounding
check**: the prediction against the one with every parameter moved by 1e-10 of itself
(:func:`rounding_check`, warned about above :data:`ROUNDING_WARN`): a response that jumps at
that scale defeats the search's finite differences.
"""

from __future__ import annotations

import math
import threading
import warnings
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from femupdate.errors import ConfigError, FemupdateWarning

if TYPE_CHECKING:
    from femupdate.case.schema import Case
    from femupdate.model.modes import NaturalModes
    from femupdate.model.structure import Structure

__all__ = [
    "FULL_CHECK_MAX_DOF",
    "ROUNDING_WARN",
    "STEP_HALVING_WARN",
    "TRUNCATION_WARN",
    "ReducedPath",
    "describe_simulation",
    "rounding_check",
    "simulation_record",
    "step_halving",
]

#: The default ``cutoff_factor`` of a model with friction or Bouc–Wen elements (Craig–Bampton):
#: stick–slip forces have a broad spectrum and excite the interior's modes far above the band.
#: Measured by benchmarks/craig_bampton.py (femupdate.paper.bench.friction_beam: a 122-DOF beam with
#: a friction damper, an EC8 accelerogram at 200 Hz, the band to Nyquist 100 Hz): truncation error
#: (φ of the reduced prediction against the full one, at the truth) 3.6e-3, 6.1e-5, 1.2e-6
#: and 8.5e-8 at factors 4, 8, 16 and 32 (19, 28, 39 and 57 reduced DOFs).
NONLINEAR_CUTOFF_FACTOR = 16.0
#: Up to this many DOFs the truncation error is measured against the full exact model; above,
#: against the reduced model with four times the cut-off (or the modes). The full model's
#: dense 2n × 2n eigen-decomposition at 1,000 DOFs took 11 s and 390 MB of peak memory (load
#: average 10 on 2 cores), more than the run itself (a 1,000-DOF update stays under 500 MB
#: without it); growing like n³ and n², it is kept to half that size.
FULL_CHECK_MAX_DOF = 500
#: A truncation error above this is warned about (raise ``cutoff_factor``).
TRUNCATION_WARN = 1e-6
#: A step-halving check (φ of the prediction at the case's substeps against the one at twice
#: as many) above this is warned about (raise ``[preprocess] substeps``): a difference of 1 %
#: rms, a quarter of the φ that noise of 2 % rms leaves at the truth (4e-4), where the
#: integration error would start to move a best fit.
STEP_HALVING_WARN = 1e-4
#: The rounding check moves every parameter by this share of itself: far below the search's
#: difference steps (1e-3 of a range), far above rounding (1e-16).
ROUNDING_STEP = 1e-10
#: A prediction that moves by more than this NMSE under ROUNDING_STEP is warned about: a smooth
#: model moves by about (sensitivity × 1e-10)², 2.5e-19 on the 100-link frame of examples/frames;
#: without its footings its links on almost massless feet chatter when they reverse and the
#: same change moves it by 3.5e-7 (tests/problem/test_integrator_choice.py).
ROUNDING_WARN = 1e-12
#: The integrators whose step the step-halving check halves.
STEPPED_NONLINEAR = ("nonlinear", "implicit")


class ReducedPath:
    """How a case's model is simulated on the reduced path (picklable).

    Parameters
    ----------
    case : Case
        The validated case (method ``"reduced"``).
    structure : Structure
        Its structure (``CaseModel.structure``).
    direction : str
        The base motion's direction.
    """

    def __init__(self, case: Case, structure: Structure, direction: str) -> None:
        from femupdate.simulate.reduced import DEFAULT_CUTOFF_FACTOR

        sim = case.simulation
        #: A model with friction or Bouc–Wen elements: Craig–Bampton, its nonlinear DOFs kept
        self.nonlinear = case.model.has_nonlinear
        self.substeps = case.preprocess.substeps
        default = NONLINEAR_CUTOFF_FACTOR if self.nonlinear else DEFAULT_CUTOFF_FACTOR
        self.cutoff_factor = default if sim.cutoff_factor is None else float(sim.cutoff_factor)
        self.n_modes = sim.n_modes
        if self.n_modes is not None and self.n_modes > structure.n_dof:
            raise ConfigError(f"{case.label}: simulation.n_modes: got {self.n_modes} but the "
                              f"model has {structure.n_dof} DOFs (allowed: 1 to "
                              f"{structure.n_dof})")
        self._structure = structure
        self._direction = direction
        self._nominal = case.nominal()
        self._starts: dict[float, NaturalModes] = {}
        self._lock = threading.Lock()

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_lock": None}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._lock = threading.Lock()

    def band_hz(self, dt: float) -> float:
        """The fitted band's upper end: the Nyquist frequency of samples ``dt`` apart."""
        return 0.5 / float(dt)

    def cutoff_hz(self, dt: float) -> float | None:
        """Modes are kept up to this frequency (None when ``n_modes`` counts them)."""
        if self.n_modes is not None:
            return None
        from femupdate.simulate.reduced import cutoff_from_band

        return cutoff_from_band(self.band_hz(dt), self.cutoff_factor)

    def start_modes(self, dt: float) -> NaturalModes:
        """The modes at the case's nominal point that start every eigensolution (computed once
        per process and cut-off, without a start of their own: the same in every process)."""
        from femupdate.model.modes import initial_stiffness
        from femupdate.model.sparse import lowest_modes

        key = float(dt)
        with self._lock:
            modes = self._starts.get(key)
            if modes is None:
                system = self._structure.assemble(self._nominal, direction=self._direction,
                                                  sparse=True)
                modes = lowest_modes(initial_stiffness(system), system.M,
                                     n_modes=self.n_modes, cutoff_hz=self.cutoff_hz(dt))
                self._starts[key] = modes
        return modes

    def system(self, values: Mapping[str, float]) -> Any:
        """The sparse system (CSR ``M``, ``C``, ``K``) at ``values``."""
        return self._structure.assemble(values, direction=self._direction, sparse=True)

    def simulator(self, values: Mapping[str, float], dt: float, outputs: np.ndarray, *,
                  factor: float = 1.0) -> Any:
        """The reduced simulator of the sparse system at ``values``; ``factor`` multiplies the
        cut-off (or the modes) for a reference of more modes. A nonlinear model: its
        Craig–Bampton reduction (:mod:`femupdate.simulate.craig_bampton`) with the nonlinear
        integrator at the case's substeps."""
        from femupdate.simulate.reduced import ReducedSimulator

        system = self._structure.assemble(values, direction=self._direction, sparse=True)
        if self.nonlinear:
            return self._craig_bampton(system, dt, outputs, factor)
        n_modes = self.n_modes
        if n_modes is not None and factor != 1.0:
            n_modes = min(round(n_modes * factor), mode_count(system))
        # the nominal modes start the eigensolver (with more modes, their count is the first
        # request, which then doubles: 3 Lanczos calls instead of 5 at 4× the cut-off)
        start = self.start_modes(dt)
        return ReducedSimulator(system, dt, outputs, band_hz=self.band_hz(dt),
                                cutoff_factor=self.cutoff_factor * factor, n_modes=n_modes,
                                previous=start)

    def _craig_bampton(self, system: Any, dt: float, outputs: np.ndarray, factor: float) -> Any:
        from femupdate.simulate import prepare
        from femupdate.simulate.craig_bampton import craig_bampton, nonlinear_dofs

        n_modes = self.n_modes
        if n_modes is not None and factor != 1.0:
            n_modes = round(n_modes * factor)
        boundary = np.union1d(nonlinear_dofs(system), np.asarray(outputs, dtype=np.int64))
        if n_modes is not None:
            n_modes = max(1, min(n_modes, mode_count(system) - boundary.size))
        cutoff = None if n_modes is not None else self.cutoff_hz(dt) * factor
        reduced, position = craig_bampton(system, boundary, cutoff_hz=cutoff, n_modes=n_modes)
        return prepare(reduced, dt, method="nonlinear", outputs=position[outputs],
                       substeps=self.substeps)

    def frequencies(self, values: Mapping[str, float], dt: float | None = None,
                    count: int = 12) -> np.ndarray:
        """The lowest natural frequencies (Hz) at ``values``, by the sparse eigensolver: those
        kept for samples ``dt`` apart, or the lowest ``count`` (never a dense eigenproblem).
        Friction and Bouc–Wen elements count by their initial stiffness."""
        from femupdate.model.modes import initial_stiffness
        from femupdate.model.sparse import lowest_modes

        system = self._structure.assemble(values, direction=self._direction, sparse=True)
        if dt is None:
            modes = lowest_modes(initial_stiffness(system), system.M,
                                 n_modes=min(count, mode_count(system)))
        else:
            modes = lowest_modes(initial_stiffness(system), system.M, n_modes=self.n_modes,
                                 cutoff_hz=self.cutoff_hz(dt), previous=self.start_modes(dt))
        return modes.freqs_hz


def mode_count(system: Any) -> int:
    """How many modes a (sparse) system has: one per DOF with mass (a DOF without mass is
    condensed, :mod:`femupdate.model.sparse`)."""
    from femupdate.model.sparse import massless_dofs

    return int(system.n_dof - massless_dofs(system.M).size)


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    """‖a − b‖² / ‖b‖² (the NMSE that φ is made of)."""
    return float(np.sum((a - b) ** 2) / np.sum(b**2))


def trial_truncation(trial: Any, values: Mapping[str, float]) -> dict[str, Any]:
    """The reduced prediction of one trial (a ``femupdate.problem.update.TrialProblem``, a layer
    above this module) at ``values`` against the full model's (or, above
    :data:`FULL_CHECK_MAX_DOF` DOFs, against the reduced model with four times the cut-off)."""
    from femupdate.simulate.exact import ExactSimulator
    from femupdate.simulate.reduced import ReducedSimulator

    model = trial.model
    path = model.reduced
    dt = trial.experiment.dt
    reduced = path.simulator(values, dt, model.outputs)
    n = model.structure.n_dof
    system = path.system(values)
    massed = mode_count(system)
    record = {"trial": trial.name, "n_dof": n, "n_modes": getattr(reduced, "n_modes", None),
              "cutoff_hz": path.cutoff_hz(dt), "band_hz": path.band_hz(dt)}
    if path.nonlinear:
        from femupdate.simulate import prepare

        if n <= FULL_CHECK_MAX_DOF:
            full = prepare(model.system(values), dt, method="nonlinear", outputs=model.outputs,
                           substeps=path.substeps)
            against = f"the full model ({n} DOFs, nonlinear)"
        else:
            full = path.simulator(values, dt, model.outputs, factor=4.0)
            against = "the Craig–Bampton model with 4× the cut-off"
        got = trial.scored(trial.prediction(reduced.run(trial._ag)))
        ref = trial.scored(trial.prediction(full.run(trial._ag)))
        return {**record, "n_modes": reduced.n_dof,
                "truncation_error": trial.phi_against(got, ref),
                "against": against, "phi_reduced": trial.objective(got),
                "phi_full": trial.objective(ref)}
    if massed < n and reduced.n_modes == massed:  # every mode kept: nothing to measure
        phi = trial.objective(trial.scored(trial.prediction(reduced.run(trial._ag))))
        return {**record, "truncation_error": 0.0, "phi_reduced": phi, "phi_full": phi,
                "against": (f"nothing (no mode truncated: all {massed} modes kept, the "
                            f"{n - massed} DOFs without mass condensed exactly)")}
    if massed < n and massed <= FULL_CHECK_MAX_DOF:  # all modes and the condensation: exact
        full = ReducedSimulator(system, dt, model.outputs, n_modes=massed)
        against = (f"the full model (exact: its {massed} modes, its {n - massed} DOFs "
                   "without mass condensed)")
    elif n <= FULL_CHECK_MAX_DOF:
        full = ExactSimulator(model.system(values), dt, model.outputs)
        against = f"the full model (exact, {n} DOFs)"
    else:
        full = path.simulator(values, dt, model.outputs, factor=4.0)
        against = f"the reduced model with 4× the cut-off ({full.n_modes} modes)"
    ag = trial._ag
    got = trial.scored(trial.prediction(reduced.run(ag)))
    ref = trial.scored(trial.prediction(full.run(ag)))
    phi_reduced, phi_full = trial.objective(got), trial.objective(ref)
    return {**record, "truncation_error": _relative(got, ref), "against": against,
            "phi_reduced": phi_reduced, "phi_full": phi_full}


def _compared(trial: Any, simulations: Callable[[], tuple[Any, Any]], failed: float
              ) -> dict[str, Any]:
    """``{"nmse": …}`` of the trial's prediction from the second of ``simulations()`` against
    the first's (the error function's weights and normalisation), or ``failed`` with the
    ``failure`` when a simulation raises or diverges."""
    from femupdate.errors import SimulationError

    try:
        first, second = simulations()
    except SimulationError as exc:
        return {"nmse": failed, "failure": str(exc)}
    if first.diverged or second.diverged:
        return {"nmse": failed, "failure": "the simulation diverged"}
    nmse = trial.phi_against(trial.scored(trial.prediction(first)),
                             trial.scored(trial.prediction(second)))
    return {"nmse": nmse if math.isfinite(nmse) else failed}


def _nominal_response(trial: Any, values: Mapping[str, float]) -> Any:
    """The trial's response at ``values``, or None when it fails (each check then simulates
    again and says why)."""
    from femupdate.errors import SimulationError

    try:
        return trial.model.simulate(values, trial._ag, trial.experiment.dt)
    except SimulationError:
        return None


def _simulated(trial: Any, values: Mapping[str, float], response: Any = None) -> Any:
    """The trial's response at ``values`` (``response`` when the caller has it)."""
    if response is not None:
        return response
    return trial.model.simulate(values, trial._ag, trial.experiment.dt)


def step_halving(trial: Any, values: Mapping[str, float], nominal: Any = None
                 ) -> dict[str, Any]:
    """The step-halving check of one trial (a ``femupdate.problem.update.TrialProblem``) at
    ``values``: φ of its prediction at the case's substeps (``nominal``, its response there,
    when the caller has it) against the prediction at twice as many as the measured target,
    on the integrator the trial holds. ``nmse`` is inf when either fails (its ``failure``
    says why)."""
    model = trial.model
    twice = model.with_substeps(2 * model.substeps)
    return {"trial": trial.name, "substeps": [model.substeps, 2 * model.substeps],
            **_compared(trial, lambda: (_simulated(trial, values, nominal), twice.simulate(
                values, trial._ag, trial.experiment.dt)), math.inf)}


def rounding_check(trial: Any, values: Mapping[str, float], nominal: Any = None
                   ) -> dict[str, Any]:
    """The rounding check of one trial at ``values``: φ of its prediction (``nominal``, its
    response there, when the caller has it) against the one with every parameter moved by
    :data:`ROUNDING_STEP` of itself. ``nmse`` is NaN when either fails (its ``failure`` says
    why)."""
    moved = {name: value * (1.0 + ROUNDING_STEP) if value else ROUNDING_STEP
             for name, value in values.items()}
    return {"trial": trial.name, "step": ROUNDING_STEP,
            **_compared(trial, lambda: (_simulated(trial, values, nominal),
                                        _simulated(trial, moved)), math.nan)}


def warn_rounding(label: str, worst: Mapping[str, Any]) -> None:
    """FemupdateWarning when the worst trial's rounding check exceeds ROUNDING_WARN."""
    if not worst["nmse"] > ROUNDING_WARN:  # NaN (a failed check) is said by the step check
        return
    warnings.warn(f"{label}: simulation: moving every parameter by {worst['step']:g} of itself "
                  f"moves the prediction by NMSE {worst['nmse']:.2g} at the nominal point "
                  f"(trial {worst['trial']!r}), above {ROUNDING_WARN:g}: the response is not "
                  "smooth at rounding level, so the search's finite differences see noise; "
                  "hysteretic links or sliders on DOFs with almost no mass chatter when they "
                  "reverse: give those DOFs their mass (a footing)", FemupdateWarning,
                  stacklevel=4)


def warn_step_halving(label: str, worst: Mapping[str, Any]) -> None:
    """FemupdateWarning when the worst trial's step-halving check exceeds STEP_HALVING_WARN."""
    if worst["nmse"] <= STEP_HALVING_WARN:
        return
    coarse, fine = worst["substeps"]
    what = (f"failed ({worst['failure']})" if "failure" in worst
            else f"gives NMSE {worst['nmse']:.2g}")
    warnings.warn(f"{label}: simulation: the step-halving check at the nominal point {what} "
                  f"between {coarse} and {fine} substeps (trial {worst['trial']!r}), above "
                  f"{STEP_HALVING_WARN:g}: the integration error is not small against the "
                  "noise; raise [preprocess] substeps", FemupdateWarning, stacklevel=4)


def nonlinear_record(problem: Any) -> dict[str, Any]:
    """What :func:`simulation_record` says of a nonlinear model on the full path: the
    integrator and its substeps, why it was chosen (no ``[simulation] method``), and the
    step-halving check of every fitted trial at the nominal point (the worst, warned about)."""
    model = problem.model
    method = model.method
    record: dict[str, Any] = {"substeps": model.substeps}
    if method == "implicit":
        record["hht_alpha"] = model.hht_alpha  # [simulation] hht_alpha, 0 by default
    choice = model.choices.get(float(problem.fitted[0].experiment.dt))
    if choice is not None:
        record["chosen"] = choice.reason
        if choice.explicit_substeps is not None:
            record.update(explicit_substeps=choice.explicit_substeps,
                          stable_substeps=choice.stable_substeps)
    methods = sorted({t.model.method for t in problem.fitted})
    if len(methods) > 1:  # trials sampled at different rates may take different integrators
        record["trial_methods"] = {t.name: t.model.method for t in problem.fitted}
    values = problem.case.nominal()
    nominal = [_nominal_response(t, values) for t in problem.fitted]  # shared by both checks
    checks = [step_halving(t, values, r) for t, r in zip(problem.fitted, nominal, strict=True)]
    worst = max(checks, key=lambda c: c["nmse"])
    record["step_halving"] = {**worst, "at": "the nominal point", "warn_above": STEP_HALVING_WARN,
                              "trials": checks}
    warn_step_halving(problem.case.label, worst)
    checks = [rounding_check(t, values, r) for t, r in zip(problem.fitted, nominal, strict=True)]
    worst = max(checks, key=lambda c: -math.inf if math.isnan(c["nmse"]) else c["nmse"])
    record["rounding"] = {**worst, "at": "the nominal point", "warn_above": ROUNDING_WARN,
                          "trials": checks}
    warn_rounding(problem.case.label, worst)
    return record


def simulation_record(problem: Any) -> dict[str, Any] | None:
    """Which path simulated the case's model (``problem``: a
    ``femupdate.problem.update.UpdateProblem``), and on the reduced path its truncation error at
    the nominal point for every fitted trial (warned about above :data:`TRUNCATION_WARN`); for
    a nonlinear model on the full path its integrator, why it was chosen and the step-halving
    check (:func:`nonlinear_record`). None for an external model."""
    case = problem.case
    model = problem.model
    if model.structure is None:
        return None
    method = model.method  # the integrator chosen for a nonlinear model without method
    record: dict[str, Any] = {"method": method, "n_dof": model.structure.n_dof}
    if method in STEPPED_NONLINEAR and case.model.has_nonlinear:
        return {**record, **nonlinear_record(problem)}
    if method != "reduced":
        return record
    from femupdate._parallel import single_blas_thread

    values = case.nominal()
    with single_blas_thread():  # as the runs have: the dense full model is many times faster
        trials = [trial_truncation(t, values) for t in problem.fitted]
    worst = max(trials, key=lambda t: t["truncation_error"])
    record.update(nonlinear=model.reduced.nonlinear, n_modes=worst["n_modes"],
                  cutoff_hz=worst["cutoff_hz"],
                  band_hz=worst["band_hz"], cutoff_factor=model.reduced.cutoff_factor,
                  truncation_error=worst["truncation_error"], against=worst["against"],
                  at="the nominal point", trials=trials)
    warn_truncation(case.label, worst)
    return record


def worst_truncation(trials: Sequence[Any], values: Mapping[str, float]) -> dict[str, Any]:
    """:func:`trial_truncation` of every trial at ``values``, the worst one, warned about
    above :data:`TRUNCATION_WARN` (``femupdate validate`` at the values it is given, as
    ``run`` at the nominal point)."""
    from femupdate._parallel import single_blas_thread

    with single_blas_thread():
        worst = max((trial_truncation(t, values) for t in trials),
                    key=lambda t: t["truncation_error"])
    warn_truncation(trials[0].case.label, worst)
    return worst


def warn_truncation(label: str, worst: Mapping[str, Any]) -> None:
    """FemupdateWarning when the worst trial's truncation error exceeds TRUNCATION_WARN."""
    if not worst["truncation_error"] <= TRUNCATION_WARN:
        warnings.warn(f"{label}: simulation: the reduced model's truncation error is "
                      f"{worst['truncation_error']:.2g} (trial {worst['trial']!r}, against "
                      f"{worst['against']}), above {TRUNCATION_WARN:g}: φ cannot be trusted "
                      "below it; raise [simulation] cutoff_factor (or n_modes)",
                      FemupdateWarning, stacklevel=3)


def describe_simulation(record: Mapping[str, Any]) -> str:
    """One line: which path ran (``"reduced: 25 modes ≤ 200 Hz of 1000 DOFs; …"``)."""
    method, n = record["method"], record["n_dof"]
    dofs = f"full model, {n} DOF{'' if n == 1 else 's'}"
    if "substeps" in record:  # a nonlinear model on the full path
        return describe_nonlinear(record, dofs)
    if method != "reduced":
        return f"simulation: {method} ({dofs})"
    cut = record.get("cutoff_hz")
    where = f" ≤ {cut:.4g} Hz" if cut is not None else ""
    err = record.get("truncation_error")
    tail = "" if err is None or not math.isfinite(err) else (
        f"; truncation error {err:.2g} against {record['against']} at {record['at']}")
    if str(record.get("against", "")).startswith("nothing"):
        tail = f"; {record['against'].removeprefix('nothing (').rstrip(')')}"
    if record.get("nonlinear"):
        return (f"simulation: reduced (Craig–Bampton: the nonlinear elements' and sensors' DOFs "
                f"kept, the interior's modes{where}): {record['n_modes']} DOFs of {n}{tail}")
    return f"simulation: reduced: {record['n_modes']} modes{where} of {n} DOFs{tail}"


def describe_nonlinear(record: Mapping[str, Any], dofs: str) -> str:
    """The line of a nonlinear model on the full path: ``"simulation: implicit (HHT α = 0, 2
    substeps; full model, 12 DOFs), chosen at the nominal point: central differences would
    need …; step-halving check at the nominal point: NMSE 4.8e-05 between 2 and 4 substeps"``."""
    method, substeps = record["method"], record["substeps"]
    steps = f"{substeps:,} substep{'' if substeps == 1 else 's'}"
    name = (f"implicit (HHT α = {record.get('hht_alpha', 0.0):g}, " if method == "implicit"
            else "nonlinear (central differences, ")
    line = f"simulation: {name}{steps}; {dofs})"
    if record.get("chosen"):
        line += f", chosen at the nominal point: {record['chosen']}"
    if record.get("trial_methods"):  # trials sampled at other intervals chose for themselves
        line += "; by trial: " + ", ".join(f"{name} {method}" for name, method
                                           in record["trial_methods"].items())
    check = record.get("step_halving")
    if check is not None:
        coarse, fine = check["substeps"]
        what = (f"failed ({check['failure']})" if "failure" in check
                else f"NMSE {check['nmse']:.2g}")
        line += (f"; step-halving check at {check['at']}: {what} between {coarse:,} and "
                 f"{fine:,} substeps")
        if len(check.get("trials", ())) > 1:
            line += f" (trial {check['trial']!r}, the largest)"
    rounding = record.get("rounding")
    if rounding is not None and math.isfinite(rounding["nmse"]):
        line += (f"; rounding check: NMSE {rounding['nmse']:.2g} for parameters moved by "
                 f"{rounding['step']:g}")
    return line


#: `femupdate modes` of a model on the reduced path: this many lowest modes.
MODES_SHOWN = 12


def lowest_case_modes(path: ReducedPath, values: Mapping[str, float],
                      count: int = MODES_SHOWN) -> tuple[NaturalModes, Any, tuple[str, ...]]:
    """The lowest ``count`` undamped modes of the model at ``values`` by the sparse
    eigensolver, the damped modes of its damping projected on them (``Φᵀ C Φ``: exact for
    damping that does not couple modes), and the DOF labels; never a dense n × n matrix.
    Friction and Bouc–Wen elements count by their initial stiffness, as on the dense path."""
    from femupdate.model.modes import damped_modes, initial_stiffness
    from femupdate.model.sparse import lowest_modes
    from femupdate.model.system import System

    system = path.system(values)
    modes = lowest_modes(initial_stiffness(system), system.M,
                         n_modes=min(count, mode_count(system)))
    phi = modes.shapes
    c_red = phi.T @ np.asarray(system.C @ phi)
    m = phi.shape[1]
    projected = System(M=np.eye(m), C=0.5 * (c_red + c_red.T),
                       K=np.diag((2.0 * np.pi * modes.freqs_hz) ** 2), r=np.zeros(m))
    return modes, damped_modes(projected), tuple(system.dof_labels)


def lowest_frequencies(model: Any, values: Mapping[str, float],
                       count: int = MODES_SHOWN) -> np.ndarray | None:
    """The lowest ``count`` natural frequencies (Hz) of a case's model on the reduced path by
    the sparse eigensolver; None for a model on another path (its callers' dense one)."""
    path = getattr(model, "reduced", None)
    if path is None:
        return None
    return lowest_case_modes(path, values, count)[0].freqs_hz

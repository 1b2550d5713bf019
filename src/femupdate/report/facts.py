"""What the report computes from a results directory besides what ``summary.json`` holds: where
values sit between their bounds, the modes and damping of a model, the truth of a virtual
experiment, the span of a spectrum plot. Pure functions and small records; nothing is drawn.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from femupdate.case import Case
from femupdate.case.checks import check_parameter_values
from femupdate.errors import FemupdateError
from femupdate.model.modes import damped_modes, initial_stiffness, natural_frequencies
from femupdate.model.system import System
from femupdate.pipeline.results import Results
from femupdate.problem.case_model import CaseModel
from femupdate.problem.reduced_path import lowest_frequencies

#: Relative size of K M⁻¹C − C M⁻¹K below which damping counts as classical (proportional).
PROPORTIONAL_TOL = 1e-8
#: Modes shown in the frequency and damping tables.
N_MODES = 6
#: Written beside the records by ``femupdate synth`` (femupdate.trials.virtual).
TRUTH_FILE = "truth.json"
MANIFEST_FILE = "manifest.json"


def bound_positions(values: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                    log: np.ndarray) -> np.ndarray:
    """Where values sit between their bounds: 0 at the lower, 1 at the upper.

    Measured in the search space, as the optimizers see it: log10 for log-scale parameters
    (a non-positive value of a log parameter is at −∞, below its lower bound).

    Parameters
    ----------
    values : ndarray, shape (..., n)
        Physical parameter values.
    lower, upper : ndarray, shape (n,)
        Physical bounds.
    log : ndarray of bool, shape (n,)
        Log-scale parameters.
    """
    values = np.asarray(values, dtype=float)
    log = np.asarray(log, dtype=bool)
    with np.errstate(divide="ignore", invalid="ignore"):
        v = np.where(log, np.log10(np.where(values > 0, values, np.nan)), values)
        v = np.where(log & ~(values > 0), -np.inf, v)
        lo = np.where(log, np.log10(np.where(log, lower, 1.0)), lower)
        hi = np.where(log, np.log10(np.where(log, upper, 1.0)), upper)
    return (v - lo) / (hi - lo)


def case_positions(case: Case, values: np.ndarray) -> np.ndarray:
    """:func:`bound_positions` of physical ``values`` (..., n) with the case's bounds."""
    params = case.parameters
    return bound_positions(values, np.array([p.lower for p in params]),
                           np.array([p.upper for p in params]),
                           np.array([p.scale == "log" for p in params]))


def spectrum_limit(f: np.ndarray, amplitude: np.ndarray, *, fraction: float = 0.995,
                   margin: float = 1.5) -> float:
    """Upper frequency of a spectrum plot: ``margin`` × where the energy reaches ``fraction``.

    The energy is Σ|Y|² over the frequencies (all channels together); the limit is capped at
    the last frequency (Nyquist).
    """
    f = np.asarray(f, dtype=float)
    power = np.sum(np.asarray(amplitude, dtype=float).reshape(f.size, -1) ** 2, axis=1)
    total = power.sum()
    if not np.isfinite(total) or total <= 0.0:
        return float(f[-1])
    k = int(np.searchsorted(np.cumsum(power) / total, fraction))
    return float(min(f[-1], margin * f[min(k, f.size - 1)]))


# ----------------------------------------------------------------------------- modes


def is_proportional(system: System, tol: float = PROPORTIONAL_TOL) -> bool:
    """Whether the damping is classical: ``K M⁻¹ C = C M⁻¹ K`` (Caughey and O'Kelly).

    Then the undamped mode shapes diagonalise C, every mode's ``|λ|`` is its undamped
    frequency and its damped frequency is below it. Otherwise the modes are complex and
    ``|λ|/2π`` of a mode may differ from, even exceed, the undamped frequency of the same rank.
    """
    k = initial_stiffness(system)
    m_inv = np.linalg.inv(system.M)
    a = k @ m_inv @ system.C
    scale = float(np.linalg.norm(k) * np.linalg.norm(m_inv) * np.linalg.norm(system.C))
    return scale == 0.0 or float(np.linalg.norm(a - a.T)) <= tol * scale


@dataclass(frozen=True)
class Modes:
    """The first modes of a model at some parameter values.

    Attributes
    ----------
    undamped_hz : list of float
        Natural frequencies of K and M (friction elements stuck).
    pole_hz, damping_ratios, damped_hz : list of float
        Of the complex modes (state-space eigenvalues λ): ``|λ|/2π``, ``ζ = −Re λ/|λ|`` and
        ``Im λ/2π`` (0 for an overdamped pole).
    proportional : bool
        Classical damping (:func:`is_proportional`).
    """

    undamped_hz: list[float]
    pole_hz: list[float]
    damping_ratios: list[float]
    damped_hz: list[float]
    proportional: bool


def modes_at(model: CaseModel, values: Mapping[str, float], n: int = N_MODES) -> Modes:
    """The first ``n`` undamped and complex modes of the case's model at ``values``."""
    if model.reduced is not None:  # a large model: sparse, its lowest modes only
        from femupdate.problem.reduced_path import lowest_case_modes

        (undamped, phi), poles, _ = lowest_case_modes(model.reduced, values, n)
        f, zeta = poles.freqs_hz[:n], poles.damping_ratios[:n]
        damped = f * np.sqrt(np.clip(1.0 - zeta**2, 0.0, None))
        # classical damping: the kept modes diagonalise C (K M⁻¹ C = C M⁻¹ K in their span)
        c_modal = phi.T @ np.asarray(model.reduced.system(values).C @ phi)
        off = c_modal - np.diag(np.diag(c_modal))
        return Modes(undamped.tolist(), f.tolist(), zeta.tolist(), damped.tolist(),
                     bool(np.linalg.norm(off) <= PROPORTIONAL_TOL * np.linalg.norm(c_modal)))
    system = model.system(values)
    undamped = natural_frequencies(system).freqs_hz[:n]
    poles = damped_modes(system)
    f, zeta = poles.freqs_hz[:n], poles.damping_ratios[:n]
    damped = f * np.sqrt(np.clip(1.0 - zeta**2, 0.0, None))
    return Modes(undamped.tolist(), f.tolist(), zeta.tolist(), damped.tolist(),
                 is_proportional(system))


# ----------------------------------------------------------------------------- the truth


@dataclass(frozen=True)
class Truth:
    """What the results are compared with when they come from a virtual experiment.

    Attributes
    ----------
    values : dict or None
        The true parameter values (None: no truth to overlay).
    frequencies_hz : list of float
        The truth model's natural frequencies.
    source : str
        Where the truth comes from (the bridge benchmark, or a ``truth.json`` file), or why
        there is none.
    noise_floor : float or None
        φ of the truth against the noisy data (the bridge benchmark).
    manifest : dict
        The virtual experiment's ``manifest.json`` (motion, noise, seed), when found.
    """

    values: dict[str, float] | None
    frequencies_hz: list[float] = field(default_factory=list)
    source: str = ""
    noise_floor: float | None = None
    manifest: dict[str, Any] = field(default_factory=dict)

    def at(self, names: Sequence[str]) -> list[float] | None:
        """The true values in the order of ``names`` (None without a truth)."""
        return None if self.values is None else [self.values[n] for n in names]


def _read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise FemupdateError(f"{path}: cannot be read as JSON: {exc}") from None


def find_truth(res: Results, model: CaseModel | None) -> Truth:
    """The truth of the results: the bridge benchmark's, or ``truth.json`` beside the records.

    ``truth.json`` (written with ``manifest.json`` by ``femupdate synth``) is used when it names
    exactly the case's parameters; its natural frequencies are computed with ``model``.
    """
    bench = res.summary.benchmark
    if bench is not None:
        return Truth(dict(bench.truth), list(bench.truth_frequencies_hz),
                     f"the bridge benchmark's virtual experiment ({bench.data})",
                     bench.noise_floor)
    if res.case.data is None:
        return Truth(None, source="the case has no [data] section")
    directory = res.case.data_directory()
    path = directory / TRUTH_FILE
    if not path.is_file():
        return Truth(None, source=f"no {TRUTH_FILE} beside the records in {directory}")
    manifest_path = directory / MANIFEST_FILE
    try:
        values = check_parameter_values(_read_json(path), res.names, str(path))
        manifest = _read_json(manifest_path) if manifest_path.is_file() else {}
    except FemupdateError as exc:
        return Truth(None, source=f"{TRUTH_FILE} not used: {exc}")
    freqs: list[float] = []
    if model is not None:
        try:
            sparse = lowest_frequencies(model, values, N_MODES)  # a large model's, sparse
            freqs = (natural_frequencies(model.system(values)).freqs_hz[:N_MODES].tolist()
                     if sparse is None else sparse.tolist())
        except FemupdateError:
            freqs = []
    return Truth(values, freqs, f"{path} (a virtual experiment)",
                 manifest=manifest if isinstance(manifest, dict) else {})


def relative_error(value: float | None, reference: float | None) -> float | None:
    """100 (value / reference − 1), %; None when either is missing or the reference is 0."""
    if value is None or reference is None or reference == 0.0 or not math.isfinite(reference):
        return None
    return 100.0 * (value / reference - 1.0)


# ----------------------------------------------------------------------------- the context


@dataclass(frozen=True)
class Context:
    """What every section of the report reads: the results, the case's model and the truth.

    Attributes
    ----------
    res : Results
    model : CaseModel or None
        The case's model (None when it cannot be built: ``model_note`` says why).
    truth : Truth
    model_note : str or None
    """

    res: Results
    model: CaseModel | None
    truth: Truth
    model_note: str | None = None


def context(res: Results) -> Context:
    """Build the case's model once and find the truth."""
    try:
        model, why = CaseModel(res.case), None
    except FemupdateError as exc:
        model, why = None, f"the model cannot be built: {exc}"
    return Context(res, model, find_truth(res, model), why)

"""The results of an update, typed: what ``summary.json`` holds, written and read back.

A results directory (``femupdate run CASE --out DIR``) holds:

- ``summary.json`` (:data:`SUMMARY_FILE`): a :class:`Summary`: the case, the settings, every
  run, the best one, the spread over the successful runs;
- ``results.sqlite`` (:data:`STORE_FILE`): every evaluation and the optimizer checkpoints
  (:mod:`femupdate.runs.store`);
- ``fit.npz`` (:data:`FIT_FILE`): the best model's prediction beside the measurement, channel by
  channel, so that a report draws it without the data or a simulation;
- the report (:data:`REPORT_FILE`) and the plots, once drawn.

File names are defined here once. :func:`load_results` reads a directory back for the report.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from femupdate.case import Case, parse_case
from femupdate.errors import FemupdateError
from femupdate.inference.records import LaplaceRecord, PosteriorRecord
from femupdate.runs.store import FILENAME as STORE_FILENAME

__all__ = [
    "FIT_FILE",
    "POSTERIOR_FILE",
    "REPORT_FILE",
    "STORE_FILE",
    "SUMMARY_FILE",
    "Best",
    "BridgeBenchmark",
    "Fit",
    "Results",
    "RunRecord",
    "Spread",
    "Summary",
    "TrialRecord",
    "load_fits",
    "load_results",
    "read_summary",
    "save_fits",
    "write_summary",
]

SUMMARY_FILE = "summary.json"
STORE_FILE = STORE_FILENAME
FIT_FILE = "fit.npz"
REPORT_FILE = "report.html"
#: The sampled posterior's arrays (``femupdate posterior``): samples, modes, predictive bands.
POSTERIOR_FILE = "posterior.npz"


class _Record(BaseModel):
    # Extra keys are refused: a summary is femupdate's own output, read back by femupdate.
    model_config = ConfigDict(extra="forbid")


class RunRecord(_Record):
    """One run of the update (summary.json ``runs[i]``).

    ``x`` is the run's best point in the search space (log10 for log-scale parameters),
    ``params`` the same in physical values; ``at_bounds`` names the parameters that ended at a
    bound ("lower" or "upper"): an improper minimum, the typical failure of a bounded search.
    ``nfail`` counts the evaluations that failed (φ = inf: an unstable step, an external
    model's error) and ``failure`` says why the first did (the store keeps every message).
    """

    index: int
    seed: dict[str, Any]
    success: bool
    status: int
    message: str
    stop: dict[str, Any]
    phi: float
    nfev: int
    nit: int
    restarts: int = 0
    nfail: int = 0
    failure: str | None = None
    wall_s: float
    x: list[float]
    params: dict[str, float]
    at_bounds: dict[str, Literal["lower", "upper"]] = Field(default_factory=dict)


class Best(_Record):
    """The best run: φ, parameters, natural frequencies and the error of each channel."""

    run: int
    phi: float
    nmse_percent: float
    params: dict[str, float]
    frequencies_hz: list[float]
    nmse_per_channel: dict[str, float]


class TrialRecord(_Record):
    """One trial of the case at the best parameters (summary.json ``trials[i]``).

    ``phi`` is the trial's NMSE (as a fraction) over its scored samples; ``role`` says whether
    it was fitted or only predicted (a validation); ``notes`` what was noticed reading it
    (repaired glitches, doubtful delays).
    """

    name: str
    role: Literal["fit", "validate"]
    weight: float
    phi: float
    nmse_per_channel: dict[str, float]
    delays_s: dict[str, float]
    samples: int
    dt: float
    start_s: float
    score_window: list[float] | None = None
    notes: list[str] = Field(default_factory=list)


class Spread(_Record):
    """Mean, std, min and max of parameters and frequencies over the successful runs."""

    params: dict[str, dict[str, float]] = Field(default_factory=dict)
    frequencies_hz: dict[str, dict[str, float]] = Field(default_factory=dict)


class BridgeBenchmark(_Record):
    """What ``femupdate bench bridge`` adds: the truth and each run's errors against it."""

    model: str
    band: str
    seed: int
    snr: float
    f_target: float | None
    data: str
    truth: dict[str, float]
    noise_floor: float
    truth_frequencies_hz: list[float]
    parameter_errors: list[dict[str, float]]
    frequency_errors: list[list[float]]
    within_1_5_noise_floor: int | None


class VerdictRecord(_Record):
    """Whether the best was found again by independent searches (docs/verdicts.md): see
    :class:`femupdate.runs.verdict.Verdict`."""

    converged: bool
    agreeing_runs: list[int]
    confirmations: int
    minima: int
    phi_range: list[float]
    fits: bool
    words: str
    #: Runs asked for, when the agreement stop left some not needed (None: every run ran).
    planned: int | None = None
    #: The Good–Turing share: about how often another run would end at a φ none reached.
    unseen: float = 0.0


class DefectRecord(_Record):
    """A defect found in a trial's records (summary.json ``defects[i]``): what, where, the
    evidence, the repair, and whether it is ``open`` (the runs are then no success),
    ``repaired`` or ``accepted`` (:mod:`femupdate.data.defects`)."""

    kind: str
    file: str
    channel: str
    severity: Literal["error", "warning"]
    evidence: str
    repair: str
    status: Literal["open", "repaired", "accepted"]
    trial: str = ""


class Summary(_Record):
    """``summary.json``: the case, the settings, every run, the best and the spread.

    The evaluation statistics (``successes`` … ``evals_per_success``) are those of
    :func:`femupdate.runs.stats.evaluation_stats`; ``success_rule`` says what success meant.
    ``defects``: what the checks found in the records; an open one makes every run no success.
    ``laplace``: the Laplace approximation of the posterior at the best fit (a least-squares
    run); ``posterior``: the sampled posterior (``femupdate posterior``); None in summaries
    written without them.
    """

    case: dict[str, Any]
    case_file: str | None
    settings: dict[str, Any]
    delays_s: dict[str, float]
    fingerprint: str
    method: str
    successes: int
    success_ratio: float
    evals_min: int | None
    evals_mean: float | None
    evals_median: float | None
    evals_max: int | None
    evals_per_success: float | None
    success_rule: str
    wall_s: float
    runs: list[RunRecord]
    best: Best
    spread: Spread
    trials: list[TrialRecord] = Field(default_factory=list)
    identifiability: dict[str, Any] | None = None
    benchmark: BridgeBenchmark | None = None
    verdict: VerdictRecord | None = None
    defects: list[DefectRecord] = Field(default_factory=list)
    laplace: LaplaceRecord | None = None
    posterior: PosteriorRecord | None = None
    #: Which path simulated the model (``femupdate.problem.reduced_path.simulation_record``): the
    #: method and DOFs, and on the reduced path its modes, cut-off and truncation error.
    simulation: dict[str, Any] | None = None

    @property
    def name(self) -> str:
        """The case's name (``[case] name``)."""
        return str(self.case["case"]["name"])

    def runs_as_dicts(self) -> list[dict[str, Any]]:
        """The runs as plain dicts (JSON-ready)."""
        return [r.model_dump() for r in self.runs]

    def to_json(self) -> str:
        """JSON text; φ = inf (a run that never evaluated successfully) as ``Infinity``."""
        return json.dumps(self.model_dump(), indent=2, allow_nan=True) + "\n"


def write_summary(summary: Summary, directory: Path) -> Path:
    """Write ``directory/summary.json``."""
    path = Path(directory) / SUMMARY_FILE
    path.write_text(summary.to_json(), encoding="utf-8")
    return path


def read_summary(path: Path) -> Summary:
    """A ``summary.json`` read back, or a FemupdateError naming the file and what is wrong."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise FemupdateError(f"{path}:{exc.lineno}:{exc.colno}: not valid JSON ({exc.msg}); "
                             "rerun `femupdate run` to write it again") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise FemupdateError(f"{path}: cannot read the summary: {exc}") from None
    if not isinstance(data, dict):
        raise FemupdateError(f"{path}: got a JSON {type(data).__name__}, expected an object "
                             "(the summary of `femupdate run`)")
    try:
        return Summary.model_validate(data)
    except ValidationError as exc:
        errors = exc.errors(include_url=False)
        missing = [".".join(map(str, e["loc"])) for e in errors if e["type"] == "missing"]
        other = [f"{'.'.join(map(str, e['loc'])) or '(top level)'}: {e['msg']}"
                 for e in errors if e["type"] != "missing"]
        what = "; ".join(([f"missing {', '.join(missing)}"] if missing else []) + other[:5])
        raise FemupdateError(f"{path}: not a summary of this femupdate ({what}); rerun "
                             "`femupdate run` to write it again") from None


@dataclass(frozen=True)
class Fit:
    """A trial's prediction by the best model beside its measurement.

    ``measured`` is what φ compares the prediction with (displacements: the measurement plus
    its fitted integration constants; over the scored samples, ``t``); ``measured_acc`` and
    ``predicted_acc`` are the accelerations relative to the table over the whole trial
    (``t_acc``), for spectra.
    """

    t: np.ndarray
    measured: np.ndarray
    predicted: np.ndarray
    measured_acc: np.ndarray
    predicted_acc: np.ndarray
    channels: tuple[str, ...]
    unit: str
    phi: float
    trial: str = ""
    role: str = "fit"
    t_acc: np.ndarray | None = None

    _ARRAYS = ("t", "measured", "predicted", "measured_acc", "predicted_acc")

    def arrays(self, prefix: str) -> dict[str, np.ndarray]:
        out = {f"{prefix}{k}": getattr(self, k) for k in self._ARRAYS}
        out.update({f"{prefix}channels": np.array(self.channels), f"{prefix}unit":
                    np.array(self.unit), f"{prefix}phi": np.array(self.phi),
                    f"{prefix}trial": np.array(self.trial), f"{prefix}role": np.array(self.role),
                    f"{prefix}t_acc": self.t if self.t_acc is None else self.t_acc})
        return out

    @classmethod
    def from_arrays(cls, data: Any, prefix: str) -> Fit:
        return cls(**{k: data[f"{prefix}{k}"] for k in cls._ARRAYS},
                   channels=tuple(str(c) for c in data[f"{prefix}channels"]),
                   unit=str(data[f"{prefix}unit"]), phi=float(data[f"{prefix}phi"]),
                   trial=str(data[f"{prefix}trial"]), role=str(data[f"{prefix}role"]),
                   t_acc=data[f"{prefix}t_acc"])


def save_fits(fits: list[Fit], directory: Path) -> Path:
    """Write every trial's fit to ``directory/fit.npz`` (trial ``i``'s arrays as ``i/…``)."""
    path = Path(directory) / FIT_FILE
    arrays: dict[str, np.ndarray] = {"count": np.array(len(fits))}
    for i, fit in enumerate(fits):
        arrays.update(fit.arrays(f"{i}/"))
    np.savez_compressed(path, **arrays)
    return path


def load_fits(path: Path) -> list[Fit]:
    """The fits written by :func:`save_fits`."""
    with np.load(path, allow_pickle=False) as data:
        return [Fit.from_arrays(data, f"{i}/") for i in range(int(data["count"]))]


@dataclass
class Results:
    """What a results directory holds, read once.

    Attributes
    ----------
    directory : Path
    summary : Summary
    case : Case
        Rebuilt from the summary.
    meta : dict or None
        The results store's meta (settings, software versions), None without a store.
    histories : dict
        Run index → history (``x`` in the search space, ``fun``, and the optimizer's trace);
        empty without a store.
    fits : list of Fit, or str
        The best model against each trial's measurement, or why they are not there.
    store_note : str or None
        Why the store was not used (None when it was).
    """

    directory: Path
    summary: Summary
    case: Case
    meta: dict[str, Any] | None = None
    histories: dict[int, dict[str, np.ndarray]] = field(default_factory=dict)
    fits: list[Fit] | str = "not read"
    store_note: str | None = None

    @property
    def names(self) -> tuple[str, ...]:
        return self.case.parameter_names

    @property
    def fit(self) -> Fit | str:
        """The first fitted trial's fit (or why there is none)."""
        if isinstance(self.fits, str):
            return self.fits
        return next((f for f in self.fits if f.role == "fit"), self.fits[0])

    @property
    def best_index(self) -> int:
        return self.summary.best.run


def load_results(results_dir: str | Path) -> Results:
    """Read ``summary.json``, the fit and, if present, the results store of a directory.

    Raises
    ------
    FemupdateError
        No such directory, no or unreadable ``summary.json``, or one that is not a summary
        of ``femupdate run`` (the message names the file and what is wrong).
    """
    directory = Path(results_dir)
    if not directory.is_dir():
        raise FemupdateError(f"results directory not found: {directory} (allowed: the --out "
                             "directory of `femupdate run`)")
    path = directory / SUMMARY_FILE
    if not path.is_file():
        raise FemupdateError(f"{path}: no {SUMMARY_FILE} in {directory}; a report needs the "
                             f"summary that `femupdate run CASE --out {directory}` writes when "
                             "its runs are finished")
    summary = read_summary(path)
    try:
        case = parse_case(summary.case)
    except FemupdateError as exc:
        raise FemupdateError(f"{path}: the saved case is not valid:\n{exc}") from None
    results = Results(directory, summary, case)
    fit_path = directory / FIT_FILE
    results.fits = (load_fits(fit_path) if fit_path.is_file()
                    else f"no {FIT_FILE} in this directory (written by `femupdate run`)")
    if not isinstance(results.fits, str):
        scored = {t.name: t.phi for t in summary.trials}
        stale = [f.trial for f in results.fits if f.trial in scored and not math.isclose(
            f.phi, scored[f.trial], rel_tol=1e-9, abs_tol=1e-15)]
        if stale:
            results.fits = (f"{FIT_FILE} does not belong to this summary's best run (trial "
                            f"{stale[0]!r}: φ differs)")
    _read_store(results)
    return results


def _read_store(results: Results) -> None:
    from femupdate.runs.store import ResultsStore, StoreError

    if not (results.directory / STORE_FILE).is_file():
        results.store_note = f"no results store ({STORE_FILE}) in this directory"
        return
    try:
        with ResultsStore.open(results.directory, read_only=True) as store:
            meta = store.meta()
            fingerprint = results.summary.fingerprint
            if fingerprint and meta.get("fingerprint") and meta["fingerprint"] != fingerprint:
                results.store_note = (f"{STORE_FILE} belongs to another case than "
                                      f"{SUMMARY_FILE} (fingerprints differ); not used")
                return
            results.meta = meta
            stored = {row.run for row in store.runs()}
            for run in results.summary.runs:
                if run.index in stored:
                    results.histories[run.index] = store.history(run.index)
    except StoreError as exc:
        results.store_note = f"{STORE_FILE} could not be read: {exc}"

"""The real case: a one-storey steel-strip model on a mini shake table.

Measured by Chrystal Chern and Claudio Perez (UC Berkeley, the ``mdof`` project, BSD-2-Clause;
see PROVENANCE.md beside the data): absolute accelerations of the table and of the roof block,
recorded by two Xsens DOT IMUs at 120 Hz, in an El Centro trial and a 2 Hz sine trial. The
storey stiffness and damping of a one-DOF shear building (the mass fixed at the authors'
0.179 kg) are updated from the El Centro trial; the identified natural frequency is checked
against the peak of the measured transfer function (table → roof, H1 estimate), and the
updated model predicts the sine trial without refitting.

**The sensor latency.** Below the storey's resonance the roof moves with the table, so the
table → roof transfer function should have a phase near 0; measured, it falls linearly with
frequency (−42° at 5 Hz, −84° at 10 Hz, coherence above 0.97): the roof channel lags the table
channel by 23 ms (2.8 samples) once the files are aligned by their time stamps, the same in both
trials (15 ms if the files are paired sample by sample, ignoring the stamps). That is a sensor
delay, not structural dynamics, and at 22 Hz it is half a period: uncorrected, no storey
stiffness fits (φ ≈ 97 %). The case files say ``delay = "auto"`` for the roof channel:
:func:`femupdate.experiment.load_experiment` measures the delay from the phase slope in
``[preprocess] delay_band_hz`` (1–10 Hz, well below the resonance; no model involved) with
:func:`femupdate.data.signal.estimate_delay` and removes it with
:func:`femupdate.data.signal.advance`, each trial on its own record.
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from femupdate.case import Case, load_case
from femupdate.data import signal
from femupdate.errors import ConfigError, DataError
from femupdate.experiment import Experiment, load_experiment
from femupdate.model.modes import damped_modes
from femupdate.update import UpdateProblem
from femupdate.workflow import UpdateResult, run_case, with_data_directory

__all__ = [
    "DATA_FILES",
    "DATA_SUBDIR",
    "find_data",
    "format_table",
    "nmse_at",
    "run_minishake",
    "spectral_peak",
]

#: Folder of the records under the shared data directory, and the files it must hold.
DATA_SUBDIR = "minishake_1story"
DATA_FILES = (
    "stiff1_elcentro_t1_ground.csv",
    "stiff1_elcentro_t1_top.csv",
    "stiff1_sine2hz_t1_ground.csv",
    "stiff1_sine2hz_t1_top.csv",
)
#: Environment variable naming the shared data directory.
DATA_ENV = "FEMUPDATE_DATA"

#: Band searched for the resonance peak of the transfer function (Hz).
PEAK_BAND_HZ = (10.0, 40.0)
#: Welch segment of the spectral check: 512 samples (4.3 s, 0.23 Hz bins, 9 averages on the
#: El Centro record), several decay times of the lightly damped mode, so the peak is not
#: smeared by leakage.
PEAK_NPERSEG = 512


# ----------------------------------------------------------------------------- data


def find_data(data_dir: str | os.PathLike[str] | None = None) -> Path:
    """The folder holding the four minishake records.

    Parameters
    ----------
    data_dir : path, optional
        The shared data directory (holding ``minishake_1story/``) or that folder itself.
        Default: the environment variable ``FEMUPDATE_DATA``.

    Raises
    ------
    DataError
        When neither candidate holds the files; the message lists where it looked.
    """
    if data_dir is None:
        env = os.environ.get(DATA_ENV)
        if not env:
            raise DataError(f"no data directory given and {DATA_ENV} is not set (allowed: the "
                            f"shared data directory holding {DATA_SUBDIR}/, e.g. ../shared/data)")
        data_dir = env
    root = Path(data_dir).expanduser()
    candidates = [root / DATA_SUBDIR, root]
    for folder in candidates:
        if all((folder / name).is_file() for name in DATA_FILES):
            return folder.resolve()
    looked = ", ".join(str(c) for c in candidates)
    raise DataError(f"minishake records not found: looked for {', '.join(DATA_FILES)} in "
                    f"{looked} (allowed: the shared data directory with {DATA_SUBDIR}/ "
                    f"from PROVENANCE.md's source)")


def spectral_peak(experiment: Experiment, *, band: tuple[float, float] = PEAK_BAND_HZ,
                  nperseg: int = PEAK_NPERSEG, channel: int = 0) -> float:
    """Peak frequency (Hz) of the measured table → output transfer function (H1, Welch).

    Absolute accelerations in and out; a delay does not change ``|H1|``. The peak of the
    absolute-acceleration transmissibility of a storey is at
    ``f_n √((√(1 + 8ζ²) − 1) / 4ζ²) ≈ f_n (1 − ζ²)``: within 0.1 % of the undamped natural
    frequency for ζ < 3 %.
    """
    f, h, _ = signal.transfer_function(experiment.ag, experiment.accelerations[:, channel],
                                       1.0 / experiment.dt,
                                       nperseg=min(nperseg, experiment.t.size))
    return float(signal.peak_frequency(f, h, band=band))


# ----------------------------------------------------------------------------- fitting


def nmse_at(problem: UpdateProblem, params: Mapping[str, float]) -> float:
    """φ of ``problem`` at physical parameter values (no search): the prediction error."""
    return problem(problem.case.to_search(params))


def _fit(case: Case, experiment: Experiment, out_dir: Path | None, name: str,
         opts: Mapping[str, Any]) -> UpdateResult:
    """``run_case`` on an experiment already loaded; ``out_dir/name`` is rewritten afresh."""
    where = None if out_dir is None else out_dir / name
    if where is not None:
        shutil.rmtree(where, ignore_errors=True)  # this benchmark's own output: start anew
    return run_case(case, where, experiments=[experiment], **opts)


def _as_case(case: Case | str | os.PathLike[str], data: Path | None) -> Case:
    loaded = case if isinstance(case, Case) else load_case(case)
    return loaded if data is None else with_data_directory(loaded, data)


def _modal(problem: UpdateProblem, params: Mapping[str, float]) -> tuple[float, float]:
    modes = damped_modes(problem.system(dict(params)))
    return float(modes.freqs_hz[0]), float(modes.damping_ratios[0])


def run_minishake(
    elcentro: Case | str | os.PathLike[str],
    sine: Case | str | os.PathLike[str],
    *,
    data_dir: str | os.PathLike[str] | None = None,
    runs: int | None = None,
    seed: int | None = None,
    max_evals: int | None = None,
    workers: int = 1,
    out_dir: Path | None = None,
    refit_sine: bool = True,
) -> dict[str, Any]:
    """Fit the El Centro trial, check the frequency, validate on the sine trial.

    Parameters
    ----------
    elcentro, sine : Case or path
        The two case files (``examples/minishake-1story/elcentro.toml`` and ``sine.toml``).
    data_dir : path, optional
        Where the records are (see :func:`find_data`); default: each case's own ``[data]
        directory``.
    runs, seed, max_evals, workers
        Override the El Centro case's ``[search]`` (the sine refit uses the same).
    out_dir : Path, optional
        Writes ``elcentro/`` (summary.json, plots), ``sine/`` (with ``refit_sine``) and
        ``minishake.json``.
    refit_sine : bool
        Also fit the sine trial on its own: the error a refit reaches, a reference for the
        validation error.

    Returns
    -------
    dict
        ``fit`` (El Centro: φ, parameters, frequency, damping, delay, spectral peak, frequency
        error), ``validation`` (sine: φ of the El Centro model, delay, spectral peak,
        frequency error) and, with ``refit_sine``, ``sine_refit``.
    """
    data = find_data(data_dir) if data_dir is not None else None
    ec_case, sine_case = _as_case(elcentro, data), _as_case(sine, data)
    if set(ec_case.parameter_names) != set(sine_case.parameter_names):
        raise ConfigError(f"{sine_case.source}: parameters {list(sine_case.parameter_names)} "
                          f"differ from {ec_case.source}'s {list(ec_case.parameter_names)} "
                          "(allowed: the same parameters, so one model predicts both)")
    opts = {"runs": runs, "seed": seed, "max_evals": max_evals, "workers": workers}

    ec_exp = load_experiment(ec_case)
    ec = _fit(ec_case, ec_exp, out_dir, "elcentro", opts)
    best = ec.summary.best
    params = best.params
    freq, zeta = _modal(ec.problem, params)
    ec_peak = spectral_peak(ec_exp)

    sine_exp = load_experiment(sine_case)  # its own delay, estimated on its own record
    sine_problem = UpdateProblem(sine_case, sine_exp)
    sine_peak = spectral_peak(sine_exp)
    phi_sine = nmse_at(sine_problem, params)
    result: dict[str, Any] = {
        "data_dir": str(ec_case.data_directory()),
        "quantity": ec_exp.quantity,
        "fit": {
            "case": ec_case.case.name,
            "case_file": ec_case.label,
            "phi": best.phi,
            "nmse_percent": 100.0 * best.phi,
            "params": params,
            "frequency_hz": freq,
            "damping_ratio": zeta,
            "delay_s": ec_exp.delays,
            "peak_hz": ec_peak,
            "frequency_error_percent": 100.0 * (freq / ec_peak - 1.0),
            "runs": len(ec.summary.runs),
            "successes": ec.summary.successes,
            "nfev": [r.nfev for r in ec.summary.runs],
            "wall_s": ec.summary.wall_s,
        },
        "validation": {
            "case": sine_case.case.name,
            "case_file": sine_case.label,
            "phi": phi_sine,
            "nmse_percent": 100.0 * phi_sine,
            "delay_s": sine_exp.delays,
            "peak_hz": sine_peak,
            "frequency_error_percent": 100.0 * (freq / sine_peak - 1.0),
        },
        "spectral": {"band_hz": list(PEAK_BAND_HZ), "nperseg": PEAK_NPERSEG,
                     "delay_band_hz": list(ec_case.preprocess.delay_band_hz)},
    }
    if refit_sine:
        ref = _fit(sine_case, sine_exp, out_dir, "sine", opts)
        ref_params = ref.summary.best.params
        ref_freq, ref_zeta = _modal(ref.problem, ref_params)
        result["sine_refit"] = {
            "phi": ref.summary.best.phi,
            "nmse_percent": 100.0 * ref.summary.best.phi,
            "params": ref_params,
            "frequency_hz": ref_freq,
            "damping_ratio": ref_zeta,
        }
    if out_dir is not None:
        out_dir.mkdir(parents=True, exist_ok=True)
        (out_dir / "minishake.json").write_text(json.dumps(result, indent=2) + "\n")
    return result


def format_table(result: Mapping[str, Any]) -> str:
    """The figures of :func:`run_minishake` as a small plain-text table."""
    fit_, val = result["fit"], result["validation"]
    ref = result.get("sine_refit")

    def ms(delays: Mapping[str, float]) -> str:
        return ", ".join(f"{1e3 * d:.1f}" for d in delays.values())

    rows = [
        ("", "El Centro (fit)", "sine 2 Hz (validation)"),
        ("sensor delay removed [ms]", ms(fit_["delay_s"]), ms(val["delay_s"])),
        ("H1 peak, table -> roof [Hz]", f"{fit_['peak_hz']:.2f}", f"{val['peak_hz']:.2f}"),
        ("model frequency [Hz]", f"{fit_['frequency_hz']:.2f}", "(El Centro model)"),
        ("frequency vs peak", f"{fit_['frequency_error_percent']:+.1f} %",
         f"{val['frequency_error_percent']:+.1f} %"),
        ("damping ratio", f"{100 * fit_['damping_ratio']:.2f} %", ""),
        (f"NMSE ({result['quantity']})", f"{fit_['nmse_percent']:.1f} %",
         f"{val['nmse_percent']:.1f} %"),
    ]
    if ref is not None:
        rows.append(("sine refit (reference)", "",
                     f"{ref['nmse_percent']:.1f} %, {ref['frequency_hz']:.2f} Hz, "
                     f"ζ {100 * ref['damping_ratio']:.2f} %"))
    params = ", ".join(f"{k} = {v:.4g}" for k, v in fit_["params"].items())
    widths = [max(len(r[i]) for r in rows) for i in range(3)]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip()
             for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    lines.append(f"updated parameters: {params}  ({fit_['successes']}/{fit_['runs']} runs at "
                 f"the best φ)")
    return "\n".join(lines)

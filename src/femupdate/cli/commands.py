"""The ``femupdate`` commands: each parses its options, runs the pipeline and prints.

Messages and help are printed as written (no rich markup), femupdate's errors as one line
with exit code 2, Ctrl-C as one line and exit code 130.

Why this file is long (about 600 lines): typer declares each command's options, with their
help, in the command's signature: ten commands and their options are most of it; what they
print is in ``tables``, the shared options in ``options``.
"""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer
from rich.table import Table
from rich.text import Text

from femupdate.cli.bench import _bench_dynamic, bench_app
from femupdate.cli.options import (
    CaseArgument,
    CaseWorkersOption,
    JsonOption,
    LogJsonOption,
    QuietOption,
    SchedulerOption,
    WorkersOption,
    _input_dir,
    _inputs,
    _load,
    _output_dir,
    _outside_bounds,
    _posterior_limit,
    _read_params,
    _search_limit,
    _seed_check,
    _warn_outside_bounds,
    _write_json,
    console,
    say,
)
from femupdate.cli.tables import (
    SHAPES_SHOWN,
    _records_table,
    _resume_hint,
    _shapes_table,
    _unsigned_zero,
    pair_modes,
    print_coverage,
    print_trials,
    print_update_summary,
)
from femupdate.errors import ConfigError, FemupdateError

# Help and messages are printed as written: rich markup would eat bracketed names such as
# [search] or [[parameters]] (rich_markup_mode=None; console output with markup=False).
app = typer.Typer(
    help="Finite element model updating in structural dynamics, in the time domain.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
    rich_markup_mode=None,
)


app.add_typer(bench_app, name="bench")


@app.command()
def report(
    results: Annotated[Path, typer.Argument(help="A results directory (femupdate run --out).")],
) -> None:
    """Write RESULTS/report.html: one self-contained HTML file (figures embedded, no external
    files, opens offline) of a results directory."""
    from femupdate.report.html import write_report

    with console.status("writing the report…"):
        path = write_report(results)
    say(f"report: {path}")


@app.command()
def demo(
    runs: Annotated[int, typer.Option(min=1, help="Independent AB runs.",
                                      callback=_search_limit("runs", "--runs"))] = 20,
    out: Annotated[Path, typer.Option(help="Where the figures go.",
                                      callback=_output_dir("--out"))] = Path("femupdate-demo"),
    workers: WorkersOption = 2,
) -> None:
    """Run the paper's dynamic benchmark quickly with AB and draw its figures."""
    console.print(
        "femupdate demo: the adaptive Beta-sampling search (AB) identifies the 8 parameters of "
        f"a two-mode free vibration (Zapico-Valle et al. 2010, §4), {runs} independent runs."
    )
    _bench_dynamic("ab", runs, 0, workers, out)
    say(f"figures in {out.resolve()}")


@app.command()
def run(
    case_file: CaseArgument,
    out: Annotated[Path, typer.Option("--out", help="Results directory.",
                                      callback=_output_dir("--out"))] = Path("results"),
    runs: Annotated[int | None, typer.Option(min=1, help="Override [search] runs.",
                                             callback=_search_limit("runs", "--runs"))] = None,
    seed: Annotated[int | None, typer.Option(help="Override [search] seed.",
                                             callback=_search_limit("seed", "--seed"))] = None,
    max_evals: Annotated[int | None, typer.Option(min=1, help="Override [search] max_evals.",
                                                  callback=_search_limit("max_evals",
                                                                         "--max-evals"))
                         ] = None,
    method: Annotated[str | None, typer.Option(
        help="Override [search] method: multistart-lm (the default of case files), ab, ib, "
             "cmaes (or a registered plug-in); the case's options for its own method are then "
             "not used.")] = None,
    data: Annotated[Path | None, typer.Option(help="Read the records from this directory "
                                                   "instead of [data] directory.",
                                              callback=_input_dir("--data"))] = None,
    resume: Annotated[bool, typer.Option(
        "--resume", help="Continue the runs stored in --out, unfinished or interrupted "
        "(from their last checkpoint); refused, naming what changed, if the case, its data "
        "files or the settings changed.")] = False,
    restart: Annotated[bool, typer.Option(
        "--restart", help="Discard the runs stored in --out (results.sqlite, summary.json, "
        "fit.npz) and start over there, e.g. after a run that aborted or a change of the "
        "case.")] = False,
    scheduler: SchedulerOption = None,
    quiet: QuietOption = False,
    log_json: LogJsonOption = None,
    workers: CaseWorkersOption = None,
    json_path: JsonOption = None,
) -> None:
    """Update the model of a case from its measured data: repeated runs and their summary
    (`femupdate report OUT` draws the plots).

    Every evaluation and the optimizers' checkpoints go to OUT/results.sqlite as they happen,
    so an interrupted or killed run continues with --resume; --restart starts over.
    """
    from femupdate.optimize.minimize import METHODS
    from femupdate.pipeline.run import run_case, with_data_directory, with_method
    from femupdate.problem.reduced_path import describe_simulation
    from femupdate.runs import Execution

    if resume and restart:
        raise ConfigError("--resume and --restart exclude each other: --resume continues the "
                          "runs stored in --out, --restart discards them and starts over")
    from femupdate.runs.store import FILENAME

    if resume and not (out / FILENAME).is_file():
        # a wrong --out is the likely cause: a long search must not start there unasked
        raise ConfigError(f"--resume: nothing is stored in {out} to continue (allowed: "
                          "--resume into the --out of an interrupted `femupdate run`; without "
                          "--resume the runs start)")
    case = _load(case_file)
    if data is not None:
        case = with_data_directory(case, data)
    if method is not None:
        if method not in METHODS:
            raise ConfigError(f"--method: got {method!r} (allowed: {', '.join(METHODS)})")
        own = case.search.method
        case, dropped = with_method(case, method)
        if dropped:
            say(f"--method {method}: not using {', '.join(dropped)} (set for {own})")
    execution = Execution(scheduler=scheduler, quiet=quiet, log_json=log_json, label=case.label)
    try:
        result = run_case(case, out, runs=runs, seed=seed, max_evals=max_evals,
                          workers=workers, resume=resume, restart=restart,
                          execution=execution, keep_history=True)
    except KeyboardInterrupt:
        words = ["femupdate", "run", str(case_file), "--out", str(out)]
        for flag, value in (("--runs", runs), ("--seed", seed), ("--max-evals", max_evals),
                            ("--method", method), ("--data", data)):
            if value is not None:
                words += [flag, str(value)]
        _resume_hint([*words, "--resume"])
        raise SystemExit(130) from None
    print_update_summary(result.summary)
    if result.summary.simulation is not None:  # which path ran (reduced: modes, truncation)
        say(describe_simulation(result.summary.simulation))
    say(f"results in {out.resolve()}")
    _write_json(json_path, result.summary.model_dump())


#: The integrators of `femupdate frame3d` (linear methods of femupdate.simulate).
FRAME3D_METHODS = ("exact", "newmark", "central_difference")


#: Exit code of a command that finished without the result it is for (a sampled posterior
#: whose runs did not reach β = 1); 2 is femupdate's errors, 130 Ctrl-C.
NOT_THE_RESULT = 1


@app.command()
def posterior(
    case_file: CaseArgument,
    out: Annotated[Path, typer.Option("--out", help="Results directory.",
                                      callback=_output_dir("--out"))] = Path("results"),
    seed: Annotated[int | None, typer.Option(help="Override [posterior] seed.",
                                             callback=_posterior_limit("seed", "--seed"))
                    ] = None,
    samples: Annotated[int | None, typer.Option(
        min=20, help="Override [posterior] samples (TMCMC's population, per run).",
        callback=_posterior_limit("samples", "--samples"))] = None,
    runs: Annotated[int | None, typer.Option(
        min=1, max=64, help="Override [posterior] runs (independent sampler runs, pooled; "
        "their agreement checks the effective samples).")] = None,
    max_runs: Annotated[int | None, typer.Option(
        "--max-runs", min=1, max=256, help="Override [posterior] max_runs (while a parameter "
        "is unsettled, runs are added, --runs at a time, up to this many).")] = None,
    recentre: Annotated[int | None, typer.Option(
        "--recentre", min=0, max=8, help="Override [posterior] recentre (how many times at "
        "most to sample again from a better fit the sampler finds; 0: only say so).")] = None,
    error_model: Annotated[str | None, typer.Option(
        "--error-model", help="Override [posterior] error_model (the sampled posterior's "
        "likelihood; allowed: neff, the default, or eiv, errors in the variables for a noisy "
        "table record on a linear model).")] = None,
    ess: Annotated[int | None, typer.Option(
        "--ess", min=10, max=10_000_000, help="Override [posterior] ess (the effective samples "
        "every parameter needs; runs are added until it has them, up to --max-runs).")
    ] = None,
    search_from: Annotated[Path | None, typer.Option(
        "--from", help="Take the search of this results directory (`femupdate run --out`, "
        "same case) instead of searching in --out; a finished search is not run again.")
    ] = None,
    data: Annotated[Path | None, typer.Option(help="Read the records from this directory "
                                                   "instead of [data] directory.",
                                              callback=_input_dir("--data"))] = None,
    resume: Annotated[bool, typer.Option(
        "--resume", help="Continue the sampler (and the search) stored in --out from its "
        "last checkpoint: the samples are those of an uninterrupted run.")] = False,
    restart: Annotated[bool, typer.Option(
        "--restart", help="Discard the search and the sampler stored in --out and start "
        "over.")] = False,
    scheduler: SchedulerOption = None,
    quiet: QuietOption = False,
    log_json: LogJsonOption = None,
    workers: CaseWorkersOption = None,
    surrogate: Annotated[bool | None, typer.Option(
        "--surrogate/--no-surrogate", help="TMCMC on a Gaussian-process surrogate trained at "
        "300 model runs at most (default: [posterior] surrogate, else on for an external "
        "model); results in OUT/summary.json (posterior) as TMCMC's.")] = None,
    json_path: JsonOption = None,
) -> None:
    """The posterior of the parameters by TMCMC, beside the best fit: intervals,
    correlations, frequency posteriors, predictive bands, log-evidence.

    The case's search runs first (a finished one in OUT is reused); then the sampler, with
    its settings from [posterior]: independent runs (default 4), pooled, and their verdict
    (do they agree on each parameter?), checkpointed in OUT/posterior (--resume continues
    them to the same samples). The results go into OUT/summary.json (posterior) and
    OUT/posterior.npz; `femupdate report OUT` draws them. With --surrogate (the default for an
    external model) TMCMC samples a Gaussian-process surrogate of the model trained at 300
    model runs at most instead, checked against true runs at its samples.
    """
    from femupdate.pipeline.posterior.console import print_posterior
    from femupdate.pipeline.posterior.run import run_posterior
    from femupdate.pipeline.run import with_data_directory
    from femupdate.runs import Execution

    if resume and restart:
        raise ConfigError("--resume and --restart exclude each other: --resume continues the "
                          "sampler stored in --out, --restart discards it and starts over")
    case = _load(case_file)
    if data is not None:
        case = with_data_directory(case, data)
    execution = Execution(scheduler=scheduler, quiet=quiet, log_json=log_json, label=case.label)
    from femupdate.pipeline.posterior.run import run_surrogate_posterior

    aided = run_surrogate_posterior(case, out, surrogate=surrogate, seed=seed, workers=workers,
                                    execution=execution, resume=resume)
    if aided is not None:
        from femupdate.pipeline.results import SUMMARY_FILE, read_summary

        summary = read_summary(out / SUMMARY_FILE)
        print_posterior(summary.posterior, console)
        say(f"results in {out.resolve()} (femupdate report {out})")
        _write_json(json_path, summary.model_dump())
        if not aided.reached:  # finished, but its check or accuracy not met: scripts must tell
            raise SystemExit(NOT_THE_RESULT)
        return
    try:
        result = run_posterior(case, out, seed=seed, samples=samples, runs=runs,
                               max_runs=max_runs, recentre=recentre, workers=workers,
                               resume=resume, restart=restart, execution=execution,
                               error_model=error_model, search_from=search_from, ess=ess)
    except KeyboardInterrupt:
        words = ["femupdate", "posterior", str(case_file), "--out", str(out)]
        for flag, value in (("--seed", seed), ("--samples", samples), ("--runs", runs),
                            ("--max-runs", max_runs), ("--recentre", recentre),
                            ("--error-model", error_model), ("--ess", ess),
                            ("--from", search_from),
                            ("--data", data)):
            if value is not None:
                words += [flag, str(value)]
        _resume_hint([*words, "--resume"])
        raise SystemExit(130) from None
    print_posterior(result.record, console)
    if result.bands:
        print_coverage(result.bands)
    say(f"results in {out.resolve()} (femupdate report {out})")
    _write_json(json_path, result.summary.model_dump())
    if not result.record.reached:  # finished, but not a posterior: scripts must tell
        raise SystemExit(NOT_THE_RESULT)


@app.command()
def modes(
    case_file: CaseArgument,
    params: Annotated[str | None, typer.Option(
        help="Parameter values: a JSON object, a JSON file, or a summary.json (its best run). "
             "Default: the case's nominal values.")] = None,
    json_path: JsonOption = None,
) -> None:
    """Natural frequencies, damping ratios and mode shapes of a case's model."""
    from femupdate.model.modes import damped_modes, natural_frequencies
    from femupdate.problem.case_model import CaseModel

    case = _load(case_file)
    values = case.nominal() if params is None else _read_params("--params", params, case)
    _warn_outside_bounds("--params", case, values)
    model = CaseModel(case)
    if model.reduced is not None:  # a large model: its lowest modes, sparse (no dense n × n)
        from femupdate.problem.reduced_path import lowest_case_modes

        (freqs, shapes), damped, dof_labels = lowest_case_modes(model.reduced, values)
        title = (f"{case.label}: the lowest {freqs.size} natural frequencies of "
                 f"{len(dof_labels)} DOFs (sparse eigensolver; damped: C projected on them)")
    else:
        system = model.system(values)
        freqs, shapes = natural_frequencies(system)
        damped = damped_modes(system)
        dof_labels = system.dof_labels
        title = (f"{case.label}: natural frequencies"
                 + (" (friction elements stuck)" if system.n_friction else "")
                 + (" (Bouc–Wen initial tangent)" if system.n_bouc_wen else ""))
    table = Table(title=title)
    for col in ("mode", "f [Hz]", "damped f [Hz]", "ζ [%]"):
        table.add_column(col, justify="right", overflow="fold")
    above = False
    match = pair_modes(np.asarray(freqs), np.asarray(damped.freqs_hz))
    for i, f in enumerate(freqs):
        j = match[i]
        fd = damped.damped_freqs_hz[j] if j >= 0 else float("nan")
        zeta = damped.damping_ratios[j] if j >= 0 else float("nan")
        above |= bool(fd > f * (1 + 1e-9))
        table.add_row(str(i + 1), f"{f:.4f}", _unsigned_zero(f"{fd:.4f}"),
                      _unsigned_zero(f"{100 * zeta:.3f}"))
    extra = sorted(set(range(len(damped.freqs_hz))) - set(match.tolist()))
    for j in extra:  # real poles of DOFs that dashpots hold more than springs
        table.add_row("–", "–", _unsigned_zero(f"{damped.damped_freqs_hz[j]:.4f}"),
                      _unsigned_zero(f"{100 * damped.damping_ratios[j]:.3f}"))
    console.print(table)
    if extra:
        say(f"–: {len(extra)} overdamped pole(s) of the damped model (ζ = 100 %, no "
            "oscillation: a real pole whose 'f' is its decay rate |λ|/2π) beside the modes of "
            "K and M; each undamped mode is shown with the damped mode of nearest |λ|/2π.")
    if above:
        say("f: undamped, from K and M; damped f and ζ: the complex modes of the damped model. "
            "Its damping is not proportional (C is not a combination of M and K that the "
            "undamped modes diagonalise), so the damped modes are not the undamped ones with "
            "damping added: a damped frequency can exceed its undamped one.")
    labels = list(dof_labels)
    console.print(_shapes_table(labels, np.asarray(shapes), np.asarray(freqs)))
    if shapes.shape[1] > SHAPES_SHOWN:
        say(f"{shapes.shape[1] - SHAPES_SHOWN} more mode shapes with --json")
    _write_json(json_path, {
        "params": values, "frequencies_hz": freqs.tolist(),
        "damped_frequencies_hz": np.asarray(damped.damped_freqs_hz).tolist(),
        "damping_ratios": np.asarray(damped.damping_ratios).tolist(),
        "dof_labels": labels, "mode_shapes": shapes.tolist(),
    })


#: Sensor errors `femupdate synth` adds to noisy records unless told otherwise (as the bridge
#: benchmark): offsets up to this (m/s²), drifts up to this (m/s² per s).
SYNTH_OFFSET = 0.05


SYNTH_DRIFT = 0.01


@app.command()
def validate(
    case_file: CaseArgument,
    params: Annotated[str, typer.Option(
        help="Parameter values: a summary.json of `femupdate run` (its best run), a JSON file "
             "or a JSON object.")],
    out: Annotated[Path | None, typer.Option(
        "--out", help="Write validation.json and a fit plot per trial here.",
        callback=_output_dir("--out"))] = None,
    data: Annotated[Path | None, typer.Option(help="Read the records from this directory "
                                                   "instead of [data] directory.",
                                              callback=_input_dir("--data"))] = None,
    json_path: JsonOption = None,
    posterior_dir: Annotated[Path | None, typer.Option(
        "--posterior", help="Also the 5–95 % predictive bands of the posterior in this "
        "directory (the --out of `femupdate posterior`) on every trial, and the share of "
        "each measured record inside them.")] = None,
) -> None:
    """Evaluate fixed parameters on every trial of a case: NMSE per trial and channel.

    Each trial is simulated over its whole window and scored over its score_window, fitted
    trials and validation trials alike; nothing is searched.
    """
    from femupdate.pipeline.run import validate_case, with_data_directory

    case = _load(case_file)
    if data is not None:
        case = with_data_directory(case, data)
    values = _read_params("--params", params, case)
    _warn_outside_bounds("--params", case, values)
    result = validate_case(case, values, unseen=data is not None)
    if result.frequencies_hz:
        say("natural frequencies of the model [Hz]: "
            + ", ".join(f"{f:.3f}" for f in result.frequencies_hz))
    print_trials(result.trials, f"{case.label}: the given parameters on each trial")
    bands = None
    if posterior_dir is not None:
        from femupdate.pipeline.posterior.validate import validate_posterior

        bands = validate_posterior(case, posterior_dir)
        print_coverage(bands, f"{case.label}: 5–95 % predictive bands of the posterior")
    report = result.to_dict()
    if bands is not None:
        report["coverage"] = {b.trial: dict(zip(b.channels, b.coverage.tolist(), strict=True))
                              for b in bands}
    if out is not None:
        from femupdate.report.figures import plot_fit, save_png

        out.mkdir(parents=True, exist_ok=True)
        (out / "validation.json").write_text(json.dumps(report, indent=2) + "\n")
        records = {t.name: t for t in result.trials}
        for fit in result.fits:
            nmse = [100.0 * records[fit.trial].nmse_per_channel[c] for c in fit.channels]
            save_png(plot_fit(fit.t, fit.measured, fit.predicted, channels=fit.channels,
                              unit=fit.unit, nmse_percent=nmse,
                              title=f"{fit.trial} ({fit.role})"), out / f"fit-{fit.trial}.png")
        if bands is not None:
            from femupdate.report.posterior_plots import plot_bands

            for b in bands:
                save_png(plot_bands(b.t, b.measured, np.stack([b.q05, b.q50, b.q95]),
                                    b.channels, b.unit, b.coverage, f"{b.trial} ({b.role})"),
                         out / f"bands-{b.trial}.png")
        console.print(f"validation in {out.resolve()}")
    _write_json(json_path, report)


def _channel_list(text: str | None) -> list[int | str] | None:
    """``--channels``: comma-separated station channel numbers or selectors."""
    if text is None:
        return None
    items = [item.strip() for item in text.split(",")]
    if not all(items):
        raise ConfigError(f"--channels: got {text!r} (allowed: channel numbers or "
                          "'location / direction' selectors separated by commas)")
    return [int(item) if item.isdigit() else item for item in items]


@app.command()
def synth(
    case_file: CaseArgument,
    truth: Annotated[str, typer.Option(help="Truth parameter values: a JSON object or file.")],
    out: Annotated[Path, typer.Option("--out", help="Directory for the records.",
                                      callback=_output_dir("--out"))],
    seed: Annotated[int, typer.Option(help="Seed of the motion and of the noise.",
                                      callback=_seed_check("--seed"))] = 0,
    snr: Annotated[float, typer.Option(min=0.0, help="rms noise / rms signal per channel; 0: "
                                       "noise-free records.")] = 0.02,
    duration: Annotated[float, typer.Option(min=0.01, help="Record length, s (model scale).")
                        ] = 4.6,
    rate: Annotated[float | None, typer.Option(help="Sampling rate, Hz, in (0, 1e7] (default: "
                                                    "the case's [data] rate, else 1035).")
                    ] = None,
    pga: Annotated[float, typer.Option(help="Peak ground acceleration of the EC8 spectrum, g."
                                       )] = 0.25,
    motion: Annotated[Path | None, typer.Option(
        help="A recorded ground motion instead of the EC8 artificial one: an El Centro record "
             "(e.g. ../shared/data/elcentro1940/...) or a network record (an event's zip "
             "archive, a .V2/.V2c/.AT2 file).")] = None,
    channels: Annotated[str | None, typer.Option(
        help="The network record's channels, comma-separated, one per component "
             "([[data.components]]) or support group of the case, in its order: station "
             "channel numbers or 'location / direction' selectors (`femupdate inspect` "
             "lists them).")] = None,
    motion_start: Annotated[float, typer.Option(
        min=0.0, help="Start of the recorded motion's window, s of the record.")] = 0.0,
    motion_seconds: Annotated[float | None, typer.Option(
        min=0.0, help="Length of the recorded motion's window, s of the record (default: to "
        "its end).")] = None,
    motion_scale: Annotated[float, typer.Option(
        min=0.0, help="Factor on the recorded motion's accelerations.")] = 1.0,
    length_scale: Annotated[float, typer.Option(
        help="Model length scale λ; time scales by √λ. The default, 1/50, is the paper's 1:50 "
             "model (a motion 7.1× faster than full scale); 1 for a full-scale structure.")
                            ] = 1 / 50,
    offset: Annotated[float | None, typer.Option(
        min=0.0, help=f"Accelerometer offsets up to this, m/s² (default: {SYNTH_OFFSET:g} with "
        "noise, 0 with --snr 0).")] = None,
    drift: Annotated[float | None, typer.Option(
        min=0.0, help=f"Accelerometer drifts up to this, m/s² per s (default: {SYNTH_DRIFT:g} "
        "with noise, 0 with --snr 0).")] = None,
) -> None:
    """A virtual experiment: simulate a truth model and write what the sensors would record.

    With --snr 0 and no --offset or --drift the records are exact (no sensor errors): the
    truth then fits them to rounding. The sensor errors added are printed.
    """
    from femupdate.trials import virtual as virtual

    case = _load(case_file)
    values = _read_params("--truth", truth, case)
    for problem in _outside_bounds(case, values):
        say(f"warning: --truth: {problem} in {case.label}: an update of this case cannot reach "
            "the truth", "yellow")
    if rate is None:
        rate = case.data.rate if case.data is not None and case.data.rate else 1035.0
    elif not (math.isfinite(rate) and 0.0 < rate <= 1e7):
        raise ConfigError(f"--rate: got {rate:g} (allowed: a sampling rate in (0, 1e7] Hz)")
    offset = (SYNTH_OFFSET if snr > 0 else 0.0) if offset is None else offset
    drift = (SYNTH_DRIFT if snr > 0 else 0.0) if drift is None else drift
    if motion is None and (channels is not None or motion_seconds is not None
                           or motion_start != 0.0 or motion_scale != 1.0):
        raise ConfigError("--channels, --motion-start, --motion-seconds and --motion-scale "
                          "choose a recorded motion's part (allowed: with --motion)")
    base = (None if motion is None
            else virtual.recorded_motion(motion, rate=rate, length_scale=length_scale,
                                         channels=_channel_list(channels), start=motion_start,
                                         seconds=motion_seconds, scale=motion_scale))
    manifest = virtual.virtual_experiment(case, values, out, seed=seed, motion=base, snr=snr,
                                          offset=offset, drift=drift, duration=duration,
                                          rate=rate, pga_g=pga, length_scale=length_scale)
    say(f"{manifest['motion']}; {manifest['samples']} samples at {manifest['rate_hz']:g} Hz")
    errors = [f"noise {100 * snr:g} % rms of each channel"] if snr > 0 else []
    if offset > 0:
        errors.append(f"offsets up to {offset:g} m/s²")
    if drift > 0:
        errors.append(f"drifts up to {drift:g} m/s² per s")
    say("sensor errors added: " + (", ".join(errors) if errors else
                                   "none (noise-free records: the truth fits them to rounding)"))
    say(f"wrote {', '.join(manifest['files'])}, truth.json, manifest.json in {out}")


@app.command()
def frame3d(
    case_file: Annotated[Path, typer.Argument(help="A 3-D frame case file (docs/frames-3d.md).")],
    out: Annotated[Path | None, typer.Option("--out", help="Write the responses (CSV) here.",
                                             callback=_output_dir("--out"))] = None,
    method: Annotated[str, typer.Option(help="Integrator: exact, newmark or "
                                             "central_difference.")] = "exact",
) -> None:
    """Simulate a 3-D frame under its ground motions (one record per support group)."""
    from femupdate.pipeline.frame3d import run_frame3d_case

    if method not in FRAME3D_METHODS:  # before the case is read and assembled
        raise ConfigError(f"--method: got {method!r} (allowed: {', '.join(FRAME3D_METHODS)})")

    for line in run_frame3d_case(case_file, out, method=method):
        say(line)


@app.command()
def inspect(
    records: Annotated[Path, typer.Argument(
        help="A network record: a zip archive of an event (CSMIP or COSMOS V2 files), a "
             "folder of them, one such file, or a PEER .AT2 file.")],
    json_path: JsonOption = None,
) -> None:
    """List the channels of a strong-motion record: location, direction, rate, length, peak.

    The peaks are in m/s² (converted from the file's unit, listed); each file's header has
    been checked against its samples. A case reads a channel by its number or by
    "location / direction" as listed here ([data] format = "csmip", "cosmos" or "at2").
    """
    from femupdate.data.network import channel_label, read_network_records

    channels = read_network_records(records)
    rows = [{
        "channel": ch.number, "location": ch.location, "direction": ch.direction,
        "selector": channel_label(ch), "rate_hz": ch.rate, "dt_s": ch.dt,
        "samples": ch.n_samples, "duration_s": (ch.n_samples - 1) * ch.dt,
        "peak_m_s2": float(np.max(np.abs(ch.acceleration))), "file_unit": ch.file_unit,
        "header_peak": ch.peak, "recorder": ch.recorder, "station": ch.station,
        "source": ch.source,
    } for ch in channels]
    stations = sorted({ch.station for ch in channels if ch.station})
    title = f"{records.name}: {len(rows)} channel{'s' if len(rows) > 1 else ''}" + (
        f", {', '.join(stations)}" if stations else "")  # station, or an AT2's event
    console.print(_records_table(title, rows))
    recorders: dict[str, list[Any]] = {}
    for ch in channels:
        recorders.setdefault(ch.recorder, []).append(ch)
    if len(recorders) > 1 and len({ch.dt for ch in channels}) > 1:
        listing = "; ".join(
            f"{name or '?'}: channels {', '.join(str(c.number) for c in chans)} at "
            f"{', '.join(f'{1 / dt:g}' for dt in sorted({c.dt for c in chans}))} Hz"
            for name, chans in recorders.items())
        say(f"recorders (serial numbers): {listing}. Channels of different rates are "
            "resampled to one ([preprocess] resample_hz) when a case reads them together; "
            "each file's time starts at its recorder's first sample.")
    _write_json(json_path, rows)


def _show_warning(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                  file: Any = None, line: str | None = None) -> None:
    """Every warning as one line on the console, without Python's source echo."""
    from femupdate.console import warning_text

    say(warning_text(message, category), "yellow")


def main() -> None:
    """Console entry point: femupdate errors become a one-line message and exit code 2; Ctrl-C
    a line and exit code 130."""
    warnings.showwarning = _show_warning
    try:
        app()
    except FemupdateError as exc:
        console.print(Text("error: ", style="red") + Text(str(exc)))
        raise SystemExit(2) from None
    except KeyboardInterrupt:
        say("interrupted", "yellow")
        raise SystemExit(130) from None
    except OSError as exc:  # a file system's refusal (full, read-only, removed): one line too
        console.print(Text("error: ", style="red") + Text(_inputs().os_error_line(exc)),
                      soft_wrap=True)
        raise SystemExit(2) from None


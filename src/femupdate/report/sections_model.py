"""The report's sections on the best model: its fit to the measurement (with the channel
delays), its natural frequencies and damping, the identifiability of its parameters, and the
validation trials. Each is a function of the :class:`~femupdate.report.facts.Context`."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from femupdate.errors import FemupdateError
from femupdate.pipeline.results import Fit, Summary
from femupdate.report.facts import Context, Modes, modes_at, relative_error, spectrum_limit
from femupdate.report.markup import Page, esc, format_number, note, num, pairs, table, td, warn

# ----------------------------------------------------------------------------- the fit


def _delays(ctx: Context) -> str:
    """The delay removed from each channel, and how it was found."""
    case = ctx.res.case
    delays = ctx.res.summary.delays_s
    low, high = case.preprocess.delay_band_hz
    how = {c.label: ("estimated (\"auto\") from the phase slope in "
                     f"{format_number(low)}–{format_number(high)} Hz" if c.delay == "auto"
                     else "given in the case")
           for c in (case.data.outputs if case.data is not None else [])}
    if not delays:
        return note("No channel delay was removed (every channel's delay is 0).")
    rows = [[td(esc(ch)), td(num(d), "num"), td(num(1e3 * d), "num"),
             td(esc(how.get(ch, "")))] for ch, d in delays.items()]
    return table(["channel", "delay [s]", "delay [ms]", "how"], rows, table_id="delays",
                 caption="Delays removed from the channels behind the table's record "
                         f"(band of the estimate: [preprocess] delay_band_hz = "
                         f"[{format_number(low)}, {format_number(high)}] Hz)")


def section_fit(ctx: Context, page: Page) -> str:
    """Per-channel NMSE, the delays, and measured against predicted (Figs. 13, 18, 19)."""
    from femupdate.data.signal import fourier_amplitude
    from femupdate.report.figures import MAX_FIT_CHANNELS, plot_fit
    from femupdate.report.plots import plot_spectra

    res = ctx.res
    fit = res.fit
    best = res.summary.best
    out = []
    if best.nmse_per_channel:
        rows = [[td(esc(ch)), td(num(100.0 * v), "num")]
                for ch, v in best.nmse_per_channel.items()]
        out.append(table(["channel", "NMSE %"], rows, table_id="channels-nmse",
                         caption=f"Best run ({res.best_index}), per channel"))
    out.append(_delays(ctx))
    if not isinstance(fit, Fit):
        out.append(page.absent("measured against predicted time histories and spectra", fit))
        return "\n".join(out)
    shown = ("" if len(fit.channels) <= MAX_FIT_CHANNELS else
             f" The first {MAX_FIT_CHANNELS} of {len(fit.channels)} channels are drawn; the "
             "table above gives every channel's NMSE.")
    nmse = [100.0 * best.nmse_per_channel.get(c, math.nan) for c in fit.channels]
    fig = plot_fit(fit.t, fit.measured, fit.predicted, channels=fit.channels, unit=fit.unit,
                   nmse_percent=nmse, title=f"best run {res.best_index}")
    what = ("measured (with the fitted integration constants, as φ compares them)"
            if fit.unit == "m" else "measured")
    out.append(page.figure(fig, "fit", f"{what} against predicted time histories of the best "
                                       "model, residual (measured − predicted) under each; a "
                                       "long record also in a detail window around its peak "
                                       "(shaded in the whole record)." + shown))
    fs = 1.0 / float(fit.t[1] - fit.t[0])
    f, measured = fourier_amplitude(fit.measured_acc, fs=fs)
    _, predicted = fourier_amplitude(fit.predicted_acc, fs=fs)
    fig = plot_spectra(f, measured, predicted, labels=[f"{c} [m/s]" for c in fit.channels],
                       f_max=spectrum_limit(f, measured), marks=best.frequencies_hz,
                       truth_marks=ctx.truth.frequencies_hz,
                       title="Fourier amplitude of the acceleration relative to the table")
    out.append(page.figure(fig, "spectra", "Fourier amplitude spectra of the accelerations "
                                           "relative to the table, measured and predicted "
                                           "(dotted: natural frequencies of the best model"
                           + ("; dashed: of the truth" if ctx.truth.frequencies_hz else "")
                           + ")." + shown))
    return "\n".join(out)


# ----------------------------------------------------------------------------- the modes


def _frequency_table(summary: Summary, truth_hz: list[float], truth_name: str) -> str:
    best = summary.best.frequencies_hz
    spread = summary.spread.frequencies_hz
    header = ["mode", "best model [Hz]", "mean ± std, successful runs [Hz]"]
    if truth_hz:
        header += [f"{truth_name} [Hz]", f"best − {truth_name} [%]"]
    rows = []
    for i, fb in enumerate(best):
        s = spread.get(f"f{i + 1}", {})
        ms = (f"{format_number(s['mean'])} ± {format_number(s['std'], 2)}"
              if "mean" in s else "–")
        cells = [td(esc(i + 1)), td(num(fb), "num"), td(esc(ms), "num")]
        if truth_hz:
            fr = truth_hz[i] if i < len(truth_hz) else None
            cells += [td(num(fr), "num truth"), td(num(relative_error(fb, fr), 3), "num")]
        rows.append(cells)
    return table(header, rows, table_id="frequencies",
                 caption="Undamped natural frequencies (K and M; friction elements stuck)")


def _damping_table(best: Modes, truth: Modes | None) -> str:
    header = ["mode", "|λ|/2π [Hz]", "ζ [%]", "damped frequency [Hz]"]
    if truth is not None:
        header += ["truth |λ|/2π [Hz]", "truth ζ [%]"]
    rows = []
    for i, (f, zeta, fd) in enumerate(zip(best.pole_hz, best.damping_ratios, best.damped_hz,
                                          strict=True)):
        cells = [td(esc(i + 1)), td(num(f), "num"), td(num(100.0 * zeta), "num"),
                 td(num(fd), "num")]
        if truth is not None:
            has = i < len(truth.pole_hz)
            cells += [td(num(truth.pole_hz[i] if has else None), "num truth"),
                      td(num(100.0 * truth.damping_ratios[i] if has else None), "num truth")]
        rows.append(cells)
    return table(header, rows, table_id="damping",
                 caption="Complex modes of the best model (state-space eigenvalues λ): "
                         "ζ = −Re λ / |λ|, damped frequency = Im λ / 2π")


def section_modes(ctx: Context) -> str:
    """Natural frequencies (Tables 7, 11) and the damping ratios of the best model."""
    res = ctx.res
    summary = res.summary
    if not summary.best.frequencies_hz:
        return note("The summary holds no natural frequencies.")
    truth = ctx.truth
    out = [_frequency_table(summary, truth.frequencies_hz, "truth")]
    if not truth.frequencies_hz:
        out.append(note("No true frequencies to compare with."))
    if ctx.model is None:
        out.append(note(f"Damping ratios not computed: {ctx.model_note}."))
        return "\n".join(out)
    try:
        best = modes_at(ctx.model, summary.best.params, len(summary.best.frequencies_hz))
        true_modes = (modes_at(ctx.model, truth.values, len(summary.best.frequencies_hz))
                      if truth.values is not None else None)
    except FemupdateError as exc:
        out.append(note(f"Damping ratios not computed: {exc}."))
        return "\n".join(out)
    out.append(_damping_table(best, true_modes))
    if best.proportional:
        out.append(f'<p id="proportional">{esc(_PROPORTIONAL)}</p>')
    else:
        out.append(warn(_NON_PROPORTIONAL, "non-proportional"))
    return "\n".join(out)


_PROPORTIONAL = ("Damping is proportional (K M⁻¹C = C M⁻¹K): the modes are those of K and M, "
                 "|λ|/2π equals the undamped frequency and the damped frequency is below it.")
_NON_PROPORTIONAL = ("Damping is non-proportional (K M⁻¹C ≠ C M⁻¹K): the modes are complex, "
                     "so |λ|/2π of a mode, and even its damped frequency, may differ from the "
                     "undamped frequency of the same rank, and may exceed it.")


# ----------------------------------------------------------------------------- identifiability


def section_identifiability(ctx: Context, page: Page) -> str:
    """Sensitivity of φ to each parameter, singular values and correlations at the best run."""
    from femupdate.report.plots import plot_correlation

    summary = ctx.res.summary
    ident = summary.identifiability
    if ident is None:
        return page.absent("identifiability", "the summary holds no sensitivities")
    if "error" in ident:
        return page.absent("identifiability", f"the sensitivities failed: {ident['error']}")
    names = list(ident["names"])
    phi_best = summary.best.phi
    undetermined = set(ident.get("undetermined", []))
    change = ident.get("phi_change_1pct", {})
    rows = []
    for name, value in zip(names, ident.get("values", [None] * len(names)), strict=True):
        d = change.get(name)
        rel = d / phi_best if d is not None and phi_best > 0 else None
        rows.append([td(esc(name)), td(num(value), "num"), td(num(d), "num"),
                     td(num(rel, 3), "num"),
                     td("no" if name in undetermined else "yes",
                        "fail" if name in undetermined else "ok")])
    out = [table(["parameter", "value", "Δφ for a 1 % change", "Δφ / φ", "determined"], rows,
                 table_id="identifiability",
                 caption="Sensitivity of φ at the best solution (to second order, from the "
                         "Jacobian of the residuals)")]
    sv = np.asarray(ident.get("singular_values", []), dtype=float)
    if sv.size:
        ratios = sv / sv[0] if sv[0] > 0 else sv
        text = ", ".join(f"{format_number(s)} ({format_number(r, 2)})"
                         for s, r in zip(sv, ratios, strict=True))
        cond = sv[0] / sv[-1] if sv[-1] > 0 else math.inf
        out.append(pairs([("singular values (÷ largest)", esc(text)),
                          ("condition number", num(cond, 3))]))
    corr = np.asarray(ident.get("correlations", []), dtype=float)
    if corr.shape == (len(names), len(names)):
        out.append(page.figure(plot_correlation(corr, names), "correlation",
                               "correlation matrix of the parameter estimates"))
    if undetermined:
        out.append(warn("The data cannot determine: "
                        f"{', '.join(n for n in names if n in undetermined)}.", "undetermined"))
    else:
        out.append('<p id="undetermined">Every parameter is determined by the data.</p>')
    return "\n".join(out)


# ----------------------------------------------------------------------------- validation


def validation_trials(summary: Summary) -> dict[str, dict[str, float]]:
    """The best model's NMSE (fraction) on each trial of a case of several, fitted or
    validated: "trial (role)" → "all" and each channel → NMSE. Empty for one trial."""
    if len(summary.trials) < 2:
        return {}
    return {f"{t.name} ({t.role})": {"all": t.phi, **t.nmse_per_channel}
            for t in summary.trials}


def _without_repeated_totals(trials: Mapping[str, Mapping[str, float]]
                             ) -> dict[str, dict[str, float]]:
    """The trials without their "all" NMSE where it repeats their one channel's."""
    return {name: {c: v for c, v in values.items()
                   if not (c == "all" and len(values) == 2)}
            for name, values in trials.items()}


def section_validation(trials: Mapping[str, Mapping[str, float]], page: Page) -> str:
    """The best model on the records it was not fitted to: NMSE per trial and channel."""
    from femupdate.report.plots import plot_trial_nmse

    if not trials:  # one trial, the record fitted: no section ([[trials]] add records)
        return ""
    trials = _without_repeated_totals(trials)
    channels = sorted({c for values in trials.values() for c in values})
    rows = [[td(esc(name)), *(td(num(100.0 * values[c]) if c in values else "–", "num")
                              for c in channels)]
            for name, values in trials.items()]
    percent = {name: {c: 100.0 * v for c, v in values.items()} for name, values in
               trials.items()}
    return "\n".join([
        table(["trial", *(f"{c}: NMSE %" for c in channels)], rows, table_id="validation",
              caption="NMSE of the best model on each trial, fitted or validated"
                      + (" (\"all\": the trial's NMSE over its channels)"
                         if "all" in channels else "")),
        page.figure(plot_trial_nmse(percent), "validation",
                    "NMSE of the best model on each validation trial, per channel (log)"),
    ])

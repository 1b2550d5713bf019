"""The report's uncertainty section: the Laplace approximation at the best fit (every update)
and, after ``femupdate posterior``, the sampled posterior: marginals, evidence, stages, the
corner plot, predictive bands on measured-against-predicted and the frequency posteriors."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from femupdate.errors import MissingDependencyError
from femupdate.inference.records import LaplaceRecord, Marginal, PosteriorRecord
from femupdate.pipeline.posterior.agreement import MIN_ESS
from femupdate.pipeline.results import POSTERIOR_FILE
from femupdate.report.facts import Context
from femupdate.report.markup import Page, esc, note, num, pairs, table, td, warn

#: Predictive bands of at most this many trials are drawn (all are in the coverage table).
MAX_BAND_FIGURES = 6


def _marginal_rows(items: list[tuple[str, Marginal]], undetermined: set[str],
                   not_gaussian: frozenset[str] = frozenset()) -> list[list[str]]:
    def determined(name: str) -> str:
        if name in undetermined:
            return td("no", "fail")
        return td("not Gaussian", "fail") if name in not_gaussian else td("yes", "ok")

    return [[td(esc(name)), td(num(m.mean), "num"), td(num(m.sd, 3), "num"),
             td(num(m.q05), "num"), td(num(m.q50), "num"), td(num(m.q95), "num"),
             determined(name)]
            for name, m in items]


def _ess_cell(value: float | None) -> str:
    if value is None:
        return "–"
    return "∞" if value >= 1e300 else f"{value:,.0f}"


def _settled_cell(record: PosteriorRecord, name: str) -> str:
    """Whether the runs settled a parameter ("–" for the modes: not checked)."""
    if name not in record.ess_params:
        return td("–")
    return td("no", "fail") if name in record.unsettled else td("yes", "ok")


def _sentences(sentences: list[str], flagged: list[str], ident: str) -> str:
    said = [s for s in sentences if any(s.startswith((f"{n} ", f"{n}:")) for n in flagged)]
    if not said:
        return f'<p id="{ident}">The data determine every parameter (each 90 % interval ' \
               "spans less than half of its prior's).</p>"
    return warn(" ".join(s + "." for s in said), ident)


def section_laplace(record: LaplaceRecord | None) -> str:
    """The Gaussian approximation at the best fit: sd, 90 % intervals, words."""
    if record is None:
        return note("No Laplace approximation in this summary (written by an older femupdate).")
    if record.note:
        return note(record.note)
    header = ["parameter", "mean", "sd", "5 %", "50 %", "95 %", "determined"]
    return "\n".join([
        table(header, _marginal_rows(list(record.params.items()), set(record.undetermined),
                                     frozenset(record.not_quadratic)),
              table_id="laplace",
              caption=f"Laplace approximation at the best fit (error model "
                      f"{record.error_model!r}; lognormal on a log scale; quantiles clipped "
                      f"to the bounds; {record.nfev} evaluations)"),
        *[warn(caveat + ".", "laplace-caveat") for caveat in record.caveats],
        _sentences(record.sentences, [*record.undetermined, *record.not_quadratic],
                   "laplace-undetermined"),
    ])


def _read_npz(path: Path) -> dict[str, np.ndarray] | str:
    if not path.is_file():
        return f"no {POSTERIOR_FILE} beside the summary (written by `femupdate posterior`)"
    with np.load(path, allow_pickle=False) as data:
        return {k: data[k] for k in data.files}


def section_posterior(ctx: Context, page: Page) -> str:
    """The sampled posterior, when the summary has one."""
    from femupdate.report.plots import plot_correlation
    from femupdate.report.posterior_plots import plot_corner, plot_frequency_posteriors

    record: PosteriorRecord | None = ctx.res.summary.posterior
    if record is None:
        return ('<p class="note">No sampled posterior: <code>femupdate posterior CASE.toml '
                "--out DIR</code> samples it (TMCMC) and adds it to this report.</p>")
    out = []
    if not record.reached:
        out.append(warn(f"Not a posterior: {record.message}. No samples are reported.",
                        "not-reached"))
    elif record.unsettled:
        out.append(warn(record.agreement + ".", "posterior-agreement"))
    elif record.agreement:
        out.append(note(record.agreement + "."))
    out.extend(warn(w[0].upper() + w[1:] + ".", f"posterior-start-{i}")
               for i, w in enumerate(record.start_warnings))
    out.extend(warn(w[0].upper() + w[1:] + ".", f"posterior-error-model-{i}")
               for i, w in enumerate(record.error_model_notes))
    out.append(pairs([
        ("sampler", esc(f"{record.method}, {record.runs} independent run(s), "
                        f"{record.samples:,} samples in all, error model "
                        f"{record.error_model!r}, "
                        + (f"seed {record.seed}" if record.seed is not None
                           else "no seed given (fresh entropy)"))),
        ("evaluations", esc(f"{record.nfev:,} ({record.failed_evaluations:,} failed) in "
                            f"{record.wall_s:.1f} s (the runs' times summed)")),
        ("log-evidence", (num(record.log_evidence, 8) + esc(record.evidence_spread()))
         if record.log_evidence is not None else "–"),
        ("effective sample size", num(record.ess, 4) if record.ess is not None else "–"),
    ], table_id="posterior-facts"))
    undetermined = set(record.undetermined)
    items = [*record.params.items(),
             *((f"{k} [Hz]", m) for k, m in record.frequencies_hz.items()),
             *((k, m) for k, m in record.damping_ratios.items())]
    rows = [[*row, td(_ess_cell(record.ess_params.get(name)), "num"),
             td(num(record.rhat[name], 4) if record.rhat.get(name) is not None else "–", "num"),
             _settled_cell(record, name)]
            for row, (name, _) in zip(_marginal_rows(items, undetermined), items, strict=True)]
    out.append(table(["quantity", "mean", "sd", "5 %", "50 %", "95 %", "determined", "ESS",
                      "R̂", "settled"], rows, table_id="posterior",
                     caption="Posterior mean, standard deviation and quantiles (frequencies "
                             f"and damping ratios over {record.modes_from} of the samples); "
                             "ESS: effective samples, the smaller of the runs' own estimates "
                             "and what the scatter of their means shows; settled: ESS ≥ "
                             f"{MIN_ESS:.0f}"))
    out.append(_sentences(record.sentences, record.undetermined, "posterior-undetermined"))
    stages = [[td(str(i + 1)), td(num(s.beta, 4), "num"), td(num(s.acceptance, 3), "num"),
               td(num(s.ess, 4), "num")] for i, s in enumerate(record.stages)]
    out.append(table(["stage", "β", "acceptance", "ESS"], stages, table_id="stages",
                     caption="TMCMC stages of the first run: tempering exponent, acceptance "
                             "rate of the moves, effective sample size of the weights"))
    if record.joint_correlations:
        out.append(page.figure(plot_correlation(np.array(record.joint_correlations, dtype=float),
                                                record.joint_names), "posterior-correlation",
                               "posterior correlations of the parameters, natural frequencies "
                               "and damping ratios"))
    data = _read_npz(ctx.res.directory / POSTERIOR_FILE)
    if isinstance(data, str):
        out.append(page.absent("posterior figures", data))
        return "\n".join(out)
    names = [str(n) for n in data["names"]]
    truth = ctx.truth.at(names)
    try:
        out.append(page.figure(plot_corner(data["samples"], names, truth), "corner",
                               "posterior samples: marginals and pairs (5/50/95 % dashed"
                               + (", truth in green)" if truth is not None else ")")))
    except MissingDependencyError as exc:  # an optional extra: the rest of the report stands
        out.append(page.absent("corner plot", str(exc)))
    if "mode_freqs" in data and data["mode_freqs"].size:
        out.append(page.figure(plot_frequency_posteriors(
            data["mode_freqs"], ctx.truth.frequencies_hz or None), "frequency-posteriors",
            "natural frequencies of the model over the posterior samples"))
    out.append(section_bands(data, page))
    return "\n".join(out)


def section_bands(data: dict[str, np.ndarray], page: Page) -> str:
    """Predictive bands of each trial and the share of the measured record they cover."""
    from femupdate.report.posterior_plots import plot_bands

    count = int(data.get("band_count", np.array(0)))
    if count == 0:
        return note("No predictive bands were computed.")
    rows, figures = [], []
    for i in range(count):
        p = f"band{i}/"
        channels = [str(c) for c in data[p + "channels"]]
        coverage = data[p + "coverage"]
        trial, role = str(data[p + "trial"]), str(data[p + "role"])
        rows.append([td(esc(trial)), td(esc(role)),
                     *(td(f"{esc(c)} {100 * v:.1f} %", "num")
                       for c, v in zip(channels, coverage, strict=True))])
        if i < MAX_BAND_FIGURES:
            bands = np.stack([data[p + "q05"], data[p + "q50"], data[p + "q95"]])
            figures.append(page.figure(
                plot_bands(data[p + "t"], data[p + "measured"], bands, channels,
                           str(data[p + "unit"]), coverage, f"{trial} ({role})"),
                f"bands-{i}", f"{trial}: measured against the 5–95 % predictive band"))
    width = max(len(r) for r in rows)
    rows = [r + [td("")] * (width - len(r)) for r in rows]
    return "\n".join([
        table(["trial", "role", *["channel: covered"] * (width - 2)], rows, table_id="coverage",
              caption="Share of each measured record inside the 5–95 % predictive band "
                      "(parameter uncertainty and the error model's noise)"),
        *figures])


def section_uncertainty(ctx: Context, page: Page) -> str:
    """How far to trust the parameters: Laplace at the best fit, then the sampled posterior."""
    return "\n".join([
        "<h3>At the best fit (Laplace)</h3>", section_laplace(ctx.res.summary.laplace),
        '<h3 id="sampled">Sampled posterior</h3>', section_posterior(ctx, page)])

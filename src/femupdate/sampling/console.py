"""The uncertainty in the console summaries: Laplace at the best fit, the sampled posterior."""

from __future__ import annotations

from rich.console import Console
from rich.table import Table
from rich.text import Text

from femupdate.posterior.records import LaplaceRecord, Marginal, PosteriorRecord


def _interval(m: Marginal) -> str:
    return f"[{m.q05:.4g}, {m.q95:.4g}]"


def print_laplace(record: LaplaceRecord | None, best: dict[str, float], out: Console) -> None:
    """The best fit's standard deviations and 90 % intervals (Laplace), and in words which
    parameters the data do not determine."""
    if record is None:
        return
    if record.note:
        out.print(Text(record.note))
        return
    table = Table(title=Text(f"uncertainty at the best fit (Laplace, error model "
                             f"{record.error_model!r})"),
                  caption=Text("90 % interval: 5–95 % of the Gaussian approximation at the "
                               "best fit (lognormal on a log scale), clipped to the bounds"))
    for col in ("parameter", "best", "sd", "90 % interval", "determined"):
        table.add_column(col, justify="right")
    for name, m in record.params.items():
        determined = ("no" if name in record.undetermined
                      else "not Gaussian" if name in record.not_quadratic else "yes")
        table.add_row(name, f"{best.get(name, float('nan')):.4g}", f"{m.sd:.2g}",
                      _interval(m), determined)
    out.print(table)
    for sentence in [*record.caveats, *record.flagged_sentences()]:
        out.print(Text(sentence + "."))


def print_posterior(record: PosteriorRecord, out: Console) -> None:
    """The sampled posterior: stages, evidence, marginals of parameters and modes."""
    words = (f"TMCMC, {record.runs} run(s), {record.samples:,} samples in all, error model "
             f"{record.error_model!r}: {record.nfev:,} evaluations in {record.wall_s:.1f} s "
             "(the runs' times summed)")
    if record.reached and record.log_evidence is not None and record.ess is not None:
        words += (f"; {record.message}; log-evidence {record.log_evidence:.6g}"
                  f"{record.evidence_spread()}")
    out.print(Text(words))
    if not record.reached:
        out.print(Text(f"NOT A POSTERIOR: {record.message}", style="bold yellow"))
    elif record.agreement:
        out.print(Text(f"verdict: {record.agreement}",
                       style="bold yellow" if record.unsettled else "green"))
    for warning in record.start_warnings:
        out.print(Text(f"start: {warning}", style="bold yellow"))
    if record.failed_evaluations:
        out.print(Text(f"{record.failed_evaluations:,} evaluations failed (zero likelihood): "
                       f"{record.failure}"))
    if not record.reached:  # no samples, so no marginals: nothing more to show
        return
    table = Table(title=Text("posterior: mean, sd and 5/50/95 % quantiles"),
                  caption=Text("ESS: effective samples, the smaller of the runs' own estimates "
                               "and what the scatter of their means shows; R̂: Gelman–Rubin"))
    for col in ("quantity", "mean", "sd", "5 %", "50 %", "95 %", "ESS", "R̂"):
        table.add_column(col, justify="right")
    rows = [*record.params.items(),
            *((f"{k} [Hz]", m) for k, m in record.frequencies_hz.items()),
            *((k, m) for k, m in record.damping_ratios.items())]
    for name, m in rows:
        ess, rhat = record.ess_params.get(name), record.rhat.get(name)
        table.add_row(name, f"{m.mean:.4g}", f"{m.sd:.2g}", f"{m.q05:.4g}", f"{m.q50:.4g}",
                      f"{m.q95:.4g}", "–" if ess is None else f"{min(ess, 1e9):,.0f}",
                      "–" if rhat is None else f"{rhat:.3f}",
                      style="yellow" if name in record.unsettled else None)
    out.print(table)
    for sentence in record.sentences:
        if any(sentence.startswith(f"{n} ") for n in record.undetermined):
            out.print(Text(sentence + "."))

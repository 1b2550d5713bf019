"""The uncertainty in the console summaries: Laplace at the best fit, the sampled posterior.

The tables fit 80 columns with every number whole (no column is cut to an ellipsis: a cell
too wide folds), and an interval's ends carry the significant digits that tell them apart
(:func:`interval_digits`): a narrow interval of a large number is not printed as
``[1.2e+06, 1.2e+06]``.
"""

from __future__ import annotations

import math

from rich import box
from rich.console import Console
from rich.table import Table
from rich.text import Text

from femupdate.inference.records import LaplaceRecord, Marginal, PosteriorRecord

#: Significant digits at least, and at most, of the numbers of an interval.
MIN_DIGITS, MAX_DIGITS = 4, 12


def interval_digits(low: float, high: float, least: int = MIN_DIGITS) -> int:
    """The fewest significant digits (≥ ``least``, ≤ :data:`MAX_DIGITS`) at which ``low``
    and ``high`` print differently (trailing zeros kept), plus one to show how far apart
    they are."""
    if not (math.isfinite(low) and math.isfinite(high)) or low == high:
        return least
    for digits in range(least - 1, MAX_DIGITS):
        if f"{low:#.{digits}g}" != f"{high:#.{digits}g}":
            return max(least, digits + 1)
    return MAX_DIGITS


def number(value: float, digits: int) -> str:
    """``value`` to ``digits`` significant digits, trailing zeros kept ('–' for a missing
    one)."""
    if value is None or math.isnan(value):
        return "–"
    return f"{value:#.{digits}g}".replace(".e", "e").rstrip(".")


def _interval(m: Marginal) -> str:
    digits = interval_digits(m.q05, m.q95)
    return f"[{number(m.q05, digits)}, {number(m.q95, digits)}]"


def _table(title: str, caption: str, columns: tuple[str, ...]) -> Table:
    """A compact table whose cells fold rather than end in an ellipsis."""
    table = Table(title=Text(title), caption=Text(caption), box=box.SIMPLE_HEAD,
                  padding=(0, 1), collapse_padding=True)
    for col in columns:
        table.add_column(col, justify="right", overflow="fold")
    return table


def print_laplace(record: LaplaceRecord | None, best: dict[str, float], out: Console) -> None:
    """The best fit's standard deviations and 90 % intervals (Laplace), and in words which
    parameters the data do not determine."""
    if record is None:
        return
    if record.note:
        out.print(Text(record.note))
        return
    table = _table(f"uncertainty at the best fit (Laplace, error model {record.error_model!r})",
                   "90 % interval: 5–95 % of the Gaussian approximation at the best fit "
                   "(lognormal on a log scale), clipped to the bounds",
                   ("parameter", "best", "sd", "90 % interval", "determined"))
    for name, m in record.params.items():
        determined = ("no" if name in record.undetermined
                      else "not Gaussian" if name in record.not_quadratic else "yes")
        table.add_row(name, number(best.get(name, math.nan),
                                   interval_digits(m.q05, m.q95)),
                      f"{m.sd:.2g}", _interval(m), determined)
    out.print(table)
    for sentence in [*record.caveats, *record.flagged_sentences()]:
        out.print(Text(sentence + "."))


def print_posterior(record: PosteriorRecord, out: Console) -> None:
    """The sampled posterior: stages, evidence, marginals of parameters and modes."""
    words = (f"TMCMC, {record.runs} run(s), {record.samples:,} samples in all, error model "
             f"{record.error_model!r}: {record.nfev:,} evaluations in {record.wall_s:.1f} s "
             "(the runs' times summed)")
    message = record.message
    if record.method == "surrogate":  # the verdict line below says its check
        words = (f"TMCMC on a Gaussian-process surrogate, {record.samples:,} samples, error "
                 f"model {record.error_model!r}: {record.nfev:,} model runs in "
                 f"{record.wall_s:.1f} s")
        message = message.split(";")[0].split(":")[0]
    if record.reached and record.log_evidence is not None and record.ess is not None:
        words += (f"; {message}; log-evidence {record.log_evidence:.6g}"
                  f"{record.evidence_spread()}")
    out.print(Text(words))
    if not record.reached:
        out.print(Text(f"NOT A POSTERIOR: {record.message}", style="bold yellow"))
    elif record.agreement:
        out.print(Text(f"verdict: {record.agreement}",
                       style="bold yellow" if record.unsettled else "green"))
    for warning in record.start_warnings:
        out.print(Text(f"start: {warning}", style="bold yellow"))
    for words in record.error_model_notes:
        out.print(Text(words, style="bold yellow"))
    if record.failed_evaluations:
        out.print(Text(f"{record.failed_evaluations:,} evaluations failed (zero likelihood): "
                       f"{record.failure}"))
    if not record.reached:  # no samples, so no marginals: nothing more to show
        return
    table = _table("posterior: median, sd and 90 % interval (5–95 % quantiles)",
                   "mean and every quantile in summary.json; ESS: effective samples, the "
                   "smaller of the runs' own estimates and what the scatter of their means "
                   "shows; R̂: Gelman–Rubin", ("quantity", "50 %", "sd", "5 %", "95 %",
                                               "ESS", "R̂"))
    rows = [*record.params.items(),
            *((f"{k} [Hz]", m) for k, m in record.frequencies_hz.items()),
            *((k, m) for k, m in record.damping_ratios.items())]
    for name, m in rows:
        ess, rhat = record.ess_params.get(name), record.rhat.get(name)
        digits = interval_digits(m.q05, m.q95)
        table.add_row(name, number(m.q50, digits), f"{m.sd:.2g}", number(m.q05, digits),
                      number(m.q95, digits), "–" if ess is None else f"{min(ess, 1e9):,.0f}",
                      "–" if rhat is None else f"{rhat:.3f}",
                      style="yellow" if name in record.unsettled else None)
    out.print(table)
    for sentence in record.sentences:
        if any(sentence.startswith(f"{n} ") for n in record.undetermined):
            out.print(Text(sentence + "."))

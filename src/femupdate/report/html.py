"""``femupdate report DIR``: one self-contained HTML page of a results directory.

Reads the results directory (:func:`femupdate.pipeline.results.load_results`: ``summary.json``, the
best model's fit ``fit.npz`` and, optionally, the results store with the runs' histories) and
writes ``DIR/report.html``: one file that opens offline with nothing beside it (the figures
are PNG data URIs; plain HTML and inline CSS, no JavaScript, no link to any file).

Sections: the case; the table of runs (the paper's Tables 3–6 and 9); convergence (φ of every
run, the Beta trace, the parameters); the spread of the parameters over the successful runs,
with values at a bound flagged as improper minima; measured against predicted time histories
and Fourier spectra (Figs. 13, 18, 19) with the channel delays; natural frequencies and damping
(Tables 7, 11); identifiability; validation. Results of a virtual experiment are compared with
its truth throughout. What cannot be drawn (no results store, no fit) is said where it would be.
The sections are in :mod:`~femupdate.report.sections_runs` and
:mod:`~femupdate.report.sections_model`.
"""

from __future__ import annotations

from pathlib import Path

from femupdate.pipeline.results import REPORT_FILE, Results, load_results
from femupdate.report.facts import bound_positions, context, spectrum_limit
from femupdate.report.markup import Page, esc, format_number
from femupdate.report.sections_defects import section_defects
from femupdate.report.sections_model import (
    section_fit,
    section_identifiability,
    section_modes,
    section_validation,
    validation_trials,
)
from femupdate.report.sections_posterior import section_uncertainty
from femupdate.report.sections_runs import (
    section_case,
    section_convergence,
    section_runs,
    section_spread,
)
from femupdate.runs.stats import BOUND_TOL, bound_flags

__all__ = [
    "BOUND_TOL",
    "bound_flags",
    "bound_positions",
    "format_number",
    "render_report",
    "spectrum_limit",
    "write_report",
]

#: The figures of earlier reports, written beside the page (report/<name>.png); removed so
#: that none is mistaken for the current one.
_OLD_FIGURES = ("phi", "beta", "parameters", "spread", "fit", "spectra", "correlation")

_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 2em auto;
       max-width: 72em; padding: 0 1em; color: #222; line-height: 1.4; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; } h2 { border-bottom: 1px solid #ccc;
     margin-top: 2em; } h3 { font-size: 1.05em; margin-bottom: 0.3em; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.88em; line-height: 1.25; }
th, td { border: 1px solid #ddd; padding: 0.25em 0.6em; vertical-align: top;
         overflow-wrap: anywhere; }
td.code { font-family: ui-monospace, monospace; font-size: 0.95em; overflow-wrap: normal; }
@media (max-width: 900px) { body { padding: 0 0.5em; } table { font-size: 0.8em; }
         th, td { padding: 0.2em 0.4em; } }
thead th { background: #f2f2f2; } table.pairs th { text-align: left; background: #fafafa;
     font-weight: normal; color: #555; }
caption { caption-side: top; text-align: left; color: #555; padding-bottom: 0.3em; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
td.bound { background: #fde2c8; } td.ok { color: #176117; } td.fail { color: #a31515; }
.note { color: #666; font-style: italic; } .warn { color: #8a4b00; }
figure { margin: 1em 0; } figure img { max-width: 100%; height: auto;
     border: 1px solid #eee; box-sizing: border-box; }
td.truth { color: #1b5e20; }
figcaption { color: #555; font-size: 0.9em; } .missing { background: #fff8e5;
     border: 1px solid #f0d48a; padding: 0.5em 1em; } code { font-size: 0.95em; }
.scroll { overflow-x: auto; }
"""


def render_report(results_dir: str | Path) -> str:
    """The report of a results directory as the text of one HTML page.

    Raises
    ------
    FemupdateError
        No results directory, or no readable ``summary.json`` in it.
    """
    from threadpoolctl import threadpool_limits

    res = load_results(results_dir)
    # The modes of a small model are dense algebra that one BLAS thread does fastest (threads
    # only contend, e.g. 1.7 s instead of 0.03 s for a 200 × 200 eig on a busy machine).
    with threadpool_limits(limits=1):
        return _render(res)


def _render(res: Results) -> str:
    ctx = context(res)
    page = Page()
    sections = [
        ("case", "The case", section_case(ctx)),
        ("runs", "Runs", section_runs(ctx)),
        ("convergence", "Convergence", section_convergence(ctx, page)),
        ("spread", "Spread of the parameters", section_spread(ctx, page)),
        ("fit", "Measured against predicted", section_fit(ctx, page)),
        ("frequencies", "Natural frequencies and damping", section_modes(ctx)),
        ("identifiability", "Identifiability", section_identifiability(ctx, page)),
        ("validation", "Validation",
         section_validation(validation_trials(res.summary), page)),
        ("uncertainty", "Uncertainty", section_uncertainty(ctx, page)),
    ]
    # numbered once the empty ones are left out (a report without validation trials went
    # from 7 to 9)
    sections = [(key, f"{i}. {title}", content) for i, (key, title, content)
                in enumerate([s for s in sections if s[2]], start=1)]
    defects = section_defects(res.summary.defects)
    if defects:  # shown only when the checks found something, first
        sections.insert(0, ("defects", "Defects in the records", defects))
    # sections are "section-KEY": a table may carry the section's name as its own id
    toc = " · ".join(f'<a href="#section-{key}">{esc(title)}</a>' for key, title, _ in sections)
    missing = ""
    if page.missing:
        lis = "".join(f"<li>{esc(m)}</li>" for m in page.missing)
        missing = f'<div class="missing" id="missing"><p>Not drawn:</p><ul>{lis}</ul></div>'
    summary = res.summary
    name = res.case.case.name
    planned = summary.verdict.planned if summary.verdict is not None else None
    ran = (f"{len(summary.runs)} runs" if planned is None else
           f"{len(summary.runs)} of {planned} runs (the others were not needed)")
    lead = (f"{ran} of {summary.method}; best run {res.best_index}, NMSE "
            f"{format_number(summary.best.nmse_percent)} %."
            + (" Compared with the truth of a virtual experiment." if ctx.truth.values else ""))
    body = "\n".join(f'<section id="section-{key}"><h2>{esc(title)}</h2>\n{content}\n</section>'
                     for key, title, content in sections)
    return (
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
        f"<title>femupdate report: {esc(name)}</title>\n<style>{_CSS}</style>\n</head>\n"
        f"<body>\n<h1>femupdate report: {esc(name)}</h1>\n<p>{esc(lead)}</p>\n"
        f"<nav>{toc}</nav>\n{missing}\n{body}\n</body>\n</html>\n"
    )


def write_report(results_dir: str | Path) -> Path:
    """Write ``report.html`` into a results directory: one self-contained file.

    Parameters
    ----------
    results_dir : path
        The ``--out`` directory of ``femupdate run``: ``summary.json`` and, if present,
        ``fit.npz`` and ``results.sqlite``.

    Returns
    -------
    Path
        ``results_dir/report.html``.

    Raises
    ------
    FemupdateError
        No results directory, or no readable ``summary.json`` in it.
    """
    text = render_report(results_dir)
    directory = Path(results_dir)
    out = directory / REPORT_FILE
    out.write_text(text, encoding="utf-8")
    _remove_old_figures(directory / "report")
    return out


def _remove_old_figures(folder: Path) -> None:
    for stem in _OLD_FIGURES:
        (folder / f"{stem}.png").unlink(missing_ok=True)
    if folder.is_dir() and not any(folder.iterdir()):
        folder.rmdir()

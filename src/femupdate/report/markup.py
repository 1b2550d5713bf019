"""HTML building blocks of the report: numbers as tables show them, escaped cells and tables,
and :class:`Page`, which embeds figures as PNG data URIs and lists what could not be drawn."""

from __future__ import annotations

import base64
import html
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from femupdate.report.canvas import DPI, png_bytes

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def format_number(value: Any, digits: int = 4) -> str:
    """A number as a table shows it: ``digits`` significant digits, thousands separated.

    Integers are shown in full (``12,345``); floats with ``digits`` significant digits, in
    scientific notation with a plain exponent (``2.1e11``, ``3.5e-5``) outside [1e-3, 1e5);
    None and NaN as an en dash.
    """
    if value is None:
        return "–"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, (int, np.integer)):
        return f"{int(value):,}"
    x = float(value)
    if math.isnan(x):
        return "–"
    if math.isinf(x):
        return "∞" if x > 0 else "−∞"
    if x == 0.0:
        return "0"
    if 1e-3 <= abs(x) < 1e5:
        # Positional, never "1e+04": rounded to ``digits`` significant digits.
        return np.format_float_positional(x, precision=digits, unique=False,
                                          fractional=False, trim="-")
    mantissa, exponent = f"{x:.{digits - 1}e}".split("e")
    mantissa = mantissa.rstrip("0").rstrip(".") if "." in mantissa else mantissa
    return f"{mantissa}e{int(exponent)}"


def format_value(value: float | str, unit: str = "") -> str:
    """A model property: a number (with its unit) or the name of the parameter it stands for.

    Any property of a case's model may name a parameter (``alpha = "alpha"``); a number is
    formatted by :func:`format_number`.
    """
    if isinstance(value, str):
        return f"parameter {value}"
    return format_number(value) + (f" {unit}" if unit else "")


def esc(text: Any) -> str:
    """``text`` as HTML text (quotes escaped too: safe in attributes)."""
    return html.escape(str(text), quote=True)


def num(value: Any, digits: int = 4) -> str:
    """A number as escaped HTML text."""
    return esc(format_number(value, digits))


def td(content: str, cls: str = "", title: str = "") -> str:
    """A table cell of finished HTML ``content``."""
    attrs = (f' class="{cls}"' if cls else "") + (f' title="{esc(title)}"' if title else "")
    return f"<td{attrs}>{content}</td>"


def table(header: Sequence[str], rows: Sequence[Sequence[str]], *, table_id: str = "",
          caption: str = "") -> str:
    """A table: ``header`` is plain text (escaped here), ``rows`` hold finished ``<td>`` cells."""
    ident = f' id="{table_id}"' if table_id else ""
    head = "".join(f"<th>{esc(h)}</th>" for h in header)
    body = "\n".join(f"<tr>{''.join(r)}</tr>" for r in rows)
    cap = f"<caption>{esc(caption)}</caption>" if caption else ""
    return (f'<div class="scroll"><table{ident}>{cap}<thead><tr>{head}</tr></thead>\n<tbody>\n'
            f"{body}\n</tbody></table></div>")


def pairs(items: Sequence[tuple[str, str]], *, table_id: str = "") -> str:
    """A two-column definition table; values are finished HTML."""
    ident = f' id="{table_id}"' if table_id else ""
    rows = "".join(f"<tr><th>{esc(k)}</th><td>{v}</td></tr>" for k, v in items)
    return f'<table class="pairs"{ident}>{rows}</table>'


def note(text: str) -> str:
    """A remark in italics."""
    return f'<p class="note">{esc(text)}</p>'


def warn(text: str, ident: str = "") -> str:
    """A warning paragraph."""
    attr = f' id="{ident}"' if ident else ""
    return f'<p class="warn"{attr}>{esc(text)}</p>'


class Page:
    """Embeds figures in the page (PNG data URIs: nothing beside the HTML file) and collects
    what could not be drawn."""

    def __init__(self) -> None:
        self.missing: list[str] = []
        self.figures: list[str] = []

    def figure(self, fig: Figure, name: str, caption: str) -> str:
        """``fig`` as a ``<figure id="figure-NAME">`` holding its PNG."""
        data = base64.b64encode(png_bytes(fig)).decode("ascii")
        width, height = (round(v * DPI) for v in fig.get_size_inches())
        self.figures.append(name)
        return (f'<figure id="figure-{esc(name)}"><img src="data:image/png;base64,{data}" '
                f'width="{width}" height="{height}" alt="{esc(caption)}">'
                f"<figcaption>{esc(caption)}</figcaption></figure>")

    def absent(self, what: str, why: str) -> str:
        """Say where a figure or table would be that it is not drawn, and why."""
        self.missing.append(f"{what}: {why}")
        return note(f"{what} not drawn: {why}.")

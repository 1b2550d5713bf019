"""Matplotlib plumbing shared by every figure: a figure without pyplot, ticks that carry their
own power of ten, many lines as one artist, and the PNG bytes.

Matplotlib is imported only inside :mod:`femupdate.report`, and lazily, so that importing
femupdate does not import it.
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

#: Resolution of every PNG (the report's and the saved ones).
DPI = 100
#: Above this many lines an axis gets one LineCollection instead of one Line2D each (the
#: cost of drawing grows with the number of artists, not of points).
MAX_LINE_ARTISTS = 20


def new_figure(width: float, height: float) -> Figure:
    """A figure with the constrained layout, outside pyplot's global state (nothing to close).

    Parameters
    ----------
    width, height : float
        Size in inches.
    """
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height), layout="constrained")


def tick_labels(locs: Sequence[float]) -> list[str]:
    """Tick labels that carry their own power of ten: ``["0", "2.5e-5", "5e-5"]``.

    One exponent for all the ticks, that of the largest, when it is outside [1e-3, 1e4); the
    fewest decimals that tell the ticks apart. Matplotlib's default writes the common factor
    (``1e11``) as an offset text at the end of the axis, where it collides with titles.
    """
    values = np.asarray(locs, dtype=float)
    finite = np.abs(values[np.isfinite(values) & (values != 0.0)])
    if finite.size == 0:
        return ["0" if v == 0.0 else str(v) for v in values]
    top = float(finite.max())
    exponent = 0 if 1e-3 <= top < 1e4 else math.floor(math.log10(top))
    mantissas = values / 10.0**exponent
    steps = np.diff(np.sort(mantissas[np.isfinite(mantissas)]))
    step = float(steps[steps > 0].min()) if np.any(steps > 0) else abs(float(mantissas[0]))
    decimals = 0
    while decimals < 12 and np.any(np.abs(np.round(mantissas, decimals) - mantissas)
                                   > 1e-6 * step):
        decimals += 1
    labels = []
    for m in mantissas:
        text = f"{m:.{decimals}f}"
        if float(text) == 0.0:
            labels.append("0")
        else:
            labels.append(text if exponent == 0 else f"{text}e{exponent}")
    return [label.replace("-", "−") for label in labels]


def tick_formatter() -> Any:
    """A matplotlib formatter writing :func:`tick_labels` (its offset text stays empty)."""
    from matplotlib.ticker import Formatter

    class SciTicks(Formatter):
        def __init__(self) -> None:
            self._labels: dict[float, str] = {}

        def set_locs(self, locs: Sequence[float]) -> None:
            self._labels = dict(zip(locs, tick_labels(locs), strict=True))

        def __call__(self, x: float, pos: int | None = None) -> str:
            return self._labels.get(x) or tick_labels([x])[0]

        def get_offset(self) -> str:
            return ""

    return SciTicks()


def plain_ticks(fig: Figure) -> None:
    """Give every numeric linear axis of ``fig`` the :func:`tick_formatter`.

    Log axes keep theirs (no offset text), and so do axes with named ticks.
    """
    from matplotlib.ticker import ScalarFormatter

    for ax in fig.axes:
        for axis, scale in ((ax.xaxis, ax.get_xscale()), (ax.yaxis, ax.get_yscale())):
            if scale == "linear" and type(axis.get_major_formatter()) is ScalarFormatter:
                axis.set_major_formatter(tick_formatter())


def lines(ax: Axes, x: np.ndarray, ys: np.ndarray, *, labels: Sequence[str] | None = None,
          **style: Any) -> None:
    """Draw the columns of ``ys`` against ``x``: one line each, or one collection when many.

    Parameters
    ----------
    x : ndarray, shape (m,)
    ys : ndarray, shape (m, k)
    labels : sequence of str, optional
        Legend labels; used only when the lines are drawn one by one.
    """
    from matplotlib.collections import LineCollection

    ys = np.asarray(ys, dtype=float).reshape(len(x), -1)
    if ys.shape[1] <= MAX_LINE_ARTISTS:
        for j in range(ys.shape[1]):
            ax.plot(x, ys[:, j], label=labels[j] if labels is not None else None, **style)
        return
    segments = np.stack([np.broadcast_to(np.asarray(x, float)[:, None], ys.shape), ys],
                        axis=-1).transpose(1, 0, 2)
    colors = [f"C{j % 10}" for j in range(ys.shape[1])]
    ax.add_collection(LineCollection(list(segments), colors=colors,
                                     linewidths=style.get("lw", 0.8), alpha=0.8))
    finite = ys[np.isfinite(ys) & ((ys > 0) if ax.get_yscale() == "log" else True)]
    if finite.size:
        ax.update_datalim([(float(np.min(x)), float(finite.min())),
                           (float(np.max(x)), float(finite.max()))])
    ax.autoscale_view()


def png_bytes(fig: Figure) -> bytes:
    """The figure as PNG."""
    plain_ticks(fig)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=DPI)
    return buffer.getvalue()


def save_png(fig: Figure, path: Path) -> Path:
    """Write the figure to ``path`` as PNG (folders created)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(png_bytes(fig))
    return path

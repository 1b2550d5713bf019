"""mkdocs-gallery configuration (``conf_script`` in mkdocs.yml).

femupdate draws its figures outside pyplot (``femupdate.report.canvas.new_figure``: nothing to
close, no global state), so matplotlib's own scraper never sees them. This scraper shows every
matplotlib ``Figure`` an example binds to a top-level name (or puts in a top-level list), once,
after the code block that made it.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

from mkdocs_gallery.scrapers import HLIST_HEADER, figure_md_or_html


def _pathless_warning(message: Warning | str, category: type[Warning], filename: str,
                      lineno: int, line: str | None = None) -> str:
    """A warning in an executed example's output as a reader sees it: its kind and message,
    with the files named from the repository's root, not by the paths of the machine that
    built the docs."""
    text = str(message).replace(f"{_REPO.parent}/shared/", "../shared/")
    return f"{category.__name__}: {text.replace(f'{_REPO}/', '')}\n"


_REPO = Path(__file__).resolve().parents[1]
warnings.formatwarning = _pathless_warning

#: Marks a figure already shown, so that a figure kept in a variable is drawn once.
_SHOWN = "_femupdate_docs_shown"


def _figures(value: Any) -> list[Any]:
    from matplotlib.figure import Figure

    if isinstance(value, Figure):
        return [value]
    if isinstance(value, list | tuple):
        return [v for v in value if isinstance(v, Figure)]
    return []


def femupdate_figures(block: Any, script: Any, **kwargs: Any) -> str:
    """Save the example's new figures as PNG and return the markdown that shows them."""
    new = []
    for value in list(script.run_vars.example_globals.values()):
        for fig in _figures(value):
            if not getattr(fig, _SHOWN, False) and all(fig is not f for f in new):
                new.append(fig)
    if not new:
        return ""
    paths = []
    for fig, path in zip(new, script.run_vars.image_path_iterator, strict=False):
        fig.savefig(Path(path), dpi=100)
        setattr(fig, _SHOWN, True)
        paths.append(Path(path))
    if len(paths) == 1:
        return figure_md_or_html(paths, script)
    items = (f"<li>\n{figure_md_or_html([p], script, raw_html=True)}\n</li>" for p in paths)
    return HLIST_HEADER % "".join(items)


conf = {"image_scrapers": ("matplotlib", femupdate_figures)}

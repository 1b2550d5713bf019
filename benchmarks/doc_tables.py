"""Tables of measured figures that docs/benchmarks.md includes, written by the scripts.

A benchmark script given ``--table`` writes its figures as a Markdown table to
``docs/tables/NAME.md`` (beside the page, in the repository, whatever the working folder), and
``docs/benchmarks.md`` includes that file with pymdownx.snippets (``--8<-- "tables/NAME.md"``):
a figure is printed once, by the script that measured it, and never retyped.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path

#: Where the generated tables go: docs/tables/ of this checkout.
TABLES = Path(__file__).resolve().parents[1] / "docs" / "tables"
#: A table's name is a file name: lower-case words joined by hyphens.
NAME = re.compile(r"^[a-z0-9]+(?:-[a-z0-9]+)*$")


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    """A Markdown pipe table of ``header`` and ``rows`` (cells as given, ``str()`` of each).

    Raises
    ------
    ValueError
        When a row has not as many cells as the header, or a cell holds ``|`` or a line break
        (either would break the table).
    """
    cells = [list(map(str, header)), *([str(c) for c in row] for row in rows)]
    for i, row in enumerate(cells):
        if len(row) != len(header):
            raise ValueError(f"table row {i}: {len(row)} cells, the header has {len(header)}")
        for cell in row:
            if "|" in cell or "\n" in cell:
                raise ValueError(f"table row {i}: cell {cell!r} holds '|' or a line break")
    lines = ["| " + " | ".join(cells[0]) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in cells[1:]]
    return "\n".join(lines) + "\n"


def write_table(name: str, header: Sequence[str], rows: Sequence[Sequence[object]],
                command: str, note: str = "", directory: Path = TABLES) -> Path:
    """Write ``directory/NAME.md``: the table, then the command and the date that produced it.

    Parameters
    ----------
    name
        The table's file name without ``.md`` (lower-case words joined by hyphens).
    header, rows
        The column titles and the rows of cells.
    command
        The command that reproduces the figures, printed under the table.
    note
        A sentence printed after the command: the conditions of the measurement.
    directory
        Where to write; ``docs/tables`` of this checkout by default.

    Returns
    -------
    Path
        The file written.
    """
    if not NAME.match(name):
        raise ValueError(f"table name {name!r}: lower-case letters, digits and hyphens only")
    when = datetime.now(UTC).strftime("%Y-%m-%d")
    text = (markdown_table(header, rows)
            + f"\n*Written by `{command}` on {when}.{' ' + note if note else ''}*\n")
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / f"{name}.md"
    path.write_text(text, encoding="utf-8")
    return path

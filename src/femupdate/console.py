"""Warnings on one line, for the command line and for scripts that use femupdate.

Python prints a warning as ``file:line: Category: message`` followed by the source line that
issued it: two lines of which a user of femupdate can act on neither the path nor the echo.
:func:`one_line_warnings` prints each as one line instead, ``warning: message`` for
femupdate's own (:class:`~femupdate.errors.FemupdateWarning`) and ``warning (Category):
message`` for the others, wrapped to the terminal's width by rich.
"""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Callable, Iterator
from typing import Any, TextIO

from rich.console import Console
from rich.text import Text

from femupdate.errors import FemupdateWarning

__all__ = ["one_line_warnings", "warning_text"]


def warning_text(message: Warning | str, category: type[Warning]) -> str:
    """The one line a warning is shown as: ``warning: ...`` for femupdate's own,
    ``warning (Category): ...`` for any other."""
    if issubclass(category, FemupdateWarning):
        return f"warning: {message}"
    return f"warning ({category.__name__}): {message}"


def _printer(console: Console | None) -> Callable[..., None]:
    def show(message: Warning | str, category: type[Warning], filename: str, lineno: int,
             file: TextIO | None = None, line: str | None = None) -> None:
        out = console if console is not None else Console(stderr=True, markup=False)
        out.print(Text(warning_text(message, category), style="yellow"))

    return show


@contextlib.contextmanager
def one_line_warnings(console: Console | None = None) -> Iterator[None]:
    """Within the block, show every warning as one line (no source echo) on ``console``
    (default: standard error), wrapped to its width; Python's display is restored after.

    Examples
    --------
    >>> import warnings
    >>> from femupdate.console import one_line_warnings
    >>> with one_line_warnings():
    ...     warnings.warn("records cut to their overlap")  # doctest: +SKIP
    warning (UserWarning): records cut to their overlap
    """
    previous: Any = warnings.showwarning
    warnings.showwarning = _printer(console)
    try:
        yield
    finally:
        warnings.showwarning = previous

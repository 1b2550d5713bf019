"""Problems found by cross-field checks, and the small helpers that word them.

A check returns a list of ``Issue`` (field path relative to its section, what is wrong, what is
allowed); ``raise_issues`` hands them to pydantic as one error, which ``load`` expands to one
line each.
"""

from __future__ import annotations

import difflib
from collections.abc import Sequence

from pydantic_core import PydanticCustomError

#: A problem found by a cross-field check: field path (relative), what is wrong, allowed.
Issue = tuple[str, str, str]


def raise_issues(issues: list[Issue]) -> None:
    """Report cross-field problems through pydantic, one error carrying them all.

    The loader expands them to one line each, prefixed by the section's location.
    """
    if issues:
        summary = "; ".join(f"{path}: {what}" if path else what for path, what, _ in issues)
        raise PydanticCustomError("case_consistency", "{summary}",
                                  {"summary": summary, "issues": issues})


def join_path(*parts: str | int) -> str:
    path = ""
    for part in parts:
        if isinstance(part, int):
            path += f"[{part}]"
        elif part:
            path += f".{part}" if path else part
    return path


def did_you_mean(name: str, candidates: Sequence[str]) -> str:
    """``"; did you mean 'x'?"`` for the closest candidate (same first letter preferred)."""
    close = difflib.get_close_matches(name, list(candidates), n=3, cutoff=0.5)
    same_start = [c for c in close if c[:1].lower() == name[:1].lower()]
    best = (same_start or close or [None])[0]
    return f"; did you mean {best!r}?" if best is not None else ""


def duplicates(names: Sequence[tuple[str, str]], what: str, section: str = "") -> list[Issue]:
    """``names``: (path, name) pairs; one issue per repeated name, at its later uses.

    ``section`` prefixes the path of the first use in the message (paths are relative to it).
    """
    seen: dict[str, str] = {}
    issues = []
    for path, name in names:
        if name in seen:
            first = join_path(section, seen[name])
            issues.append((path, f"duplicate {what} {name!r}, already used at {first}",
                           f"a {what} not used before"))
        else:
            seen[name] = path
    return issues

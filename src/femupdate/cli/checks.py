"""Checks of what a user passes beside the case file: output paths, inline JSON, overrides.

Each check raises a one-line :class:`~femupdate.errors.ConfigError` naming the flag (or the
keyword), the value and what is allowed, before any work starts: a run that would fail on
writing its results after an hour must fail at once instead.
"""

from __future__ import annotations

import errno
import os
import tempfile
from pathlib import Path
from typing import Any

from femupdate.errors import ConfigError

__all__ = ["check_output_dir", "check_output_file",
           "json_source", "method_list", "os_error_line"]

#: What an inline JSON object starts with (after blanks): text, never a path, is tried.
_JSON_STARTS = ("{", "[", '"')


def _nearest_existing(path: Path) -> Path:
    """``path`` or its nearest existing ancestor (the folder a new path would be made in)."""
    probe = path.absolute()
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    return probe


def _writable(folder: Path) -> bool:
    """Whether a file can be made in ``folder``, tried (permissions alone do not tell of a
    read-only file system, or of what root may not write)."""
    try:
        with tempfile.TemporaryFile(dir=folder):
            return True
    except OSError:
        return False


def check_output_dir(flag: str, path: Path, target: Path | None = None) -> None:
    """An output folder: an existing writable folder, or a new one that can be made.

    Raises
    ------
    ConfigError
        ``path`` is a file, or neither it nor the folder it would be made in is writable.
        The message names ``target`` (a file to be written in ``path``) if given.
    """
    named = path if target is None else target
    if path.exists() and not path.is_dir():
        raise ConfigError(f"{flag}: {path} is a file, not a folder (allowed: a folder, new "
                          "or existing; choose another name)")
    base = _nearest_existing(path)
    if not base.is_dir():
        raise ConfigError(f"{flag}: {named} cannot be made: {base} is a file, not a folder "
                          "(allowed: a path under folders)")
    if not _writable(base):
        raise ConfigError(f"{flag}: {named} cannot be written: {base} is read-only for this "
                          "user or on a read-only file system (allowed: a writable folder)")


def check_output_file(flag: str, path: Path) -> None:
    """An output file: not a folder, in a folder that exists or can be made, writable.

    Raises
    ------
    ConfigError
        ``path`` is a folder, an existing file that cannot be written, or under a path that
        cannot be made or written.
    """
    if path.is_dir():
        raise ConfigError(f"{flag}: {path} is a folder (allowed: a file name, e.g. "
                          f"{path / 'results.json'})")
    if path.exists():
        if not os.access(path, os.W_OK):
            raise ConfigError(f"{flag}: {path} cannot be written (read-only; allowed: a "
                              "writable file)")
        return
    check_output_dir(flag, path.parent, target=path)


def json_source(text: str) -> str:
    """The JSON of a flag that takes a JSON object or the path of a file holding one: the
    text itself when it reads as JSON (so a long object is never tried as a file name), else
    the file's contents, else the text (whose parse error then says what was wrong)."""
    if text.lstrip().startswith(_JSON_STARTS):
        return text
    source = Path(text)
    try:
        if source.is_file():
            return source.read_text(encoding="utf-8-sig")
    except OSError as exc:
        if exc.errno != errno.ENAMETOOLONG:
            raise ConfigError(f"{text!r}: cannot read the file: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise ConfigError(f"{text}: not a UTF-8 text file (allowed: a JSON file, or a JSON "
                          "object)") from None
    return text


def method_list(flag: str, text: str, allowed: Any) -> list[str]:
    """The methods of a comma-separated list, every one checked before any is run.

    Raises
    ------
    ConfigError
        An empty list, an empty name, a repeated or unknown one (naming it and the allowed).
    """
    names = [m.strip() for m in text.split(",")]
    unknown = [m for m in names if m not in allowed]
    if unknown:
        raise ConfigError(f"{flag}: {', '.join(repr(m) for m in unknown)} in {text!r} "
                          f"(allowed: {', '.join(allowed)}, or a comma-separated list of them)")
    repeated = sorted({m for m in names if names.count(m) > 1})
    if repeated:
        raise ConfigError(f"{flag}: {', '.join(repeated)} given twice in {text!r} (allowed: "
                          "each method once)")
    return names


def os_error_line(exc: OSError) -> str:
    """An operating-system error on a file as one line: what, which file, what to do."""
    name = exc.filename if exc.filename is not None else "a file"
    what = exc.strerror or type(exc).__name__
    hint = {
        errno.EEXIST: "choose another name, or remove it",
        errno.ENOENT: "check the path; its folder must exist",
        errno.EACCES: "it is not writable for this user: choose another place",
        errno.EROFS: "the file system is read-only: choose another place",
        errno.ENOSPC: "the disk is full: free space, then resume",
        errno.ENAMETOOLONG: "use a shorter path",
        errno.EISDIR: "name a file, not a folder",
        errno.ENOTDIR: "a part of the path is a file, not a folder",
    }.get(exc.errno or 0, "check the path and its permissions")
    return f"{name}: {what} ({hint})"

"""What changed between the runs in a results store and a resume: the case, its data, settings.

A resume must continue the same computation. When it would not, the store refuses it and says
what differs in the words of the case file: the fields of the case (``search.max_evals: 20000 →
100``), the data files whose content changed, the setting and the command-line option or field
it comes from. The data are fingerprinted by the content hash of every file the case reads.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Mapping
from typing import Any

__all__ = ["SETTING_NAMES", "SETTING_WORDS", "case_changes", "data_changes", "file_hashes", "short"]


#: Where each setting a resume must match comes from (the command line's words first).
SETTING_WORDS = {
    "method": "[search] method",
    "bounds": "[[parameters]] lower, upper, scale",
    "runs": "--runs or [search] runs",
    "max_evals": "--max-evals or [search] max_evals",
    "f_target": "[search] f_target",
    "options": "[search] options, sigma_min, f_change_min",
    "names": "[[parameters]] name",
    "entropy": "--seed or [search] seed",
}

#: Settings stored under another name than the user gives them (the root SeedSequence's
#: entropy is the seed given).
SETTING_NAMES = {"entropy": "the root seed"}


def short(value: Any, limit: int = 80) -> str:
    """``repr(value)``, cut to ``limit`` characters."""
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 1] + "…"


def case_changes(old: Any, new: Any, path: str = "", limit: int = 8) -> list[str]:
    """The fields that differ between two cases as saved (``Case.to_dict()``), in words.

    Each entry reads ``field: old → new`` with the field path of the case file
    (``search.max_evals``, ``parameters[2].upper``); at most ``limit`` entries, then a count of
    the others. Empty when either case is unknown (None) or both are equal.
    """
    if old is None or new is None:
        return []
    found: list[str] = []

    def walk(a: Any, b: Any, here: str) -> None:
        if isinstance(a, Mapping) and isinstance(b, Mapping):
            for key in list(a) + [k for k in b if k not in a]:
                sub = f"{here}.{key}" if here else str(key)
                if key not in a:
                    found.append(f"{sub}: added ({short(b[key], 40)})")
                elif key not in b:
                    found.append(f"{sub}: removed (was {short(a[key], 40)})")
                else:
                    walk(a[key], b[key], sub)
        elif (isinstance(a, list) and isinstance(b, list) and len(a) == len(b)
              and any(isinstance(v, Mapping | list) for v in a)):
            for i, (x, y) in enumerate(zip(a, b, strict=True)):
                walk(x, y, f"{here}[{i}]")
        elif _plain(a) != _plain(b):
            found.append(f"{here or '(the case)'}: {short(a, 40)} → {short(b, 40)}")

    walk(old, _plain(new), path)
    if len(found) > limit:
        found = [*found[:limit], f"and {len(found) - limit} more field(s)"]
    return found


def data_changes(old: Mapping[str, str], new: Mapping[str, str]) -> list[str]:
    """The data files whose content differs between two fingerprints (file → SHA-256)."""
    out = []
    for name in sorted(set(old) | set(new)):
        if name not in new:
            out.append(f"{name} is no longer read")
        elif name not in old:
            out.append(f"{name} is read now but was not")
        elif old[name] != new[name]:
            out.append(f"{name} changed (content hash {old[name][:12]}… → {new[name][:12]}…)")
    return out


def file_hashes(paths: Mapping[str, str | os.PathLike[str]]) -> dict[str, str]:
    """SHA-256 of the content of each file, by name (the fingerprint of a case's data)."""
    out = {}
    for name, path in paths.items():
        digest = hashlib.sha256()
        with open(path, "rb") as fh:
            for block in iter(lambda fh=fh: fh.read(1 << 20), b""):
                digest.update(block)
        out[name] = digest.hexdigest()
    return out


def _plain(value: Any) -> Any:
    """``value`` as it would be stored (JSON round trip; numpy values as Python values)."""
    return json.loads(json.dumps(value, default=_default))


def _default(value: Any) -> Any:
    if hasattr(value, "tolist"):  # numpy scalars and arrays
        return value.tolist()
    if isinstance(value, set | frozenset | tuple):
        return list(value)
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")

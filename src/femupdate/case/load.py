"""Reading a case file: TOML, validation, and pydantic's errors in the case file's words.

Every problem found is reported in one ``ConfigError``, one line per problem::

    case.toml: model.beams[2].E: got -2e11: out of range (allowed: a number in [0, 1e13] (Pa)
    or a parameter name)
"""

from __future__ import annotations

import os
import re
import tomllib
import types
import typing
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ValidationError

from femupdate.case.fields import field_range, format_value
from femupdate.case.issues import did_you_mean, join_path
from femupdate.case.schema import Case
from femupdate.errors import ConfigError


def load_case(path: str | os.PathLike[str]) -> Case:
    """Read and validate a case file.

    Parameters
    ----------
    path : str or PathLike
        The TOML case file.

    Returns
    -------
    Case
        The validated case; ``case.source`` is ``path``.

    Raises
    ------
    ConfigError
        The file cannot be read, is not valid TOML (the message gives line and column), or
        does not describe a valid case (the message lists every problem, one per line, as
        ``file: field.path: what is wrong (allowed: ...)``).
    """
    path = Path(path)
    try:
        # utf-8-sig: a byte-order mark (as some Windows editors write) is dropped, not a
        # syntax error at line 1, column 1
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise ConfigError(f"case file not found: {path}") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: not a UTF-8 text file (byte {exc.start}); TOML files "
                          "are UTF-8") from None
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the case file: {exc.strerror}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(_toml_message(path, text, exc)) from None
    return parse_case(data, source=path)


def parse_case(data: Mapping[str, Any], source: str | os.PathLike[str] | None = None) -> Case:
    """Validate a case given as a mapping (the parsed TOML).

    Parameters
    ----------
    data : Mapping
        The case, as ``tomllib`` returns it.
    source : str or PathLike, optional
        The file it came from: messages name it, relative data paths start from its folder.

    Raises
    ------
    ConfigError
        Listing every problem found.
    """
    label = str(source) if source is not None else "case"
    try:
        case = Case.model_validate(dict(data))
    except ValidationError as exc:
        lines = _error_lines(label, exc)
        head = (f"{label}: {len(lines)} problem{'s' if len(lines) > 1 else ''} in the case "
                "file:\n  ")
        raise ConfigError(head + "\n  ".join(lines)) from None
    case._source = Path(source) if source is not None else None
    return case


def _toml_message(path: Path, text: str, exc: tomllib.TOMLDecodeError) -> str:
    match = re.search(r"^(.*) \(at line (\d+), column (\d+)\)$", str(exc))
    if match is None:  # "at end of document"
        return f"{path}: TOML syntax error: {exc}"
    what, line, column = match.group(1), int(match.group(2)), int(match.group(3))
    lines = text.splitlines()
    shown = lines[line - 1] if 0 < line <= len(lines) else ""
    return (f"{path}:{line}:{column}: TOML syntax error: {what} (line {line}, column {column})\n"
            f"    {shown}\n    {' ' * (column - 1)}^")


def _loc_path(loc: Sequence[str | int]) -> str:
    return join_path(*loc) or "(top level)"


def _error_lines(label: str, exc: ValidationError) -> list[str]:
    lines = []
    for err in exc.errors(include_url=False):
        loc = tuple(err["loc"])
        ctx = err.get("ctx") or {}
        if err["type"] == "case_consistency":
            for rel, what, allowed in ctx["issues"]:
                path = join_path(join_path(*loc), rel) or "(top level)"
                lines.append(f"{label}: {path}: {what} (allowed: {allowed})")
            continue
        what, allowed = _describe(err, loc)
        tail = f" (allowed: {allowed})" if allowed else ""
        lines.append(f"{label}: {_loc_path(loc)}: {what}{tail}")
    return lines


_TYPE_WORDS = {
    "model_type": "a table",
    "model_attributes_type": "a table",
    "dict_type": "a table",
    "list_type": "an array",
    "string_type": "a string",
    "bool_type": "true or false",
    "int_type": "an integer",
    "float_type": "a number",
}


def _describe(err: Mapping[str, Any], loc: tuple[str | int, ...]) -> tuple[str, str]:
    kind = err["type"]
    ctx = err.get("ctx") or {}
    value = err.get("input")
    if "allowed" in ctx:  # our own validators
        return err["msg"], ctx["allowed"]
    if kind == "missing":
        return _missing(loc)
    if kind == "list_type" and isinstance(value, dict):
        name = join_path(*loc)
        return (f"got a table where an array of tables is expected: write [[{name}]] "
                f"instead of [{name}]", f"[[{name}]] tables, or [ ... ]")
    if kind == "string_too_short":
        return f"got {format_value(value)}: empty", "a non-empty string"
    if kind == "string_too_long":
        return (f"got a text of {len(value)} characters",
                f"at most {ctx.get('max_length')} characters")
    if kind == "extra_forbidden":
        owner = _model_at(loc[:-1])
        fields = list(owner.model_fields) if owner is not None else []
        key = str(loc[-1])
        hint = did_you_mean(key, fields)
        return f"unknown field {key!r}{hint}", ", ".join(fields)
    if kind == "literal_error":
        return f"got {format_value(value)}", ctx.get("expected", "").replace(" or ", ", ")
    if kind in ("too_short", "too_long"):
        low, high = _length_limits(loc)
        low = low if low is not None else ctx.get("min_length", 0)
        high = high if high is not None else ctx.get("max_length")
        allowed = (f"exactly {low} items" if low == high else
                   f"{low} to {high} items" if high is not None else f"at least {low} items")
        return f"got {ctx.get('actual_length', '?')} items", allowed
    if kind in _TYPE_WORDS:
        return f"got {format_value(value)}: not {_TYPE_WORDS[kind]}", _TYPE_WORDS[kind]
    if kind == "bool_parsing":
        return f"got {format_value(value)}", "true or false"
    return f"got {format_value(value)}: {err['msg']}", ""


def _missing(loc: tuple[str | int, ...]) -> tuple[str, str]:
    name = join_path(*loc)
    field = _field_at(loc)
    if field is None:
        return "required field is missing", ""
    rng = field_range(field)
    tp = _unwrap(field.annotation)
    if rng is not None:
        return "required field is missing", rng.describe()
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return f"required section [{name}] is missing", f"a [{name}] table"
    if typing.get_origin(tp) is list:
        item = _unwrap(typing.get_args(tp)[0])
        if isinstance(item, type) and issubclass(item, BaseModel):
            return f"required [[{name}]] is missing", f"at least one [[{name}]] table"
    if typing.get_origin(tp) is Literal:
        return "required field is missing", ", ".join(repr(a) for a in typing.get_args(tp))
    return "required field is missing", ""


def _length_limits(loc: Sequence[str | int]) -> tuple[int | None, int | None]:
    """(min_length, max_length) declared for the array field at ``loc``."""
    field = _field_at(loc)
    if field is None:
        return None, None
    found: dict[str, int] = {}

    def visit(metadata: Sequence[Any]) -> None:
        for meta in metadata:
            for key in ("min_length", "max_length"):
                if getattr(meta, key, None) is not None:
                    found.setdefault(key, getattr(meta, key))
            visit(getattr(meta, "metadata", ()))

    visit(field.metadata)
    tp = field.annotation
    for arg in (tp, *typing.get_args(tp)):  # Optional[Annotated[list, Field(...)]]
        visit(getattr(arg, "__metadata__", ()))
    return found.get("min_length"), found.get("max_length")


def _unwrap(tp: Any) -> Any:
    """Strip Annotated and Optional layers of a type annotation."""
    while True:
        origin = typing.get_origin(tp)
        if origin is Annotated:
            tp = typing.get_args(tp)[0]
        elif origin in (typing.Union, types.UnionType):
            args = [a for a in typing.get_args(tp) if a is not type(None)]
            if len(args) != 1:
                return tp
            tp = args[0]
        else:
            return tp


def _field_at(loc: Sequence[str | int]) -> Any:
    """The pydantic FieldInfo of the field at ``loc`` (None if not a model field)."""
    if not loc or not isinstance(loc[-1], str):
        return None
    owner = _model_at(loc[:-1])
    if owner is None:
        return None
    return owner.model_fields.get(loc[-1])


def _model_at(loc: Sequence[str | int]) -> type[BaseModel] | None:
    """The model class of the table at ``loc`` (walking fields and list items from Case)."""
    tp: Any = Case
    for key in loc:
        tp = _unwrap(tp)
        if isinstance(key, int):
            if typing.get_origin(tp) is not list:
                return None
            tp = typing.get_args(tp)[0]
        elif isinstance(tp, type) and issubclass(tp, BaseModel) and key in tp.model_fields:
            tp = tp.model_fields[key].annotation
        else:
            return None
    tp = _unwrap(tp)
    return tp if isinstance(tp, type) and issubclass(tp, BaseModel) else None

"""Find the user's code: ``"package.module:function"``, ``"path/to/file.py:function"`` or a
script ``"path/to/file.py"``.

Every failure is a ConfigError in the case files' style: the field, the value, what is wrong and
what is allowed. Nothing here runs in the parent process of an isolated model unless asked: the
worker process that evaluates the model is the one that imports it.
"""

from __future__ import annotations

import difflib
import hashlib
import importlib
import importlib.util
import inspect
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import CodeType, ModuleType
from typing import Any

from femupdate.errors import ConfigError

__all__ = ["CodeRef", "compile_script", "load_function", "parse_ref"]

_ALLOWED_FUNCTION = "'package.module:function' (importable here) or 'path/to/file.py:function'"
_ALLOWED_SCRIPT = _ALLOWED_FUNCTION + ", or a script 'path/to/file.py'"


@dataclass(frozen=True)
class CodeRef:
    """A reference to user code, parsed but not loaded.

    Attributes
    ----------
    text : str
        The value as given (for messages).
    field : str
        The field that gave it (``"model.function"``), for messages.
    module : str or None
        Dotted module name, or None for a file.
    path : Path or None
        Absolute path of a ``.py`` file, or None for a module.
    function : str or None
        Function name, or None for a script run as a whole.
    """

    text: str
    field: str
    module: str | None = None
    path: Path | None = None
    function: str | None = None

    def error(self, problem: str, allowed: str = _ALLOWED_FUNCTION) -> ConfigError:
        return ConfigError(f"{self.field}: got {self.text!r}: {problem} (allowed: {allowed})")


def _is_identifier_path(name: str) -> bool:
    return bool(name) and all(part.isidentifier() for part in name.split("."))


def parse_ref(text: str, *, field: str, base_dir: str | Path | None = None,
              script_allowed: bool = False) -> CodeRef:
    """Parse ``text`` into a CodeRef; relative file paths are relative to ``base_dir``.

    Parameters
    ----------
    text : str
        ``"pkg.mod:function"``, ``"file.py:function"`` or (when ``script_allowed``)
        ``"file.py"``.
    field : str
        Names the field in messages.
    base_dir : path or None
        Folder of relative files (the case file's folder); default the current directory.
    script_allowed : bool
        Accept a file without a function.

    Raises
    ------
    ConfigError
        A malformed value, or a file that does not exist.
    """
    allowed = _ALLOWED_SCRIPT if script_allowed else _ALLOWED_FUNCTION
    if not isinstance(text, str) or not text.strip():
        raise ConfigError(f"{field}: got {text!r}: not a reference to code (allowed: {allowed})")
    text = text.strip()
    # A file ends in .py (a Windows drive's colon must not split it); else split at the last ':'.
    if text.endswith(".py"):
        target, function = text, None
    else:
        target, sep, function = text.rpartition(":")
        if not sep:
            raise ConfigError(f"{field}: got {text!r}: no function named; write "
                              f"'{text}:function' (allowed: {allowed})")
    if function is not None and not function.isidentifier():
        raise ConfigError(f"{field}: got {text!r}: {function!r} is not a function name "
                          f"(allowed: {allowed})")
    if target.endswith(".py") or "/" in target or "\\" in target:
        path = Path(target).expanduser()
        if not path.is_absolute():
            path = Path(base_dir or ".") / path
        path = path.resolve()
        if not path.is_file():
            raise ConfigError(f"{field}: got {text!r}: no file {str(path)!r} (allowed: a file "
                              f"relative to the case file's folder; {allowed})")
        if function is None and not script_allowed:
            raise ConfigError(f"{field}: got {text!r}: a file without a function; write "
                              f"'{target}:function' (allowed: {allowed})")
        return CodeRef(text, field, path=path, function=function)
    if not _is_identifier_path(target):
        raise ConfigError(f"{field}: got {text!r}: {target!r} is neither a module name nor a "
                          f".py file (allowed: {allowed})")
    return CodeRef(text, field, module=target, function=function)


def _import_file(ref: CodeRef) -> ModuleType:
    assert ref.path is not None
    digest = hashlib.sha1(str(ref.path).encode()).hexdigest()[:10]
    name = f"_femupdate_user_{ref.path.stem}_{digest}"
    if name in sys.modules:
        return sys.modules[name]
    folder = str(ref.path.parent)
    if folder not in sys.path:  # the file may import its neighbours
        sys.path.insert(0, folder)
    spec = importlib.util.spec_from_file_location(name, ref.path)
    if spec is None or spec.loader is None:
        raise ref.error("not a Python file that can be imported")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses and pickling look the module up by name
    try:
        spec.loader.exec_module(module)
    except BaseException as exc:
        del sys.modules[name]
        raise ref.error(f"importing the file raised {_describe(exc)}") from exc
    return module


def _import_module(ref: CodeRef) -> ModuleType:
    assert ref.module is not None
    try:
        return importlib.import_module(ref.module)
    except ModuleNotFoundError as exc:
        if exc.name is not None and (ref.module == exc.name
                                     or ref.module.startswith(exc.name + ".")):
            raise ref.error(f"no module named {exc.name!r} on the Python path") from exc
        raise ref.error(f"importing module {ref.module!r} failed: {exc}") from exc
    except BaseException as exc:
        raise ref.error(f"importing module {ref.module!r} raised {_describe(exc)}") from exc


def _describe(exc: BaseException) -> str:
    text = str(exc)
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def load_function(ref: CodeRef) -> Callable[..., Any]:
    """Import the module or file of ``ref`` and return its function.

    Raises
    ------
    ConfigError
        The module or file cannot be imported (or raised while importing), or has no such
        callable; the message lists the functions it does define.
    """
    if ref.function is None:
        raise ref.error("a script, where a function is needed")
    module = _import_file(ref) if ref.path is not None else _import_module(ref)
    fn = getattr(module, ref.function, None)
    if fn is None or not callable(fn):
        defined = sorted(name for name, obj in vars(module).items()
                         if inspect.isfunction(obj) and not name.startswith("_"))
        close = difflib.get_close_matches(ref.function, defined, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        where = f"file {str(ref.path)!r}" if ref.path is not None else f"module {ref.module!r}"
        what = "no function" if fn is None else "an object that is not callable named"
        raise ref.error(f"{where} has {what} {ref.function!r}{hint}",
                        f"a function of it: {', '.join(map(repr, defined)) or 'none defined'}")
    return fn


def compile_script(ref: CodeRef) -> CodeType:
    """The compiled code of a script reference (a file without a function).

    Raises
    ------
    ConfigError
        The file cannot be read or has a syntax error (with its line).
    """
    if ref.path is None or ref.function is not None:
        raise ref.error("not a script", _ALLOWED_SCRIPT)
    try:
        source = ref.path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise ref.error(f"cannot read the script ({exc})", _ALLOWED_SCRIPT) from exc
    try:
        return compile(source, str(ref.path), "exec")
    except SyntaxError as exc:
        raise ref.error(f"syntax error at line {exc.lineno}: {exc.msg}",
                        _ALLOWED_SCRIPT) from exc

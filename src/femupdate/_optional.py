"""Lazy import of optional dependencies with a message naming the extra to install."""

from __future__ import annotations

import importlib
from types import ModuleType

from femupdate.errors import MissingDependencyError


def require(module: str, extra: str) -> ModuleType:
    """Import ``module`` or raise an error naming the femupdate extra that provides it.

    Parameters
    ----------
    module : str
        Dotted module name, e.g. ``"dask.distributed"``.
    extra : str
        Name of the femupdate extra, e.g. ``"dask"``.
    """
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise MissingDependencyError(
            f"{module!r} is needed for this feature but is not installed; "
            f"install it with: pip install 'femupdate[{extra}]'"
        ) from exc

"""Importing OpenSeesPy: the optional extra, and the BLAS its Linux wheel needs preloaded."""

from __future__ import annotations

import ctypes
import functools
import importlib
import importlib.util
import sys
from pathlib import Path
from types import ModuleType

from femupdate._optional import require
from femupdate.errors import MissingDependencyError

__all__ = ["OPENSEES_EXTRA", "import_opensees"]

OPENSEES_EXTRA = "opensees"


def _bundled_blas() -> Path | None:
    """The ``libblas.so.3`` shipped inside the openseespy Linux wheel, if there is one."""
    spec = importlib.util.find_spec("openseespylinux")
    if spec is None or not spec.submodule_search_locations:
        return None
    for folder in spec.submodule_search_locations:
        path = Path(folder) / "lib" / "libblas.so.3"
        if path.is_file():
            return path
    return None


@functools.cache
def import_opensees() -> ModuleType:
    """Import ``openseespy.opensees``, preloading the BLAS its Linux wheel bundles.

    The wheel's ``opensees.so`` needs symbols of its own ``libblas.so.3`` but does not find
    them by itself on Linux: the library is loaded first with ``RTLD_GLOBAL``.

    Returns
    -------
    module
        ``openseespy.opensees``.

    Raises
    ------
    MissingDependencyError
        When openseespy is not installed (``pip install 'femupdate[opensees]'``), or is
        installed but cannot be imported.
    """
    require("openseespy", OPENSEES_EXTRA)
    if sys.platform.startswith("linux"):
        blas = _bundled_blas()
        if blas is not None:
            ctypes.CDLL(str(blas), mode=ctypes.RTLD_GLOBAL)
    try:
        return importlib.import_module("openseespy.opensees")
    except (ImportError, RuntimeError) as exc:  # the package turns any failure into RuntimeError
        raise MissingDependencyError(
            f"openseespy is installed but 'openseespy.opensees' failed to import ({exc}); "
            f"reinstall it with: pip install --force-reinstall 'femupdate[{OPENSEES_EXTRA}]'"
        ) from exc

"""femupdate: finite element model updating in structural dynamics, in the time domain.

The public API, re-exported here (heavier parts are imported on first use):

- :func:`minimize`: bounded minimisation by IB/AB (the paper's adaptive Beta sampling),
  multistart Levenberg–Marquardt (the case files' default) or CMA-ES, returning a
  :class:`scipy.optimize.OptimizeResult` (scipy's conventions: ``success``,
  ``callback(intermediate_result)``, ``workers``).
- :class:`Structure`, :func:`shear_building`, :class:`System`: the structural model.
- ``simulate``: linear (exact, central differences, Newmark) and friction time stepping.
- :func:`natural_frequencies`, :func:`damped_modes`.
- :func:`load_case`, :class:`Case`: validated case files.
- :func:`nmse`, :class:`ErrorFunction`: the error function of the paper (Eq. 1).
- :func:`run_case`: a case file's update end to end; :func:`load_results`, :class:`Summary`:
  its results read back.

Renamed, still accepted with a DeprecationWarning: ``Objective`` (now ``ErrorFunction``),
``minimize(map=...)`` (now ``workers=``), ``callback(x, f)`` (now scipy's
``callback(intermediate_result)``).
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

from femupdate.errors import (
    ConfigError,
    DataError,
    FemupdateError,
    MissingDependencyError,
    ModelError,
    SimulationError,
)

__version__ = "0.1.0"

_LAZY = {
    "minimize": "femupdate.optimize.minimize",  # scipy.optimize and numba: not for --help
    "Structure": "femupdate.model.structure",
    "shear_building": "femupdate.model.structure",
    "System": "femupdate.model.system",
    "FrictionElements": "femupdate.model.system",
    "natural_frequencies": "femupdate.model.modes",
    "NaturalModes": "femupdate.model.modes",
    "damped_modes": "femupdate.model.modes",
    "DampedModes": "femupdate.model.modes",
    "Response": "femupdate.simulate.response",
    "load_case": "femupdate.case",
    "Case": "femupdate.case",
    "nmse": "femupdate.problem.objective",
    "ErrorFunction": "femupdate.problem.objective",
    "Objective": "femupdate.problem.objective",  # deprecated name of ErrorFunction (not in __all__)
    "run_case": "femupdate.pipeline.run",
    "load_results": "femupdate.pipeline.results",
    "Summary": "femupdate.pipeline.results",
}

__all__ = [
    "Case",
    "ConfigError",
    "DampedModes",
    "DataError",
    "ErrorFunction",
    "FemupdateError",
    "FrictionElements",
    "MissingDependencyError",
    "ModelError",
    "NaturalModes",
    "Response",
    "SimulationError",
    "Structure",
    "Summary",
    "System",
    "__version__",
    "damped_modes",
    "load_case",
    "load_results",
    "minimize",
    "natural_frequencies",
    "nmse",
    "run_case",
    "shear_building",
    "simulate",
]


def __getattr__(name: str) -> Any:
    if name == "simulate":  # the subpackage, callable as its function (femupdate.simulate)
        return import_module("femupdate.simulate")
    if name in _LAZY:
        return getattr(import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'femupdate' has no attribute {name!r}")

"""Exceptions raised by femupdate.

Every error says what was wrong, where (file, field, element) and what is allowed.
"""

from __future__ import annotations


class FemupdateError(Exception):
    """Base class of all femupdate errors."""


class ConfigError(FemupdateError, ValueError):
    """Invalid configuration: a case file, an option, a bound."""


class DataError(FemupdateError, ValueError):
    """Invalid or unreadable measured data."""


class ModelError(FemupdateError, ValueError):
    """An invalid structural model (element, node, DOF, matrix)."""


class SimulationError(FemupdateError, RuntimeError):
    """A simulation that cannot be carried out (for example an unstable time step)."""


class MissingDependencyError(FemupdateError, ImportError):
    """An optional dependency is not installed."""


class StoreError(FemupdateError):
    """A results store that cannot be used: another case's, locked, corrupt, incompatible."""


class FemupdateWarning(UserWarning):
    """Something femupdate did or accepted that the user should know: records cut to their
    overlap, a truth outside the bounds, a run in which no evaluation succeeded."""

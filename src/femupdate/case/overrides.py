"""Overrides of a case's fields given outside the file (command-line options, keywords),
checked against the range the field has in a case file."""

from __future__ import annotations

from femupdate.case.fields import field_range
from femupdate.case.schema import Search
from femupdate.errors import ConfigError

__all__ = ["check_search_override"]


def check_search_override(field: str, value: int | None, flag: str) -> None:
    """A command-line or keyword override of ``[search] field`` within the case file's range.

    Raises
    ------
    ConfigError
        Naming the flag, the value and the range of ``[search] field``.
    """
    if value is None:
        return
    rng = field_range(Search.model_fields[field])
    if isinstance(value, bool) or not isinstance(value, int) or not rng.contains(value):
        raise ConfigError(f"{flag}: got {value!r} (allowed: {rng.describe()}, as [search] "
                          f"{field} in a case file)")

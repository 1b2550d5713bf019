"""The ``femupdate`` command line: the commands (``commands``, ``bench``), what they print
(``tables``), their options (``options``) and argument checks (``checks``). ``main`` is the
console script."""

from femupdate.cli.commands import app, main
from femupdate.cli.options import console
from femupdate.cli.tables import print_update_summary

__all__ = ["app", "console", "main", "print_update_summary"]

"""Repeated independent runs of an optimisation, and the results store that makes them last.

- :mod:`~femupdate.runs.outcome`: what a run returns; seeds of repeated runs.
- :mod:`~femupdate.runs.repeat`: whole runs in memory (``repeat``).
- :mod:`~femupdate.runs.runner`: runs with a store, resume, processes or Dask (``run_all``).
- :mod:`~femupdate.runs.chunks`: a run advanced chunk by chunk from its checkpoint.
- :mod:`~femupdate.runs.store`, :mod:`~femupdate.runs.executors`,
  :mod:`~femupdate.runs.progress`, :mod:`~femupdate.runs.stats`.
"""

from femupdate.runs.outcome import RunOutcome, run_seeds
from femupdate.runs.repeat import repeat
from femupdate.runs.runner import CaseIdentity, Execution, run_all

__all__ = ["CaseIdentity", "Execution", "RunOutcome", "repeat", "run_all", "run_seeds"]

"""What ``femupdate bench`` runs: the paper's benchmarks and the speed of the integrators.

- :mod:`~femupdate.bench.dynamic`, :mod:`~femupdate.bench.bridge`: repeated runs of the paper's
  problems (:mod:`femupdate.problems`), summarised as its tables.
- :mod:`~femupdate.bench.simulate`: every integrator timed beside OpenSeesPy
  (:mod:`~femupdate.bench.opensees`, which builds the same models in OpenSees).
"""

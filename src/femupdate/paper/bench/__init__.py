"""What ``femupdate bench`` runs: the paper's benchmarks and the speed of the integrators.

- :mod:`~femupdate.paper.bench.dynamic`, :mod:`~femupdate.paper.bench.bridge`: repeated runs of
  the paper's
  problems (:mod:`femupdate.paper.problems`), summarised as its tables.
- :mod:`~femupdate.paper.bench.simulate`: every integrator timed beside OpenSeesPy
  (:mod:`~femupdate.paper.bench.opensees`, which builds the same models in OpenSees).
"""

"""The paper's benchmark problems, one definition each.

- :mod:`~femupdate.paper.problems.dynamic`: benchmark 1, a two-mode free vibration (§4).
- :mod:`~femupdate.paper.problems.bridge`: benchmark 2, the 1:50 bridge on a shaking table (§5).
"""

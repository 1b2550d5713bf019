"""``run_all`` with the tests' flat keyword arguments, grouped as it takes them."""

from __future__ import annotations

from typing import Any

from femupdate import runs

_EXECUTION = {"workers", "scheduler", "executor", "connect_timeout", "chunk_evals",
              "chunk_seconds", "quiet", "log_json", "label"}
_IDENTITY = {"case_dict", "fingerprint", "names"}


def run_all(fun: Any, bounds: Any, method: str = "ab", **kw: Any) -> list[runs.RunOutcome]:
    execution = runs.Execution(**{k: kw.pop(k) for k in list(kw) if k in _EXECUTION})
    identity = runs.CaseIdentity(**{k: kw.pop(k) for k in list(kw) if k in _IDENTITY})
    return runs.run_all(fun, bounds, method, execution=execution, identity=identity, **kw)

"""What one run returns, and the seeds of repeated runs.

Run ``i`` draws its randomness from child ``i`` of ``SeedSequence(seed)`` (``spawn``), never from
consecutive integer seeds, so any run can be repeated alone, bit for bit.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import OptimizeResult

from femupdate.errors import ConfigError


@dataclass(frozen=True)
class RunOutcome:
    """What one run returns: small enough to send between processes."""

    index: int
    seed: dict[str, Any]
    x: np.ndarray
    fun: float
    nfev: int
    nit: int
    success: bool
    status: int
    message: str
    stop: dict[str, Any]
    wall_s: float
    restarts: int = 0
    nfail: int = 0
    failure: str | None = None
    history: dict[str, np.ndarray] | None = field(default=None, repr=False)
    #: What the optimizer handed back besides its best point (JSON-ready; a sampler's final
    #: samples), None for the searches.
    extras: dict[str, Any] | None = field(default=None, repr=False)

    def to_dict(self, names: Sequence[str] | None = None) -> dict[str, Any]:
        """JSON-ready summary; ``params`` maps the names to the values when names are given."""
        out: dict[str, Any] = {
            "index": self.index,
            "seed": self.seed,
            "success": self.success,
            "status": self.status,
            "message": self.message,
            "stop": {k: _jsonable(v) for k, v in self.stop.items()},
            "phi": self.fun,
            "nfev": self.nfev,
            "nit": self.nit,
            "restarts": self.restarts,
            "nfail": self.nfail,
            "failure": self.failure,
            "wall_s": self.wall_s,
            "x": self.x.tolist(),
        }
        if self.extras is not None:  # only then: the searches' stored results are unchanged
            out["extras"] = self.extras
        if names is not None:
            out["params"] = dict(zip(names, self.x.tolist(), strict=True))
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> RunOutcome:
        """The outcome written by :meth:`to_dict` (without history)."""
        return cls(
            index=int(data["index"]),
            seed=dict(data["seed"]),
            x=np.array(data["x"], dtype=float),
            fun=float(data["phi"]),
            nfev=int(data["nfev"]),
            nit=int(data["nit"]),
            success=bool(data["success"]),
            status=int(data["status"]),
            message=str(data["message"]),
            stop=dict(data["stop"]),
            wall_s=float(data["wall_s"]),
            restarts=int(data.get("restarts", 0)),
            nfail=int(data.get("nfail", 0)),
            failure=data.get("failure"),
            extras=data.get("extras"),
        )


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value


def run_seeds(seed: int | None, runs: int) -> list[np.random.SeedSequence]:
    """Children of one SeedSequence, one per run."""
    if runs < 1:
        raise ConfigError(f"runs must be at least 1, got {runs}")
    return np.random.SeedSequence(seed).spawn(runs)


def seed_record(ss: np.random.SeedSequence) -> dict[str, Any]:
    return {"entropy": int(ss.entropy), "spawn_key": list(ss.spawn_key)}


def seed_from_record(record: Mapping[str, Any]) -> np.random.SeedSequence:
    # What SeedSequence.spawn builds for a child: same entropy, the child's spawn key.
    return np.random.SeedSequence(int(record["entropy"]), spawn_key=tuple(record["spawn_key"]))



def outcome_of(index: int, seed: np.random.SeedSequence, res: OptimizeResult, wall_s: float,
               history: dict[str, np.ndarray] | None = None) -> RunOutcome:
    """The outcome of run ``index`` from ``minimize``'s result."""
    return RunOutcome(index=index, seed=seed_record(seed), x=np.asarray(res.x),
                      fun=float(res.fun), nfev=int(res.nfev), nit=int(res.nit),
                      success=bool(res.success), status=int(res.status),
                      message=str(res.message), stop=dict(res.stop), wall_s=wall_s,
                      restarts=int(res.restarts), nfail=int(res.get("nfail", 0)),
                      failure=res.get("failure"), history=history,
                      extras=res.get("extras"))

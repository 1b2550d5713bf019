"""Same seeds, same bits: small runs recorded before the architecture step (commit 4bd0868).

``runs_before_refactor.json`` holds φ, nfev and x (as float.hex) of small runs of the paper's
bridge (viscous and friction, AB and CMA-ES, through ``run_case``) and of the dynamic benchmark
(AB, IB, CMA-ES, through the store-less runner), made with the code as it was before the
refactor. The same runs made now must give the same numbers to the last bit.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from femupdate.bench.dynamic import run_benchmark
from femupdate.case import parse_case
from femupdate.problems.bridge import bridge_case, truth
from femupdate.virtual import virtual_experiment
from femupdate.workflow import run_case

FIXTURE = Path(__file__).with_name("runs_before_refactor.json")
EXPECTED = json.loads(FIXTURE.read_text())


def _rows(runs: list[dict]) -> list[dict]:
    return [{"phi": float(r["phi"]).hex(), "nfev": r["nfev"],
             "x": [float(v).hex() for v in r["x"]]} for r in runs]


@pytest.mark.parametrize("model", ["viscous", "friction"])
def test_bridge_runs_are_bit_identical(model: str, tmp_path: Path) -> None:
    data = tmp_path / f"data-{model}"
    case = parse_case(bridge_case(model, "narrow", directory=str(data)),
                      source=tmp_path / f"{model}.toml")
    virtual_experiment(case, truth(model), data, seed=3, duration=0.8, rate=1035.0, snr=0.02)
    for method in ("ab", "cmaes"):
        case_m = parse_case(bridge_case(model, "narrow", directory=str(data)) | {
            "search": {"method": method, "runs": 2, "seed": 7, "max_evals": 150}},
            source=tmp_path / f"{model}.toml")
        result = run_case(case_m, None)
        assert _rows(result.summary.runs_as_dicts()) == EXPECTED[f"{model}-{method}"], method


@pytest.mark.parametrize("method", ["ab", "ib", "cmaes"])
def test_dynamic_runs_are_bit_identical(method: str) -> None:
    row = run_benchmark(method, runs=3, seed=5, workers=1, max_evals=400)
    assert _rows(row["per_run"]) == EXPECTED[f"dynamic-{method}"]

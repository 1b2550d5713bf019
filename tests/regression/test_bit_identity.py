"""Same seeds, same bits: small runs recorded before the architecture step (commit 4bd0868).

``runs_before_refactor.json`` holds φ, nfev and x (as float.hex) of small runs of the paper's
bridge (viscous and friction, AB and CMA-ES, through ``run_case``) and of the dynamic benchmark
(AB, IB, CMA-ES, through the store-less runner), made with the code as it was before the
refactor. The same runs made now through the step-by-step evaluation of φ (the code path of
then) must give the same numbers to the last bit. Through the compiled evaluator (faster, equal
to rounding: docs/evaluation.md) the runs visit the same points and φ agrees to 1e-10.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from femupdate.bench.dynamic import run_benchmark
from femupdate.case import parse_case
from femupdate.problems.bridge import bridge_case, truth
from femupdate.update import EVALUATOR_ENV
from femupdate.virtual import virtual_experiment
from femupdate.workflow import run_case

FIXTURE = Path(__file__).with_name("runs_before_refactor.json")
EXPECTED = json.loads(FIXTURE.read_text())


def _rows(runs: list[dict]) -> list[dict]:
    return [{"phi": float(r["phi"]).hex(), "nfev": r["nfev"],
             "x": [float(v).hex() for v in r["x"]]} for r in runs]


@pytest.mark.parametrize("evaluator", ["reference", "compiled"])
@pytest.mark.parametrize("model", ["viscous", "friction"])
def test_bridge_runs_are_bit_identical(model: str, evaluator: str, tmp_path: Path,
                                       monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(EVALUATOR_ENV, evaluator)
    data = tmp_path / f"data-{model}"
    case = parse_case(bridge_case(model, "narrow", directory=str(data)),
                      source=tmp_path / f"{model}.toml")
    virtual_experiment(case, truth(model), data, seed=3, duration=0.8, rate=1035.0, snr=0.02)
    for method in ("ab", "cmaes"):
        case_m = parse_case(bridge_case(model, "narrow", directory=str(data)) | {
            "search": {"method": method, "runs": 2, "seed": 7, "max_evals": 150}},
            source=tmp_path / f"{model}.toml")
        result = run_case(case_m, None, sensitivities=False)
        rows, expected = _rows(result.summary.runs_as_dicts()), EXPECTED[f"{model}-{method}"]
        if evaluator == "reference":
            assert rows == expected, method
            continue
        for row, ref in zip(rows, expected, strict=True):
            assert (row["x"], row["nfev"]) == (ref["x"], ref["nfev"]), method
            phi, phi_ref = float.fromhex(row["phi"]), float.fromhex(ref["phi"])
            assert phi == pytest.approx(phi_ref, rel=1e-10), method


@pytest.mark.parametrize("method", ["ab", "ib", "cmaes"])
def test_dynamic_runs_are_bit_identical(method: str) -> None:
    row = run_benchmark(method, runs=3, seed=5, workers=1, max_evals=400)
    assert _rows(row["per_run"]) == EXPECTED[f"dynamic-{method}"]

"""Same seeds, same runs: small runs recorded before the architecture step (commit 4bd0868).

``runs_before_refactor.json`` holds φ, nfev and x (as float.hex) of small runs of the paper's
bridge (viscous and friction, AB and CMA-ES, through ``run_case``) and of the dynamic benchmark
(AB, IB, CMA-ES, through the store-less runner), made with the code as it was before the
refactor, on the machine of that day.

The bits of a floating-point result depend on the processor as well as on the code: numpy's
and numba's SIMD kernels (AVX2, AVX-512) round differently, and one φ that moves by an ulp
moves CMA-ES's eigendecomposition by a few. The fixture's bits held on the processor it was
made on and no longer on a Zen 5 (φ of IB and AB 1 ulp apart, CMA-ES's x 2e-12 apart). So
the same runs made now, through the step-by-step and the compiled evaluator, must use the same
evaluations count and agree with the fixture to rounding (φ to 1e-9 relative, x to 1e-7:
CMA-ES's updates amplify the ulps, 7e-9 measured on the friction bridge after 150
evaluations), and the same seed must give the same bits on this machine: each set of runs is
made twice here and compared to the last bit.

One entry was made again: ``friction-cmaes``, when CMA-ES's redraws of a candidate outside the
box were capped at 1,000 (then projected; issue 21: a bridge run had drawn 25.9 million
candidates for 9,515 evaluations), which changed these runs.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from femupdate.case import parse_case
from femupdate.paper.bench.dynamic import run_benchmark
from femupdate.paper.problems.bridge import bridge_case, truth
from femupdate.pipeline.run import run_case
from femupdate.problem.update import EVALUATOR_ENV
from femupdate.trials.virtual import virtual_experiment

FIXTURE = Path(__file__).with_name("runs_before_refactor.json")
EXPECTED = json.loads(FIXTURE.read_text())


def _assert_same_runs(rows: list[dict], expected: list[dict], label: str) -> None:
    """The same evaluations count; φ and x equal to rounding (1e-9 and 1e-7 relative)."""
    assert len(rows) == len(expected), label
    for row, ref in zip(rows, expected, strict=True):
        assert row["nfev"] == ref["nfev"], label
        for key, rtol in (("x", 1e-7), ("phi", 1e-9)):
            got = np.array([float.fromhex(v) for v in np.atleast_1d(row[key])])
            want = np.array([float.fromhex(v) for v in np.atleast_1d(ref[key])])
            np.testing.assert_allclose(got, want, rtol=rtol, atol=0, err_msg=f"{label} {key}")


def _rows(runs: list[dict]) -> list[dict]:
    return [{"phi": float(r["phi"]).hex(), "nfev": r["nfev"],
             "x": [float(v).hex() for v in r["x"]]} for r in runs]


@pytest.mark.slow
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
        rows, again = (_rows(run_case(case_m, None, sensitivities=False).summary.runs_as_dicts())
                       for _ in range(2))
        assert rows == again, method  # same seed, same bits
        _assert_same_runs(rows, EXPECTED[f"{model}-{method}"], method)


@pytest.mark.parametrize("method", ["ab", "ib", "cmaes"])
def test_dynamic_runs_are_bit_identical(method: str) -> None:
    rows, again = (_rows(run_benchmark(method, runs=3, seed=5, workers=1, max_evals=400)["per_run"])
                   for _ in range(2))
    assert rows == again  # same seed, same bits
    _assert_same_runs(rows, EXPECTED[f"dynamic-{method}"], method)

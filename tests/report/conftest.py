"""Finished results directories of virtual experiments (truth.json beside the records):

- ``results_dir``: a 2-storey shear building with storey dampers (non-proportional damping),
  3 runs;
- ``rayleigh_dir``: a 3-storey building whose Rayleigh coefficients are parameters, channel
  delays estimated and given, a record long enough for the detail window;
- ``wide_dir``: 25 storeys with k and c per storey (50 parameters), 2 short runs;
- ``many_runs_dir``: the 2-storey building on noisy records updated by 25 runs of
  multistart-lm (stop reasons with values, restarts: the table that must fit one screen).
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from femupdate.case import Case, parse_case
from femupdate.pipeline.run import run_case
from femupdate.trials.virtual import virtual_experiment

TRUTH = {"k1": 2000.0, "k2": 1500.0, "c1": 1.0, "c2": 0.5}
#: Text that must come out HTML-escaped.
DESCRIPTION = "2-storey shear building <b>test</b> & friends"
RAYLEIGH_TRUTH = {"k": 3000.0, "alpha": 0.4, "beta": 0.002}
WIDE_STOREYS = 25


def _data(data_dir: Path, outputs: list[dict[str, Any]]) -> dict[str, Any]:
    return {"format": "csv", "directory": str(data_dir.resolve()), "time_column": "t",
            "input": {"file": "table.csv", "column": "a"}, "outputs": outputs}


def _floor(i: int, **extra: Any) -> dict[str, Any]:
    return {"file": "floors.csv", "column": f"f{i}", "node": f"F{i}", "dof": "ux", **extra}


def two_storey_case(data_dir: Path) -> Case:
    """k1 linear, k2 log-scale, two dampers; displacements of both floors, noise-free CSVs."""
    return parse_case({
        "case": {"name": "two-storey", "description": DESCRIPTION},
        "model": {"shear_building": {"masses": [1.0, 1.0], "stiffnesses": ["k1", "k2"],
                                     "dampers": ["c1", "c2"]}},
        "parameters": [
            {"name": "k1", "lower": 500.0, "upper": 5000.0, "unit": "N/m"},
            {"name": "k2", "lower": 500.0, "upper": 5000.0, "unit": "N/m", "scale": "log"},
            {"name": "c1", "lower": 0.0, "upper": 5.0, "unit": "N·s/m"},
            {"name": "c2", "lower": 0.0, "upper": 5.0, "unit": "N·s/m"},
        ],
        "data": _data(data_dir, [_floor(1), _floor(2)]),
        "search": {"method": "ab", "runs": 3, "seed": 1, "max_evals": 300},
    })


def rayleigh_case(data_dir: Path) -> Case:
    """Three equal storeys of stiffness k, damping α M + β K with α and β parameters."""
    return parse_case({
        "case": {"name": "rayleigh"},
        "model": {"shear_building": {"masses": [1.0, 1.0, 1.0], "stiffnesses": ["k", "k", "k"]},
                  "rayleigh": {"alpha": "alpha", "beta": "beta"}},
        "parameters": [
            {"name": "k", "lower": 1000.0, "upper": 6000.0, "unit": "N/m"},
            {"name": "alpha", "lower": 0.0, "upper": 2.0, "unit": "1/s"},
            {"name": "beta", "lower": 0.0, "upper": 0.01, "unit": "s"},
        ],
        "data": _data(data_dir, [_floor(1, delay="auto"), _floor(3, delay=0.01)]),
        "preprocess": {"delay_band_hz": [1.0, 2.5]},  # below the first mode (4.2 Hz)
        "search": {"method": "ab", "runs": 2, "seed": 2, "max_evals": 200},
    })


def wide_case(data_dir: Path, storeys: int = WIDE_STOREYS) -> Case:
    """A shear building with a stiffness and a damper parameter per storey; 5 floors measured."""
    ks, cs = [f"k{i + 1}" for i in range(storeys)], [f"c{i + 1}" for i in range(storeys)]
    return parse_case({
        "case": {"name": f"{storeys}-storey"},
        "model": {"shear_building": {"masses": [1.0] * storeys, "stiffnesses": ks,
                                     "dampers": cs}},
        "parameters": ([{"name": k, "lower": 500.0, "upper": 5000.0, "unit": "N/m"}
                        for k in ks]
                       + [{"name": c, "lower": 0.0, "upper": 5.0, "unit": "N·s/m"} for c in cs]),
        # 2 s of a 0.5 Hz building: too short a record to identify it, accepted to keep the
        # report's tests fast (femupdate.data.defects, "short")
        "data": {**_data(data_dir, [_floor(i) for i in range(1, storeys + 1, 5)]),
                 "accept": ["short"]},
        "search": {"method": "ab", "runs": 2, "seed": 3, "max_evals": 20},
    })


def _run(root: Path, case: Case, truth: dict[str, float], *, duration: float, rate: float,
         snr: float = 0.0) -> Path:
    virtual_experiment(case, truth, root / "data", seed=0, duration=duration, rate=rate,
                       snr=snr, offset=0.0, drift=0.0)
    out = root / "out"
    run_case(case, out, workers=1)
    return out


@pytest.fixture(scope="session")
def results_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``femupdate run`` output (summary.json, results.sqlite); do not modify: copy it."""
    root = tmp_path_factory.mktemp("report")
    return _run(root, two_storey_case(root / "data"), TRUTH, duration=3.0, rate=200.0)


@pytest.fixture(scope="session")
def rayleigh_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("rayleigh")
    return _run(root, rayleigh_case(root / "data"), RAYLEIGH_TRUTH, duration=6.0, rate=200.0)


@pytest.fixture(scope="session")
def wide_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("wide")
    case = wide_case(root / "data")
    truth = {n: 2000.0 if n.startswith("k") else 1.0 for n in case.parameter_names}
    return _run(root, case, truth, duration=2.0, rate=120.0)


@pytest.fixture(scope="session")
def many_runs_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("many-runs")
    case = two_storey_case(root / "data")
    spec = case.to_dict()
    spec["search"] = {"method": "multistart-lm", "runs": 25, "seed": 4, "max_evals": 300,
                      "agree": 0}  # every run: the report of many runs
    return _run(root, parse_case(spec, source=case.source), TRUTH, duration=3.0, rate=200.0,
                snr=0.01)


@pytest.fixture
def copy_results(results_dir: Path, tmp_path: Path) -> Callable[[], Path]:
    """A fresh copy of the results directory (and of its data) to edit."""

    def make() -> Path:
        target = tmp_path / "out"
        shutil.copytree(results_dir, target, ignore=shutil.ignore_patterns("report*"))
        return target

    return make


@pytest.fixture(scope="session")
def report(results_dir: Path) -> Path:
    """The report of ``results_dir``, written once."""
    from femupdate.report.html import write_report

    return write_report(results_dir)


@pytest.fixture(scope="session")
def summary(results_dir: Path) -> dict[str, Any]:
    import json

    return json.loads((results_dir / "summary.json").read_text())


#: A 1 × 1 PNG.
TINY_PNG = bytes.fromhex("89504e470d0a1a0a0000000d4948445200000001000000010806000000"
                         "1f15c4890000000d49444154789c63f8ffff3f0005fe02fea7d6a4"
                         "0000000049454e44ae426082")


@pytest.fixture
def tables_only(monkeypatch: pytest.MonkeyPatch) -> None:
    """Figures are built but not rendered (a 1 × 1 PNG each): for tests of the tables."""
    monkeypatch.setattr("femupdate.report.markup.png_bytes", lambda fig: TINY_PNG)

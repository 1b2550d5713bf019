"""A small finished results directory: a 2-storey shear building, a virtual experiment, 3 runs."""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path

import pytest

from femupdate.case import Case, parse_case
from femupdate.virtual import virtual_experiment
from femupdate.workflow import run_case

TRUTH = {"k1": 2000.0, "k2": 1500.0, "c1": 1.0, "c2": 0.5}
#: Text that must come out HTML-escaped.
DESCRIPTION = "2-storey shear building <b>test</b> & friends"


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
        "data": {
            "format": "csv", "directory": str(data_dir.resolve()), "time_column": "t",
            "input": {"file": "table.csv", "column": "a"},
            "outputs": [{"file": "floors.csv", "column": "f1", "node": "F1", "dof": "ux"},
                        {"file": "floors.csv", "column": "f2", "node": "F2", "dof": "ux"}],
        },
        "search": {"method": "ab", "runs": 3, "seed": 1, "max_evals": 300},
    })


@pytest.fixture(scope="session")
def results_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``femupdate run`` output (summary.json, results.sqlite); do not modify: copy it."""
    root = tmp_path_factory.mktemp("report")
    data = root / "data"
    case = two_storey_case(data)
    virtual_experiment(case, TRUTH, data, seed=0, duration=3.0, rate=200.0, snr=0.0,
                       offset=0.0, drift=0.0)
    out = root / "out"
    run_case(case, out, runs=3, max_evals=300, workers=1)
    return out


@pytest.fixture
def copy_results(results_dir: Path, tmp_path: Path) -> Callable[[], Path]:
    """A fresh copy of the results directory (and of its data) to edit."""

    def make() -> Path:
        target = tmp_path / "out"
        shutil.copytree(results_dir, target, ignore=shutil.ignore_patterns("report*"))
        return target

    return make

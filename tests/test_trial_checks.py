"""The first natural frequency the record checks compare the sample rate with."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from femupdate.case import parse_case
from femupdate.model.modes import natural_frequencies
from femupdate.paper.bench import large_building as MAKE
from femupdate.problem.case_model import CaseModel
from femupdate.trials.checks import first_mode_hz


def _case(tmp_path: Path, storeys: int, method: str | None = None):
    text = MAKE.case_text(storeys, 3, method=method, data_directory=str(tmp_path))
    return parse_case(tomllib.loads(text), source=tmp_path / "case.toml")


def test_first_mode_of_a_model_on_the_reduced_path_is_the_dense_one_without_a_dense_solve(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    case = _case(tmp_path, 150)  # 150 DOFs: the reduced path by default, the sparse Lanczos
    dense = natural_frequencies(CaseModel(case).system(case.nominal())).freqs_hz.min()

    def refuse(*args: object, **kwargs: object) -> None:
        raise AssertionError("a dense eigenproblem of a model on the reduced path")

    monkeypatch.setattr("femupdate.model.modes.natural_frequencies", refuse)
    assert first_mode_hz(case) == pytest.approx(dense, rel=1e-10)


def test_first_mode_of_a_small_model_is_the_dense_one(tmp_path: Path) -> None:
    case = _case(tmp_path, 20)  # the full exact path
    assert CaseModel(case).reduced is None
    freqs = natural_frequencies(CaseModel(case).system(case.nominal())).freqs_hz
    assert first_mode_hz(case) == pytest.approx(float(np.min(freqs)), rel=1e-12)

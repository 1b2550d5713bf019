"""Fixtures of the external-model tests."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from external_helpers import USER_CODE, Space, experiment

from femupdate.external import ExternalProblem, PythonModel


@pytest.fixture(scope="session")
def user_module(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("user") / "user_model.py"
    path.write_text(USER_CODE)
    return path


@pytest.fixture(scope="module")
def problem(user_module: Path) -> Iterator[ExternalProblem]:
    """Isolated, with a 1.5 s time-out; its child process reused across a module's tests."""
    model = PythonModel(f"{user_module}:model", ["roof"], frequencies=f"{user_module}:frequencies")
    prob = ExternalProblem(model, experiment(), Space(), timeout=1.5)
    yield prob
    prob.close()

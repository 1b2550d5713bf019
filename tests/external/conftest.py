"""Fixtures of the external-model tests."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from external_helpers import USER_CODE, problem_for

from femupdate.problem.update import UpdateProblem


@pytest.fixture(scope="session")
def user_module(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("user") / "user_model.py"
    path.write_text(USER_CODE)
    return path


@pytest.fixture(scope="module")
def problem(user_module: Path) -> Iterator[UpdateProblem]:
    """Isolated, with a 1.5 s time-out; its child process reused across a module's tests."""
    prob = problem_for({"python": {"function": f"{user_module}:model",
                                   "frequencies": f"{user_module}:frequencies",
                                   "timeout": 1.5}})
    yield prob
    prob.close()

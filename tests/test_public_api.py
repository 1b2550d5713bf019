"""The public surface re-exported by ``femupdate``."""

from __future__ import annotations

import inspect
import subprocess
import sys

import pytest

import femupdate


def test_every_public_name_resolves() -> None:
    for name in femupdate.__all__:
        assert getattr(femupdate, name) is not None, name


@pytest.mark.parametrize("first", ["femupdate.simulate.exact", "femupdate"])
def test_simulate_calls_the_function_whichever_is_imported_first(first: str) -> None:
    # A fresh interpreter each: the order of the first imports is the point.
    code = (f"import {first}; import numpy as np, femupdate; "
            "from femupdate.simulate import simulate; "
            "s = femupdate.System(M=np.eye(1), C=np.zeros((1, 1)), K=np.eye(1), "
            "r=np.ones(1)); ag = np.sin(np.arange(50) * 0.1); "
            "a = femupdate.simulate(s, 0.05, ag=ag).displacement; "
            "b = simulate(s, 0.05, ag=ag).displacement; print(np.array_equal(a, b))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.stdout.strip() == "True", out.stderr


def test_importing_femupdate_loads_neither_numba_nor_scipy() -> None:
    # What `femupdate --help` pays for: the package's names resolve on first use.
    code = ("import sys, femupdate, femupdate.cli; "
            "print(sorted(m for m in ('numba', 'scipy', 'pydantic') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"


def test_minimize_signature() -> None:
    params = inspect.signature(femupdate.minimize).parameters
    assert list(params)[:3] == ["fun", "bounds", "method"]
    assert params["method"].default == "ab"
    for keyword in ("seed", "max_evals", "f_target", "callback", "workers"):
        assert params[keyword].kind is inspect.Parameter.KEYWORD_ONLY


def test_renamed_names_warn_and_still_work() -> None:
    import warnings

    from femupdate.problem.objective import ErrorFunction

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        old = femupdate.Objective
    assert old is ErrorFunction
    assert any(issubclass(w.category, DeprecationWarning) for w in caught)

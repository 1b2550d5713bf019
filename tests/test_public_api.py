"""The public surface re-exported by ``femupdate``."""

from __future__ import annotations

import inspect

import femupdate


def test_every_public_name_resolves() -> None:
    for name in femupdate.__all__:
        assert getattr(femupdate, name) is not None, name


def test_simulate_is_the_function_even_after_its_subpackage_is_imported() -> None:
    import femupdate.simulate.exact  # imports the subpackage of the same name

    assert inspect.isfunction(femupdate.simulate)
    assert femupdate.simulate.__name__ == "simulate"


def test_minimize_signature() -> None:
    params = inspect.signature(femupdate.minimize).parameters
    assert list(params)[:3] == ["fun", "bounds", "method"]
    assert params["method"].default == "ab"
    for keyword in ("seed", "max_evals", "f_target", "callback", "workers"):
        assert params[keyword].kind is inspect.Parameter.KEYWORD_ONLY


def test_renamed_names_warn_and_still_work() -> None:
    import warnings

    from femupdate.objective import ErrorFunction

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        old = femupdate.Objective
    assert old is ErrorFunction
    assert any(issubclass(w.category, DeprecationWarning) for w in caught)

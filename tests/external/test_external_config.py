"""Missing modules, functions and files are ConfigErrors naming the field and the value."""

from __future__ import annotations

from pathlib import Path

import pytest
from external_helpers import case_for, problem_for

from femupdate.errors import ConfigError, FemupdateError
from femupdate.external import PythonModel, load_function, parse_ref
from femupdate.external.loader import compile_script


@pytest.mark.slow
def test_a_missing_module_is_named_when_the_model_is_loaded() -> None:
    problem = problem_for({"python": {"function": "no_such_package.models:predict"}})
    with pytest.raises(ConfigError) as info:
        problem.evaluate([2.0, 0.0])
    problem.close()
    assert str(info.value) == (
        "model.python.function: got 'no_such_package.models:predict': no module named "
        "'no_such_package' on the Python path (allowed: 'package.module:function' (importable "
        "here) or 'path/to/file.py:function')")


@pytest.mark.slow
def test_a_missing_function_lists_the_functions_there(user_module: Path) -> None:
    problem = problem_for({"python": {"function": f"{user_module}:modle"}})
    with pytest.raises(ConfigError, match=r"model\.python\.function: got '.*user_model\.py:modle'"
                                          r": file "
                                          r"'.*' has no function 'modle'; did you mean 'model'\? "
                                          r"\(allowed: a function of it: 'fragile', 'frequencies', "
                                          r"'helper_not_for_users', 'model'\)"):
        problem.evaluate([2.0, 0.0])
    problem.close()


@pytest.mark.slow
def test_a_model_that_kills_its_process_while_loading_stops_the_run(tmp_path: Path) -> None:
    (tmp_path / "crash.py").write_text("import os\nos._exit(3)\n")
    problem = problem_for({"python": {"function": "crash.py:f"}},
                          source=tmp_path / "case.toml")
    with pytest.raises(FemupdateError, match=r"could not be loaded in its own process: the "
                                             r"model's process died \(exit code 3\) while "
                                             r"loading the model"):
        problem.evaluate([2.0, 0.0])
    problem.close()


def test_a_module_function_is_found_on_the_path() -> None:
    fn = load_function(parse_ref("json:dumps", field="model.function"))
    assert fn([1]) == "[1]"
    with pytest.raises(ConfigError, match=r"module 'json' has no function 'dumpss'; did you "
                                          r"mean 'dumps'\?"):
        load_function(parse_ref("json:dumpss", field="model.function"))


def test_a_module_that_fails_to_import_says_why(tmp_path: Path) -> None:
    (tmp_path / "broken.py").write_text("import no_such_dependency\n")
    with pytest.raises(ConfigError, match=r"model\.function: got 'broken\.py:f': importing the "
                                          r"file raised ModuleNotFoundError: No module named "
                                          r"'no_such_dependency'"):
        load_function(parse_ref("broken.py:f", field="model.function", base_dir=tmp_path))


@pytest.mark.parametrize(("value", "message"), [
    ("models.py:predict", r"no file '.*models\.py' \(allowed: a file relative to the case "
                          r"file's folder"),
    ("package.module", r"no function named; write 'package\.module:function'"),
    ("pkg.mod:2fast", r"'2fast' is not a function name"),
    ("pkg-x.mod:f", r"'pkg-x\.mod' is neither a module name nor a \.py file"),
    ("", r"not a reference to code"),
])
def test_malformed_references_are_refused_before_loading(tmp_path: Path, value: str,
                                                         message: str) -> None:
    with pytest.raises(ConfigError, match=r"^model\.function: got .*" + message):
        PythonModel(value, ["roof"], base_dir=tmp_path)


def test_a_file_without_function_is_refused_for_a_function(tmp_path: Path) -> None:
    (tmp_path / "m.py").write_text("x = 1\n")
    with pytest.raises(ConfigError, match=r"a file without a function; write 'm\.py:function'"):
        parse_ref("m.py", field="model.function", base_dir=tmp_path)
    ref = parse_ref("m.py", field="model.build", base_dir=tmp_path, script_allowed=True)
    assert ref.function is None and ref.path == (tmp_path / "m.py").resolve()


def test_a_script_with_a_syntax_error_names_its_line(tmp_path: Path) -> None:
    (tmp_path / "s.py").write_text("a = 1\nb = (\n")
    ref = parse_ref("s.py", field="model.build", base_dir=tmp_path, script_allowed=True)
    with pytest.raises(ConfigError, match=r"model\.build: got 's\.py': syntax error at line 2"):
        compile_script(ref)


def test_outputs_and_quantity_are_checked() -> None:
    with pytest.raises(ConfigError, match=r"model\.outputs: got \['a', 'a'\]"):
        PythonModel("json:dumps", ["a", "a"])
    with pytest.raises(ConfigError, match=r"model\.quantity: got 'velocity'"):
        PythonModel("json:dumps", ["a"], quantity="velocity")
    with pytest.raises(ConfigError, match=r"model\.influence: got \[1, 0\]"):
        PythonModel("json:dumps", ["a"], influence=[1, 0])


def test_a_missing_file_is_named_with_the_case_field(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"model\.python\.function: got 'nothere\.py:f': "
                                          r"no file"):
        problem_for({"python": {"function": "nothere.py:f"}}, source=tmp_path / "case.toml")


def test_an_external_model_with_elements_or_too_few_channels_is_refused() -> None:
    with pytest.raises(ConfigError, match=r"model\.python: an external model given together "
                                          r"with model\.shear_building"):
        case_for({"python": {"function": "m.py:f"},
                  "shear_building": {"masses": [1.0], "stiffnesses": [1.0]}})
    with pytest.raises(ConfigError, match=r"data\.outputs: 1 channels but "
                                          r"model\.opensees\.outputs gives 2"):
        case_for({"opensees": {"build": "m.py:build", "outputs": [[2, 2], [3, 2]]}})

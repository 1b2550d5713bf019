"""The optimizers' registry: the product ships four; plug-ins join by an explicit call."""

from __future__ import annotations

import subprocess
import sys

import pytest

from femupdate.errors import ConfigError
from femupdate.optimize import METHODS, register_method


def test_the_product_registers_its_four_methods_and_nothing_else() -> None:
    # A fresh interpreter: other tests in this process register the comparison plug-ins.
    code = ("import femupdate, femupdate.case, femupdate.pipeline.run; "
            "from femupdate.optimize import METHODS; print(sorted(METHODS))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == str(sorted(["ab", "cmaes", "ib", "multistart-lm"]))


def test_a_name_taken_by_another_factory_is_refused() -> None:
    with pytest.raises(ConfigError, match="'ab' is registered already"):
        register_method("ab", lambda n, rng: None)
    register_method("ab", METHODS["ab"])  # the same factory again: a no-op


def test_a_case_names_only_registered_methods() -> None:
    from femupdate.case import parse_case

    case = {"case": {"name": "c"}, "model": {"shear_building": {"masses": [1.0],
                                                                 "stiffnesses": ["k"]}},
            "parameters": [{"name": "k", "lower": 1.0, "upper": 2.0}],
            "search": {"method": "multistart_lm"}}
    with pytest.raises(ConfigError, match="did you mean 'multistart-lm'"):
        parse_case(case)

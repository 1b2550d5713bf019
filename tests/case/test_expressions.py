"""The parser of derived fields and constraints: what it accepts, computes and refuses."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

from femupdate.case.expressions import (
    ExpressionError,
    FieldValues,
    first_violation,
    parse_constraint,
    parse_expression,
)
from femupdate.errors import ModelError

VALUES = {"beta": 3.0, "r": 0.4, "kp1": 5000.0, "E": 2.1e11, "k": 400.0, "m": 2.5,
          "a": -1.5, "b": 2.0}


@pytest.mark.parametrize(("text", "expected", "names"), [
    ("0.5 * beta", 1.5, ("beta",)),
    ("r * beta", 0.4 * 3.0, ("r", "beta")),
    ("kp1 / 2", 2500.0, ("kp1",)),
    ("E * 1.05", 2.1e11 * 1.05, ("E",)),
    ("sqrt(k * m)", 31.622776601683793, ("k", "m")),
    ("-a + b ** 2", 1.5 + 4.0, ("a", "b")),
    ("+b - -a", 2.0 - 1.5, ("b", "a")),
    ("(a + b) * 2", 1.0, ("a", "b")),
    ("max(a, b, 3)", 3.0, ("a", "b")),
    ("min(a, b)", -1.5, ("a", "b")),
    ("exp(log(b))", 2.0, ("b",)),
    ("abs(a)", 1.5, ("a",)),
    ("2 ** -1 * beta", 1.5, ("beta",)),
    ("1e3", 1000.0, ()),
])
def test_value_is_the_hand_computed_one(text: str, expected: float,
                                        names: tuple[str, ...]) -> None:
    expression = parse_expression(text)
    assert expression.names == names
    assert float(expression(VALUES)) == pytest.approx(expected, rel=1e-15)


def test_a_batch_gives_each_point_s_value() -> None:
    expression = parse_expression("sqrt(k * m) + r * beta")
    k = np.array([100.0, 400.0, 900.0])
    batch = expression({"k": k, "m": 1.0, "r": np.array([0.1, 0.2, 0.3]), "beta": 2.0})
    singles = [float(expression({"k": kk, "m": 1.0, "r": rr, "beta": 2.0}))
               for kk, rr in zip(k, [0.1, 0.2, 0.3], strict=True)]
    assert batch.tolist() == singles == [10.2, 20.4, 30.6]


def test_division_by_zero_is_inf_not_an_exception() -> None:
    assert math.isinf(parse_expression("kp1 / b")({"kp1": 1.0, "b": 0.0}))
    assert math.isnan(parse_expression("sqrt(a)")({"a": -1.0}))


@pytest.mark.parametrize(("text", "why"), [
    ("__import__('os')", "calls __import__, which is not an allowed function"),
    ("__import__('os').system('true')", "attribute access (.) is not allowed"),
    ("().__class__.__bases__[0].__subclasses__()", "attribute access (.) is not allowed"),
    ("beta.real", "attribute access"),
    ("beta[0]", "indexing"),
    ("open('x')", "calls open, which is not an allowed function"),
    ("eval('1')", "calls eval"),
    ("sqrt(a, b)", "sqrt() takes 1 arguments, got 2"),
    ("max(a)", "max() takes 2 to 8 arguments, got 1"),
    ("sqrt(x=a)", "keyword arguments"),
    ("a if b else 1", "if/else"),
    ("'text'", "the constant 'text'"),
    ("True", "the constant True"),
    ("a == b", "a comparison"),
    ("a <= b", "a comparison"),
    ("lambda: 0", "lambda"),
    ("a ^ 2", "the operator ^ (a power is **)"),
    ("a // 2", "the operator //"),
    ("a % 2", "the operator %"),
    ("[a, b]", "a list"),
    ("a and b", "and/or"),
    ("2 +", "not a valid expression"),
    ("2.5 kN/m", "not a valid expression"),
    ("", "an empty expression"),
    ("a" * 401, "more than 400"),
    ("(" * 40 + "a" + ")" * 40 + " + 1" * 40, "nested more than"),
    ("1e999 * a", "not finite"),
])
def test_refused_with_the_reason(text: str, why: str) -> None:
    with pytest.raises(ExpressionError) as info:
        parse_expression(text)
    assert why in str(info.value)


def test_constraints_compare_expressions() -> None:
    rule = parse_constraint("gamma <= beta")
    assert rule.names == ("gamma", "beta") and rule.ops == ("<=",)
    assert rule.holds({"gamma": 2.0, "beta": 2.0})
    assert not rule.holds({"gamma": 2.5, "beta": 2.0})
    chain = parse_constraint("0 < gamma <= 0.8 * beta")
    gamma = np.array([-1.0, 0.0, 1.0, 1.6, 1.7])
    assert chain.holds({"gamma": gamma, "beta": 2.0}).tolist() == [False, False, True, True,
                                                                    False]
    assert not parse_constraint("a < b").holds({"a": math.nan, "b": 1.0})
    assert parse_constraint("k2 >= 2 * k1").holds({"k1": 1.0, "k2": 2.0})


@pytest.mark.parametrize(("text", "why"), [
    ("gamma == beta", "the comparison Eq is not allowed"),
    ("gamma != beta", "the comparison NotEq is not allowed"),
    ("gamma - beta", "not a comparison"),
    ("gamma <= beta.real", "attribute access"),
    ("gamma <= ", "not a valid constraint"),
])
def test_constraints_refused_with_the_reason(text: str, why: str) -> None:
    with pytest.raises(ExpressionError) as info:
        parse_constraint(text)
    assert why in str(info.value)


def test_first_violation_says_which_and_where() -> None:
    rules = [parse_constraint("k2 <= 2 * k1"), parse_constraint("gamma <= beta")]
    assert first_violation(rules, {"k1": 1.0, "k2": 2.0, "gamma": 1.0, "beta": 1.0}) is None
    why = first_violation(rules, {"k1": 1.0, "k2": 2.0, "gamma": 2.5, "beta": 2.0})
    assert why == "constraint 'gamma <= beta' does not hold: gamma = 2.5, beta = 2"


def test_parsed_objects_pickle_and_still_compute() -> None:
    expression = pickle.loads(pickle.dumps(parse_expression("0.5 * beta")))
    assert expression({"beta": 4.0}) == 2.0
    rule = pickle.loads(pickle.dumps(parse_constraint("gamma <= beta")))
    assert not rule.holds({"gamma": 3.0, "beta": 2.0})


def test_field_values_map_case_values_to_the_structure_s() -> None:
    plain = FieldValues(("k1", "k2"))
    values = {"k1": 1.0, "k2": 2.0}
    assert not plain and plain(values) is values  # the identity without expressions
    derived = FieldValues(("beta", "0.5 * beta", "k"))
    assert derived
    out = derived({"beta": 3.0, "k": 7.0})
    assert out == {"beta": 3.0, "k": 7.0, "0.5 * beta": 1.5}
    assert derived(out) is out  # already the structure's values: unchanged
    with pytest.raises(ModelError, match=r"'0\.5 \* beta' needs a value of beta"):
        derived({"k": 7.0})

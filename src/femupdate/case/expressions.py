"""Derived parameters and constraints: arithmetic of parameters in a case file's fields.

A numeric field of ``[model]`` may be an expression of parameters and numbers
(``gamma = "0.5 * beta"``, ``k = "sqrt(k1 * k2)"``), and ``[[constraints]]`` holds conditions
between parameters (``rule = "gamma <= beta"``) that every searched point must satisfy.

The text is parsed by Python's :mod:`ast` and only a whitelist of nodes is accepted: numbers,
parameter names, ``+ - * / **``, unary ``-`` and ``+``, parentheses, and calls of
:data:`FUNCTIONS`; a constraint is one comparison (``<``, ``<=``, ``>``, ``>=``, chains such as
``"0 < gamma <= beta"`` too). Nothing is ever passed to ``eval``: the tree is compiled once into
nested closures over numpy's ufuncs, so the same :class:`Expression` evaluates one point (floats)
or a batch of points (arrays, broadcast) at a few microseconds per node.
"""

from __future__ import annotations

import ast
import functools
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from femupdate.errors import ModelError

__all__ = [
    "FUNCTIONS",
    "Constraint",
    "Expression",
    "ExpressionError",
    "FieldValues",
    "first_violation",
    "parse_constraint",
    "parse_expression",
]

#: The functions an expression may call: (numpy function, least and most arguments).
FUNCTIONS: dict[str, tuple[Callable[..., Any], int, int]] = {
    "sqrt": (np.sqrt, 1, 1),
    "exp": (np.exp, 1, 1),
    "log": (np.log, 1, 1),
    "abs": (np.abs, 1, 1),
    "min": (np.minimum, 2, 8),
    "max": (np.maximum, 2, 8),
}
_BINARY: dict[type, Callable[..., Any]] = {
    ast.Add: np.add, ast.Sub: np.subtract, ast.Mult: np.multiply, ast.Div: np.divide,
    ast.Pow: np.power}
_UNARY: dict[type, Callable[..., Any]] = {ast.USub: np.negative, ast.UAdd: np.positive}
_COMPARE: dict[type, tuple[str, Callable[..., Any]]] = {
    ast.Lt: ("<", np.less), ast.LtE: ("<=", np.less_equal), ast.Gt: (">", np.greater),
    ast.GtE: (">=", np.greater_equal)}
_SYMBOLS = {ast.FloorDiv: "//", ast.Mod: "%", ast.BitXor: "^", ast.MatMult: "@",
            ast.BitAnd: "&", ast.BitOr: "|", ast.LShift: "<<", ast.RShift: ">>",
            ast.Invert: "~", ast.Not: "not"}
#: Longest text and deepest nesting accepted (a field is a formula, not a program).
MAX_LENGTH = 400
MAX_DEPTH = 30
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")

#: What an expression may contain, in words (the "allowed" of every message).
ALLOWED = ("numbers, parameter names, + - * / **, parentheses and "
           + ", ".join(f"{name}()" for name in FUNCTIONS))

Env = Mapping[str, Any]
_Node = Callable[[Env], Any]


class ExpressionError(ValueError):
    """Text that is not an allowed expression or constraint; the message says why."""


def _describe(node: ast.AST) -> str:
    """How a message names a node that is not allowed."""
    words = {ast.Attribute: "attribute access (.)", ast.Subscript: "indexing ([])",
             ast.Lambda: "lambda", ast.BoolOp: "and/or", ast.IfExp: "if/else",
             ast.Compare: "a comparison", ast.keyword: "keyword arguments",
             ast.Starred: "* arguments", ast.List: "a list", ast.Tuple: "a tuple",
             ast.Dict: "a dict", ast.Set: "a set", ast.JoinedStr: "an f-string",
             ast.NamedExpr: ":=", ast.Await: "await", ast.ListComp: "a comprehension",
             ast.GeneratorExp: "a comprehension"}
    if isinstance(node, ast.BinOp | ast.UnaryOp):
        symbol = _SYMBOLS.get(type(node.op), type(node.op).__name__)
        hint = " (a power is **)" if isinstance(node.op, ast.BitXor) else ""
        return f"the operator {symbol}{hint}"
    if isinstance(node, ast.Constant):
        return f"the constant {node.value!r}"
    return words.get(type(node), type(node).__name__)


def _compile(node: ast.AST, names: dict[str, None], depth: int = 0) -> _Node:
    """The closure computing ``node`` from an environment of parameter values; the names it
    reads are added to ``names`` (first-use order)."""
    if depth > MAX_DEPTH:
        raise ExpressionError(f"nested more than {MAX_DEPTH} levels deep")
    if isinstance(node, ast.Constant):
        value = node.value
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ExpressionError(f"{_describe(node)} is not allowed")
        number = np.float64(value)
        if not np.isfinite(number):
            raise ExpressionError(f"the number {value!r} is not finite")
        return lambda env: number
    if isinstance(node, ast.Name):
        key = node.id
        names.setdefault(key, None)
        return lambda env: env[key]
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        op = _BINARY[type(node.op)]
        left, right = (_compile(n, names, depth + 1) for n in (node.left, node.right))
        return lambda env: op(left(env), right(env))
    if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
        op1 = _UNARY[type(node.op)]
        inner = _compile(node.operand, names, depth + 1)
        return lambda env: op1(inner(env))
    if isinstance(node, ast.Call):
        if not isinstance(node.func, ast.Name):
            raise ExpressionError(f"{_describe(node.func)} is not allowed")
        if node.func.id not in FUNCTIONS:
            raise ExpressionError(f"calls {node.func.id}, which is not an allowed function")
        if node.keywords:
            raise ExpressionError(f"{node.func.id}() with keyword arguments")
        fn, least, most = FUNCTIONS[node.func.id]
        if not least <= len(node.args) <= most:
            count = str(least) if least == most else f"{least} to {most}"
            raise ExpressionError(f"{node.func.id}() takes {count} arguments, got "
                                  f"{len(node.args)}")
        args = [_compile(a, names, depth + 1) for a in node.args]
        if len(args) == 1:
            arg = args[0]
            return lambda env: fn(arg(env))
        return lambda env: functools.reduce(fn, (a(env) for a in args))
    raise ExpressionError(f"{_describe(node)} is not allowed")


def _tree(text: str, what: str) -> ast.AST:
    """The body of ``text`` parsed as one Python expression (never executed)."""
    if not isinstance(text, str):
        raise ExpressionError(f"not text: {text!r}")
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"{len(text)} characters, more than {MAX_LENGTH}")
    if not text.strip():
        raise ExpressionError(f"an empty {what}")
    try:
        return ast.parse(text.strip(), mode="eval").body
    except (SyntaxError, ValueError, RecursionError, MemoryError) as exc:
        reason = getattr(exc, "msg", None) or type(exc).__name__
        raise ExpressionError(f"not a valid {what} ({reason})") from None


def _evaluate(fn: _Node, env: Env) -> Any:
    with np.errstate(all="ignore"):  # a NaN or inf result says it; the caller judges it
        return fn(env)


@dataclass(frozen=True, eq=False)
class Expression:
    """A parsed arithmetic expression of parameters (see :func:`parse_expression`).

    Attributes
    ----------
    text : str
        The text as written.
    names : tuple of str
        The parameters it reads, in first-use order.
    """

    text: str
    names: tuple[str, ...]
    _fn: _Node = field(repr=False)

    def __call__(self, values: Env) -> Any:
        """The value at ``values`` ({name: float or array}; arrays broadcast: a batch)."""
        return _evaluate(self._fn, values)

    def __reduce__(self) -> tuple[Any, ...]:  # closures do not pickle: parse again
        return parse_expression, (self.text,)


@dataclass(frozen=True, eq=False)
class Constraint:
    """A parsed condition between parameters (see :func:`parse_constraint`).

    Attributes
    ----------
    text : str
        The text as written.
    names : tuple of str
        The parameters it reads, in first-use order.
    terms : tuple of Expression
        The compared expressions, left to right.
    ops : tuple of str
        The comparisons between consecutive terms (``"<"``, ``"<="``, ``">"``, ``">="``).
    """

    text: str
    names: tuple[str, ...]
    terms: tuple[Expression, ...]
    ops: tuple[str, ...]
    _tests: tuple[Callable[..., Any], ...] = field(repr=False)

    def holds(self, values: Env) -> Any:
        """Whether the condition holds at ``values`` (a bool, or a bool array for arrays of
        values); False where a term is NaN."""
        sides = [term(values) for term in self.terms]
        result: Any = True
        for test, a, b in zip(self._tests, sides, sides[1:], strict=False):
            result = np.logical_and(result, test(a, b))
        return result

    def explain(self, values: Env) -> str:
        """``'gamma <= beta' does not hold: gamma = 2.5, beta = 2`` at one point."""
        shown = ", ".join(f"{n} = {float(values[n]):.6g}" for n in self.names)
        return f"constraint {self.text!r} does not hold: {shown}"

    def __reduce__(self) -> tuple[Any, ...]:
        return parse_constraint, (self.text,)


@functools.lru_cache(maxsize=4096)
def parse_expression(text: str) -> Expression:
    """Parse a field's expression of parameters and numbers.

    Parameters
    ----------
    text : str
        E.g. ``"0.5 * beta"``, ``"r * beta"``, ``"kp1 / 2"``, ``"sqrt(k * m)"``.

    Returns
    -------
    Expression
        Compiled once (the same object for the same text, in one process).

    Raises
    ------
    ExpressionError
        Bad syntax, or a node outside the whitelist (attribute access, subscripts, calls of
        other functions, comparisons, strings...): the message names it.
    """
    body = _tree(text, "expression")
    names: dict[str, None] = {}
    fn = _compile(body, names)
    return Expression(text, tuple(names), fn)


@functools.lru_cache(maxsize=1024)
def parse_constraint(text: str) -> Constraint:
    """Parse a constraint: expressions compared by ``<``, ``<=``, ``>``, ``>=``.

    Parameters
    ----------
    text : str
        E.g. ``"gamma <= beta"``, ``"k2 <= 2 * k1"``, ``"0 < gamma <= beta"``.

    Raises
    ------
    ExpressionError
        Not one comparison of allowed expressions (``==`` and ``!=`` are refused: a
        continuous parameter meets them with probability zero).
    """
    body = _tree(text, "constraint")
    if not isinstance(body, ast.Compare):
        raise ExpressionError("not a comparison (e.g. \"gamma <= beta\")")
    bad = [type(op).__name__ for op in body.ops if type(op) not in _COMPARE]
    if bad:
        raise ExpressionError(f"the comparison {bad[0]} is not allowed (use <, <=, >, >=)")
    names: dict[str, None] = {}
    terms = []
    for node in (body.left, *body.comparators):
        term_names: dict[str, None] = {}
        fn = _compile(node, term_names)
        for name in term_names:
            names.setdefault(name, None)
        terms.append(Expression(ast.unparse(node), tuple(term_names), fn))
    symbols = tuple(_COMPARE[type(op)][0] for op in body.ops)
    tests = tuple(_COMPARE[type(op)][1] for op in body.ops)
    return Constraint(text, tuple(names), tuple(terms), symbols, tests)


def is_name(text: str) -> bool:
    """Whether a field's text is a plain parameter name (not an expression)."""
    return bool(_NAME.fullmatch(text))


def first_violation(constraints: Sequence[Constraint], values: Mapping[str, float]
                    ) -> str | None:
    """Why the point ``values`` is outside the constraints (None: it satisfies them all)."""
    for constraint in constraints:
        if not bool(constraint.holds(values)):
            return constraint.explain(values)
    return None


class FieldValues:
    """The values of a structure's parameters (its fields' texts: names or expressions) from
    a case's parameter values. Picklable; the identity when no field is an expression.

    Parameters
    ----------
    keys : sequence of str
        ``Structure.parameters``: every field text that is not a number.
    """

    def __init__(self, keys: Sequence[str]) -> None:
        self.keys = tuple(keys)
        self.expressions = {k: parse_expression(k) for k in self.keys if not is_name(k)}

    def __bool__(self) -> bool:
        """Whether some field is an expression (else the values pass unchanged)."""
        return bool(self.expressions)

    def __call__(self, values: Mapping[str, float]) -> Mapping[str, float]:
        """``{key: value}`` for every key (a missing name is left for the structure to name);
        values already keyed so (an expression's text among them) pass unchanged."""
        if not self.expressions or next(iter(self.expressions)) in values:
            return values
        out = {key: values[key] for key in self.keys
               if key not in self.expressions and key in values}
        for key, expression in self.expressions.items():
            missing = [n for n in expression.names if n not in values]
            if missing:
                raise ModelError(f"{key!r} needs a value of {', '.join(missing)}")
            out[key] = float(expression(values))
        return out

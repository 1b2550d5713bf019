"""A model that is the user's own Python function.

``predict(values, ag, dt) -> (n_samples, n_outputs)``: the parameter values (name → value), the
base acceleration (m/s², every ``dt`` s, linear in between) and its time step; optionally a
second function ``frequencies(values) -> Hz``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from femupdate.errors import ConfigError
from femupdate.external.loader import CodeRef, load_function, parse_ref
from femupdate.external.protocol import QUANTITIES, Quantity

__all__ = ["PythonModel", "check_outputs", "check_quantity"]


def check_outputs(outputs: Sequence[str], field: str) -> tuple[str, ...]:
    """Output labels as a tuple of distinct non-empty strings, or ConfigError."""
    if isinstance(outputs, str) or not isinstance(outputs, Sequence) or not outputs:
        raise ConfigError(f"{field}: got {outputs!r}: not a list of output labels (allowed: "
                          "1 or more distinct labels)")
    labels = tuple(outputs)
    bad = [o for o in labels if not isinstance(o, str) or not o]
    if bad or len(set(labels)) != len(labels):
        raise ConfigError(f"{field}: got {list(labels)!r}: labels must be distinct non-empty "
                          "strings (allowed: 1 or more distinct labels)")
    return labels


def check_quantity(quantity: str, field: str) -> Quantity:
    if quantity not in QUANTITIES:
        raise ConfigError(f"{field}: got {quantity!r} (allowed: 'acceleration' (absolute), "
                          "'displacement' (relative to the base))")
    return quantity  # type: ignore[return-value]


def _influence(influence: Sequence[float] | None, n: int, field: str) -> np.ndarray:
    if influence is None:
        return np.ones(n)
    arr = np.asarray(influence, dtype=float)
    if arr.shape != (n,) or not np.all(np.isfinite(arr)):
        raise ConfigError(f"{field}: got {influence!r}: one finite number per output ({n}) "
                          "(allowed: 1 for a translation along the base motion, 0 otherwise)")
    return arr


class PythonModel:
    """The user's Python function as a model.

    Parameters
    ----------
    function : str
        ``"package.module:function"`` or ``"path/to/file.py:function"`` (relative to
        ``base_dir``), called as ``function(values, ag, dt)``.
    outputs : sequence of str
        Labels of the columns the function returns.
    quantity : {"acceleration", "displacement"}
        What it returns: absolute accelerations or displacements relative to the base.
    frequencies : str or None
        A second function, ``frequencies(values)`` → natural frequencies in Hz.
    influence : sequence of float or None
        Per output, its displacement for a unit rigid base displacement (default all 1:
        translations along the base motion).
    base_dir : path or None
        Folder of relative file paths (the case file's folder).
    field : str
        Prefix of the case-file fields in messages.

    Raises
    ------
    ConfigError
        A malformed reference, a missing file, bad outputs or quantity (the module itself is
        imported by :meth:`prepare`, in the process that evaluates).
    """

    def __init__(self, function: str, outputs: Sequence[str], *,
                 quantity: str = "acceleration", frequencies: str | None = None,
                 influence: Sequence[float] | None = None,
                 base_dir: str | Path | None = None, field: str = "model") -> None:
        self.outputs = check_outputs(outputs, f"{field}.outputs")
        self.quantity = check_quantity(quantity, f"{field}.quantity")
        self._influence = _influence(influence, len(self.outputs), f"{field}.influence")
        self.ref: CodeRef = parse_ref(function, field=f"{field}.function", base_dir=base_dir)
        self.frequencies_ref: CodeRef | None = None
        if frequencies is not None:
            self.frequencies_ref = parse_ref(frequencies, field=f"{field}.frequencies",
                                             base_dir=base_dir)
        self._loaded: tuple[Callable[..., Any], Callable[..., Any] | None] | None = None

    @property
    def influence(self) -> np.ndarray:
        return self._influence.copy()

    def __getstate__(self) -> dict[str, Any]:
        # The loaded functions stay in the process that loaded them.
        return {**self.__dict__, "_loaded": None}

    def __repr__(self) -> str:
        return f"PythonModel({self.ref.text!r}, outputs={list(self.outputs)!r})"

    def prepare(self) -> None:
        """Import the function(s); ConfigError naming the field if they cannot be."""
        if self._loaded is None:
            freq = None if self.frequencies_ref is None else load_function(self.frequencies_ref)
            self._loaded = (load_function(self.ref), freq)

    def _functions(self) -> tuple[Callable[..., Any], Callable[..., Any] | None]:
        self.prepare()
        assert self._loaded is not None
        return self._loaded

    def predict(self, values: Mapping[str, float], ag: np.ndarray, dt: float) -> np.ndarray:
        """``function(dict(values), ag, dt)`` (its result is checked by the caller)."""
        fn, _ = self._functions()
        # A copy each: the user's function may modify what it is given.
        return fn(dict(values), np.array(ag, dtype=float), float(dt))

    def frequencies(self, values: Mapping[str, float]) -> np.ndarray | None:
        """``frequencies(dict(values))`` as an array of Hz, or None without that function."""
        _, fn = self._functions()
        if fn is None:
            return None
        return np.asarray(fn(dict(values)), dtype=float)

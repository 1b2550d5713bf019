"""Time integration of the assembled equations of motion (:class:`~femupdate.model.system.System`).

``simulate()`` is the front door. For the hot path of model updating (one simulation per
evaluation of the error function) prepare once per system and run per input::

    sim = prepare_exact(system, dt, outputs=[2, 4, 6])
    response = sim.run(ag)

Methods
-------
exact
    Exact discretisation for a piecewise-linear input (modal first-order-hold filters). The
    reference for linear systems: no step limit, exact at the samples to rounding.
central_difference
    The paper's explicit scheme, with ``substeps`` per sample; stable for h < 2/ω_max.
newmark
    Newmark's method (average acceleration by default), with ``substeps``.
nonlinear
    Central differences with the elasto-slip friction and Bouc–Wen elements; also runs linear
    systems.
implicit
    HHT-α (Newmark's average acceleration by default) with Newton–Raphson on the friction and
    Bouc–Wen elements: unconditionally stable, for systems whose stiff elements would hold
    central differences to a step far below the record's (:func:`nonlinear_method` chooses).
"""

from __future__ import annotations

import math
import sys
import types
from collections.abc import Sequence
from typing import Any

import numpy as np

from femupdate.errors import ConfigError, SimulationError
from femupdate.model.system import System
from femupdate.simulate.central_difference import (
    CentralDifferenceSimulator,
    prepare_central_difference,
)
from femupdate.simulate.exact import ExactSimulator, prepare_exact
from femupdate.simulate.implicit import (
    ImplicitSimulator,
    explicit_stable_step,
    prepare_implicit,
)
from femupdate.simulate.newmark import NewmarkSimulator, prepare_newmark
from femupdate.simulate.nonlinear import NonlinearSimulator, prepare_nonlinear
from femupdate.simulate.response import Response

__all__ = [
    "METHODS",
    "CentralDifferenceSimulator",
    "ExactSimulator",
    "ImplicitSimulator",
    "NewmarkSimulator",
    "NonlinearSimulator",
    "Response",
    "explicit_substeps",
    "nonlinear_method",
    "prepare",
    "prepare_central_difference",
    "prepare_exact",
    "prepare_implicit",
    "prepare_newmark",
    "prepare_nonlinear",
    "simulate",
]

METHODS: tuple[str, ...] = ("exact", "central_difference", "newmark", "nonlinear", "implicit")
LINEAR_METHODS: tuple[str, ...] = ("exact", "central_difference", "newmark")

Simulator = (ExactSimulator | CentralDifferenceSimulator | NewmarkSimulator | NonlinearSimulator
             | ImplicitSimulator)

#: Central differences need ``h ω_max < 2``; the default keeps them only where ``h ω_max`` stays
#: below this at the nominal point (a factor 2 of room for the stiffer corners of a search box).
EXPLICIT_MARGIN = 1.0


def nonlinear_method(system: System, dt: float, substeps: int = 1) -> str:
    """The default integrator of a nonlinear ``system`` at ``h = dt / substeps``.

    ``"nonlinear"`` (central differences, the paper's) where their stable step ``2/ω_max``
    (sliders stuck, Bouc–Wen elements at their largest tangent) is at least twice ``h``;
    ``"implicit"`` where it is below: stiff elements (zero-length links) would hold the
    explicit scheme to a step far below the record's, which the implicit one does not need.
    """
    h = float(dt) / int(substeps)
    return "nonlinear" if h * 2.0 / explicit_stable_step(system) < EXPLICIT_MARGIN else "implicit"


def explicit_substeps(system: System, dt: float, limit: float = EXPLICIT_MARGIN) -> int:
    """The fewest substeps per sample interval ``dt`` that keep central differences on
    ``system`` at ``h ω_max < limit`` (sliders stuck, Bouc–Wen elements at their largest
    tangent): with the default ``limit``, where :func:`nonlinear_method` keeps them; with
    ``limit = 2``, where they are stable at all. 1 for a system without stiffness."""
    if not limit > 0.0:
        raise ConfigError(f"explicit_substeps: limit = {limit!r} (allowed: > 0)")
    step = explicit_stable_step(system)  # 2/ω_max
    if math.isinf(step):
        return 1
    return math.floor(float(dt) * 2.0 / step / limit) + 1


def prepare(
    system: System,
    dt: float,
    *,
    method: str = "exact",
    outputs: Sequence[int] | np.ndarray | None = None,
    substeps: int = 1,
    newmark_beta: float = 0.25,
    newmark_gamma: float = 0.5,
    hht_alpha: float = 0.0,
) -> Simulator:
    """Prepare an integrator for ``system`` by name; call ``.run(ag, force, x0=, v0=)`` on it.

    Arguments as for :func:`simulate`.
    """
    if method not in METHODS:
        raise ConfigError(f"method = {method!r} is unknown; choose one of {', '.join(METHODS)}")
    if method in LINEAR_METHODS and not system.is_linear:
        raise SimulationError(
            f"method {method!r} is for linear systems; this system has "
            f"{system.nonlinear_elements()}: use method='nonlinear'"
        )
    if method == "exact":
        if substeps != 1:
            raise ConfigError(
                f"substeps = {substeps!r} with method 'exact': the exact discretisation needs "
                "no substeps; leave substeps at 1"
            )
        return prepare_exact(system, dt, outputs)
    if method == "central_difference":
        return prepare_central_difference(system, dt, outputs, substeps)
    if method == "newmark":
        return prepare_newmark(system, dt, outputs, substeps, newmark_beta, newmark_gamma)
    if method == "implicit":
        return prepare_implicit(system, dt, outputs, substeps, hht_alpha)
    return prepare_nonlinear(system, dt, outputs, substeps)


def simulate(
    system: System,
    dt: float,
    *,
    ag: np.ndarray | None = None,
    force: np.ndarray | None = None,
    method: str = "exact",
    outputs: Sequence[int] | np.ndarray | None = None,
    substeps: int = 1,
    x0: np.ndarray | None = None,
    v0: np.ndarray | None = None,
    newmark_beta: float = 0.25,
    newmark_gamma: float = 0.5,
    hht_alpha: float = 0.0,
) -> Response:
    """Response of ``system`` to a base acceleration and/or nodal forces sampled every ``dt``.

    Solves ``M ÿ + C ẏ + K y (+ friction) = -M r a_g(t) + f(t)`` with inputs linear between
    samples, from rest or from ``(x0, v0)``.

    Parameters
    ----------
    system : System
        The assembled equations.
    dt : float
        Sample interval of the inputs and outputs (s), > 0.
    ag : ndarray (n_samples,), optional
        Base acceleration.
    force : ndarray (n_samples, n_dof), optional
        Nodal forces on the free DOFs. At least one of ``ag`` and ``force`` is needed.
    method : {"exact", "central_difference", "newmark", "nonlinear", "implicit"}
        Integrator. Systems with friction or Bouc–Wen elements need ``"nonlinear"`` or
        ``"implicit"`` (:func:`nonlinear_method` says which suits them).
    outputs : sequence of int, optional
        DOF indices to output (default: all).
    substeps : int
        Integration steps per sample interval (not for ``"exact"``).
    x0, v0 : ndarray (n_dof,), optional
        Initial displacement and velocity relative to the base (default: rest).
    newmark_beta, newmark_gamma : float
        Newmark parameters (method ``"newmark"`` only).
    hht_alpha : float
        HHT ``α`` in [-1/3, 0] (method ``"implicit"`` only; 0 is average acceleration).

    Returns
    -------
    Response
        Relative displacement and velocity and absolute acceleration at every sample;
        ``diverged=True`` (and NaN arrays) if the solution overflowed.

    Raises
    ------
    DataError
        NaN/inf or wrong shapes in the inputs (the message names the argument and sample).
    ConfigError
        Unknown method, bad outputs, dt, substeps, β or γ.
    SimulationError
        A friction system with a linear method, or an unstable step.
    """
    sim = prepare(
        system,
        dt,
        method=method,
        outputs=outputs,
        substeps=substeps,
        newmark_beta=newmark_beta,
        newmark_gamma=newmark_gamma,
        hht_alpha=hht_alpha,
    )
    return sim.run(ag, force, x0=x0, v0=v0)


class _CallableModule(types.ModuleType):
    """This package, callable as :func:`simulate`: ``femupdate.simulate(system, dt, ag=ag)``.

    The package shares the name of its front-door function, and ``femupdate`` imports neither
    until it is used (``femupdate --help`` must not load numba and scipy), so
    ``femupdate.simulate`` is this module whichever is imported first; calling it calls the
    function.
    """

    def __call__(self, *args: Any, **kwargs: Any) -> Response:
        return simulate(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule

"""Central differences with elasto-slip friction elements (Zapico-Valle et al. 2010, §5.3,
Eqs. 19–21).

    M ÿ + C ẏ + K y + B_fᵀ f_D(B_f y) = -M r a_g(t) + f(t)

The friction forces ``f_D`` follow the elasto-slip law
(:func:`femupdate.model.friction.elasto_slip`) evaluated at the current displacement, so the
scheme stays explicit: the linear part is the fused recurrence of
:mod:`femupdate.simulate.central_difference` and the nonlinear part touches only the DOFs the
elements connect. The stable step is set by the stuck stiffness ``K + B_fᵀ diag(k_r) B_f``
(elements with ``f_u > 0``). Friction forces and slip offsets are returned at the samples
(``Response.friction_force``, ``Response.slip``) for hysteresis plots. A linear system (no
friction elements) runs too and gives the central-difference result.
"""

from __future__ import annotations

from collections.abc import Sequence

from femupdate.model.system import System
from femupdate.simulate.central_difference import CentralDifferenceSimulator

__all__ = ["NonlinearSimulator", "prepare_nonlinear"]


class NonlinearSimulator(CentralDifferenceSimulator):
    """Central differences with the system's elasto-slip elements, prepared for one ``h``."""

    def __init__(
        self,
        system: System,
        dt: float,
        outputs: Sequence[int] | None = None,
        substeps: int = 1,
    ) -> None:
        super().__init__(system, dt, outputs, substeps, method="nonlinear")


def prepare_nonlinear(
    system: System,
    dt: float,
    outputs: Sequence[int] | None = None,
    substeps: int = 1,
) -> NonlinearSimulator:
    """Prepare central differences with friction for ``system`` at ``h = dt / substeps``.

    Parameters
    ----------
    system : System
        Linear or with friction elements (``system.friction``).
    dt : float
        Sample interval of the inputs and outputs (s).
    outputs : sequence of int, optional
        DOF indices to output (default: all).
    substeps : int
        Integration steps per sample interval; the input is interpolated linearly.

    Returns
    -------
    NonlinearSimulator
        Call ``.run(ag, force, x0=..., v0=...)``; the response carries ``friction_force`` and
        ``slip`` (n_samples, n_friction) when the system has friction elements.

    Raises
    ------
    SimulationError
        If ``h >= 2/ω_max`` of the stuck system (unstable).
    """
    return NonlinearSimulator(system, dt, outputs, substeps)

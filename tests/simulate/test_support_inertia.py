"""Base excitation of a beam whose consistent mass touches its moving supports."""

from __future__ import annotations

import numpy as np

from femupdate.model.structure import Structure
from femupdate.simulate import simulate


def _cantilever(n_el: int = 4) -> Structure:
    s = Structure(dofs_per_node=2)
    for i in range(n_el + 1):
        s.add_node(f"N{i}", x=0.5 * i)
    for i in range(n_el):
        s.add_beam(f"N{i}", f"N{i + 1}", E=2.1e11, A=1e-3, I=2e-7, rho=7850.0)
    s.fix("N0")
    return s


def test_support_inertia_enters_the_load() -> None:
    system = _cantilever().assemble()
    assert system.seismic is not None
    assert not np.allclose(system.seismic, system.M @ system.r)


def test_integrators_agree_on_absolute_acceleration_with_support_inertia() -> None:
    system = _cantilever().assemble()
    dt = 1e-4  # fine enough for central differences to resolve the 2.7 kHz top mode
    t = np.arange(5000) * dt
    ag = np.sin(2 * np.pi * 5.0 * t) ** 3  # smooth start
    exact = simulate(system, dt, ag=ag, method="exact")
    cd = simulate(system, dt, ag=ag, method="central_difference", substeps=10)
    # The exact method's state derivative omits the direct input term; it must add
    # (r − M⁻¹p)·a_g, which is not 0 here (p ≠ M r): without it the accelerations were 91 % off.
    for quantity in ("displacement", "acceleration"):
        a, b = getattr(exact, quantity), getattr(cd, quantity)
        assert np.abs(a - b).max() < 1e-4 * np.abs(a).max(), quantity

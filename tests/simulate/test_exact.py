"""The exact discretisation's closed form for uncoupled modal coordinates (the reduced path)."""

from __future__ import annotations

import numpy as np
import pytest

from femupdate.model.system import System
from femupdate.simulate.exact import ExactSimulator


@pytest.mark.parametrize("zeta", [0.0, 0.02, 0.7, 3.0], ids=["undamped", "light", "heavy",
                                                            "overdamped"])
def test_uncoupled_modes_in_closed_form_equal_the_eigen_decomposition(zeta: float) -> None:
    # the reduced model's modal system: M = I, K = Ω², C diagonal
    rng = np.random.default_rng(3)
    w = 2 * np.pi * np.sort(rng.uniform(0.5, 40.0, 12))
    zetas = np.full(12, zeta)
    zetas[::3] = 0.05  # light and the given damping side by side
    system = System(M=np.eye(12), C=np.diag(2 * zetas * w), K=np.diag(w**2),
                    r=np.zeros(12), seismic=rng.standard_normal(12))
    ag = rng.standard_normal(800)
    general = ExactSimulator(system, 0.005, np.arange(12))
    closed = ExactSimulator(system, 0.005, np.arange(12), decoupled=True)
    assert general.modal and closed.modal
    assert closed.condition == pytest.approx(general.condition, rel=1e-9)
    a, b = general.run(ag), closed.run(ag)
    for field in ("displacement", "velocity", "acceleration"):
        x, y = getattr(a, field), getattr(b, field)
        assert np.max(np.abs(x - y)) <= 1e-10 * np.max(np.abs(x)), field


def test_critical_damping_has_no_closed_form_and_takes_the_matrix_exponential() -> None:
    w = np.array([3.0, 7.0])
    system = System(M=np.eye(2), C=np.diag(2 * w), K=np.diag(w**2), r=np.zeros(2),
                    seismic=np.ones(2))  # ζ = 1 for both: equal roots
    closed = ExactSimulator(system, 0.01, [0, 1], decoupled=True)
    assert not closed.modal
    ag = np.sin(np.linspace(0, 6, 300))
    ref = ExactSimulator(system, 0.01, [0, 1]).run(ag)
    np.testing.assert_allclose(closed.run(ag).displacement, ref.displacement, rtol=1e-9,
                               atol=1e-14)

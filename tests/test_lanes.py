"""The friction recurrence in SIMD lanes (femupdate.evaluation.lanes, through the module codegen
writes): each lane is the one-lane kernel bit for bit, both are the generic loops of
central._kernel to rounding, for every output quantity; a lane that diverges is flagged alone.
"""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from femupdate.evaluation import central, codegen
from femupdate.evaluation.lanes import LANES, lane_work, to_lane

N_SAMPLES = 400
SUBSTEPS = 4
DT = 0.01
OUTPUTS = np.array([0, 2])
QUANTITIES = {"relative acceleration": central.RELATIVE_ACCELERATION,
              "displacement": central.DISPLACEMENT,
              "absolute acceleration": central.ABSOLUTE_ACCELERATION}


def _shear_building(stiffness: float, slip_force: float) -> dict[str, np.ndarray]:
    """A 3-storey shear building with Rayleigh damping, a friction damper from the first
    floor to the ground and one between the second and third floors, one without force."""
    m = np.diag([1.0, 1.2, 0.8])
    k = stiffness * np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    return {"M": m, "K": k, "C": 0.3 * m + 2e-4 * k, "load": m @ np.ones(3),
            "minv": np.linalg.inv(m), "kr": np.array([0.4 * stiffness, 0.2 * stiffness, 0.0]),
            "fu": np.array([slip_force, 0.5 * slip_force, 1.0]),
            "fi": np.array([0, 1, 2]), "fj": np.array([-1, 2, -1])}


def _record() -> np.ndarray:
    t = np.arange(N_SAMPLES) * DT
    return np.sin(2 * np.pi * 1.3 * t) * np.exp(-0.5 * t) + 0.3 * np.sin(2 * np.pi * 4.1 * t)


def _prepared(system: dict[str, np.ndarray], ag: np.ndarray) -> tuple[central.CentralWork, int]:
    work = central.central_work(3, 3, OUTPUTS.size)
    status, active = central.prepare_central(
        system["M"], system["K"], system["C"], system["load"], system["minv"], system["kr"],
        system["fu"], system["fi"], system["fj"], OUTPUTS, DT / SUBSTEPS, ag[0], work)
    assert status == central.CENTRAL_OK and active == 2
    return work, active


@pytest.fixture(scope="module")
def module() -> ModuleType:
    written = codegen.friction_kernel(3, 3, OUTPUTS.size, SUBSTEPS)
    assert written is not None
    return written


@pytest.fixture(scope="module")
def points() -> list[tuple[central.CentralWork, int]]:
    ag = _record()
    return [_prepared(_shear_building(k, f), ag)
            for k, f in ((40.0, 0.05), (55.0, 0.08), (70.0, 0.02), (90.0, 0.2))]


def _one(module: ModuleType, work: central.CentralWork, ag: np.ndarray, quantity: int
         ) -> tuple[np.ndarray, bool]:
    y = np.empty((OUTPUTS.size, ag.size))
    diverged = module.kernel(ag, SUBSTEPS, DT / SUBSTEPS, quantity, np.ones(OUTPUTS.size),
                             work.modal, work.yf, work.pf, work.limit, work.po, work.eta0, y)
    return y, bool(diverged)


def _lanes(module: ModuleType, works: list[central.CentralWork], ag: np.ndarray,
           quantity: int) -> tuple[np.ndarray, int]:
    lanes = lane_work(3, 3, OUTPUTS.size, ag.size)
    for q, w in enumerate(works):
        to_lane(w, lanes, q)
    mask = module.run_lanes(ag, DT / SUBSTEPS, quantity, np.ones(OUTPUTS.size), lanes)
    return lanes.y.copy(), int(mask)


@pytest.mark.parametrize("quantity", QUANTITIES.values(), ids=list(QUANTITIES))
def test_each_lane_is_the_one_lane_kernel_and_the_generic_loops(
        module: ModuleType, points: list, quantity: int) -> None:
    ag = _record()
    works = [w for w, _ in points]
    assert len(works) == LANES
    y_lanes, mask = _lanes(module, works, ag, quantity)
    assert mask == 0
    for q, (work, active) in enumerate(points):
        y_one, diverged = _one(module, work, ag, quantity)
        assert not diverged
        assert np.array_equal(y_lanes[q], y_one)  # bit for bit
        y_loops = np.empty_like(y_one)
        assert not central.run_central(ag, SUBSTEPS, DT / SUBSTEPS, quantity,
                                       np.ones(OUTPUTS.size), active, work, y_loops)
        # The loops sum in another order; stick-slip carries the rounding along the record
        # (3e-12 of the largest output measured over these 400 samples).
        assert np.max(np.abs(y_one - y_loops)) <= 1e-10 * np.max(np.abs(y_loops))


def test_the_dampers_slip(module: ModuleType, points: list) -> None:
    # Else the tests above would not see the friction law at all.
    ag = _record()
    work = points[0][0]
    stuck = central.central_work(3, 3, OUTPUTS.size)
    for field in central.CentralWork._fields:
        np.copyto(getattr(stuck, field), getattr(work, field))
    stuck.limit[:] = np.inf  # the same dampers, never slipping
    sliding, _ = _one(module, work, ag, central.DISPLACEMENT)
    linear, _ = _one(module, stuck, ag, central.DISPLACEMENT)
    assert np.max(np.abs(sliding - linear)) > 0.05 * np.max(np.abs(linear))


def test_a_diverging_lane_is_flagged_alone(module: ModuleType, points: list) -> None:
    ag = _record()
    works = [w for w, _ in points]
    y_ok, _ = _lanes(module, works, ag, central.RELATIVE_ACCELERATION)
    unstable = central.central_work(3, 3, OUTPUTS.size)
    for field in central.CentralWork._fields:
        np.copyto(getattr(unstable, field), getattr(works[2], field))
    unstable.modal[0] *= 1.5  # a mode that grows at every step
    y, mask = _lanes(module, [works[0], works[1], unstable, works[3]], ag,
                     central.RELATIVE_ACCELERATION)
    assert mask == 1 << 2
    for q in (0, 1, 3):
        assert np.array_equal(y[q], y_ok[q])
    assert _one(module, unstable, ag, central.RELATIVE_ACCELERATION)[1]
    _, every = _lanes(module, [unstable] * LANES, ag, central.RELATIVE_ACCELERATION)
    assert every == (1 << LANES) - 1


def test_changed_sources_get_a_module_of_their_own(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    # numba checks a cached function against its own file only: a module compiled against
    # other femupdate sources must not be the one loaded.
    monkeypatch.setenv(codegen.KERNEL_DIR_ENV, str(tmp_path))
    files = []
    for fingerprint in ("before", "after"):
        monkeypatch.setattr(codegen, "_LOADED", {})
        monkeypatch.setattr(codegen, "_sources_fingerprint", lambda f=fingerprint: f)
        written = codegen.friction_kernel(2, 1, 1, SUBSTEPS)
        assert written is not None
        files.append(Path(written.__file__))
    assert files[0] != files[1] and all(f.parent == tmp_path and f.exists() for f in files)

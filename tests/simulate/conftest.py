"""Fixtures for the integrator tests: the 10-DOF bridge-like system and a smooth base motion."""

from __future__ import annotations

import numpy as np
import pytest
from bridge_like import bridge_like, smooth_base_motion

from femupdate.model.system import System


@pytest.fixture(scope="session")
def bridge() -> System:
    return bridge_like()


@pytest.fixture(scope="session")
def base_motion() -> np.ndarray:
    """4,768 samples at 1035 Hz (the paper's record length), band-limited to 40 Hz."""
    return smooth_base_motion(np.random.default_rng(20100601), 4768)

"""A 10-DOF bridge-like test system built directly as matrices (no Structure needed).

A continuous deck of 4 Euler–Bernoulli beam elements (consistent mass, cubic shape functions),
5 nodes with (transverse translation, rotation): DOFs 0..9, pier translations at 2, 4, 6,
abutments at 0 and 8. Abutment and pier springs to ground, added masses lumped at the nodes,
dashpots at the abutment rotations (c1) and at the piers (c2–c4): damping is not proportional.
The first frequencies are near the paper's specimen (11, 13, 25, 28 Hz) and the stiff
abutment springs make 2/ω_max = 3.0e-4 s, below the 1035 Hz sample interval, like the real bridge.
"""

from __future__ import annotations

import numpy as np

from femupdate.model.system import FrictionElements, System

DT = 1.0 / 1035.0
PIER_DOFS = (2, 4, 6)


def beam_element(ei: float, rho_a: float, length: float) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and consistent mass of a 2-node Euler–Bernoulli beam (v1, θ1, v2, θ2)."""
    L = length
    k = (ei / L**3) * np.array(
        [
            [12, 6 * L, -12, 6 * L],
            [6 * L, 4 * L**2, -6 * L, 2 * L**2],
            [-12, -6 * L, 12, -6 * L],
            [6 * L, 2 * L**2, -6 * L, 4 * L**2],
        ]
    )
    m = (rho_a * L / 420.0) * np.array(
        [
            [156, 22 * L, 54, -13 * L],
            [22 * L, 4 * L**2, 13 * L, -3 * L**2],
            [54, 13 * L, 156, -22 * L],
            [-13 * L, -3 * L**2, -22 * L, 4 * L**2],
        ]
    )
    return k, m


def bridge_like(
    *,
    kp: tuple[float, float, float, float] = (1e9, 2e5, 1.5e6, 3e5),
    c: tuple[float, float, float, float] = (5.0, 150.0, 1500.0, 150.0),
    friction: bool = False,
    k_r: tuple[float, float, float, float] = (2e3, 1e5, 5e5, 1e5),
    f_u: tuple[float, float, float, float] = (2.0, 20.0, 100.0, 20.0),
) -> System:
    """The 10-DOF system; with ``friction=True`` the dashpots become elasto-slip elements.

    ``kp``: abutment spring (both ends), piers P1–P3; ``c``: rotational dashpot at both
    abutments, dashpots at the piers; ``k_r, f_u``: rotational element at each abutment (two
    elements with the first values) and elements at the piers.
    """
    n = 10
    K = np.zeros((n, n))
    M = np.zeros((n, n))
    ei, rho_a, span = 1.0e4, 40.0, 1.0
    ke, me = beam_element(ei, rho_a, span)
    for e in range(4):
        sl = slice(2 * e, 2 * e + 4)
        K[sl, sl] += ke
        M[sl, sl] += me
    for d in (0, 2, 4, 6, 8):
        M[d, d] += 20.0  # added masses bolted to the deck
    K[0, 0] += kp[0]
    K[8, 8] += kp[0]
    for d, k in zip(PIER_DOFS, kp[1:], strict=True):
        K[d, d] += k
    r = np.zeros(n)
    r[0::2] = 1.0
    C = np.zeros((n, n))
    fr = None
    if friction:
        fr = FrictionElements(
            dof_i=np.array([1, 9, 2, 4, 6], dtype=np.int64),
            dof_j=np.full(5, -1, dtype=np.int64),
            k_r=np.array([k_r[0], k_r[0], *k_r[1:]], dtype=float),
            f_u=np.array([f_u[0], f_u[0], *f_u[1:]], dtype=float),
        )
    else:
        C[1, 1] += c[0]
        C[9, 9] += c[0]
        for d, cc in zip(PIER_DOFS, c[1:], strict=True):
            C[d, d] += cc
    return System(M=M, C=C, K=K, r=r, friction=fr)


def smooth_base_motion(rng: np.random.Generator, n_samples: int, dt: float = DT) -> np.ndarray:
    """A random, smooth (band-limited to about 40 Hz), tapered base acceleration in m/s²."""
    from scipy.signal import butter, sosfiltfilt

    white = rng.standard_normal(n_samples + 400)
    sos = butter(4, 40.0, fs=1.0 / dt, output="sos")
    ag = sosfiltfilt(sos, white)[200:-200]
    taper = np.ones(n_samples)
    ramp = min(100, n_samples // 4)
    taper[:ramp] = np.sin(0.5 * np.pi * np.arange(ramp) / ramp) ** 2
    taper[-ramp:] = taper[:ramp][::-1]
    ag = ag * taper
    return 2.0 * ag / np.max(np.abs(ag))

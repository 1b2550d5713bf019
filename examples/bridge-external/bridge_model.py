"""The paper's bridge as a plain Python function (numpy and scipy only).

What an engineer with their own code would hand to femupdate: ``predict(params, ag, dt)`` returns
the absolute accelerations of the deck over the three piers, ``frequencies(params)`` the natural
frequencies. Independent of femupdate's model code: the Timoshenko beam matrices are integrated
numerically from the interdependent shape functions, the response is a state-space model
simulated by ``scipy.signal.lsim`` (input linear between samples, like femupdate's ``exact``).

The structure (femupdate.paper.problems.bridge): a steel deck of four 2.8 m spans (80 × 80 × 5 mm
square tube, κ = 0.44, ν = 0.3, ρ = 7850 kg/m³) on nodes A1, P1, P2, P3, A2, each with 48 kg
and the DOFs (uy, rz); springs kp1 (both abutments), kp2–kp4 (piers) on uy; rotational dampers
c1 at the abutments and dampers c2–c4 on the piers' uy.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from scipy import linalg
from scipy import signal as sps

SPAN = 2.8
WIDTH, WALL = 0.08, 0.005
AREA = WIDTH**2 - (WIDTH - 2 * WALL) ** 2
INERTIA = (WIDTH**4 - (WIDTH - 2 * WALL) ** 4) / 12.0
DENSITY, POISSON, KAPPA = 7850.0, 0.3, 0.44
NODE_MASS = 48.0
N_NODES = 5
OUTPUT_NODES = (1, 2, 3)  # P1, P2, P3
N_DOF = 2 * N_NODES  # (v, ψ) per node

# Five-point Gauss–Legendre rule on [0, 1]: exact for the degree-6 products of cubic shapes.
_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(5)
_XI, _WEIGHT = (_GAUSS_X + 1.0) / 2.0, _GAUSS_W / 2.0


def shape_functions(xi: np.ndarray, length: float, phi: float
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Interdependent Timoshenko interpolation at ``xi`` (0..1) for DOFs (v1, ψ1, v2, ψ2).

    Returns the deflection shapes N, their x-derivatives, the rotation shapes and theirs, each
    (len(xi), 4). Φ = 12 EI / (κ G A L²).
    """
    s, L = 1.0 / (1.0 + phi), length
    x1, x2, x3 = xi, xi**2, xi**3
    n = s * np.column_stack([2 * x3 - 3 * x2 - phi * x1 + 1 + phi,
                             L * (x3 - (2 + phi / 2) * x2 + (1 + phi / 2) * x1),
                             -2 * x3 + 3 * x2 + phi * x1,
                             L * (x3 - (1 - phi / 2) * x2 - phi / 2 * x1)])
    dn = s / L * np.column_stack([6 * x2 - 6 * x1 - phi,
                                  L * (3 * x2 - (4 + phi) * x1 + 1 + phi / 2),
                                  -6 * x2 + 6 * x1 + phi,
                                  L * (3 * x2 - (2 - phi) * x1 - phi / 2)])
    g = 6 * s / L * (x2 - x1)
    psi = np.column_stack([g, s * (3 * x2 - (4 + phi) * x1 + 1 + phi), -g,
                           s * (3 * x2 - (2 - phi) * x1)])
    dg = 6 * s / L**2 * (2 * x1 - 1)
    dpsi = np.column_stack([dg, s / L * (6 * x1 - 4 - phi), -dg, s / L * (6 * x1 - 2 + phi)])
    return n, dn, psi, dpsi


def beam_matrices(E: float, length: float = SPAN) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and consistent mass (4 × 4) of one deck span, by Gauss quadrature."""
    G = E / (2.0 * (1.0 + POISSON))
    phi = 12.0 * E * INERTIA / (KAPPA * G * AREA * length**2)
    n, dn, psi, dpsi = shape_functions(_XI, length, phi)
    w = _WEIGHT * length
    shear = dn - psi
    k = E * INERTIA * (dpsi.T * w) @ dpsi + KAPPA * G * AREA * (shear.T * w) @ shear
    m = DENSITY * AREA * (n.T * w) @ n + DENSITY * INERTIA * (psi.T * w) @ psi
    return k, m


def matrices(params: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """M, C, K of the ten DOFs (v, ψ of A1, P1, P2, P3, A2)."""
    k_beam, m_beam = beam_matrices(params["E"])
    M, C, K = (np.zeros((N_DOF, N_DOF)) for _ in range(3))
    for span in range(N_NODES - 1):
        dofs = np.arange(2 * span, 2 * span + 4)
        K[np.ix_(dofs, dofs)] += k_beam
        M[np.ix_(dofs, dofs)] += m_beam
    for node in range(N_NODES):
        M[2 * node, 2 * node] += NODE_MASS
    for node, name in enumerate(("kp1", "kp2", "kp3", "kp4", "kp1")):
        K[2 * node, 2 * node] += params[name]
    C[1, 1] += params["c1"]
    C[2 * (N_NODES - 1) + 1, 2 * (N_NODES - 1) + 1] += params["c1"]
    for node, name in zip(OUTPUT_NODES, ("c2", "c3", "c4"), strict=True):
        C[2 * node, 2 * node] += params[name]
    return M, C, K


def predict(params: Mapping[str, float], ag: np.ndarray, dt: float) -> np.ndarray:
    """Absolute accelerations (m/s²) of P1, P2, P3 under base acceleration ``ag``, from rest.

    State x = (u, u̇) relative to the base; M ü + C u̇ + K u = −M r a_g, with r = 1 on every v;
    the absolute acceleration of a v DOF is ü + a_g = −M⁻¹(K u + C u̇) (the a_g terms cancel).
    """
    M, C, K = matrices(params)
    minv_k, minv_c = linalg.solve(M, K), linalg.solve(M, C)
    r = np.zeros(N_DOF)
    r[0::2] = 1.0
    a = np.block([[np.zeros((N_DOF, N_DOF)), np.eye(N_DOF)], [-minv_k, -minv_c]])
    b = np.concatenate([np.zeros(N_DOF), -r])[:, None]
    rows = [2 * node for node in OUTPUT_NODES]
    c = np.hstack([-minv_k[rows], -minv_c[rows]])
    d = np.zeros((len(rows), 1))
    t = np.arange(len(ag)) * dt
    _, y, _ = sps.lsim((a, b, c, d), ag, t, interp=True)
    return np.asarray(y).reshape(len(ag), len(rows))


def frequencies(params: Mapping[str, float]) -> np.ndarray:
    """The six lowest undamped natural frequencies (Hz)."""
    M, _, K = matrices(params)
    w2 = linalg.eigh(K, M, eigvals_only=True)
    return np.sqrt(np.clip(w2[:6], 0.0, None)) / (2.0 * np.pi)

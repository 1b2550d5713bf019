"""The assembled equations of motion that every integrator consumes.

``M ÿ + C ẏ + K y + B_fᵀ f_D(B_f y) = P u(t)``, with ``y`` relative to the base.
For uniform base excitation ``a_g(t)`` the load is ``P = -M r`` and ``u = a_g``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class FrictionElements:
    """Elasto-slip (Jenkins) elements: a spring ``k_r`` in series with a Coulomb slider ``f_u``.

    Element ``e`` deforms by ``y[dof_i[e]] - y[dof_j[e]]``; ``dof_j[e] == -1`` means ground.

    Attributes
    ----------
    dof_i, dof_j : ndarray of int64, shape (n_f,)
        Free-DOF indices (``dof_j`` may be -1 for ground).
    k_r : ndarray of float64, shape (n_f,)
        Stiffness of the spring in series with the slider (stuck stiffness).
    f_u : ndarray of float64, shape (n_f,)
        Slip force.
    """

    dof_i: np.ndarray
    dof_j: np.ndarray
    k_r: np.ndarray
    f_u: np.ndarray

    @property
    def count(self) -> int:
        return int(self.k_r.shape[0])

    def connectivity(self, n_dof: int) -> np.ndarray:
        """Matrix ``B_f`` (n_f × n_dof) mapping DOF displacements to element deformations."""
        b = np.zeros((self.count, n_dof))
        rows = np.arange(self.count)
        b[rows, self.dof_i] = 1.0
        ground = self.dof_j < 0
        b[rows[~ground], self.dof_j[~ground]] = -1.0
        return b

    def stuck_stiffness(self, n_dof: int) -> np.ndarray:
        """Stiffness the elements add while none slips: ``B_fᵀ diag(k_r) B_f``."""
        b = self.connectivity(n_dof)
        return b.T @ (self.k_r[:, None] * b)


@dataclass(frozen=True)
class System:
    """Mass, damping and stiffness of the free DOFs, and how the base motion loads them.

    Attributes
    ----------
    M, C, K : ndarray, shape (n, n)
        Symmetric mass (positive definite), damping and stiffness matrices of the free DOFs.
    r : ndarray, shape (n,)
        Influence vector: the displacement of each free DOF for a unit rigid base displacement.
    friction : FrictionElements or None
        Elasto-slip elements, or None for a linear system.
    dof_labels : tuple of str
        A label per free DOF (``"P1.uy"``), for messages and outputs.
    seismic : ndarray, shape (n,), optional
        The vector ``p`` of the base-excitation load ``-p a_g``. Default ``M r``; it differs
        when consistent beam mass couples fixed (moving) supports to free DOFs:
        ``p = M_ff r_f + M_fc r_c``.
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    r: np.ndarray
    friction: FrictionElements | None = None
    dof_labels: tuple[str, ...] = field(default=())
    seismic: np.ndarray | None = None

    @property
    def seismic_load(self) -> np.ndarray:
        """``p`` in ``-p a_g(t)``: ``seismic`` if given, else ``M r``."""
        return self.M @ self.r if self.seismic is None else self.seismic

    @property
    def n_dof(self) -> int:
        return int(self.M.shape[0])

    @property
    def is_linear(self) -> bool:
        return self.friction is None or self.friction.count == 0

"""The assembled equations of motion that every integrator consumes.

``M ÿ + C ẏ + K y + B_fᵀ f_D(B_f y) + B_hᵀ f_H(B_h y) = P u(t)``, with ``y`` relative to the base
(``f_D`` the elasto-slip friction forces, ``f_H`` the Bouc–Wen forces).
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


def _connectivity(dof_i: np.ndarray, dof_j: np.ndarray, n_dof: int) -> np.ndarray:
    """Rows ``e_i - e_j`` (``-e_j`` left out where ``dof_j`` is -1, the ground)."""
    count = int(dof_i.shape[0])
    b = np.zeros((count, n_dof))
    rows = np.arange(count)
    b[rows, dof_i] = 1.0
    ground = dof_j < 0
    b[rows[~ground], dof_j[~ground]] = -1.0
    return b


@dataclass(frozen=True)
class BoucWenElements:
    """Bouc–Wen hysteretic elements (:mod:`femupdate.model.hysteresis`).

    Element ``e`` deforms by ``y[dof_i[e]] - y[dof_j[e]]`` (``dof_j[e] == -1``: ground) and
    carries ``α k y + (1 − α) k z``.

    Attributes
    ----------
    dof_i, dof_j : ndarray of int64, shape (n_h,)
        Free-DOF indices (``dof_j`` may be -1 for ground).
    table : ndarray of float64, shape (n_h, 9)
        ``k, alpha, A, beta, gamma, n, delta_a, delta_nu, delta_eta`` per element
        (``hysteresis.BOUC_WEN_PARAMETERS``); a table of the first six columns is completed
        with degradation rates 0.
    names : tuple of str
        Element names, for messages.
    """

    dof_i: np.ndarray
    dof_j: np.ndarray
    table: np.ndarray
    names: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        table = np.asarray(self.table, dtype=float)
        if table.ndim == 2 and table.shape[1] == 6:  # no degradation
            object.__setattr__(self, "table", np.hstack([table, np.zeros((table.shape[0], 3))]))

    @property
    def count(self) -> int:
        return int(self.table.shape[0])

    def connectivity(self, n_dof: int) -> np.ndarray:
        """Matrix ``B_h`` (n_h × n_dof) mapping DOF displacements to element deformations."""
        return _connectivity(self.dof_i, self.dof_j, n_dof)

    def _stiffness(self, n_dof: int, k: np.ndarray) -> np.ndarray:
        b = self.connectivity(n_dof)
        return b.T @ (k[:, None] * b)

    def initial_stiffness(self, n_dof: int) -> np.ndarray:
        """Stiffness the elements add at ``z = 0``: ``B_hᵀ diag(k (α + (1 − α) A)) B_h``."""
        from femupdate.model.hysteresis import bouc_wen_initial_tangent

        t = self.table
        return self._stiffness(n_dof, bouc_wen_initial_tangent(t[:, 0], t[:, 1], t[:, 2]))

    def max_stiffness(self, n_dof: int) -> np.ndarray:
        """Stiffness with every element at its largest tangent (the stable step's)."""
        from femupdate.model.hysteresis import bouc_wen_max_tangent

        t = self.table
        return self._stiffness(n_dof, bouc_wen_max_tangent(*t[:, :5].T))


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
        Elasto-slip elements, or None.
    bouc_wen : BoucWenElements or None
        Bouc–Wen elements, or None (a system with neither is linear).
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
    bouc_wen: BoucWenElements | None = None

    @property
    def seismic_load(self) -> np.ndarray:
        """``p`` in ``-p a_g(t)``: ``seismic`` if given, else ``M r``."""
        return self.M @ self.r if self.seismic is None else self.seismic

    @property
    def n_dof(self) -> int:
        return int(self.M.shape[0])

    @property
    def is_linear(self) -> bool:
        return self.n_friction == 0 and self.n_bouc_wen == 0

    @property
    def n_friction(self) -> int:
        return 0 if self.friction is None else self.friction.count

    @property
    def n_bouc_wen(self) -> int:
        return 0 if self.bouc_wen is None else self.bouc_wen.count

    def nonlinear_elements(self) -> str:
        """The nonlinear elements in words, e.g. ``"2 friction elements"``, for messages."""
        parts = [f"{self.n_friction} friction elements"] if self.n_friction else []
        parts += [f"{self.n_bouc_wen} Bouc–Wen elements"] if self.n_bouc_wen else []
        return " and ".join(parts) or "no nonlinear elements"

"""Large nonlinear models on a reduced basis: Craig–Bampton, the nonlinear DOFs kept physical.

Friction and Bouc–Wen elements act on a few DOFs of a large model; the rest is linear. The
Craig–Bampton reduction (Craig & Bampton 1968) keeps those DOFs, and the sensors', as they are
(the *boundary* ``b``) and represents the others (the *interior* ``i``) by

- the **constraint modes** ``Ψ = −K_ii⁻¹ K_ib``: the interior's static response to each
  boundary DOF moved alone (exact for any quasi-static motion of the boundary), and
- the **fixed-interface modes** ``Φ_i`` of ``(K_ii, M_ii)`` up to a cut-off above the fitted
  band (the interior's own dynamics),

``u = T q``, ``T = [[I, 0], [Ψ, Φ_i]]``, ``q = (u_b, η)``. The reduced matrices ``Tᵀ M T``,
``Tᵀ C T``, ``Tᵀ K T`` and load ``Tᵀ p`` are small and dense, and the nonlinear elements still
connect physical DOFs (now the first ones), so the reduced model is a :class:`System` that the
nonlinear integrator takes unchanged. The boundary DOFs' displacement and acceleration are
coordinates of it: the sensors read them directly. What is left out is the interior's dynamics
above the cut-off; :func:`femupdate.problem.reduced_path.trial_truncation` measures it against
the full model.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from femupdate.errors import ConfigError, ModelError
from femupdate.model.sparse import lowest_modes, massless_dofs
from femupdate.model.system import BoucWenElements, FrictionElements, System

__all__ = ["craig_bampton", "nonlinear_dofs"]


def nonlinear_dofs(system: System) -> np.ndarray:
    """The DOFs the friction and Bouc–Wen elements connect (ground, -1, left out)."""
    ends = []
    for elements in (system.friction, system.bouc_wen):
        if elements is not None:
            ends += [elements.dof_i, elements.dof_j]
    if not ends:
        return np.zeros(0, dtype=np.int64)
    dofs = np.concatenate(ends)
    return np.unique(dofs[dofs >= 0])


def _remap(dofs: np.ndarray, position: np.ndarray) -> np.ndarray:
    return np.where(dofs >= 0, position[np.maximum(dofs, 0)], -1).astype(np.int64)


def craig_bampton(system: System, boundary: Sequence[int] | np.ndarray, *,
                  cutoff_hz: float | None = None, n_modes: int | None = None
                  ) -> tuple[System, np.ndarray]:
    """The Craig–Bampton reduction of ``system`` (module docstring).

    Parameters
    ----------
    system : System
        ``M``, ``C``, ``K`` dense or ``scipy.sparse``; friction and Bouc–Wen elements on
        ``boundary`` DOFs only.
    boundary : sequence of int
        DOFs kept physical: the nonlinear elements' ends (:func:`nonlinear_dofs`) and the
        sensors; sorted and made unique here.
    cutoff_hz, n_modes : optional
        The interior's fixed-interface modes up to this frequency, or this many (exactly one).

    Returns
    -------
    (System, ndarray)
        The reduced system (boundary DOFs first, in ascending order, then the modal
        coordinates; ``dof_labels`` of the boundary kept) and the position of each original
        DOF among the reduced ones (-1 for an interior DOF).

    Raises
    ------
    ConfigError
        A boundary DOF out of range, or a nonlinear element with an end in the interior.
    ModelError
        A singular interior stiffness (the interior is a mechanism once the boundary is held).
    """
    n = system.n_dof
    b = np.unique(np.asarray(boundary, dtype=np.int64))
    if b.size == 0 or b[0] < 0 or b[-1] >= n:
        raise ConfigError(f"craig_bampton: boundary DOFs must be 0 to {n - 1}, at least one")
    missing = np.setdiff1d(nonlinear_dofs(system), b)
    if missing.size:
        labels = [system.dof_labels[i] if i < len(system.dof_labels) else f"dof {i}"
                  for i in missing[:5]]
        raise ConfigError(f"craig_bampton: nonlinear elements act on interior DOFs "
                          f"{', '.join(labels)}; put them in the boundary")
    interior = np.setdiff1d(np.arange(n), b)
    K, M, C = (sp.csr_matrix(a) for a in (system.K, system.M, system.C))
    position = np.full(n, -1, dtype=np.int64)
    position[b] = np.arange(b.size)
    if interior.size == 0:
        T = sp.identity(n, format="csr")
    else:
        k_ii = sp.csc_matrix(K[interior][:, interior])
        try:
            lu = spla.splu(k_ii)
        except RuntimeError as err:
            raise ModelError(f"craig_bampton: the interior stiffness is singular ({err}): "
                             "held at the boundary DOFs the rest is a mechanism") from None
        psi = -lu.solve(K[interior][:, b].toarray())
        m_ii = M[interior][:, interior]
        if massless_dofs(m_ii).size == interior.size:  # a static interior: no modes
            phi = np.zeros((interior.size, 0))
        else:
            phi = lowest_modes(k_ii, m_ii, cutoff_hz=cutoff_hz, n_modes=n_modes).shapes
        t = np.zeros((n, b.size + phi.shape[1]))
        t[b, np.arange(b.size)] = 1.0
        t[interior, :b.size] = psi
        t[interior, b.size:] = phi
        T = sp.csr_matrix(t)

    def project(a: sp.csr_matrix) -> np.ndarray:
        out = np.asarray((T.T @ (a @ T)).todense())
        return 0.5 * (out + out.T)

    r = np.zeros(T.shape[1])
    r[:b.size] = np.asarray(system.r, dtype=float)[b]
    friction = bouc_wen = None
    if system.friction is not None:
        f = system.friction
        friction = FrictionElements(_remap(f.dof_i, position), _remap(f.dof_j, position),
                                    f.k_r, f.f_u)
    if system.bouc_wen is not None:
        h = system.bouc_wen
        bouc_wen = BoucWenElements(_remap(h.dof_i, position), _remap(h.dof_j, position),
                                   h.table, h.names)
    labels = tuple(system.dof_labels[i] for i in b) if system.dof_labels else ()
    labels += tuple(f"mode {j + 1}" for j in range(T.shape[1] - b.size)) if labels else ()
    reduced = System(M=project(M), C=project(C), K=project(K), r=r, friction=friction,
                     dof_labels=labels,
                     seismic=np.asarray(T.T @ np.asarray(system.seismic_load, dtype=float)),
                     bouc_wen=bouc_wen)
    return reduced, position

"""The initial stiffness of the nonlinear links (friction and Bouc–Wen elements) as a matrix.

A zero-length link between free DOFs ``i`` and ``j`` (``j = -1``: the ground) of stiffness
``k`` adds ``k`` at ``(i, i)`` and ``(j, j)`` and ``-k`` at ``(i, j)`` and ``(j, i)``. The
nonlinear elements are not in ``System.K`` (the integrators add their forces), but three rules
count them by their initial tangent, as OpenSees's ``rayleigh`` with ``betaKinit`` and its
initial-stiffness eigenvalue analysis do: the check that a model is not a mechanism, the
stiffness-proportional part of Rayleigh damping, and the modes of ``femupdate modes``. The
initial tangent is the friction element's stuck stiffness ``k_r`` and the Bouc–Wen element's
``k (α + (1 − α) A)`` at ``z = 0`` (``k`` for ``A = 1``).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from femupdate.model.system import BoucWenElements, FrictionElements

__all__ = ["initial_link_stiffness", "link_stiffness"]


def link_stiffness(dof_i: np.ndarray, dof_j: np.ndarray, k: np.ndarray, n: int, *,
                   sparse: bool = False) -> np.ndarray | sp.csr_matrix:
    """``Bᵀ diag(k) B`` of zero-length links, ``B`` their rows ``e_i − e_j``.

    Parameters
    ----------
    dof_i, dof_j : ndarray of int, shape (n_links,)
        Free-DOF indices of the two ends; ``-1`` for the ground (either end).
    k : ndarray, shape (n_links,)
        Stiffness of each link.
    n : int
        Number of free DOFs.
    sparse : bool
        Return a CSR matrix (large models) instead of a dense one.
    """
    i = np.asarray(dof_i, dtype=np.int64)
    j = np.asarray(dof_j, dtype=np.int64)
    k = np.asarray(k, dtype=float)
    both = (i >= 0) & (j >= 0)
    rows = np.concatenate([i, j, i[both], j[both]])
    cols = np.concatenate([i, j, j[both], i[both]])
    vals = np.concatenate([k, k, -k[both], -k[both]])
    keep = (rows >= 0) & (cols >= 0)  # an end at the ground adds nothing at its own row
    rows, cols, vals = rows[keep], cols[keep], vals[keep]
    if sparse:
        return sp.csr_matrix(sp.coo_matrix((vals, (rows, cols)), shape=(n, n)))
    out = np.zeros((n, n))
    np.add.at(out, (rows, cols), vals)
    return out


def initial_link_stiffness(friction: FrictionElements | None, bouc_wen: BoucWenElements | None,
                           n: int, *, sparse: bool = False) -> np.ndarray | sp.csr_matrix:
    """The stiffness the friction (stuck, ``k_r``) and Bouc–Wen (``k (α + (1 − α) A)``)
    elements add at rest; zeros without any (dense, or CSR with ``sparse``)."""
    ends_i, ends_j, ks = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)], [np.zeros(0)]
    if friction is not None:
        ends_i.append(friction.dof_i)
        ends_j.append(friction.dof_j)
        ks.append(friction.k_r)
    if bouc_wen is not None:
        from femupdate.model.hysteresis import bouc_wen_initial_tangent  # numba: when needed

        t = bouc_wen.table
        ends_i.append(bouc_wen.dof_i)
        ends_j.append(bouc_wen.dof_j)
        ks.append(np.asarray(bouc_wen_initial_tangent(t[:, 0], t[:, 1], t[:, 2]), dtype=float))
    return link_stiffness(np.concatenate(ends_i), np.concatenate(ends_j), np.concatenate(ks),
                          n, sparse=sparse)

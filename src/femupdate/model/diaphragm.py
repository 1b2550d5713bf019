"""Rigid floor diaphragms of 3-D frames: the DOFs a floor slab ties together, eliminated.

A floor slab is far stiffer in its own (horizontal) plane than the frame's beams: building
models make it rigid there. Every node of the floor then follows the floor's master node in the
three in-plane DOFs (Wilson 2002, §8)::

    ux_i = ux_m − (y_i − y_m) rz_m,    uy_i = uy_m + (x_i − x_m) rz_m,    rz_i = rz_m,

and the follower DOFs are eliminated by the transformation ``u = T q`` (``q`` the independent
DOFs): ``K_q = Tᵀ K T``, ``M_q = Tᵀ M T``, ``C_q = Tᵀ C T``, loads ``Tᵀ p``. The floor's lumped
masses are carried to the master by the same ``T`` (the translation mass and its moment of
inertia about the master). The vertical translation and the two rocking rotations of each node
stay free: the slab does not stiffen the frame out of its plane.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from femupdate.errors import ModelError

__all__ = ["Diaphragms", "diaphragm_constraint"]

#: Local indices of ux, uy and rz among a 3-D frame node's six DOFs (ux, uy, uz, rx, ry, rz).
_UX, _UY, _RZ = 0, 1, 5
_DPN = 6


@dataclass(frozen=True)
class Diaphragms:
    """The elimination of the DOFs that follow a diaphragm's master.

    Attributes
    ----------
    T : scipy.sparse.csr_matrix, shape (n_free, n)
        Free DOFs (the structure's numbering without diaphragms) from the ``n`` independent ones.
    kept : ndarray of int, shape (n,)
        The free-DOF index of each independent DOF.
    index : ndarray of int, shape (n_free,)
        The independent index of each free DOF, -1 for a follower.
    labels : tuple of str
        The independent DOFs' labels.
    followed : dict
        Free-DOF index of each follower → the name of its master node (for messages).
    """

    T: sp.csr_matrix
    kept: np.ndarray
    index: np.ndarray
    labels: tuple[str, ...]
    followed: dict[int, str]

    @property
    def n(self) -> int:
        return int(self.kept.size)

    def transform(self, matrix: np.ndarray | sp.spmatrix) -> np.ndarray | sp.spmatrix:
        """``Tᵀ A T``, sparse in, sparse (CSR) out; dense in, dense out."""
        if sp.issparse(matrix):
            return (self.T.T @ matrix @ self.T).tocsr()
        dense = self.T.toarray()
        return dense.T @ np.asarray(matrix) @ dense

    def reindex(self, dofs: np.ndarray, what: str) -> np.ndarray:
        """Free-DOF indices (-1: ground) of element ends → independent indices.

        Raises ``ModelError`` for an end on a follower DOF: its element would act on a
        combination of the master's DOFs, which the nonlinear elements do not take.
        """
        dofs = np.asarray(dofs, dtype=np.int64)
        out = np.where(dofs >= 0, self.index[np.maximum(dofs, 0)], -1)
        bad = (dofs >= 0) & (out < 0)
        if np.any(bad):
            i = int(dofs[np.flatnonzero(bad)[0]])
            raise ModelError(
                f"{what} acts on a DOF that follows the rigid diaphragm of "
                f"{self.followed[i]!r}; connect it to the master node (or leave the node out "
                "of the diaphragm)")
        return out


def diaphragm_constraint(
    followers: Mapping[int, int],
    xyz: Sequence[tuple[float, float, float]],
    free: np.ndarray,
    node_names: Sequence[str],
    labels: Sequence[str],
) -> Diaphragms:
    """The :class:`Diaphragms` of a 3-D frame (6 DOFs per node).

    Parameters
    ----------
    followers : mapping
        Node index of each follower → node index of its master.
    xyz : sequence of (x, y, z)
        Node coordinates.
    free : ndarray of int, shape (n_global,)
        Free-DOF index per global DOF, -1 where fixed.
    node_names, labels : sequence of str
        Node names; free-DOF labels.

    Raises
    ------
    ModelError
        When a follower's in-plane DOF is fixed while its master's is free (or the reverse):
        the support would contradict the slab.
    """
    rows: list[int] = []
    cols: list[int] = []
    vals: list[float] = []
    follows: dict[int, str] = {}
    for s, m in followers.items():
        for j in (_UX, _UY, _RZ):
            fs, fm = free[s * _DPN + j], free[m * _DPN + j]
            if (fs < 0) != (fm < 0):
                which = node_names[s] if fs < 0 else node_names[m]
                dof = {_UX: "ux", _UY: "uy", _RZ: "rz"}[j]
                raise ModelError(
                    f"diaphragm of {node_names[m]!r}: {which}.{dof} is fixed while the slab "
                    "moves it with the other nodes; fix that DOF of every node of the floor "
                    "(master included) or of none")
            if fs >= 0:
                follows[int(fs)] = node_names[m]
    n_free = len(labels)
    index = np.full(n_free, -1, dtype=np.int64)
    kept = np.array([i for i in range(n_free) if i not in follows], dtype=np.int64)
    index[kept] = np.arange(kept.size)
    rows.extend(kept.tolist())
    cols.extend(range(kept.size))
    vals.extend([1.0] * kept.size)
    for s, m in followers.items():
        dx = xyz[s][0] - xyz[m][0]
        dy = xyz[s][1] - xyz[m][1]
        for j, terms in ((_UX, ((_UX, 1.0), (_RZ, -dy))), (_UY, ((_UY, 1.0), (_RZ, dx))),
                         (_RZ, ((_RZ, 1.0),))):
            row = int(free[s * _DPN + j])
            if row < 0:  # fixed with its master's (checked above)
                continue
            for jm, coefficient in terms:
                col = int(free[m * _DPN + jm])
                if col >= 0 and coefficient != 0.0:
                    rows.append(row)
                    cols.append(int(index[col]))
                    vals.append(coefficient)
    T = sp.csr_matrix((vals, (rows, cols)), shape=(n_free, kept.size))
    return Diaphragms(T=T, kept=kept, index=index,
                      labels=tuple(labels[i] for i in kept), followed=follows)

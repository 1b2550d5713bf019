"""Large models: sparse matrices and only the modes that matter.

A model of thousands of DOFs is assembled as ``scipy.sparse`` CSR matrices
(``Structure.assemble(sparse=True)``) and only its lowest modes are computed, by shift-invert
Lanczos (``scipy.sparse.linalg.eigsh``) on ``K φ = ω² M φ``: the cost grows like the number of
non-zeros times the number of modes kept, not like the cube of the model. The modes above a
cut-off are left out; :mod:`femupdate.simulate.reduced` adds their quasi-static response back.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from femupdate.errors import ConfigError, ModelError
from femupdate.model.modes import NaturalModes, _sign_normalised

__all__ = ["DENSE_EIGEN_MAX_DOF", "check_sparse_mass", "lowest_modes", "scatter_sparse"]

# Up to this size a dense eigen-decomposition of all modes is cheaper than Lanczos iterations
# (and has no convergence question); above it the sparse eigensolver.
DENSE_EIGEN_MAX_DOF = 120
# The first Lanczos request; it doubles until a mode above the cut-off is found.
_FIRST_REQUEST = 12
# With the previous point's modes, ask for this many more than it had (one must lie above the
# cut-off, and a mode may have crossed it).
_MARGIN = 3


def scatter_sparse(target: np.ndarray, weights: np.ndarray, n: int) -> sp.csr_matrix:
    """Sum ``weights`` into an ``n × n`` CSR matrix at flat positions ``target = row·n + col``.

    Duplicate positions add up, as ``np.bincount`` does in the dense assembly.
    """
    rows, cols = np.divmod(np.asarray(target, dtype=np.int64), n)
    mat = sp.coo_matrix((np.asarray(weights, dtype=float), (rows, cols)), shape=(n, n))
    return mat.tocsr()  # sums duplicates


def check_sparse_mass(M: sp.spmatrix, dof_labels: Sequence[str] = ()) -> None:
    """Raise ``ModelError`` naming the DOFs involved if the sparse ``M`` is not positive definite.

    A diagonal ``M`` (lumped masses) is checked entry by entry; otherwise the pivots of an
    LU factorisation without pivoting (``LDLᵀ`` for a symmetric matrix) must all be positive.
    """
    diag = M.diagonal()
    bad = np.flatnonzero(~(diag > 0.0))
    if bad.size == 0 and M.nnz == np.count_nonzero(diag):
        return
    if bad.size == 0:
        try:
            lu = spla.splu(sp.csc_matrix(M), permc_spec="NATURAL", diag_pivot_thresh=0.0,
                           options={"SymmetricMode": True})
            pivots = lu.U.diagonal()
            bad = np.flatnonzero(~(pivots > 0.0))
        except RuntimeError:  # exactly singular
            bad = np.array([int(np.argmin(np.abs(diag)))])
        if bad.size == 0:
            return
    labels = [dof_labels[i] if i < len(dof_labels) else f"dof {i}" for i in bad[:10]]
    more = f" and {bad.size - 10} more" if bad.size > 10 else ""
    raise ModelError(
        f"the mass matrix is not positive definite; DOFs without inertia: {', '.join(labels)}"
        f"{more}. Give them mass (add_mass m=, or rotary inertia J= for a rotation, or beam "
        "density rho) or fix them."
    )


def _check_modes_request(n: int, n_modes: int | None, cutoff_hz: float | None) -> None:
    if (n_modes is None) == (cutoff_hz is None):
        raise ConfigError("lowest_modes: give exactly one of n_modes and cutoff_hz")
    if n_modes is not None and (
        isinstance(n_modes, bool) or not isinstance(n_modes, int | np.integer)
        or not 1 <= n_modes <= n
    ):
        raise ConfigError(
            f"n_modes = {n_modes!r} is not allowed; the model has {n} DOFs: allowed 1 to {n}"
        )
    if cutoff_hz is not None and not (np.isfinite(cutoff_hz) and cutoff_hz > 0.0):
        raise ConfigError(f"cutoff_hz = {cutoff_hz!r} is not allowed; it must be finite and > 0")


def _dense_modes(K: np.ndarray | sp.spmatrix, M: np.ndarray | sp.spmatrix) -> tuple:
    Kd = K.toarray() if sp.issparse(K) else np.asarray(K)
    Md = M.toarray() if sp.issparse(M) else np.asarray(M)
    return sla.eigh(Kd, Md, check_finite=False)


def _lanczos(K: sp.spmatrix, M: sp.spmatrix, k: int, v0: np.ndarray | None
             ) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` eigenpairs of ``(K, M)`` nearest 0 by shift-invert Lanczos."""
    try:
        w2, V = spla.eigsh(sp.csc_matrix(K), k=k, M=sp.csc_matrix(M), sigma=0.0, which="LM",
                           v0=v0, tol=0.0)
    except RuntimeError as err:  # splu of K: exactly singular
        raise ModelError(
            f"the stiffness matrix is singular ({err}); the model is a mechanism: fix or "
            "support it so that every rigid-body motion is restrained"
        ) from None
    order = np.argsort(w2)
    return w2[order], V[:, order]


def lowest_modes(
    K: np.ndarray | sp.spmatrix,
    M: np.ndarray | sp.spmatrix,
    *,
    n_modes: int | None = None,
    cutoff_hz: float | None = None,
    previous: NaturalModes | None = None,
) -> NaturalModes:
    """Lowest natural frequencies and mass-normalised mode shapes of a (sparse) model.

    Parameters
    ----------
    K, M : ndarray or scipy.sparse matrix, shape (n, n)
        Stiffness (positive definite: a supported model) and mass.
    n_modes : int, optional
        How many modes, 1 to n.
    cutoff_hz : float, optional
        Every mode up to this frequency (Hz), at least one. Exactly one of ``n_modes`` and
        ``cutoff_hz``.
    previous : NaturalModes, optional
        The modes of a neighbouring parameter point (the previous evaluation): their sum starts
        the Lanczos iteration and their count (plus a few) is the first request, so that one
        call usually suffices. The eigenpairs do not depend on it beyond rounding; without it a
        fixed start vector makes the result repeatable.

    Returns
    -------
    NaturalModes
        ``freqs_hz`` ascending and ``shapes`` (n, m), mass-normalised, largest entry positive.

    Notes
    -----
    Up to :data:`DENSE_EIGEN_MAX_DOF` DOFs, or when the modes asked for are more than a third
    of the model, a dense ``scipy.linalg.eigh`` of the whole model; above, ``eigsh`` in
    shift-invert mode about 0 (one sparse LU of ``K``), asking for twice as many modes until
    one lies above the cut-off.
    """
    n = int(K.shape[0])
    _check_modes_request(n, n_modes, cutoff_hz)
    w_cut = None if cutoff_hz is None else (2.0 * np.pi * float(cutoff_hz)) ** 2
    v0 = np.ones(n) if previous is None else previous.shapes.sum(axis=1)
    first = _FIRST_REQUEST if previous is None else previous.shapes.shape[1] + _MARGIN
    k = n_modes if n_modes is not None else min(first, n)
    while True:
        if n <= DENSE_EIGEN_MAX_DOF or 3 * k >= n:
            w2, V = _dense_modes(K, M)
        else:
            w2, V = _lanczos(K, M, k, v0)
        if w_cut is None or w2[-1] > w_cut or w2.size == n:
            break
        k = min(2 * k, n)
    if w2[0] <= 0.0:
        raise ModelError(
            f"the lowest eigenvalue ω² = {w2[0]:.3g} is not positive; the model is a mechanism"
            " (or unstable): fix or support it so that every rigid-body motion is restrained"
        )
    keep = n_modes if n_modes is not None else max(1, int(np.count_nonzero(w2 <= w_cut)))
    w2, V = w2[:keep], V[:, :keep]
    # eigsh returns M-orthonormal vectors up to its tolerance: normalise exactly
    mv = M @ V
    V = V / np.sqrt(np.einsum("ij,ij->j", V, mv))
    return NaturalModes(np.sqrt(w2) / (2.0 * np.pi), _sign_normalised(V))

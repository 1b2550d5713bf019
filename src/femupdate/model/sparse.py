"""Large models: sparse matrices and only the modes that matter.

A model of thousands of DOFs is assembled as ``scipy.sparse`` CSR matrices
(``Structure.assemble(sparse=True)``) and only its lowest modes are computed, by shift-invert
Lanczos (``scipy.sparse.linalg.eigsh``) on ``K φ = ω² M φ``: the cost grows like the number of
non-zeros times the number of modes kept, not like the cube of the model. The modes above a
cut-off are left out; :mod:`femupdate.simulate.reduced` adds their quasi-static response back.

DOFs without inertia (a building model's vertical translations and rotations, whose mass the
engineer lumps in the floors' horizontal motion) have no mode of their own: their rows of ``M``
are zero, they follow the others statically, and the model has as many modes as DOFs with
mass. :func:`lowest_modes` finds them by static condensation (Guyan 1965, exact when the
condensed DOFs have no inertia): ``K* = K_dd − K_ds K_ss⁻¹ K_sd`` on the DOFs with mass ``d``,
``M* = M_dd``, and the massless part of each mode ``φ_s = −K_ss⁻¹ K_sd φ_d``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from femupdate.errors import ConfigError, ModelError
from femupdate.model.modes import NaturalModes, _sign_normalised

__all__ = [
    "CONDENSE_MAX_DOF",
    "DENSE_EIGEN_MAX_DOF",
    "Condensation",
    "SparsePattern",
    "check_sparse_mass",
    "condense",
    "lowest_modes",
    "lumped_masses",
    "massless_dofs",
    "scatter_sparse",
]

# Up to this size a dense eigen-decomposition of all modes is cheaper than Lanczos iterations
# (and has no convergence question); above it the sparse eigensolver.
DENSE_EIGEN_MAX_DOF = 120
# The first Lanczos request; it doubles until a mode above the cut-off is found.
_FIRST_REQUEST = 12
# With the previous point's modes, ask for this many more than it had (one must lie above the
# cut-off, and a mode may have crossed it).
_MARGIN = 3
#: A model with massless DOFs is condensed onto its DOFs with mass, and all its modes found
#: densely, when these are at most this many (the condensed matrices are dense); above, the
#: Lanczos iteration works on the whole model (``M`` positive semi-definite).
CONDENSE_MAX_DOF = 600


@dataclass(frozen=True)
class SparsePattern:
    """Where each of a fixed list of flat targets ``row·n + col`` lands in a CSR matrix: a
    model's assembly scatters the same targets at every evaluation, so the CSR structure is
    found once and each assembly is one ``np.bincount`` (duplicates summed in the order
    given, as the dense assembly sums them)."""

    inverse: np.ndarray
    indices: np.ndarray
    indptr: np.ndarray
    n: int

    @classmethod
    def of(cls, target: np.ndarray, n: int) -> SparsePattern:
        unique, inverse = np.unique(np.asarray(target, dtype=np.int64), return_inverse=True)
        rows, cols = np.divmod(unique, n)
        indptr = np.searchsorted(rows, np.arange(n + 1))
        return cls(inverse.ravel(), cols.astype(np.int32), indptr.astype(np.int32), n)

    def matrix(self, weights: np.ndarray) -> sp.csr_matrix:
        """The ``n × n`` CSR matrix of ``weights`` summed at the targets."""
        data = np.bincount(self.inverse, weights=np.asarray(weights, dtype=float),
                           minlength=self.indices.size)
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))


def scatter_sparse(target: np.ndarray, weights: np.ndarray, n: int) -> sp.csr_matrix:
    """Sum ``weights`` into an ``n × n`` CSR matrix at flat positions ``target = row·n + col``.

    Duplicate positions add up, as ``np.bincount`` does in the dense assembly.
    """
    rows, cols = np.divmod(np.asarray(target, dtype=np.int64), n)
    mat = sp.coo_matrix((np.asarray(weights, dtype=float), (rows, cols)), shape=(n, n))
    return mat.tocsr()  # sums duplicates


def massless_dofs(M: np.ndarray | sp.spmatrix) -> np.ndarray:
    """Indices of the DOFs without inertia: a zero diagonal entry of ``M`` (for a positive
    semi-definite ``M`` the whole row is then zero)."""
    return np.flatnonzero(np.asarray(M.diagonal()) == 0.0)


def check_sparse_mass(M: sp.spmatrix, dof_labels: Sequence[str] = (), *,
                      allow_massless: bool = False) -> None:
    """Raise ``ModelError`` naming the DOFs involved if the sparse ``M`` is not positive definite.

    A diagonal ``M`` (lumped masses) is checked entry by entry; otherwise the pivots of an
    LU factorisation without pivoting (``LDLᵀ`` for a symmetric matrix) must all be positive.
    With ``allow_massless`` DOFs whose row of ``M`` is zero pass (the reduced path condenses
    them: :func:`lowest_modes`) and the rest must be positive definite; at least one DOF must
    have mass.
    """
    def labels_of(idx: Sequence[int] | np.ndarray) -> list[str]:
        return [dof_labels[i] if i < len(dof_labels) else f"dof {i}" for i in idx]

    if allow_massless:
        diag = np.asarray(M.diagonal())
        massless = np.flatnonzero(diag == 0.0)
        if massless.size == diag.size:
            raise ModelError("no DOF of the model has mass (the mass matrix is zero): give the "
                             "nodes masses (add_mass m=) or the beams a density (rho)")
        if massless.size:
            rows = sp.csr_matrix(M)[massless]
            if rows.count_nonzero():
                bad = massless[np.flatnonzero(np.asarray(abs(rows).sum(axis=1)).ravel())]
                raise ModelError(
                    "the mass matrix couples DOFs without inertia of their own to others: "
                    f"{', '.join(labels_of(bad[:10]))}; it is not positive semi-definite")
            massed = np.setdiff1d(np.arange(diag.size), massless)
            check_sparse_mass(sp.csr_matrix(M)[massed][:, massed],
                              [labels_of([i])[0] for i in massed])
            return
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
    labels = labels_of(bad[:10])
    more = f" and {bad.size - 10} more" if bad.size > 10 else ""
    raise ModelError(
        f"the mass matrix is not positive definite; DOFs without inertia: {', '.join(labels)}"
        f"{more}. Give them mass (add_mass m=, or rotary inertia J= for a rotation, or beam "
        "density rho) or fix them."
    )


def _check_modes_request(n: int, n_modes: int | None, cutoff_hz: float | None,
                         n_massed: int | None = None) -> None:
    if (n_modes is None) == (cutoff_hz is None):
        raise ConfigError("lowest_modes: give exactly one of n_modes and cutoff_hz")
    most = n if n_massed is None else n_massed
    if n_modes is not None and (
        isinstance(n_modes, bool) or not isinstance(n_modes, int | np.integer)
        or not 1 <= n_modes <= most
    ):
        what = (f"{n} DOFs" if n_massed is None
                else f"{n} DOFs, {n_massed} with mass (a DOF without mass has no mode)")
        raise ConfigError(
            f"n_modes = {n_modes!r} is not allowed; the model has {what}: allowed 1 to {most}"
        )
    if cutoff_hz is not None and not (np.isfinite(cutoff_hz) and cutoff_hz > 0.0):
        raise ConfigError(f"cutoff_hz = {cutoff_hz!r} is not allowed; it must be finite and > 0")


def _dense_modes(K: np.ndarray | sp.spmatrix, M: np.ndarray | sp.spmatrix) -> tuple:
    Kd = K.toarray() if sp.issparse(K) else np.asarray(K)
    Md = M.toarray() if sp.issparse(M) else np.asarray(M)
    return sla.eigh(Kd, Md, check_finite=False)


@dataclass(frozen=True)
class Condensation:
    """A model's DOFs without mass condensed onto those with mass (module docstring).

    Attributes
    ----------
    massed, massless : ndarray of int
        The DOFs with mass (``d``) and without (``s``).
    lu : SuperLU
        The factorisation of ``K_ss``.
    follow : ndarray, shape (n_s, n_d)
        ``K_ss⁻¹ K_sd``: the massless DOFs follow the others as ``u_s = −follow · u_d``.
    k_cond : ndarray, shape (n_d, n_d)
        ``K* = K_dd − K_ds K_ss⁻¹ K_sd``.
    """

    massed: np.ndarray
    massless: np.ndarray
    lu: spla.SuperLU
    follow: np.ndarray
    k_cond: np.ndarray

    @property
    def n(self) -> int:
        return int(self.massed.size + self.massless.size)

    def modes(self, M: np.ndarray | sp.spmatrix) -> tuple[np.ndarray, np.ndarray]:
        """All the modes (ω² ascending, Φ over every DOF) of ``(K, M)``."""
        massed = self.massed
        m_dd = (sp.csr_matrix(M)[massed][:, massed].toarray() if sp.issparse(M)
                else np.asarray(M)[np.ix_(massed, massed)])
        w2, v_d = sla.eigh(self.k_cond, m_dd, check_finite=False)
        V = np.empty((self.n, massed.size))
        V[massed] = v_d
        V[self.massless] = -(self.follow @ v_d)
        return w2, V

    def solve(self, b: np.ndarray) -> np.ndarray:
        """``K⁻¹ b`` (b of shape (n,) or (n, k)) by block elimination on the factorisations
        already made: one solve with ``K_ss`` and one with the dense ``K*``."""
        b = np.asarray(b, dtype=float)
        b_s = b[self.massless]
        # K* x_d = b_d − K_ds K_ss⁻¹ b_s, and K_ds K_ss⁻¹ = followᵀ (K symmetric)
        x_d = sla.solve(self.k_cond, b[self.massed] - self.follow.T @ b_s, assume_a="pos",
                        check_finite=False)
        x = np.empty_like(b)
        x[self.massed] = x_d
        x[self.massless] = self.lu.solve(np.ascontiguousarray(b_s)) - self.follow @ x_d
        return x


def condense(K: np.ndarray | sp.spmatrix, M: np.ndarray | sp.spmatrix,
             massless: np.ndarray | None = None) -> Condensation:
    """The :class:`Condensation` of the DOFs of ``M``'s zero rows (``massless``, by default
    found), ``K_ss`` factored with a fill-reducing ordering for symmetric matrices.

    Raises ``ModelError`` when the massless DOFs are a mechanism on their own (``K_ss``
    singular)."""
    massless = massless_dofs(M) if massless is None else massless
    n = int(K.shape[0])
    massed = np.setdiff1d(np.arange(n), massless)
    Ks = sp.csr_matrix(K)
    rows_s = Ks[massless]
    k_ss = sp.csc_matrix(rows_s[:, massless])
    k_sd = rows_s[:, massed].toarray()
    try:
        lu = spla.splu(k_ss, permc_spec="MMD_AT_PLUS_A", options={"SymmetricMode": True})
    except RuntimeError as err:  # exactly singular
        raise ModelError(
            f"the stiffness of the DOFs without mass is singular ({err}): they are a mechanism "
            "on their own; fix or support them, or give them mass"
        ) from None
    follow = lu.solve(k_sd)
    k_cond = Ks[massed][:, massed].toarray() - Ks[massed][:, massless] @ follow
    return Condensation(massed, massless, lu, follow, 0.5 * (k_cond + k_cond.T))


def lumped_masses(M: np.ndarray | sp.spmatrix) -> np.ndarray | None:
    """The diagonal of ``M`` when ``M`` is diagonal with positive entries (lumped masses, every
    DOF with inertia), else None."""
    diag = np.asarray(M.diagonal(), dtype=float)
    if not np.all(diag > 0.0):
        return None
    if sp.issparse(M):
        off = sp.csr_matrix(M) - sp.diags(diag, format="csr")
        return diag if off.count_nonzero() == 0 else None
    return diag if np.count_nonzero(np.asarray(M) - np.diag(diag)) == 0 else None


def _lanczos_lumped(K: sp.spmatrix, masses: np.ndarray, k: int, v0: np.ndarray | None,
                    lu: spla.SuperLU | None = None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_lanczos` for a diagonal ``M``: the standard problem ``A y = ω² y`` of
    ``A = M^(−1/2) K M^(−1/2)`` (as sparse as ``K``), ``φ = M^(−1/2) y``. ARPACK then needs no
    product with ``M`` at each step: 1.5 times faster than the generalised problem on the
    1,000-DOF building of examples/large (eigenvalues equal to 3e-15 there; to 1e-12 on a
    graded building in tests/model/test_model_sparse.py). ``A⁻¹ y = M^(1/2) K⁻¹ M^(1/2) y``
    with ``lu``, the factorisation of ``K`` (the caller's, to reuse it; made here if None)."""
    scale = 1.0 / np.sqrt(masses)
    A = sp.csc_matrix(K, dtype=float, copy=True)
    A.sort_indices()
    A.data *= scale[A.indices] * np.repeat(scale, np.diff(A.indptr))
    if lu is None:
        lu = spla.splu(sp.csc_matrix(K))
    root = np.sqrt(masses)
    n = int(K.shape[0])
    inverse = spla.LinearOperator((n, n), matvec=lambda y: root * lu.solve(root * y),
                                  dtype=float)
    start = None if v0 is None else v0 / scale
    w2, Y = spla.eigsh(A, k=k, sigma=0.0, which="LM", v0=start, tol=0.0, OPinv=inverse)
    order = np.argsort(w2)
    return w2[order], Y[:, order] * scale[:, None]


def _lanczos(K: sp.spmatrix, M: sp.spmatrix, k: int, v0: np.ndarray | None,
             purify: bool = False, lu: spla.SuperLU | None = None
             ) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` eigenpairs of ``(K, M)`` nearest 0 by shift-invert Lanczos.

    With ``purify`` (an ``M`` with zero rows) each vector is mapped once more by ``K⁻¹M``
    and scaled by its ω²: Lanczos vectors may carry components in the null space of ``M``
    (the infinite eigenvalues), which that map removes (Ericsson 1986). ``lu``: the
    factorisation of ``K`` when the caller has it (used with lumped masses).
    """
    singular = ("the stiffness matrix is singular ({}); the model is a mechanism: fix or "
                "support it so that every rigid-body motion is restrained")
    lumped = None if purify else lumped_masses(M)
    if lumped is not None:
        try:
            return _lanczos_lumped(K, lumped, k, v0, lu)
        except RuntimeError as err:  # splu of K: exactly singular
            raise ModelError(singular.format(err)) from None
    lu = inverse = None
    if purify:  # factor K here, so the purification reuses it
        try:
            lu = spla.splu(sp.csc_matrix(K))
        except RuntimeError as err:  # exactly singular
            raise ModelError(singular.format(err)) from None
        n = int(K.shape[0])
        inverse = spla.LinearOperator((n, n), matvec=lu.solve, dtype=float)
    try:
        w2, V = spla.eigsh(sp.csc_matrix(K), k=k, M=sp.csc_matrix(M), sigma=0.0, which="LM",
                           v0=v0, tol=0.0, OPinv=inverse)
    except RuntimeError as err:  # splu of K: exactly singular
        raise ModelError(singular.format(err)) from None
    order = np.argsort(w2)
    w2, V = w2[order], V[:, order]
    if lu is not None:
        V = lu.solve(np.asarray(M @ V)) * w2
    return w2, V


def lowest_modes(
    K: np.ndarray | sp.spmatrix,
    M: np.ndarray | sp.spmatrix,
    *,
    n_modes: int | None = None,
    cutoff_hz: float | None = None,
    previous: NaturalModes | None = None,
    condensation: Condensation | None = None,
    stiffness_lu: spla.SuperLU | None = None,
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
    condensation : Condensation, optional
        The :func:`condense` of this ``(K, M)`` when the caller made it (to reuse its
        factorisation: :class:`~femupdate.simulate.reduced.ReducedSimulator`).
    stiffness_lu : SuperLU, optional
        ``scipy.sparse.linalg.splu`` of this ``K`` when the caller made it (its static
        correction solves with it too): the Lanczos iteration of a model with lumped masses
        then solves with it instead of factoring again.

    Returns
    -------
    NaturalModes
        ``freqs_hz`` ascending and ``shapes`` (n, m), mass-normalised, largest entry positive.

    Notes
    -----
    Up to :data:`DENSE_EIGEN_MAX_DOF` DOFs, or when the modes asked for are more than a third
    of the model, a dense ``scipy.linalg.eigh`` of the whole model; above, ``eigsh`` in
    shift-invert mode about 0 (one sparse LU of ``K``), asking for twice as many modes until
    one lies above the cut-off. A model with DOFs without mass (zero rows of ``M``) has one
    mode per DOF with mass: up to :data:`CONDENSE_MAX_DOF` of those, all are found by static
    condensation (module docstring); above, by ``eigsh`` on the whole model.
    """
    n = int(K.shape[0])
    massless = massless_dofs(M)
    n_massed = n - massless.size
    _check_modes_request(n, n_modes, cutoff_hz, n_massed if massless.size else None)
    w_cut = None if cutoff_hz is None else (2.0 * np.pi * float(cutoff_hz)) ** 2
    v0 = np.ones(n) if previous is None else previous.shapes.sum(axis=1)
    first = _FIRST_REQUEST if previous is None else previous.shapes.shape[1] + _MARGIN
    k = n_modes if n_modes is not None else min(first, n_massed)
    while True:
        if massless.size and (n_massed <= CONDENSE_MAX_DOF or 3 * k >= n_massed):
            w2, V = (condensation or condense(K, M, massless)).modes(M)
        elif not massless.size and (n <= DENSE_EIGEN_MAX_DOF or 3 * k >= n):
            w2, V = _dense_modes(K, M)
        else:
            w2, V = _lanczos(K, M, k, v0, purify=bool(massless.size), lu=stiffness_lu)
        if w_cut is None or w2[-1] > w_cut or w2.size == n_massed:
            break
        k = min(2 * k, n_massed)
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

"""scipy's LAPACK, callable from numba-compiled code.

The evaluation kernels solve one small eigenproblem per evaluation; calling LAPACK from inside
the compiled loop avoids the Python round trip (wrappers, checks, fresh arrays) that cost more
than the factorisation itself. The routines are scipy's own (``scipy.linalg.cython_lapack``),
the ones ``scipy.linalg.eig`` and ``eigh`` call, bound by symbol name so that the kernels can be
cached (``cache=True``): the symbols are registered with LLVM when this module is imported,
before any cached kernel is loaded.

Matrices are passed in Fortran order: a C-contiguous array holding the *transpose*. The wrappers
take every buffer from the caller (no allocation in the hot path) and return LAPACK's ``info``.
"""

from __future__ import annotations

import llvmlite.binding as llvm
import numpy as np
from numba import njit, types
from numba.extending import get_cython_function_address

__all__ = ["geev_lwork", "geev_right", "sygvd_sizes", "sygvd_vectors", "sygvx_largest",
           "sygvx_lwork"]

_P = types.CPointer
_D = _P(types.float64)
_I = _P(types.int32)
_C = _P(types.int8)

_SIGNATURES = {
    # jobvl, jobvr, n, a, lda, wr, wi, vl, ldvl, vr, ldvr, work, lwork, info
    "dgeev": types.void(_C, _C, _I, _D, _I, _D, _D, _D, _I, _D, _I, _D, _I, _I),
    # itype, jobz, uplo, n, a, lda, b, ldb, w, work, lwork, iwork, liwork, info
    "dsygvd": types.void(_I, _C, _C, _I, _D, _I, _D, _I, _D, _D, _I, _I, _I, _I),
    # itype, jobz, range, uplo, n, a, lda, b, ldb, vl, vu, il, iu, abstol, m, w, z, ldz, work,
    # lwork, iwork, ifail, info
    "dsygvx": types.void(_I, _C, _C, _C, _I, _D, _I, _D, _I, _D, _D, _I, _I, _D, _I, _D, _D,
                         _I, _D, _I, _I, _I, _I),
}


def _bind(name: str) -> types.ExternalFunction:
    symbol = f"femupdate_lapack_{name}"
    llvm.add_symbol(symbol, get_cython_function_address("scipy.linalg.cython_lapack", name))
    return types.ExternalFunction(symbol, _SIGNATURES[name])


_dgeev = _bind("dgeev")
_dsygvd = _bind("dsygvd")
_dsygvx = _bind("dsygvx")


def _lwork(name: str, *args: object, **kwargs: object) -> int:
    """The workspace scipy's wrapper of ``name`` asks for (as ``scipy.linalg`` computes it)."""
    from scipy.linalg import get_lapack_funcs
    from scipy.linalg.lapack import _compute_lwork

    routine = get_lapack_funcs(name, (np.zeros((1, 1)),))
    return int(_compute_lwork(routine, *args, **kwargs))


def geev_lwork(n: int) -> int:
    """The workspace ``scipy.linalg.eig`` gives ``dgeev`` (right vectors) for order ``n``."""
    return _lwork("geev_lwork", n, compute_vl=0, compute_vr=1)


def sygvx_lwork(n: int) -> int:
    """The workspace ``scipy.linalg.eigh(..., subset_by_index=...)`` gives ``dsygvx``."""
    return _lwork("sygvx_lwork", n, uplo="L")


def sygvd_sizes(n: int) -> tuple[int, int]:
    """``(lwork, liwork)`` of ``dsygvd`` with vectors, as scipy's wrapper sets them."""
    return 1 + 6 * n + 2 * n * n, 3 + 5 * n


@njit(cache=True)
def _chars(text: str) -> np.ndarray:
    out = np.empty(len(text), dtype=np.int8)
    for i in range(len(text)):
        out[i] = ord(text[i])
    return out


@njit(cache=True)
def geev_right(at: np.ndarray, wr: np.ndarray, wi: np.ndarray, vrt: np.ndarray,
               work: np.ndarray) -> int:
    """Eigenvalues and right eigenvectors of a real square matrix (``dgeev``, overwrites it).

    Parameters
    ----------
    at : ndarray (n, n), C-contiguous
        The transpose of the matrix (its Fortran layout); destroyed.
    wr, wi : ndarray (n,)
        Real and imaginary parts of the eigenvalues (out).
    vrt : ndarray (n, n)
        Row j is the j-th column of LAPACK's VR (out): a real eigenvector, or for a pair with
        ``wi[j] > 0`` the real and (next row) imaginary parts of the first of the pair.
    work : ndarray
        Workspace, ``geev_lwork(n)`` long.

    Returns
    -------
    int
        LAPACK's info (0: success).
    """
    n = np.empty(1, dtype=np.int32)
    n[0] = at.shape[0]
    one = np.ones(1, dtype=np.int32)
    lwork = np.empty(1, dtype=np.int32)
    lwork[0] = work.shape[0]
    info = np.zeros(1, dtype=np.int32)
    vl = np.empty(1)
    jobvl = _chars("N")
    jobvr = _chars("V")
    _dgeev(jobvl.ctypes, jobvr.ctypes, n.ctypes, at.ctypes, n.ctypes, wr.ctypes, wi.ctypes,
           vl.ctypes, one.ctypes, vrt.ctypes, n.ctypes, work.ctypes, lwork.ctypes, info.ctypes)
    return int(info[0])


@njit(cache=True)
def sygvd_vectors(a: np.ndarray, b: np.ndarray, w: np.ndarray, work: np.ndarray,
                  iwork: np.ndarray) -> int:
    """``A φ = λ B φ`` for symmetric A and positive definite B (``dsygvd``, lower triangles).

    ``a`` and ``b`` (n, n, C-contiguous, symmetric) are destroyed; on return row j of ``a`` is
    the eigenvector of ``w[j]`` (ascending), normalised so that φᵀ B φ = 1. ``work`` and
    ``iwork`` are ``sygvd_sizes(n)`` long. Returns LAPACK's info.
    """
    n = np.empty(1, dtype=np.int32)
    n[0] = a.shape[0]
    itype = np.ones(1, dtype=np.int32)
    lwork = np.empty(1, dtype=np.int32)
    lwork[0] = work.shape[0]
    liwork = np.empty(1, dtype=np.int32)
    liwork[0] = iwork.shape[0]
    info = np.zeros(1, dtype=np.int32)
    jobz = _chars("V")
    uplo = _chars("L")
    _dsygvd(itype.ctypes, jobz.ctypes, uplo.ctypes, n.ctypes, a.ctypes, n.ctypes, b.ctypes,
            n.ctypes, w.ctypes, work.ctypes, lwork.ctypes, iwork.ctypes, liwork.ctypes,
            info.ctypes)
    return int(info[0])


@njit(cache=True)
def sygvx_largest(a: np.ndarray, b: np.ndarray, work: np.ndarray, iwork: np.ndarray
                  ) -> tuple[float, int]:
    """The largest eigenvalue of ``A φ = λ B φ`` (``dsygvx``, range ``I``, lower triangles).

    ``a`` and ``b`` (n, n, C-contiguous, symmetric) are destroyed. ``work`` is
    ``sygvx_lwork(n)`` long, ``iwork`` 6n (5n for LAPACK and n for ifail). Returns (λ_max, info).
    """
    size = a.shape[0]
    n = np.empty(1, dtype=np.int32)
    n[0] = size
    itype = np.ones(1, dtype=np.int32)
    one = np.ones(1, dtype=np.int32)
    lwork = np.empty(1, dtype=np.int32)
    lwork[0] = work.shape[0]
    info = np.zeros(1, dtype=np.int32)
    found = np.zeros(1, dtype=np.int32)
    bounds = np.zeros(3)  # vl, vu (unused with range I), abstol = 0 as scipy
    w = np.empty(size)
    z = np.empty(1)
    jobz = _chars("N")
    rng = _chars("I")
    uplo = _chars("L")
    iw = iwork[:5 * size]
    ifail = iwork[5 * size:]
    _dsygvx(itype.ctypes, jobz.ctypes, rng.ctypes, uplo.ctypes, n.ctypes, a.ctypes, n.ctypes,
            b.ctypes, n.ctypes, bounds[0:1].ctypes, bounds[1:2].ctypes, n.ctypes, n.ctypes,
            bounds[2:3].ctypes, found.ctypes, w.ctypes, z.ctypes, one.ctypes, work.ctypes,
            lwork.ctypes, iw.ctypes, ifail.ctypes, info.ctypes)
    return w[0], int(info[0])

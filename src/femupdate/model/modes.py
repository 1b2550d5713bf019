"""Natural frequencies and mode shapes of an assembled ``System``."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
import scipy.linalg
import scipy.sparse

from femupdate.errors import ModelError
from femupdate.model.system import System

__all__ = [
    "DampedModes",
    "check_mass_matrix",
    "damped_modes",
    "initial_stiffness",
    "natural_frequencies",
]


def check_mass_matrix(M: np.ndarray, dof_labels: Sequence[str] = ()) -> None:
    """Raise ``ModelError`` naming the DOFs involved if ``M`` is not positive definite.

    A Cholesky factorisation decides; only when it fails is the (slower) eigen-decomposition
    used to find which DOFs carry the near-null mass vectors.
    """
    try:
        np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        pass
    else:
        return
    w, v = np.linalg.eigh(M)
    scale = max(float(np.max(np.abs(w))), np.finfo(float).tiny)
    null = v[:, w <= 1e-12 * scale]
    if null.shape[1] == 0:  # Cholesky failed on rounding alone; name the smallest mode
        null = v[:, :1]
    weight = np.max(np.abs(null), axis=1)
    dofs = np.flatnonzero(weight > 1e-6 * weight.max())
    labels = [dof_labels[i] if i < len(dof_labels) else f"dof {i}" for i in dofs]
    raise ModelError(
        f"the mass matrix is singular (smallest eigenvalue {w[0]:.3g}); DOFs without inertia: "
        f"{', '.join(labels)}. Give them mass (add_mass m=, or rotary inertia J= for a "
        "rotation, or beam density rho) or fix them."
    )


def initial_stiffness(system: System) -> Any:
    """``K`` plus the initial stiffness of the nonlinear elements: the friction elements'
    stuck stiffness ``k_r`` and the Bouc–Wen elements' ``k (α + (1 − α) A)`` at ``z = 0``
    (:mod:`femupdate.model.links`). Dense for a dense ``K``, CSR for a sparse one."""
    if system.is_linear:
        return system.K
    from femupdate.model.links import initial_link_stiffness

    sparse = scipy.sparse.issparse(system.K)
    links = initial_link_stiffness(system.friction, system.bouc_wen, system.n_dof,
                                   sparse=sparse)
    return (system.K + links).tocsr() if sparse else system.K + links


def _sign_normalised(shapes: np.ndarray) -> np.ndarray:
    """Make the largest-magnitude entry of every column positive, for reproducible output."""
    idx = np.argmax(np.abs(shapes), axis=0)
    signs = np.sign(shapes[idx, np.arange(shapes.shape[1])])
    signs[signs == 0] = 1.0
    return shapes * signs


class NaturalModes(NamedTuple):
    """Undamped natural frequencies and mode shapes (unpacks as ``freqs, shapes``)."""

    freqs_hz: np.ndarray
    """Ascending, Hz, shape (n_modes,)."""
    shapes: np.ndarray
    """Mass-normalised mode shapes, shape (n_dof, n_modes)."""


def natural_frequencies(
    system: System, n_modes: int | None = None
) -> NaturalModes:
    """Undamped natural frequencies and mass-normalised mode shapes.

    Solves ``K φ = ω² M φ`` (``scipy.linalg.eigh``); friction elements count with their stuck
    stiffness ``k_r``. Damping is ignored.

    Parameters
    ----------
    system : System
        Assembled system (``M`` positive definite).
    n_modes : int, optional
        Number of lowest modes to return (default all).

    Returns
    -------
    NaturalModes
        ``freqs_hz`` (n_modes,): ascending; rigid-body modes give 0 (tiny negative eigenvalues
        are clipped). ``shapes`` (n_dof, n_modes): columns with ``φᵀ M φ = 1``, the largest
        entry of each positive. A NamedTuple, like ``damped_modes``' result.
    """
    n = system.n_dof
    if n_modes is None:
        n_modes = n
    if (
        isinstance(n_modes, bool)
        or not isinstance(n_modes, int | np.integer)
        or not (1 <= n_modes <= n)
    ):
        raise ModelError(f"n_modes = {n_modes!r} is out of range; allowed 1..{n}")
    check_mass_matrix(system.M, system.dof_labels)
    w2, shapes = scipy.linalg.eigh(
        initial_stiffness(system), system.M, subset_by_index=(0, int(n_modes) - 1)
    )
    freqs = np.sqrt(np.clip(w2, 0.0, None)) / (2.0 * np.pi)
    return NaturalModes(freqs, _sign_normalised(shapes))


class DampedModes(NamedTuple):
    """Complex modes of a viscously damped system (unpacks as a 3-tuple).

    Attributes
    ----------
    freqs_hz : ndarray, shape (n_modes,)
        Natural frequency ``|λ| / 2π`` of each mode, ascending.
    damping_ratios : ndarray, shape (n_modes,)
        ``-Re λ / |λ|``; 1 for every real (overdamped) pole.
    shapes : ndarray of complex, shape (n_dof, n_modes)
        Displacement part of the eigenvectors, scaled so the largest-modulus entry is 1.
    """

    freqs_hz: np.ndarray
    damping_ratios: np.ndarray
    shapes: np.ndarray

    @property
    def damped_freqs_hz(self) -> np.ndarray:
        """Damped frequencies ``Im λ / 2π = f √(1 − ζ²)`` (0 for real poles)."""
        zeta = np.clip(self.damping_ratios, 0.0, 1.0)
        return self.freqs_hz * np.sqrt(1.0 - zeta * zeta)


def damped_modes(system: System) -> DampedModes:
    """Complex modes from the state-space eigenproblem, non-proportional damping allowed.

    The state matrix ``[[0, I], [-M⁻¹K, -M⁻¹C]]`` (``K`` with the stuck friction stiffness)
    has ``2n`` eigenvalues ``λ``. A conjugate pair gives one underdamped mode, taken from
    ``Im λ > 0``: ``f = |λ| / 2π``, ``ζ = -Re λ / |λ|``, damped frequency ``Im λ / 2π``.
    An overdamped mode gives two real poles; each is listed as its own mode with
    ``f = |λ| / 2π`` and ``ζ = 1`` (the convention of MATLAB's ``damp``), so the number of
    modes is ``n`` plus the number of overdamped pairs. Poles at 0 (rigid body; ``|λ|`` below
    1e-6 of the largest) give ``f = 0``, ``ζ = 0``, one mode per pair of them.

    Returns
    -------
    DampedModes
        ``(freqs_hz, damping_ratios, shapes)`` sorted by frequency, then damping.
    """
    n = system.n_dof
    check_mass_matrix(system.M, system.dof_labels)
    chol = scipy.linalg.cho_factor(system.M)
    a = np.zeros((2 * n, 2 * n))
    a[:n, n:] = np.eye(n)
    a[n:, :n] = -scipy.linalg.cho_solve(chol, initial_stiffness(system))
    a[n:, n:] = -scipy.linalg.cho_solve(chol, system.C)
    lam, vec = scipy.linalg.eig(a)
    mag = np.abs(lam)
    scale = max(float(mag.max(initial=0.0)), np.finfo(float).tiny)
    # A rigid-body double pole at 0 is defective: eig spreads it by about √eps·|λ|max.
    zero = mag <= 1e-6 * scale
    # Imaginary parts below this are rounding: such poles are real (overdamped).
    real = np.abs(lam.imag) <= 1e-9 * scale
    keep = ~zero & (real | (lam.imag > 0))
    keep[np.flatnonzero(zero)[: (int(zero.sum()) + 1) // 2]] = True  # one mode per pair
    lam, vec, mag, real, zero = lam[keep], vec[:n, keep], mag[keep], real[keep], zero[keep]
    with np.errstate(divide="ignore", invalid="ignore"):
        zeta = np.where(real, 1.0, -lam.real / mag)
    zeta[zero] = 0.0
    freqs = np.where(zero, 0.0, mag / (2.0 * np.pi))
    order = np.lexsort((zeta, freqs))
    shapes = vec[:, order]
    peak = shapes[np.argmax(np.abs(shapes), axis=0), np.arange(shapes.shape[1])]
    return DampedModes(freqs[order], zeta[order], shapes / peak)

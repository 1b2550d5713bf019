"""Large linear models on the modes that matter: truncated modal basis plus a static correction.

The model's lowest modes ``Φ`` (mass-normalised, ``ω_j`` up to a cut-off; see
:func:`femupdate.model.sparse.lowest_modes`) reduce ``M ÿ + C ẏ + K y = -p a_g + f`` to

    q̈ + Φᵀ C Φ q̇ + Ω² q = -Γ a_g + Φᵀ f,     Γ = Φᵀ p,     y ≈ Φ q + y_static,

a small system that is discretised exactly (:class:`~femupdate.simulate.exact.ExactSimulator`:
modal first-order-hold filters; ``Φᵀ C Φ`` need not be diagonal, so non-proportional damping is
kept). The modes above the cut-off respond quasi-statically to an input whose content lies well
below their frequencies; their share of the displacement at the outputs is added back by the
residual flexibility ``(K⁻¹ - Φ Ω⁻² Φᵀ)`` (one sparse solve per output, once per model):

    y_static = -(K⁻¹ p - Φ Ω⁻² Γ) a_g + (K⁻¹ - Φ Ω⁻² Φᵀ) f,

and its derivative to the velocity (``ȧ_g`` as the centred difference of the samples). The
absolute acceleration of a quasi-static truncated mode ``j`` is ``φ_j Γ_j a_g`` (its relative
acceleration is negligible), which summed with the kept modes gives ``Φ q̈ + r a_g``: the
absolute acceleration needs no other term. What the correction leaves out is the truncated
modes' dynamic amplification, about ``(f/f_j)²`` of their quasi-static share at a frequency
``f`` of the input: :func:`truncation_error` measures it against the full model.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from femupdate.errors import ConfigError, ModelError
from femupdate.model.modes import NaturalModes
from femupdate.model.sparse import CONDENSE_MAX_DOF, condense, lowest_modes, massless_dofs
from femupdate.model.system import System
from femupdate.simulate._common import (
    check_excitation,
    check_outputs,
    check_state,
    check_step,
    make_response,
)
from femupdate.simulate.exact import ExactSimulator, _modal_recursion
from femupdate.simulate.response import Response

__all__ = [
    "DEFAULT_CUTOFF_FACTOR",
    "FULL_PATH_MAX_DOF",
    "ReducedSimulator",
    "TruncationError",
    "prepare_linear",
    "prepare_reduced",
    "truncation_error",
]

#: Modes are kept up to this multiple of the highest frequency of the fitted band.
DEFAULT_CUTOFF_FACTOR = 2.0
#: :func:`prepare_linear` keeps the full exact path up to this many DOFs (the reference; below
#: it the dense 2n × 2n eigen-decomposition costs little) and reduces above it. Measured on a
#: shear building with 25 modes below the cut-off (benchmarks/scale.py's, 5,000 samples): φ
#: full 2.4 ms against reduced 3.2 ms at 30 DOFs, 5.8 against 3.4 ms at 50.
FULL_PATH_MAX_DOF = 40
#: ΦᵀCΦ is taken as diagonal when no off-diagonal entry exceeds this fraction of its largest
#: diagonal one (Rayleigh damping: rounding, about 1e-16; a local damper couples at 1e-3+).
UNCOUPLED_DAMPING = 1e-12


def _factor(K: np.ndarray | sp.spmatrix) -> spla.SuperLU | None:
    if not sp.issparse(K):
        return None
    try:
        return spla.splu(sp.csc_matrix(K))
    except RuntimeError as err:
        raise ModelError(
            f"the stiffness matrix is singular ({err}); the model is a mechanism: fix or support "
            "it so that every rigid-body motion is restrained"
        ) from None


def _solve(K: np.ndarray | sp.spmatrix, lu: spla.SuperLU | None, b: np.ndarray) -> np.ndarray:
    return lu.solve(b) if lu is not None else np.linalg.solve(K, b)


def cutoff_from_band(band_hz: float, cutoff_factor: float = DEFAULT_CUTOFF_FACTOR) -> float:
    """The modal cut-off (Hz) for a fitted band up to ``band_hz``, checked.

    Raises ``ConfigError`` for a factor below 1 (a cut-off inside the band the fit sees).
    """
    if not (np.isfinite(band_hz) and band_hz > 0.0):
        raise ConfigError(f"band_hz = {band_hz!r} is not allowed; it must be finite and > 0 (Hz)")
    if not (np.isfinite(cutoff_factor) and cutoff_factor >= 1.0):
        raise ConfigError(
            f"cutoff_factor = {cutoff_factor!r} would cut modes inside the fitted band "
            f"(0 to {band_hz:g} Hz); allowed >= 1 (default {DEFAULT_CUTOFF_FACTOR:g})"
        )
    return float(band_hz) * float(cutoff_factor)


class ReducedSimulator:
    """A linear model on its lowest modes, discretised exactly, with a static correction.

    Parameters
    ----------
    system : System
        Linear system; ``M``, ``C``, ``K`` dense or ``scipy.sparse`` (``assemble(sparse=True)``).
    dt : float
        Sample interval (s).
    outputs : sequence of int
        Output DOFs (the sensors); the correction costs one solve per output.
    band_hz : float, optional
        Highest frequency of the fitted band (the filters' pass band), Hz. Default: Nyquist.
    cutoff_factor : float
        Modes up to ``cutoff_factor × band_hz`` are kept, >= 1 (default 2).
    n_modes : int, optional
        Keep exactly this many modes instead (1 to n_dof).
    modes : NaturalModes, optional
        Modes already computed for this system (skips the eigensolver).
    previous : NaturalModes, optional
        Modes of a neighbouring parameter point (``sim.modes`` of the previous evaluation):
        the eigensolver starts from them (see :func:`~femupdate.model.sparse.lowest_modes`).
    static_correction : bool
        Add the truncated modes' quasi-static response (default True; False shows its effect).

    Attributes
    ----------
    modes : NaturalModes
        The kept modes.
    cutoff_hz : float or None
        The cut-off used (None when ``n_modes`` was given).
    """

    returns_absolute_acceleration = True

    def __init__(
        self,
        system: System,
        dt: float,
        outputs: Sequence[int] | np.ndarray,
        *,
        band_hz: float | None = None,
        cutoff_factor: float = DEFAULT_CUTOFF_FACTOR,
        n_modes: int | None = None,
        modes: NaturalModes | None = None,
        previous: NaturalModes | None = None,
        static_correction: bool = True,
    ) -> None:
        if not system.is_linear:
            raise ConfigError(
                "the reduced (modal) path is for linear systems; this one has "
                f"{system.friction.count} friction elements: use method='nonlinear'"
            )
        self.dt, _ = check_step(dt, 1)
        self.n_dof = system.n_dof
        self.outputs = check_outputs(outputs, self.n_dof)
        self.cutoff_hz = None
        # DOFs without mass: condensed, and the factorisation reused by the static correction
        massless = massless_dofs(system.M)
        condensation = (condense(system.K, system.M, massless) if massless.size and
                        self.n_dof - massless.size <= CONDENSE_MAX_DOF else None)
        # one factorisation of a sparse K for the eigensolver and the static correction
        lu = (_factor(system.K) if condensation is None and static_correction
              and sp.issparse(system.K) else None)
        if modes is None:
            if n_modes is None:
                band = 0.5 / self.dt if band_hz is None else band_hz
                self.cutoff_hz = cutoff_from_band(band, cutoff_factor)
            modes = lowest_modes(system.K, system.M, n_modes=n_modes, cutoff_hz=self.cutoff_hz,
                                 previous=previous, condensation=condensation,
                                 stiffness_lu=lu)
        self.modes = modes
        phi = modes.shapes
        w2 = (2.0 * np.pi * modes.freqs_hz) ** 2
        p = np.asarray(system.seismic_load).ravel()
        gamma = phi.T @ p
        c_red = phi.T @ (system.C @ phi)
        c_red = 0.5 * (c_red + c_red.T)
        m = phi.shape[1]
        # Damping that does not couple the modes (Rayleigh) leaves ΦᵀCΦ diagonal but for
        # rounding: drop that, and the modal system's eigenvalues come in closed form (a dense
        # 2m × 2m eigen-decomposition took 2.8 of 3.3 s of φ with 670 modes of a 3-D frame).
        diag = np.diag(c_red)
        if np.all(np.abs(c_red - np.diag(diag)) <= UNCOUPLED_DAMPING * np.abs(diag).max()):
            c_red = np.diag(diag)
        reduced = System(M=np.eye(m), C=c_red, K=np.diag(w2), r=np.zeros(m), seismic=gamma)
        # all modal coordinates as outputs
        self._sim = ExactSimulator(reduced, self.dt, decoupled=True)
        self._phi = phi
        self._phi_out = np.ascontiguousarray(phi[self.outputs])  # (n_out, m)
        self._r_out = np.asarray(system.r, dtype=float)[self.outputs]
        self._M = system.M
        self.static_correction = static_correction
        n_out = self.outputs.size
        self._flex_out = np.zeros((n_out, self.n_dof))
        self._static_ag = np.zeros(n_out)
        # -(K⁻¹ - Φ Ω⁻² Φᵀ) C Φ at the outputs: the truncated modes' quasi-static response to
        # the damping forces of the kept ones (zero for Rayleigh damping, which does not couple
        # modes; a local damper does)
        self._damp_out = np.zeros((n_out, m))
        if static_correction:
            unit = np.zeros((self.n_dof, n_out))
            unit[self.outputs, np.arange(n_out)] = 1.0
            if condensation is not None:
                kinv = condensation.solve(unit)
            else:
                kinv = _solve(system.K, lu, unit)
            kinv_out = np.atleast_2d(kinv.reshape(self.n_dof, n_out)).T
            # rows of the residual flexibility K⁻¹ - Φ Ω⁻² Φᵀ at the outputs
            self._flex_out = kinv_out - (self._phi_out / w2) @ phi.T
            self._static_ag = -(self._flex_out @ p)
            damp = -(self._flex_out @ np.asarray(system.C @ phi))
            scale = np.abs(self._phi_out).max() * max(np.abs(np.diag(c_red)).max(), 1e-300)
            if np.abs(damp).max() > 1e-12 * scale / w2.min():
                self._damp_out = damp
        self._coupled = bool(np.any(self._damp_out))
        sim = self._sim
        if sim.modal:  # fold the output rows into the mode-to-output matrix: one product
            W = sim._W
            wd, wv, wa = (W[:, i * m:(i + 1) * m] for i in range(3))
            blocks = [wd @ self._phi_out.T + wv @ self._damp_out.T, wv @ self._phi_out.T,
                      wa @ self._phi_out.T]
            if self._coupled:
                blocks.append(wa @ self._damp_out.T)
            self._W = np.ascontiguousarray(np.hstack(blocks))

    @property
    def n_modes(self) -> int:
        return int(self._phi.shape[1])

    def run(
        self,
        ag: np.ndarray | None = None,
        force: np.ndarray | None = None,
        *,
        x0: np.ndarray | None = None,
        v0: np.ndarray | None = None,
    ) -> Response:
        """Simulate from ``(x0, v0)`` (rest by default); as :meth:`ExactSimulator.run`.

        The initial state is projected on the kept modes (``q0 = Φᵀ M x0``).
        """
        ag, force, ns = check_excitation(ag, force, self.n_dof)
        x0, v0 = check_state(x0, v0, self.n_dof)
        sim = self._sim
        q0 = self._phi.T @ (self._M @ x0)
        qd0 = self._phi.T @ (self._M @ v0)
        fmod = None if force is None else np.ascontiguousarray(force @ self._phi)
        with np.errstate(over="ignore", invalid="ignore"):
            if sim.modal:
                z0 = sim._vinv @ np.concatenate([q0, qd0])
                fz = sim._no_force if fmod is None else np.ascontiguousarray(
                    fmod @ sim._b_force.T)
                a = np.zeros(ns) if ag is None else ag
                Z, diverged = _modal_recursion(a, fz, sim._e, sim._c0, sim._c1, sim._g0,
                                               sim._g1, z0)
                Y = Z @ self._W
                n_out = self.outputs.size
                disp, vel, acc = (Y[:, i * n_out:(i + 1) * n_out] for i in range(3))
                damped = Y[:, 3 * n_out:] if self._coupled else None
                if fmod is not None:
                    acc += fmod @ self._phi_out.T  # the kept modes' direct feed-through
                    if damped is not None:
                        damped = damped + fmod @ self._damp_out.T
            else:
                res = sim.run(ag, fmod, x0=q0, v0=qd0)
                diverged = res.diverged
                disp, vel, acc = (y @ self._phi_out.T for y in
                                  (res.displacement, res.velocity, res.acceleration))
                disp += res.velocity @ self._damp_out.T
                damped = res.acceleration @ self._damp_out.T if self._coupled else None
            if damped is not None:  # the damping correction's rate (its displacement is in W)
                vel += damped
                acc += np.gradient(damped, self.dt, axis=0)
            if ag is not None:
                acc += np.outer(ag, self._r_out)
                if self.static_correction:
                    disp += np.outer(ag, self._static_ag)
                    dag = np.gradient(ag, self.dt)
                    vel += np.outer(dag, self._static_ag)
                    acc += np.outer(np.gradient(dag, self.dt), self._static_ag)
            if force is not None and self.static_correction:
                disp += force @ self._flex_out.T
                dforce = np.gradient(force, self.dt, axis=0)
                vel += dforce @ self._flex_out.T
                acc += np.gradient(dforce, self.dt, axis=0) @ self._flex_out.T
        return make_response(self.dt, ns, disp, vel, acc, bool(diverged))


def prepare_reduced(system: System, dt: float, outputs: Sequence[int] | np.ndarray,
                    **options: object) -> ReducedSimulator:
    """:class:`ReducedSimulator` of ``system`` (options as its parameters)."""
    return ReducedSimulator(system, dt, outputs, **options)  # type: ignore[arg-type]


def prepare_linear(system: System, dt: float, outputs: Sequence[int] | np.ndarray, *,
                   band_hz: float | None = None,
                   cutoff_factor: float = DEFAULT_CUTOFF_FACTOR,
                   previous: NaturalModes | None = None,
                   ) -> ExactSimulator | ReducedSimulator:
    """The exact full-model simulator up to :data:`FULL_PATH_MAX_DOF` DOFs, the reduced above
    (and for a system with DOFs without mass, whose full path would need ``M⁻¹``).

    A sparse system larger than that is never made dense; a sparse small one is. ``previous``
    (the modes of the previous, neighbouring evaluation) warm-starts the reduced path.
    """
    if system.n_dof <= FULL_PATH_MAX_DOF and not massless_dofs(system.M).size:
        if sp.issparse(system.K):
            system = System(M=system.M.toarray(), C=system.C.toarray(), K=system.K.toarray(),
                            r=system.r, friction=system.friction, dof_labels=system.dof_labels,
                            seismic=system.seismic)
        return ExactSimulator(system, dt, outputs)
    return ReducedSimulator(system, dt, outputs, band_hz=band_hz, cutoff_factor=cutoff_factor,
                            previous=previous)


class TruncationError(NamedTuple):
    """How far the reduced response is from the full model's, per response quantity.

    Each is ``‖y_reduced - y_full‖² / ‖y_full‖²`` over all outputs and samples (the NMSE that
    φ is made of), after ``post`` (the fitted band's filter) when one was given.
    """

    displacement: float
    velocity: float
    acceleration: float


def truncation_error(reduced: ReducedSimulator, full: ExactSimulator, ag: np.ndarray,
                     post: object = None) -> TruncationError:
    """Relative squared error of the reduced response against the full model's.

    ``post`` is a callable applied to each (n_samples, n_out) response before comparing (e.g.
    the low-pass filter of the fitted band); None compares the raw responses.
    """
    a = reduced.run(ag)
    b = full.run(ag)

    def err(x: np.ndarray, y: np.ndarray) -> float:
        if post is not None:
            x, y = post(x), post(y)  # type: ignore[operator]
        return float(np.sum((x - y) ** 2) / np.sum(y**2))

    return TruncationError(err(a.displacement, b.displacement), err(a.velocity, b.velocity),
                           err(a.acceleration, b.acceleration))

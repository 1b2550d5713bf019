"""Checks of systems, time steps and inputs, and response assembly shared by the integrators.

Everything a user passes is checked here, once, before any compiled loop runs.
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

import numpy as np
import scipy.linalg as sla
from numba import njit

from femupdate.errors import ConfigError, DataError, ModelError, SimulationError
from femupdate.model.friction import check_friction_parameters
from femupdate.model.hysteresis import BOUC_WEN_PARAMETERS, check_bouc_wen_parameters
from femupdate.model.system import System
from femupdate.simulate.response import Response

# A state this large is no physical response in any units: call it divergence (and keep its
# square finite for the error function downstream).
DIVERGENCE_LIMIT = 1e150


T = TypeVar("T")

#: How many results :func:`cached` keeps per process (the latest used): a search's successive
#: evaluations share one linear part, a case of several trials or components a few; and the
#: bytes their arrays may hold in all (a dense 2,000-DOF model's modes are 32 MB).
CACHE_SIZE = 8
CACHE_BYTES = 256 * 2**20
_CACHE: OrderedDict[tuple[Any, bytes], Any] = OrderedDict()
_CACHE_LOCK = threading.Lock()


def _nbytes(value: Any) -> int:
    """The bytes of the arrays in a result (an array, or a tuple of them; None: 0)."""
    if isinstance(value, np.ndarray):
        return int(value.nbytes)
    if isinstance(value, tuple):
        return sum(_nbytes(v) for v in value)
    return 0


def matrix_digest(*arrays: np.ndarray) -> bytes:
    """A digest of the arrays' shapes, dtypes and bytes: equal digests, equal arrays."""
    h = hashlib.blake2b(digest_size=20)
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(f"{a.shape}{a.dtype.str};".encode())
        h.update(memoryview(a).cast("B"))
    return h.digest()


def _frozen(value: Any) -> Any:
    """``value`` with its arrays made read-only (a cached result is shared, never written)."""
    if isinstance(value, np.ndarray):
        value.setflags(write=False)
    elif isinstance(value, tuple):
        for v in value:
            _frozen(v)
    return value


def cached(function: Callable[..., T], *arrays: np.ndarray) -> T:
    """``function(*arrays)``, a pure function of the arrays, or its result for the same
    function and the same bytes when this process computed it lately (its arrays are then
    read-only).

    A search changes a nonlinear model's elements (Bouc–Wen, friction) from one evaluation to
    the next while M, C and K of its linear part stay the same: their factorisations and modes
    are then computed once (on a 256-DOF frame they cost more than its simulation). The
    results are those ``function`` gives, bit for bit; an exception is not kept.
    """
    key = (function, matrix_digest(*arrays))
    with _CACHE_LOCK:
        if key in _CACHE:
            _CACHE.move_to_end(key)
            return _CACHE[key]
    value = _frozen(function(*arrays))
    if _nbytes(value) > CACHE_BYTES:  # kept, it would push out everything else
        return value
    with _CACHE_LOCK:
        _CACHE[key] = value
        while (len(_CACHE) > CACHE_SIZE
               or sum(_nbytes(v) for v in _CACHE.values()) > CACHE_BYTES):
            _CACHE.popitem(last=False)
    return value


def mass_cholesky(M: np.ndarray) -> np.ndarray:
    """The lower Cholesky factor of ``M`` (``LinAlgError`` when it is not positive definite)."""
    return sla.cholesky(M, lower=True, check_finite=False)


def mass_inverse(M: np.ndarray) -> np.ndarray:
    """``M⁻¹`` from its (cached) Cholesky factor."""
    chol = cached(mass_cholesky, M)
    return sla.cho_solve((chol, True), np.eye(M.shape[0]), check_finite=False)


def check_system(system: System) -> np.ndarray:
    """Raise ModelError unless M, C, K, r and the friction elements are consistent and finite.

    Returns the lower Cholesky factor of M (computed by the positive-definiteness check, kept
    by :func:`cached`).
    """
    n = system.n_dof
    if n < 1:
        raise ModelError("the system has no degrees of freedom; M must be at least 1 × 1")
    for name in ("M", "C", "K"):
        mat = getattr(system, name)
        if mat.shape != (n, n):
            raise ModelError(f"system.{name} has shape {mat.shape}; expected ({n}, {n})")
        if not np.all(np.isfinite(mat)):
            raise ModelError(f"system.{name} contains NaN or inf; all entries must be finite")
    if system.r.shape != (n,):
        raise ModelError(f"system.r has shape {system.r.shape}; expected ({n},)")
    if not np.all(np.isfinite(system.r)):
        raise ModelError("system.r contains NaN or inf; all entries must be finite")
    try:
        chol = cached(mass_cholesky, system.M)
    except sla.LinAlgError:
        raise ModelError(
            "system.M is not positive definite; every free DOF needs mass (or rotary inertia)"
        ) from None
    fr = system.friction
    if fr is not None and fr.count:
        nf = fr.count
        for name in ("dof_i", "dof_j", "k_r", "f_u"):
            if np.shape(getattr(fr, name)) != (nf,):
                raise ModelError(
                    f"friction.{name} has shape {np.shape(getattr(fr, name))}; expected ({nf},)"
                )
        if np.any((fr.dof_i < 0) | (fr.dof_i >= n)):
            raise ModelError(f"friction.dof_i must lie in [0, {n - 1}]; got {fr.dof_i.tolist()}")
        if np.any((fr.dof_j < -1) | (fr.dof_j >= n)):
            raise ModelError(
                f"friction.dof_j must lie in [-1, {n - 1}] (-1 = ground); got {fr.dof_j.tolist()}"
            )
        check_friction_parameters(fr.k_r, fr.f_u)
    bw = system.bouc_wen
    if bw is not None and bw.count:
        nb = bw.count
        width = len(BOUC_WEN_PARAMETERS)
        if np.shape(bw.table) != (nb, width) or np.shape(bw.dof_i) != (nb,) or np.shape(
                bw.dof_j) != (nb,):
            raise ModelError(f"bouc_wen: table {np.shape(bw.table)}, dof_i "
                             f"{np.shape(bw.dof_i)}, dof_j {np.shape(bw.dof_j)}; expected "
                             f"({nb}, {width}), ({nb},), ({nb},)")
        if np.any((bw.dof_i < 0) | (bw.dof_i >= n)) or np.any((bw.dof_j < -1) | (bw.dof_j >= n)):
            raise ModelError(f"bouc_wen.dof_i must lie in [0, {n - 1}] and dof_j in [-1, "
                             f"{n - 1}] (-1 = ground); got {bw.dof_i.tolist()}, "
                             f"{bw.dof_j.tolist()}")
        check_bouc_wen_parameters(bw.table, bw.names or None)
    return chol


def check_step(dt: float, substeps: int) -> tuple[float, int]:
    """Return ``(dt, substeps)`` as float and int after checking them."""
    try:
        dt = float(dt)
    except (TypeError, ValueError):
        raise ConfigError(f"dt = {dt!r} is not a number; give the sample interval in s") from None
    if not (np.isfinite(dt) and dt > 0.0):
        raise ConfigError(f"dt = {dt!r} is not allowed; the sample interval must be finite and > 0")
    if isinstance(substeps, bool) or not isinstance(substeps, int | np.integer):
        raise ConfigError(f"substeps = {substeps!r} must be an integer >= 1")
    if substeps < 1:
        raise ConfigError(f"substeps = {substeps} is not allowed; it must be >= 1")
    return dt, int(substeps)


def check_outputs(outputs: Sequence[int] | np.ndarray | None, n_dof: int) -> np.ndarray:
    """DOF indices to output as an int64 array (all DOFs when ``outputs`` is None)."""
    if outputs is None:
        return np.arange(n_dof, dtype=np.int64)
    idx = np.atleast_1d(np.asarray(outputs))
    if idx.ndim != 1 or idx.size == 0 or not np.issubdtype(idx.dtype, np.integer):
        raise ConfigError(
            f"outputs = {outputs!r} must be a non-empty sequence of DOF indices (integers)"
        )
    bad = idx[(idx < 0) | (idx >= n_dof)]
    if bad.size:
        raise ConfigError(
            f"outputs contains DOF index {int(bad[0])}; allowed indices are 0 to {n_dof - 1}"
        )
    return idx.astype(np.int64)


def _as_float_array(name: str, value: object) -> np.ndarray:
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError):
        raise DataError(f"{name} must be an array of real numbers; got a ragged sequence") from None
    if arr.dtype.kind not in "biuf":  # complex would lose its imaginary part silently
        raise DataError(f"{name} must be an array of real numbers; got dtype {arr.dtype}")
    return arr.astype(np.float64, copy=False)


def _check_finite(name: str, arr: np.ndarray) -> None:
    bad = ~np.isfinite(arr)
    if bad.any():
        first = np.argwhere(bad)[0]
        where = f"sample {int(first[0])}" if arr.ndim else "value"
        if arr.ndim == 2:
            where += f", DOF {int(first[1])}"
        raise DataError(f"{name} contains NaN or inf at {where}; all values must be finite")


def check_excitation(
    ag: object, force: object, n_dof: int
) -> tuple[np.ndarray | None, np.ndarray | None, int]:
    """Check the base acceleration and nodal forces; return them as float arrays.

    Returns
    -------
    ag : ndarray (n_samples,) or None
    force : ndarray (n_samples, n_dof) or None
    n_samples : int
    """
    if ag is None and force is None:
        raise DataError("no input: give ag (base acceleration), force (nodal forces) or both")
    n_samples = None
    if ag is not None:
        ag = _as_float_array("ag", ag)
        if ag.ndim != 1 or ag.shape[0] < 1:
            raise DataError(f"ag has shape {ag.shape}; expected (n_samples,) with n_samples >= 1")
        _check_finite("ag", ag)
        ag = np.ascontiguousarray(ag)
        n_samples = ag.shape[0]
    if force is not None:
        force = _as_float_array("force", force)
        if force.ndim != 2 or force.shape[1] != n_dof or force.shape[0] < 1:
            raise DataError(
                f"force has shape {force.shape}; expected (n_samples, {n_dof}): "
                "one column per free DOF"
            )
        if n_samples is not None and force.shape[0] != n_samples:
            raise DataError(
                f"force has {force.shape[0]} samples but ag has {n_samples}; they must match"
            )
        _check_finite("force", force)
        force = np.ascontiguousarray(force)
        n_samples = force.shape[0]
    return ag, force, int(n_samples)


def check_state(x0: object, v0: object, n_dof: int) -> tuple[np.ndarray, np.ndarray]:
    """Initial displacement and velocity as float arrays (zeros when None)."""
    out = []
    for name, value in (("x0", x0), ("v0", v0)):
        if value is None:
            out.append(np.zeros(n_dof))
            continue
        arr = _as_float_array(name, value)
        if arr.shape != (n_dof,):
            raise DataError(f"{name} has shape {arr.shape}; expected ({n_dof},)")
        if not np.all(np.isfinite(arr)):
            raise DataError(f"{name} contains NaN or inf; the initial state must be finite")
        out.append(np.ascontiguousarray(arr))
    return out[0], out[1]


def omega_max(M: np.ndarray, K: np.ndarray) -> float:
    """Largest natural circular frequency (rad/s) of the generalised eigenproblem (K, M)."""
    n = M.shape[0]
    w2 = sla.eigh(K, M, eigvals_only=True, subset_by_index=[n - 1, n - 1], check_finite=False)
    return float(np.sqrt(max(w2[-1], 0.0)))


def check_critical_step(
    dt: float, substeps: int, w_max: float, omega_crit: float, method: str
) -> None:
    """Refuse a conditionally stable step ``h = dt/substeps`` with ``h·ω_max >= omega_crit``.

    The message gives the largest stable step and the smallest number of substeps that works.
    """
    h = dt / substeps
    if w_max <= 0.0 or h * w_max < omega_crit:
        return
    h_crit = omega_crit / w_max
    needed = int(np.floor(dt / h_crit)) + 1
    raise SimulationError(
        f"{method}: the time step h = dt/substeps = {h:.6g} s is not stable; the largest stable "
        f"step is {h_crit:.6g} s ({omega_crit:g}/ω_max, ω_max = {w_max:.6g} rad/s = "
        f"{w_max / (2 * np.pi):.6g} Hz); use substeps >= {needed} at dt = {dt:.6g} s"
        + ("" if method != "nonlinear" else ", or method 'implicit' ([simulation] method = "
           "\"implicit\" in a case), which needs no step below the stiffest element's")
    )


@njit(cache=True, inline="always")
def is_diverged(x: np.ndarray) -> bool:
    """Whether a state vector has left any physical range (or holds NaN), inside the kernels."""
    s = 0.0
    for i in range(x.shape[0]):
        s += abs(x[i])
    return not s < DIVERGENCE_LIMIT  # NaN fails the comparison too


def sample_loads(
    ag: np.ndarray | None, force: np.ndarray | None, g: np.ndarray, G: np.ndarray | None
) -> np.ndarray:
    """``q_k = g·a_g,k + G f_k`` for every sample: (n_samples, len(g)), C-contiguous."""
    if force is None:
        return np.ascontiguousarray(np.outer(ag, g))
    q = force @ G.T
    if ag is not None:
        q += np.outer(ag, g)
    return np.ascontiguousarray(q)


def element_histories(n_friction: int, n_bouc_wen: int, friction_force: np.ndarray,
                      slip: np.ndarray, hysteretic_force: np.ndarray, hysteretic_z: np.ndarray
                      ) -> tuple[np.ndarray | None, ...]:
    """What a nonlinear ``_integrate`` returns after (displacement, velocity, acceleration,
    diverged): the friction force and slip when there are friction elements, then the Bouc–Wen
    force and ``z`` when there are Bouc–Wen elements (friction's None without friction)."""
    friction = (friction_force, slip) if n_friction else (None, None)
    if n_bouc_wen:
        return (*friction, hysteretic_force, hysteretic_z)
    return friction if n_friction else ()


def make_response(
    dt: float,
    n_samples: int,
    disp: np.ndarray,
    vel: np.ndarray,
    acc: np.ndarray,
    diverged: bool,
    friction_force: np.ndarray | None = None,
    slip: np.ndarray | None = None,
    hysteretic_force: np.ndarray | None = None,
    hysteretic_z: np.ndarray | None = None,
) -> Response:
    """Wrap output arrays; a diverged simulation gets NaN everywhere (never partial numbers)."""
    if diverged or not (np.all(np.isfinite(disp)) and np.all(np.isfinite(vel))):
        diverged = True
        for arr in (disp, vel, acc, friction_force, slip, hysteretic_force, hysteretic_z):
            if arr is not None:
                arr.fill(np.nan)
    return Response(
        t=np.arange(n_samples) * dt,
        displacement=disp,
        velocity=vel,
        acceleration=acc,
        diverged=diverged,
        friction_force=friction_force,
        slip=slip,
        hysteretic_force=hysteretic_force,
        hysteretic_z=hysteretic_z,
    )


class Simulator:
    """What every prepared integrator shares: the checks of its inputs, absolute accelerations
    and the assembly of the :class:`Response`. Subclasses prepare the system in ``__init__``
    (after ``super().__init__``) and integrate in :meth:`_integrate`.
    """

    #: False: ``_integrate`` returns relative accelerations and ``run`` adds ``r·a_g``.
    returns_absolute_acceleration = False

    def __init__(self, system: System, dt: float, outputs: Sequence[int] | np.ndarray | None,
                 substeps: int = 1) -> None:
        check_system(system)
        self.dt, self.substeps = check_step(dt, substeps)
        self.h = self.dt / self.substeps
        self.n_dof = system.n_dof
        self.outputs = check_outputs(outputs, self.n_dof)
        self._r_out = system.r[self.outputs]
        self._minv = cached(mass_inverse, system.M)
        self._C, self._K, self._p = system.C, system.K, system.seismic_load

    def _initial_acceleration(
        self, ag: np.ndarray | None, force: np.ndarray | None, x0: np.ndarray, v0: np.ndarray,
        internal: np.ndarray | float = 0.0,
    ) -> np.ndarray:
        """Relative acceleration at t = 0 from the equations of motion, with ``internal`` the
        forces of elements outside K and C (friction)."""
        p0 = (0.0 if force is None else force[0]) - (0.0 if ag is None else ag[0] * self._p)
        return self._minv @ (p0 - self._C @ v0 - self._K @ x0 - internal)

    def run(
        self,
        ag: np.ndarray | None = None,
        force: np.ndarray | None = None,
        *,
        x0: np.ndarray | None = None,
        v0: np.ndarray | None = None,
    ) -> Response:
        """Simulate from ``(x0, v0)`` (rest by default) for the given input samples.

        Parameters
        ----------
        ag : ndarray (n_samples,), optional
            Base acceleration, linear between samples (load ``-p a_g``, ``p = M r`` unless
            supports carry consistent beam mass: ``System.seismic_load``).
        force : ndarray (n_samples, n_dof), optional
            Nodal forces on the free DOFs, linear between samples.
        x0, v0 : ndarray (n_dof,), optional
            Initial displacement and velocity relative to the base; friction elements start
            with zero slip.

        Returns
        -------
        Response
            Relative displacement and velocity, absolute acceleration at the outputs.
        """
        ag, force, ns = check_excitation(ag, force, self.n_dof)
        x0, v0 = check_state(x0, v0, self.n_dof)
        with np.errstate(over="ignore", invalid="ignore"):
            disp, vel, acc, diverged, *friction = self._integrate(ag, force, ns, x0, v0)
            if ag is not None and not diverged and not self.returns_absolute_acceleration:
                acc += np.outer(ag, self._r_out)  # absolute acceleration
        return make_response(self.dt, ns, disp, vel, acc, diverged, *friction)

    def _integrate(
        self, ag: np.ndarray | None, force: np.ndarray | None, ns: int, x0: np.ndarray,
        v0: np.ndarray,
    ) -> tuple:
        """(displacement, velocity, acceleration, diverged[, friction force, slip[,
        Bouc–Wen force, z]]).

        The acceleration is relative, or absolute if ``returns_absolute_acceleration``.
        """
        raise NotImplementedError

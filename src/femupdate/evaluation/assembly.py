"""Re-assembly of a Structure's M, C, K, base load and friction values in compiled code.

The same computation as :meth:`femupdate.model.structure.Structure.assemble`, element formula
for element formula and in the same order (property values, element matrices, then one
accumulation per matrix in the order of the structure's precomputed scatter targets, as
``numpy.bincount`` does), without a Python round trip. Without coordinate transformations (2-DOF
beams along +x, springs, dampers, masses) the matrices are the reference's bit for bit; a
transformed element (frames, beams drawn right to left) differs by rounding in its ``Tᵀ k T``.

A parameter value outside a property's range, or a mass matrix that is not positive definite,
is reported by a status code: the caller then assembles with the Structure itself, which raises
the ``ModelError`` that names the element.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
import scipy.linalg as sla
from numba import njit

from femupdate.errors import ModelError
from femupdate.model import elements
from femupdate.model.structure import Structure

__all__ = [
    "ASSEMBLY_OK",
    "BEAM_PROPS",
    "AssemblyPlan",
    "assemble",
    "physical_values",
    "plan_assembly",
]

#: Beam properties in the order of the rows of ``AssemblyPlan.beam_const`` and ``beam_pidx``.
BEAM_PROPS = ("E", "A", "I", "rho", "G", "nu", "kappa", "mass_per_length")
_E, _A, _I, _RHO, _G, _NU, _KAPPA, _MPL = range(8)

#: Status codes of :func:`assemble`.
ASSEMBLY_OK = 0
OUT_OF_RANGE = 1
NOT_FINITE = 2
MASS_NOT_DEFINITE = 3


class AssemblyPlan(NamedTuple):
    """Everything :func:`assemble` needs, as arrays (the Structure's topology, flattened).

    Each property has ``*_const`` (value per element) and ``*_pidx`` (parameter index per element
    in the search vector, -1 for a constant); ``*_spec`` holds (low, high, low_open) of its
    allowed range. Scatter targets are flat indices into an n × n matrix, ``*_keep`` the
    matching entries of the flattened element stack, as in ``Structure._topo()``.
    """

    n: int
    dofs_per_node: int
    log_scale: np.ndarray  # (n_params,) bool: the search value is log10 of the physical one
    beam_const: np.ndarray  # (8, n_beams)
    beam_pidx: np.ndarray  # (8, n_beams)
    beam_spec: np.ndarray  # (8, 3)
    beam_L: np.ndarray
    beam_L3: np.ndarray  # L**3 as numpy computes it in beam_stiffness
    beam_shear: np.ndarray  # 0 rigid in shear, 1 G given, 2 nu given
    beam_rotary: np.ndarray
    beam_T: np.ndarray  # (n_beams, d, d) global -> local, or (0, d, d) for none
    beam_target: np.ndarray
    beam_keep: np.ndarray
    coupling_rows: np.ndarray
    coupling_keep: np.ndarray
    coupling_rigid: np.ndarray  # rigid[gcols]: the support motion each coupling term carries
    spring_const: np.ndarray
    spring_pidx: np.ndarray
    spring_target: np.ndarray
    spring_keep: np.ndarray
    damper_const: np.ndarray
    damper_pidx: np.ndarray
    damper_target: np.ndarray
    damper_keep: np.ndarray
    mass_const: np.ndarray  # (2, n_masses): m, J
    mass_pidx: np.ndarray
    mass_m_target: np.ndarray
    mass_m_owner: np.ndarray
    mass_J_target: np.ndarray
    mass_J_owner: np.ndarray
    rayleigh_const: np.ndarray  # (2, 1 or 0): alpha, beta
    rayleigh_pidx: np.ndarray
    friction_const: np.ndarray  # (2, n_friction): k_r, f_u
    friction_pidx: np.ndarray
    nonneg_spec: np.ndarray  # (3,) the range of springs, dampers, masses, Rayleigh, friction
    r: np.ndarray  # influence vector
    fixed_mass: bool  # no parameter changes M: M and M⁻¹ below are used as they are
    M: np.ndarray  # (n, n) the mass matrix when fixed_mass
    minv: np.ndarray  # (n, n) its inverse, as the simulators compute it
    beam_mass_flat: np.ndarray  # the flattened beam mass stack when fixed_mass


def _prop_arrays(props: Sequence, params: Sequence[str], names: Sequence[str]
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(const, pidx in the search vector, spec rows) of the Structure's ``Prop`` objects."""
    count = len(props[0].const) if props else 0
    const = np.zeros((len(props), count))
    pidx = np.full((len(props), count), -1, dtype=np.int64)
    spec = np.zeros((len(props), 3))
    for row, prop in enumerate(props):
        const[row] = prop.const
        for e in prop.where:
            pidx[row, e] = names.index(params[prop.pidx[e]])
        spec[row] = (prop.spec.low, prop.spec.high, float(prop.spec.low_open))
    return const, pidx, spec


def plan_assembly(structure: Structure, names: Sequence[str], log_scale: Sequence[bool],
                  direction: str | None, values: dict[str, float]) -> AssemblyPlan:
    """The compiled assembly's plan of ``structure`` for search vectors over ``names``.

    Parameters
    ----------
    structure : Structure
        With its topology built.
    names : sequence of str
        The search vector's parameters, in order (every parameter of the structure).
    log_scale : sequence of bool
        Per parameter: the search value is its log10.
    direction : str or None
        Base-excitation direction (``Structure.assemble``'s).
    values : dict
        Valid physical values (e.g. the nominal ones): assembled once by the Structure to
        cache the mass matrix when no parameter changes it.
    """
    if structure.dofs_per_node == 6:
        raise ModelError("the compiled assembly is for planar structures; a 3-D frame "
                         "(dofs_per_node=6) is assembled by Structure.assemble")
    topo = structure._topo()
    params = structure.parameters
    names = list(names)
    beam_const, beam_pidx, beam_spec = _prop_arrays(
        [topo.beam_props[k] for k in BEAM_PROPS], params, names)
    spring_const, spring_pidx, _ = _prop_arrays([topo.spring_k], params, names)
    damper_const, damper_pidx, _ = _prop_arrays([topo.damper_c], params, names)
    mass_const, mass_pidx, _ = _prop_arrays([topo.mass_m, topo.mass_J], params, names)
    friction_const, friction_pidx, _ = _prop_arrays([topo.friction_kr, topo.friction_fu],
                                                     params, names)
    if topo.rayleigh is not None:
        rayleigh_const, rayleigh_pidx, _ = _prop_arrays(list(topo.rayleigh), params, names)
    else:
        rayleigh_const, rayleigh_pidx = np.zeros((2, 0)), np.zeros((2, 0), dtype=np.int64)
    spec = topo.spring_k.spec
    d = 2 * structure.dofs_per_node
    rigid = structure._rigid(direction)
    rows, keep, gcols = topo.beam_coupling
    system = structure.assemble(values, direction)
    fixed_mass = bool(topo.mass_const)
    minv = np.zeros((topo.n, topo.n))
    beam_mass_flat = np.zeros(0)
    if fixed_mass:
        chol = sla.cholesky(system.M, lower=True, check_finite=False)
        minv = sla.cho_solve((chol, True), np.eye(topo.n), check_finite=False)
        beam_mass_flat = np.ascontiguousarray(topo.cache["mass"][1]).reshape(-1)
    beam_L = np.asarray(topo.beam_L, dtype=float)
    return AssemblyPlan(
        n=int(topo.n), dofs_per_node=int(structure.dofs_per_node),
        log_scale=np.asarray(log_scale, dtype=np.bool_),
        beam_const=beam_const, beam_pidx=beam_pidx, beam_spec=beam_spec, beam_L=beam_L,
        beam_L3=beam_L**3, beam_shear=np.asarray(topo.beam_shear, dtype=np.int64),
        beam_rotary=np.asarray(topo.beam_rotary, dtype=float),
        beam_T=(np.zeros((0, d, d)) if topo.beam_T is None
                else np.ascontiguousarray(topo.beam_T, dtype=float)),
        beam_target=topo.beam_target.astype(np.int64), beam_keep=topo.beam_keep.astype(np.int64),
        coupling_rows=rows.astype(np.int64), coupling_keep=keep.astype(np.int64),
        coupling_rigid=rigid[gcols].astype(float),
        spring_const=spring_const[0], spring_pidx=spring_pidx[0],
        spring_target=topo.spring_target.astype(np.int64),
        spring_keep=topo.spring_keep.astype(np.int64),
        damper_const=damper_const[0], damper_pidx=damper_pidx[0],
        damper_target=topo.damper_target.astype(np.int64),
        damper_keep=topo.damper_keep.astype(np.int64),
        mass_const=mass_const, mass_pidx=mass_pidx,
        mass_m_target=topo.mass_m_target.astype(np.int64),
        mass_m_owner=topo.mass_m_owner.astype(np.int64),
        mass_J_target=topo.mass_J_target.astype(np.int64),
        mass_J_owner=topo.mass_J_owner.astype(np.int64),
        rayleigh_const=rayleigh_const, rayleigh_pidx=rayleigh_pidx,
        friction_const=friction_const, friction_pidx=friction_pidx,
        nonneg_spec=np.array([spec.low, spec.high, float(spec.low_open)]),
        r=system.r.astype(float), fixed_mass=fixed_mass, M=np.ascontiguousarray(system.M),
        minv=np.ascontiguousarray(minv), beam_mass_flat=beam_mass_flat,
    )


# --------------------------------------------------------------------------------- kernels


@njit(cache=True)
def physical_values(x: np.ndarray, log_scale: np.ndarray, out: np.ndarray) -> None:
    """Parameter values of search point ``x`` (``10**x`` on log scales, as ``Case``)."""
    for i in range(x.shape[0]):
        out[i] = 10.0 ** x[i] if log_scale[i] else x[i]


@njit(cache=True)
def _in_range(v: float, spec: np.ndarray) -> bool:
    above = v > spec[0] if spec[2] != 0.0 else v >= spec[0]
    return above and v <= spec[1]


@njit(cache=True)
def _values(const: np.ndarray, pidx: np.ndarray, spec: np.ndarray, p: np.ndarray,
            out: np.ndarray) -> bool:
    """Property values per element (``Prop.evaluate``); False if a parameter is out of range."""
    for e in range(const.shape[0]):
        if pidx[e] < 0:
            out[e] = const[e]
        else:
            v = p[pidx[e]]
            if not _in_range(v, spec):
                return False
            out[e] = v
    return True


# The beam formulas of model.elements, compiled: one source for both assemblies.
_stiffness_terms = njit(cache=True)(elements.beam_stiffness_terms)
_mass_terms = njit(cache=True)(elements.beam_mass_terms)
_UPPER = elements.BEAM_UPPER


@njit(cache=True)
def _symmetric_into(terms: tuple, out: np.ndarray) -> None:
    """The BEAM_UPPER entries ``terms`` into the symmetric 4 × 4 ``out``."""
    out[:, :] = 0.0
    for n in range(len(_UPPER)):
        i, j = _UPPER[n]
        out[i, j] = terms[n]
        out[j, i] = terms[n]


@njit(cache=True)
def _beam_stiffness(EI: float, L: float, L3: float, phi: float, k: np.ndarray) -> None:
    """``elements.beam_stiffness`` of one element into ``k`` (4 × 4)."""
    _symmetric_into(_stiffness_terms(EI, L, L3, phi), k)


@njit(cache=True)
def _beam_mass(mu: float, rho_i: float, L: float, phi: float, m: np.ndarray) -> None:
    """``elements.beam_mass`` of one element into ``m`` (4 × 4)."""
    _symmetric_into(_mass_terms(mu, rho_i, L, phi), m)


@njit(cache=True)
def _frame(axial: float, axial_off: float, bending: np.ndarray, out: np.ndarray) -> None:
    """``elements._frame_from``: the axial 2 × 2 on (u1, u2), ``bending`` on (v1, θ1, v2, θ2)."""
    out[:, :] = 0.0
    out[0, 0] = axial
    out[3, 3] = axial
    out[0, 3] = axial_off
    out[3, 0] = axial_off
    idx = (1, 2, 4, 5)
    for i in range(4):
        for j in range(4):
            out[idx[i], idx[j]] = bending[i, j]


@njit(cache=True)
def _transform(T: np.ndarray, k: np.ndarray, tmp: np.ndarray) -> None:
    """``k ← Tᵀ k T`` in place."""
    d = k.shape[0]
    for i in range(d):
        for j in range(d):
            s = 0.0
            for a in range(d):
                s += T[a, i] * k[a, j]
            tmp[i, j] = s
    for i in range(d):
        for j in range(d):
            s = 0.0
            for b in range(d):
                s += tmp[i, b] * T[b, j]
            k[i, j] = s


@njit(cache=True)
def _beam_matrices(plan: AssemblyPlan, p: np.ndarray, kflat: np.ndarray, mflat: np.ndarray,
                   with_mass: bool) -> bool:
    """Global stiffness (and mass) stacks of every beam, flattened; False when out of range."""
    nb = plan.beam_L.shape[0]
    d = 2 * plan.dofs_per_node
    vals = np.empty((8, nb))
    for row in range(8):
        if not _values(plan.beam_const[row], plan.beam_pidx[row], plan.beam_spec[row], p,
                       vals[row]):
            return False
    kb = np.empty((4, 4))
    mb = np.empty((4, 4))
    k = np.empty((d, d))
    m = np.empty((d, d))
    tmp = np.empty((d, d))
    frame = plan.dofs_per_node == 3
    for e in range(nb):
        E, A, I = vals[_E, e], vals[_A, e], vals[_I, e]  # noqa: E741
        L = plan.beam_L[e]
        shear = plan.beam_shear[e]
        # Φ = 12 E I / (κ G A L²); with ν given, E/G = 2(1 + ν)
        if shear == 1:
            flex = 12.0 * E / vals[_G, e]
        elif shear == 2:
            flex = 24.0 * (1.0 + vals[_NU, e])
        else:
            flex = 0.0
        phi = flex * I / (vals[_KAPPA, e] * A * L * L)
        _beam_stiffness(E * I, L, plan.beam_L3[e], phi, kb)
        if frame:
            ka = E * A / L
            _frame(ka, -ka, kb, k)
        else:
            k[:, :] = kb
        if with_mass:
            mu = vals[_RHO, e] * A + vals[_MPL, e]
            _beam_mass(mu, vals[_RHO, e] * I * plan.beam_rotary[e], L, phi, mb)
            if frame:
                ma = mu * L / 6.0
                _frame(2 * ma, ma, mb, m)
            else:
                m[:, :] = mb
        if plan.beam_T.shape[0]:
            _transform(plan.beam_T[e], k, tmp)
            if with_mass:
                _transform(plan.beam_T[e], m, tmp)
        base = e * d * d
        for i in range(d):
            for j in range(d):
                kflat[base + i * d + j] = k[i, j]
                if with_mass:
                    mflat[base + i * d + j] = m[i, j]
    return True


@njit(cache=True)
def _scatter_add(target: np.ndarray, keep: np.ndarray, flat: np.ndarray, out: np.ndarray) -> None:
    """``out.flat[target[t]] += flat[keep[t]]`` in order (``numpy.bincount``'s accumulation)."""
    for t in range(target.shape[0]):
        out[target[t]] += flat[keep[t]]


@njit(cache=True)
def _link_flat(values: np.ndarray) -> np.ndarray:
    """``elements.spring_matrix`` of every link, flattened: k, -k, -k, k per element."""
    out = np.empty(4 * values.shape[0])
    for e in range(values.shape[0]):
        v = values[e]
        out[4 * e] = v
        out[4 * e + 1] = -v
        out[4 * e + 2] = -v
        out[4 * e + 3] = v
    return out


@njit(cache=True)
def _cholesky_ok(M: np.ndarray) -> bool:
    """Whether ``M`` is positive definite (an unpivoted Cholesky factorisation succeeds)."""
    n = M.shape[0]
    L = np.zeros((n, n))
    for j in range(n):
        s = M[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not s > 0.0:
            return False
        L[j, j] = math.sqrt(s)
        for i in range(j + 1, n):
            t = M[i, j]
            for k in range(j):
                t -= L[i, k] * L[j, k]
            L[i, j] = t / L[j, j]
    return True


@njit(cache=True)
def assemble(plan: AssemblyPlan, x: np.ndarray, p: np.ndarray, M: np.ndarray, minv: np.ndarray,
             C: np.ndarray, K: np.ndarray, load: np.ndarray, kr: np.ndarray,
             fu: np.ndarray) -> int:
    """M, M⁻¹, C, K, the base load ``p`` (of ``-p a_g``) and friction values at search point x.

    ``p`` (the physical parameter values) and every other array are written; returns
    ``ASSEMBLY_OK`` or a status for which the caller must assemble with the Structure.
    """
    physical_values(x, plan.log_scale, p)
    for i in range(p.shape[0]):
        if not math.isfinite(p[i]):
            return NOT_FINITE
    n = plan.n
    nb = plan.beam_L.shape[0]
    d = 2 * plan.dofs_per_node
    kflat = np.empty(nb * d * d)
    mflat = np.empty(nb * d * d) if not plan.fixed_mass else plan.beam_mass_flat
    if not _beam_matrices(plan, p, kflat, mflat, not plan.fixed_mass):
        return OUT_OF_RANGE
    spec = plan.nonneg_spec
    ks = np.empty(plan.spring_const.shape[0])
    cs = np.empty(plan.damper_const.shape[0])
    if not (_values(plan.spring_const, plan.spring_pidx, spec, p, ks)
            and _values(plan.damper_const, plan.damper_pidx, spec, p, cs)):
        return OUT_OF_RANGE
    Mf = M.reshape(-1)
    Kf = K.reshape(-1)
    Cf = C.reshape(-1)
    if plan.fixed_mass:
        M[:, :] = plan.M
        minv[:, :] = plan.minv
    else:
        mm = np.empty(plan.mass_const.shape[1])
        mj = np.empty(plan.mass_const.shape[1])
        if not (_values(plan.mass_const[0], plan.mass_pidx[0], spec, p, mm)
                and _values(plan.mass_const[1], plan.mass_pidx[1], spec, p, mj)):
            return OUT_OF_RANGE
        Mf[:] = 0.0
        _scatter_add(plan.beam_target, plan.beam_keep, mflat, Mf)
        for t in range(plan.mass_m_target.shape[0]):
            Mf[plan.mass_m_target[t]] += mm[plan.mass_m_owner[t]]
        for t in range(plan.mass_J_target.shape[0]):
            Mf[plan.mass_J_target[t]] += mj[plan.mass_J_owner[t]]
        if not _cholesky_ok(M):
            return MASS_NOT_DEFINITE
        minv[:, :] = np.linalg.inv(M)
    Kf[:] = 0.0
    _scatter_add(plan.beam_target, plan.beam_keep, kflat, Kf)
    _scatter_add(plan.spring_target, plan.spring_keep, _link_flat(ks), Kf)
    Cf[:] = 0.0
    _scatter_add(plan.damper_target, plan.damper_keep, _link_flat(cs), Cf)
    if plan.rayleigh_const.shape[1]:
        ab = np.empty(1)
        if not _values(plan.rayleigh_const[0], plan.rayleigh_pidx[0], spec, p, ab):
            return OUT_OF_RANGE
        alpha = ab[0]
        if not _values(plan.rayleigh_const[1], plan.rayleigh_pidx[1], spec, p, ab):
            return OUT_OF_RANGE
        beta = ab[0]
        for i in range(n * n):
            Cf[i] = Cf[i] + alpha * Mf[i] + beta * Kf[i]
    coupled = np.zeros(n)  # the consistent mass coupled from moving supports
    for t in range(plan.coupling_rows.shape[0]):
        coupled[plan.coupling_rows[t]] += mflat[plan.coupling_keep[t]] * plan.coupling_rigid[t]
    for i in range(n):  # p = M r + coupled
        s = 0.0
        for j in range(n):
            s += M[i, j] * plan.r[j]
        load[i] = s + coupled[i]
    if not (_values(plan.friction_const[0], plan.friction_pidx[0], spec, p, kr)
            and _values(plan.friction_const[1], plan.friction_pidx[1], spec, p, fu)):
        return OUT_OF_RANGE
    return ASSEMBLY_OK

"""Assembly of a ``Structure``'s ``M``, ``C`` and ``K`` by its topology's scatter plan.

The element matrices of every element of a kind are evaluated together at the parameter values
(:func:`beam_stiffnesses`, :func:`beam_masses`, :func:`femupdate.model.elements.spring_matrix`)
and scattered by the precomputed flat targets (:func:`accumulator`), dense or sparse. Damping
is the dampers' matrix plus Rayleigh's ``α M + β K`` (:func:`damping_matrix`). A mass matrix
that no parameter changes is assembled and checked once, then copied from the topology's cache.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
import scipy.sparse as sp

from femupdate.model.elements import (
    beam_mass,
    beam_stiffness,
    frame_mass,
    frame_stiffness,
    spring_matrix,
)
from femupdate.model.elements3d import frame3d_mass, frame3d_stiffness
from femupdate.model.modes import check_mass_matrix
from femupdate.model.nonlinear_elements import reindexed
from femupdate.model.sparse import SparsePattern, check_sparse_mass, scatter_sparse
from femupdate.model.system import BoucWenElements, FrictionElements, System
from femupdate.model.topology import Topology

__all__ = ["accumulator", "beam_masses", "beam_shear_parameter", "beam_stiffnesses",
           "check_mass", "constrained_system", "damping_matrix", "mass_matrix", "shear_modulus",
           "structure_matrices"]

Matrix = np.ndarray | sp.spmatrix
Accumulate = Callable[..., Matrix]


def shear_modulus(E: np.ndarray, bp: Mapping[str, np.ndarray], shear: np.ndarray) -> np.ndarray:
    """``G`` per beam: given (1), from ``nu`` (2), or infinite (0)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        from_nu = E / (2.0 * (1.0 + bp["nu"]))
    return np.where(shear == 1, bp["G"], np.where(shear == 2, from_nu, np.inf))


def beam_shear_parameter(topo: Topology, bp: Mapping[str, np.ndarray]) -> np.ndarray:
    """Φ = 12 E I / (κ G A L²) per beam (0 for a beam rigid in shear)."""
    L = topo.beam_L
    E, A, I = bp["E"], bp["A"], bp["I"]  # noqa: E741
    # With ν given, E/G = 2(1 + ν), so Φ stays finite at E = 0.
    flex = np.where(
        topo.beam_shear == 1,
        12.0 * E / bp["G"],
        np.where(topo.beam_shear == 2, 24.0 * (1.0 + bp["nu"]), 0.0),
    )
    return flex * I / (bp["kappa"] * A * L * L)


def beam_stiffnesses(topo: Topology, bp: Mapping[str, np.ndarray], phi: np.ndarray, dpn: int
                     ) -> np.ndarray:
    """The beams' stiffness matrices in global axes, (n_b, 2·dpn, 2·dpn)."""
    L = topo.beam_L
    E, A, I = bp["E"], bp["A"], bp["I"]  # noqa: E741
    if dpn == 6:
        g = shear_modulus(E, bp, topo.beam_shear)
        kb = frame3d_stiffness(E, g, A, bp["Iy"], bp["Iz"], bp["J"], bp["kappa"] * A,
                               bp["kappa"] * A, L).reshape(L.size, 12, 12)
    elif dpn == 3:
        kb = frame_stiffness(E * A, E * I, L, phi)
    else:
        kb = beam_stiffness(E * I, L, phi)
    if topo.beam_T is not None:
        kb = np.swapaxes(topo.beam_T, 1, 2) @ kb @ topo.beam_T
    return kb


def beam_masses(topo: Topology, bp: Mapping[str, np.ndarray], phi: np.ndarray, dpn: int
                ) -> np.ndarray:
    """The beams' consistent mass matrices in global axes, (n_b, 2·dpn, 2·dpn)."""
    L = topo.beam_L
    E, A, I = bp["E"], bp["A"], bp["I"]  # noqa: E741
    mu = bp["rho"] * A + bp["mass_per_length"]
    rho_i = bp["rho"] * I * topo.beam_rotary
    if dpn == 6:
        g = shear_modulus(E, bp, topo.beam_shear)
        mb = np.array([
            frame3d_mass(mu[e], bp["rho"][e], E[e], g[e], A[e], bp["Iy"][e], bp["Iz"][e],
                         bp["kappa"][e] * A[e], bp["kappa"][e] * A[e], L[e],
                         Ip=bp["J"][e], rotary_inertia=bool(topo.beam_rotary[e]))
            for e in range(L.size)]).reshape(L.size, 12, 12)
    elif dpn == 3:
        mb = frame_mass(mu, rho_i, L, phi)
    else:
        mb = beam_mass(mu, rho_i, L, phi)
    if topo.beam_T is not None:
        mb = np.swapaxes(topo.beam_T, 1, 2) @ mb @ topo.beam_T
    return mb


def accumulator(topo: Topology, sparse: bool) -> Accumulate:
    """``accumulate(target, weights, key="")``: the ``n × n`` matrix of summed weights.

    Dense: ``np.bincount`` on the flat targets. Sparse: CSR, with the pattern of ``key`` (the
    targets of ``K`` and ``C`` never change) made once and kept in the topology.
    """
    n = topo.n
    nn = n * n

    def accumulate(target: np.ndarray, weights: np.ndarray, key: str = "") -> Matrix:
        if sparse:  # flat targets row·n + col summed into CSR (duplicates add up)
            if not key:
                return scatter_sparse(target, weights, n)
            pattern = topo.patterns.get(key)
            if pattern is None:
                pattern = topo.patterns[key] = SparsePattern.of(target, n)
            return pattern.matrix(weights)
        return np.bincount(target, weights=weights, minlength=nn).reshape(n, n)

    return accumulate


def check_mass(m: Matrix, labels: Sequence[str], sparse: bool) -> None:
    """Dense ``M``: positive definite (the step-by-step integrators invert it); sparse ``M``
    (the reduced path): DOFs without mass allowed, condensed there."""
    if sparse:
        check_sparse_mass(m, labels, allow_massless=True)
    else:
        check_mass_matrix(m, labels)


def mass_matrix(topo: Topology, p: np.ndarray, mb: np.ndarray, accumulate: Accumulate
                ) -> Matrix:
    """``M``: the beams' consistent masses and the lumped masses (``m`` and ``J``)."""
    mm, mj = topo.mass_m.evaluate(p), topo.mass_J.evaluate(p)
    return accumulate(
        np.concatenate([topo.beam_target, topo.mass_m_target, topo.mass_J_target]),
        np.concatenate(
            [mb.reshape(-1)[topo.beam_keep], mm[topo.mass_m_owner], mj[topo.mass_J_owner]]
        ),
    )


def damping_matrix(topo: Topology, p: np.ndarray, m: Matrix, k: Matrix,
                   accumulate: Accumulate) -> Matrix:
    """``C``: the dampers' matrix, plus Rayleigh's ``α M + β K`` when the structure has it."""
    cs = spring_matrix(topo.damper_c.evaluate(p))
    c = accumulate(topo.damper_target, cs.reshape(-1)[topo.damper_keep], "C")
    if topo.rayleigh is not None:
        alpha, beta = (float(prop.evaluate(p)[0]) for prop in topo.rayleigh)
        c = c + alpha * m + beta * k
    return c


def structure_matrices(topo: Topology, p: np.ndarray, dpn: int, sparse: bool = False
                       ) -> tuple[Matrix, Matrix, Matrix, np.ndarray]:
    """``M``, ``C``, ``K`` (dense, or CSR if ``sparse``) and the stack of beam mass matrices.

    ``M`` is checked here unless rigid diaphragms condense it first
    (:func:`constrained_system` checks the condensed one).
    """
    bp = {key: prop.evaluate(p) for key, prop in topo.beam_props.items()}
    phi = beam_shear_parameter(topo, bp)
    kb = beam_stiffnesses(topo, bp, phi, dpn)
    accumulate = accumulator(topo, sparse)
    mass_key = "mass_sparse" if sparse else "mass"
    cached = topo.cache.get(mass_key)
    if cached is not None:
        m, mb = cached[0].copy(), cached[1]
    else:
        mb = beam_masses(topo, bp, phi, dpn)
        m = mass_matrix(topo, p, mb, accumulate)
        if topo.diaphragms is None:
            check_mass(m, topo.labels, sparse)
        if topo.mass_const:
            topo.cache[mass_key] = (m.copy(), mb)

    ks = spring_matrix(topo.spring_k.evaluate(p))
    k = accumulate(
        np.concatenate([topo.beam_target, topo.spring_target]),
        np.concatenate([kb.reshape(-1)[topo.beam_keep], ks.reshape(-1)[topo.spring_keep]]),
        "K",
    )
    c = damping_matrix(topo, p, m, k, accumulate)
    return m, c, k, mb


def constrained_system(topo: Topology, m: Matrix, c: Matrix, k: Matrix, r: np.ndarray,
                       friction: FrictionElements | None, bouc_wen: BoucWenElements | None,
                       seismic: np.ndarray | None, sparse: bool) -> System:
    """The System on the independent DOFs of a structure with rigid diaphragms."""
    floors = topo.diaphragms
    if floors is None:
        raise ValueError("constrained_system: the topology has no rigid diaphragm")
    key = "diaphragm mass sparse" if sparse else "diaphragm mass"
    cached = topo.cache.get(key)
    if cached is not None and topo.mass_const:
        mq = cached[0].copy()
    else:
        mq = floors.transform(m)
        check_mass(mq, floors.labels, sparse)
        if topo.mass_const:
            topo.cache[key] = (mq.copy(), np.zeros(0))
    friction, bouc_wen = reindexed(floors, friction, bouc_wen)
    return System(M=mq, C=floors.transform(c), K=floors.transform(k), r=r[floors.kept],
                  friction=friction, dof_labels=floors.labels,
                  seismic=None if seismic is None else floors.T.T @ seismic,
                  bouc_wen=bouc_wen)

"""Sparse assembly and the lowest modes of large models (femupdate.model.sparse)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from femupdate.errors import ConfigError, ModelError
from femupdate.model import Structure, natural_frequencies, shear_building
from femupdate.model.sparse import _lanczos, lowest_modes, lumped_masses

E, A, I, RHO = 2.1e11, 1e-3, 1e-6, 7850.0  # noqa: E741


def portal_frame() -> Structure:
    """A planar frame with consistent beam mass, an inclined member, springs and dampers."""
    s = Structure(dofs_per_node=3)
    for name, x, y in (("a", 0, 0), ("b", 0, 3), ("c", 4, 3), ("d", 4, 0), ("e", 2, 5)):
        s.add_node(name, x=x, y=y)
    for i, (p, q) in enumerate((("a", "b"), ("b", "c"), ("d", "c"), ("b", "e"), ("e", "c"))):
        s.add_beam(p, q, E="E", A=A, I=I, rho=RHO, nu=0.3, name=f"b{i}")
    s.fix("a", "ux", "uy", "rz")
    s.add_spring("d", "ux", "kd")
    s.fix("d", "uy")
    s.add_damper("c", "ux", 30.0, node2="b")
    s.add_mass("e", m=50.0)
    s.set_rayleigh(0.1, 1e-4)
    return s


def test_sparse_assembly_equals_dense_for_a_frame_with_beam_mass():
    s = portal_frame()
    values = {"E": 2.0e11, "kd": 1e6}
    dense, sparse = s.assemble(values), s.assemble(values, sparse=True)
    for name in ("M", "C", "K"):
        mat = getattr(sparse, name)
        assert sp.issparse(mat)
        ref = getattr(dense, name)  # the same sums in another order: equal to rounding
        np.testing.assert_allclose(mat.toarray(), ref, rtol=0, atol=1e-15 * np.abs(ref).max())
    np.testing.assert_allclose(sparse.seismic_load, dense.seismic_load, rtol=1e-15)
    np.testing.assert_array_equal(sparse.r, dense.r)


def test_sparse_assembly_of_a_shear_building_with_parameters_twice():
    s = shear_building([1.0] * 50, ["k1"] * 25 + ["k2"] * 25, ["c"] * 50)
    for values in ({"k1": 3.0, "k2": 5.0, "c": 0.1}, {"k1": 4.0, "k2": 1.0, "c": 0.2}):
        dense, sparse = s.assemble(values), s.assemble(values, sparse=True)  # mass cached
        for name in ("M", "C", "K"):
            np.testing.assert_array_equal(getattr(sparse, name).toarray(), getattr(dense, name))


def shear_closed_form(n: int, k: float, m: float) -> np.ndarray:
    """Frequencies (Hz) of a uniform shear building fixed at its base, free at its top."""
    j = np.arange(1, n + 1)
    return 2.0 * np.sqrt(k / m) * np.sin((2 * j - 1) * np.pi / (2 * (2 * n + 1))) / (2 * np.pi)


@pytest.mark.parametrize("n", [40, 2000])  # dense path and shift-invert Lanczos
def test_lowest_modes_of_a_shear_building_match_the_closed_form(n):
    k, m = 16.0 * n * n, 1.0
    system = shear_building([m] * n, [k] * n).assemble(sparse=True)
    modes = lowest_modes(system.K, system.M, cutoff_hz=20.0)
    exact = shear_closed_form(n, k, m)
    expected = exact[exact <= 20.0]
    np.testing.assert_allclose(modes.freqs_hz, expected, rtol=1e-10)
    phi = modes.shapes
    np.testing.assert_allclose(phi.T @ (system.M @ phi), np.eye(phi.shape[1]), atol=1e-10)
    w2 = (2 * np.pi * modes.freqs_hz) ** 2
    np.testing.assert_allclose(system.K @ phi, (system.M @ phi) * w2, rtol=0,
                               atol=1e-8 * w2.max())


@pytest.mark.slow
def test_lowest_modes_agree_with_the_dense_modes_and_do_not_depend_on_the_start():
    n = 400
    s = shear_building(list(np.linspace(1.0, 2.0, n)), list(np.linspace(3e4, 1e4, n)))
    sparse = s.assemble(sparse=True)
    full = natural_frequencies(s.assemble())
    a = lowest_modes(sparse.K, sparse.M, n_modes=8)
    b = lowest_modes(sparse.K, sparse.M, cutoff_hz=float(a.freqs_hz[-1]) * 1.001, previous=a)
    np.testing.assert_allclose(a.freqs_hz, full.freqs_hz[:8], rtol=1e-10)
    np.testing.assert_allclose(b.freqs_hz, a.freqs_hz, rtol=1e-12)
    np.testing.assert_allclose(np.abs(b.shapes), np.abs(full.shapes[:, :8]), atol=1e-8)
    c = lowest_modes(sparse.K, sparse.M, n_modes=8)
    np.testing.assert_array_equal(c.shapes, a.shapes)  # same input, same result


def test_lumped_masses_take_the_standard_problem_with_the_generalised_ones_eigenpairs(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # Uneven masses and stiffnesses: the scaling by M^(-1/2) matters.
    n = 200  # above the dense eigensolver's limit of 120 DOFs
    s = shear_building(list(np.linspace(1.0, 3.0, n)), list(np.linspace(4e6, 1e6, n)))
    system = s.assemble(sparse=True)
    assert lumped_masses(system.M) is not None
    lumped = lowest_modes(system.K, system.M, n_modes=20)
    monkeypatch.setattr("femupdate.model.sparse.lumped_masses", lambda M: None)
    general = lowest_modes(system.K, system.M, n_modes=20)  # ARPACK with M at every step
    np.testing.assert_allclose(lumped.freqs_hz, general.freqs_hz, rtol=1e-12)
    np.testing.assert_allclose(lumped.shapes, general.shapes, rtol=0,
                               atol=1e-10 * np.abs(general.shapes).max())
    full = natural_frequencies(s.assemble())
    np.testing.assert_allclose(lumped.freqs_hz, full.freqs_hz[:20], rtol=1e-11)


def test_a_mass_matrix_that_is_not_diagonal_is_not_lumped() -> None:
    frame = portal_frame().assemble({"E": 2.0e11, "kd": 1e6}, sparse=True)
    assert lumped_masses(frame.M) is None  # consistent beam mass
    assert lumped_masses(sp.diags([1.0, 0.0, 2.0])) is None  # a DOF without mass
    assert lumped_masses(np.diag([1.0, 2.0])) is not None
    # the generalised path still finds the frame's modes (dense reference)
    w2, _ = _lanczos(frame.K, frame.M, 4, None)
    dense = natural_frequencies(portal_frame().assemble({"E": 2.0e11, "kd": 1e6}))
    np.testing.assert_allclose(np.sqrt(w2) / (2 * np.pi), dense.freqs_hz[:4], rtol=1e-10)


def test_mode_count_larger_than_the_model_is_refused():
    system = shear_building([1.0] * 5, [10.0] * 5).assemble(sparse=True)
    with pytest.raises(ConfigError, match=r"n_modes = 6 .* allowed 1 to 5"):
        lowest_modes(system.K, system.M, n_modes=6)
    with pytest.raises(ConfigError, match="cutoff_hz"):
        lowest_modes(system.K, system.M, cutoff_hz=-1.0)


def test_a_mechanism_is_refused_by_the_sparse_eigensolver():
    n = 300
    s = shear_building([1.0] * n, [0.0] + [10.0] * (n - 1))  # the first storey has no spring
    system = s.assemble(sparse=True)
    with pytest.raises(ModelError, match="mechanism"):
        lowest_modes(system.K, system.M, n_modes=3)


def test_a_massless_dof_is_refused_dense_and_condensed_sparse():
    """The step-by-step integrators need M⁻¹ (dense: refused, naming the DOF); the reduced
    path condenses a DOF without mass: the 3-storey chain with a massless middle storey is a
    2-DOF chain whose middle spring is k2, k3 in series (k/2)."""
    s = shear_building([1.0, 0.0, 1.0], [10.0] * 3)
    with pytest.raises(ModelError, match=r"F2\.ux"):
        s.assemble()
    system = s.assemble(sparse=True)
    modes = lowest_modes(system.K, system.M, cutoff_hz=1e3)
    k_chain = np.array([[10.0 + 5.0, -5.0], [-5.0, 5.0]])
    exact = np.sqrt(np.linalg.eigvalsh(k_chain)) / (2.0 * np.pi)
    np.testing.assert_allclose(modes.freqs_hz, exact, rtol=1e-13)
    # the massless floor sits statically between the others: u2 = (u1 + u3) / 2
    np.testing.assert_allclose(modes.shapes[1], 0.5 * (modes.shapes[0] + modes.shapes[2]),
                               rtol=1e-12)
    with pytest.raises(ConfigError, match=r"2 with mass.*allowed 1 to 2"):
        lowest_modes(system.K, system.M, n_modes=3)
    with pytest.raises(ModelError, match="no DOF of the model has mass"):
        shear_building([0.0, 0.0], [10.0] * 2).assemble(sparse=True)


def test_lanczos_and_condensation_agree_on_a_model_with_massless_dofs(monkeypatch):
    """Above CONDENSE_MAX_DOF DOFs with mass the modes come from Lanczos on the whole model
    (purified of M's null space): the same frequencies and shapes as the condensation, and as
    the dense generalised problem (M, K) solved for 1/ω²."""
    import scipy.linalg as sla

    from femupdate.model import sparse as sparse_module

    rng = np.random.default_rng(3)
    n = 300
    a = sp.random(n, n, density=0.02, random_state=1)
    K = (a @ a.T + 5.0 * sp.eye(n)).tocsr()
    m = np.zeros(n)
    m[rng.choice(n, 40, replace=False)] = rng.uniform(1.0, 2.0, 40)
    M = sp.diags(m).tocsr()
    condensed = lowest_modes(K, M, n_modes=40)
    mu = sla.eigh(M.toarray(), K.toarray(), eigvals_only=True)
    np.testing.assert_allclose((2 * np.pi * condensed.freqs_hz) ** 2,
                               np.sort(1.0 / mu[mu > 1e-12]), rtol=1e-12)
    monkeypatch.setattr(sparse_module, "CONDENSE_MAX_DOF", 10)
    lanczos = lowest_modes(K, M, cutoff_hz=float(condensed.freqs_hz[10:12].mean()))
    kept = lanczos.freqs_hz.size
    assert kept == 11
    np.testing.assert_allclose(lanczos.freqs_hz, condensed.freqs_hz[:kept], rtol=1e-12)
    np.testing.assert_allclose(lanczos.shapes, condensed.shapes[:, :kept], atol=1e-10)


def test_the_condensation_solves_the_whole_stiffness():
    """Condensation.solve (block elimination on K_ss's factorisation and K*) is K⁻¹."""
    from femupdate.model.sparse import condense

    a = sp.random(60, 60, density=0.1, random_state=2)
    K = (a @ a.T + 3.0 * sp.eye(60)).tocsr()
    m = np.zeros(60)
    m[::7] = 1.0
    b = np.random.default_rng(4).standard_normal((60, 3))
    x = condense(K, sp.diags(m)).solve(b)
    np.testing.assert_allclose(x, np.linalg.solve(K.toarray(), b), rtol=1e-11, atol=1e-12)

"""The linear part's factorisations and modes, computed once per process for a search that
changes only the nonlinear elements (femupdate.simulate._common.cached), and the explicit
stable step from those modes (central_difference.stuck_omega_max)."""

from __future__ import annotations

import numpy as np
import pytest

from femupdate.errors import SimulationError
from femupdate.model.system import BoucWenElements, System
from femupdate.simulate import _common, prepare
from femupdate.simulate import central_difference as cd_module
from femupdate.simulate._common import CACHE_SIZE, cached, omega_max
from femupdate.simulate.central_difference import stuck_omega_max

DT = 0.01


@pytest.fixture(autouse=True)
def empty_cache():
    _common._CACHE.clear()
    yield
    _common._CACHE.clear()


def _spd(rng: np.random.Generator, n: int, scale: float) -> np.ndarray:
    a = rng.standard_normal((n, n))
    return scale * (a @ a.T / n + np.eye(n))


def _chain(n: int = 6) -> System:
    """A shear chain of n masses; its base spring is a Bouc–Wen link (set per test), the
    others linear; Rayleigh damping on the mass (modal)."""
    k = np.full(n, 4e5)
    k[0] = 1e3  # the base: a soft spring beside the link
    K = np.diag(k + np.append(k[1:], 0.0)) - np.diag(k[1:], 1) - np.diag(k[1:], -1)
    M = np.diag(np.full(n, 100.0))
    return System(M=M, C=0.3 * M, K=K, r=np.ones(n))


def _with_link(system: System, k: float, alpha: float, n: float) -> System:
    table = np.array([[k, alpha, 1.0, 0.75 / 1e-3**n, 0.25 / 1e-3**n, n]])
    return System(M=system.M, C=system.C, K=system.K, r=system.r,
                  bouc_wen=BoucWenElements(dof_i=np.array([0]), dof_j=np.array([-1]),
                                           table=table))


def _record(n: int = 200) -> np.ndarray:
    rng = np.random.default_rng(3)
    a = np.convolve(rng.standard_normal(n + 10), np.hanning(11), mode="valid")[:n]
    return 3.0 * a / np.abs(a).max()


def test_cached_gives_the_function_result_once_per_function_and_bytes():
    calls = []

    def doubled(a):
        calls.append(1)
        return 2.0 * a

    def tripled(a):
        return 3.0 * a

    a = np.arange(4.0)
    first = cached(doubled, a)
    again = cached(doubled, a.copy())  # other object, same bytes
    assert again is first and len(calls) == 1
    np.testing.assert_array_equal(first, 2.0 * a)
    assert not first.flags.writeable  # shared: never written
    np.testing.assert_array_equal(cached(tripled, a), 3.0 * a)  # another function
    b = a.copy()
    b[0] = np.nextafter(0.0, 1.0)  # one ulp away: other bytes
    cached(doubled, b)
    assert len(calls) == 2
    cached(doubled, a.reshape(2, 2))  # same bytes, other shape
    assert len(calls) == 3


def test_cached_keeps_the_latest_few_and_no_exception(monkeypatch):
    calls = []

    def ident(a):
        calls.append(1)
        return a.copy()

    for i in range(CACHE_SIZE + 1):
        cached(ident, np.array([float(i)]))
    assert len(_common._CACHE) == CACHE_SIZE
    cached(ident, np.array([0.0]))  # the oldest was dropped: computed again
    assert len(calls) == CACHE_SIZE + 2

    _common._CACHE.clear()
    monkeypatch.setattr(_common, "CACHE_BYTES", 3000)
    for i in range(3):  # three of 1,008 bytes pass the byte budget
        cached(ident, np.full(126, float(i)))
    assert len(_common._CACHE) == 2
    huge = np.zeros(376)
    assert cached(ident, huge).shape == huge.shape  # computed, not kept
    assert len(_common._CACHE) == 2

    def fails(a):
        raise ValueError("no")

    for _ in range(2):
        with pytest.raises(ValueError):
            cached(fails, np.zeros(1))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_stuck_omega_max_is_the_generalised_problems(seed):
    rng = np.random.default_rng(seed)
    n, n_el = 12, 5
    M, K = _spd(rng, n, 10.0), _spd(rng, n, 1e6)
    rows = np.zeros((n_el, n))
    for e in range(n_el):  # element e between DOF e and DOF e + 3, or to the ground
        rows[e, e] = 1.0
        if e % 2:
            rows[e, e + 3] = -1.0
    k = rng.uniform(1e5, 1e8, n_el)
    w2, phi = cd_module.modal_damping(M, 0.1 * M, K)[:2]
    expected = omega_max(M, K + rows.T @ (k[:, None] * rows))
    assert stuck_omega_max(w2, phi, rows, k) == pytest.approx(expected, rel=1e-10)
    assert stuck_omega_max(w2, phi, rows[:0], k[:0]) == pytest.approx(np.sqrt(w2.max()),
                                                                       rel=1e-12)


def test_a_search_over_the_links_factorises_the_linear_part_once(monkeypatch):
    """Links changed, M, C and K not: the modes are computed once, and every response is the
    one an empty cache gives, bit for bit."""
    calls = []
    original = cd_module.modal_damping

    def counted(M, C, K):
        calls.append(1)
        return original(M, C, K)

    monkeypatch.setattr(cd_module, "modal_damping", counted)
    chain, ag = _chain(), _record()
    points = [(2e5, 0.1, 1.0), (4e5, 0.05, 2.0), (2e5, 0.1, 1.0)]
    responses = []
    for k, alpha, n in points:
        sim = prepare(_with_link(chain, k, alpha, n), DT, method="nonlinear", substeps=20)
        assert sim.modal
        responses.append(sim.run(ag))
    assert len(calls) == 1
    for (k, alpha, n), got in zip(points, responses, strict=True):
        _common._CACHE.clear()
        fresh = prepare(_with_link(chain, k, alpha, n), DT, method="nonlinear", substeps=20)
        want = fresh.run(ag)
        assert np.array_equal(got.displacement, want.displacement)
        assert np.array_equal(got.hysteretic_z, want.hysteretic_z)
    assert np.abs(responses[0].hysteretic_z).max() > 0.5e-3  # the link yields


def test_the_stable_step_still_refuses_a_stiff_link():
    """The stable step from the cached modes refuses what the generalised problem refuses."""
    system = _with_link(_chain(), 1e9, 0.1, 1.0)
    w = omega_max(system.M, system.K + system.bouc_wen.max_stiffness(system.n_dof))
    needed = int(np.floor(DT / (2.0 / w))) + 1
    with pytest.raises(SimulationError, match=f"use substeps >= {needed}"):
        prepare(system, DT, method="nonlinear", substeps=needed - 1)
    assert prepare(system, DT, method="nonlinear", substeps=needed).omega_max == pytest.approx(
        w, rel=1e-10)

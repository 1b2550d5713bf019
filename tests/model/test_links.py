"""The nonlinear links' initial stiffness as a matrix (femupdate.model.links): against the
elements' own connectivity products, dense and sparse, and its closed form for two links."""

from __future__ import annotations

import numpy as np

from femupdate.model.links import initial_link_stiffness, link_stiffness
from femupdate.model.system import BoucWenElements, FrictionElements


def test_two_links_in_series_closed_form() -> None:
    """A link to the ground at DOF 0 (k₁) and one between DOFs 0 and 1 (k₂): the textbook
    [[k₁ + k₂, −k₂], [−k₂, k₂]]; the ground may be either end."""
    expected = np.array([[3.0 + 5.0, -5.0], [-5.0, 5.0]])
    for i, j in (([0, 0], [-1, 1]), ([-1, 1], [0, 0])):
        got = link_stiffness(np.array(i), np.array(j), np.array([3.0, 5.0]), 2)
        np.testing.assert_array_equal(got, expected)
        np.testing.assert_array_equal(
            link_stiffness(np.array(i), np.array(j), np.array([3.0, 5.0]), 2,
                           sparse=True).toarray(), expected)


def test_initial_link_stiffness_is_the_elements_own() -> None:
    rng = np.random.default_rng(3)
    n = 6
    friction = FrictionElements(np.array([0, 2, 5]), np.array([-1, 3, 1]),
                                rng.uniform(1.0, 9.0, 3), np.full(3, 2.0))
    table = np.column_stack([rng.uniform(1.0, 9.0, 4), rng.uniform(0.0, 1.0, 4),
                             rng.uniform(0.5, 2.0, 4), np.full(4, 10.0), np.full(4, 5.0),
                             np.full(4, 1.0)])
    bouc_wen = BoucWenElements(np.array([1, 4, 0, 3]), np.array([-1, 2, 5, -1]), table)
    expected = friction.stuck_stiffness(n) + bouc_wen.initial_stiffness(n)
    np.testing.assert_allclose(initial_link_stiffness(friction, bouc_wen, n), expected,
                               rtol=1e-15, atol=0.0)
    np.testing.assert_allclose(
        initial_link_stiffness(friction, bouc_wen, n, sparse=True).toarray(), expected,
        rtol=1e-15, atol=0.0)
    assert not initial_link_stiffness(None, None, n).any()

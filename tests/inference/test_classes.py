"""Model-class probabilities from log-evidences (equal prior probabilities)."""

from __future__ import annotations

import math

import numpy as np

from femupdate.pipeline.posterior.classes import class_probabilities


def test_probabilities_are_the_normalised_evidences() -> None:
    p = class_probabilities([math.log(1.0), math.log(3.0)])
    np.testing.assert_allclose(p, [0.25, 0.75], rtol=1e-15)


def test_huge_log_evidences_do_not_overflow() -> None:
    p = class_probabilities([4369.69, 3643.26, 4369.69 - math.log(9.0)])
    np.testing.assert_allclose(p, [0.9, math.exp(3643.26 - 4369.69) * 0.9, 0.1], rtol=1e-12)
    assert p[1] > 0.0  # 1e-316: subnormal, not rounded to 0


def test_a_class_without_an_evidence_gets_none_and_is_left_out() -> None:
    p = class_probabilities([None, 2.0, 2.0])
    assert math.isnan(p[0])
    np.testing.assert_allclose(p[1:], [0.5, 0.5])
    assert np.isnan(class_probabilities([None])).all()

"""The elasto-slip (Jenkins) friction law of Zapico-Valle et al. 2010, §5.3 (Eqs. 19–21;
docs/method.md §8.3).

A spring of stiffness ``k_r`` in series with a Coulomb slider of slip force ``f_u``. With the
element deformation ``y`` and the slip offset ``y_r`` (the slider's accumulated slip), the spring
stretches by ``y - y_r``:

    f = k_r (y - y_r)               while |y - y_r| <= f_u / k_r   (stuck)
    f = f_u sign(y - y_r)           otherwise, and y_r moves so that |y - y_r| = f_u / k_r (slip)

The law is rate independent and explicit: the force follows from the current deformation and
the previous slip offset only. It is compiled with numba so the integrators can call it inside
their time loops; it can be called from Python too (scalars in, a tuple out).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from femupdate.errors import ModelError


@njit(cache=True, inline="always")
def elasto_slip(y: float, y_r: float, k_r: float, f_u: float) -> tuple[float, float]:
    """Force in an elasto-slip element and its updated slip offset.

    Parameters
    ----------
    y : float
        Element deformation (``y_i - y_j``).
    y_r : float
        Slip offset before this update.
    k_r : float
        Stiffness of the spring in series with the slider, ``>= 0``. ``0`` gives no force.
    f_u : float
        Slip force, ``>= 0``. ``0`` gives no force (the slider follows ``y``); ``inf`` gives a
        linear spring that never slips.

    Returns
    -------
    force : float
        Force the element exerts, positive in tension (``k_r (y - y_r)`` while stuck).
    y_r : float
        Slip offset after the update, so that ``|y - y_r| <= f_u / k_r``.
    """
    if k_r <= 0.0:
        return 0.0, y_r
    limit = f_u / k_r  # inf for f_u = inf: never slips
    # The slider follows only as far as it must: clamping y_r to [y - limit, y + limit] is the
    # stick/slip decision without branches (a mispredicted branch costs more than the law).
    # The force is clamped too: k_r (y - y_r) loses digits to cancellation when |y| >> limit.
    y_r = min(max(y_r, y - limit), y + limit)
    return min(max(k_r * (y - y_r), -f_u), f_u), y_r


def check_friction_parameters(k_r: np.ndarray, f_u: np.ndarray) -> None:
    """Raise ModelError unless every ``k_r`` is finite and ``>= 0`` and every ``f_u >= 0``.

    ``f_u = inf`` (a slider that never slips) is allowed.
    """
    k_r = np.asarray(k_r, dtype=np.float64)
    f_u = np.asarray(f_u, dtype=np.float64)
    bad = np.flatnonzero(~(np.isfinite(k_r) & (k_r >= 0.0)))
    if bad.size:
        e = int(bad[0])
        raise ModelError(
            f"friction element {e}: k_r = {float(k_r[e])!r} is not allowed; "
            "the stick stiffness must be finite and >= 0"
        )
    bad = np.flatnonzero(~(f_u >= 0.0))  # catches NaN too
    if bad.size:
        e = int(bad[0])
        raise ModelError(
            f"friction element {e}: f_u = {float(f_u[e])!r} is not allowed; "
            "the slip force must be >= 0 (inf for a slider that never slips)"
        )

"""The prediction's processing and the error function, compiled: :func:`process_and_compare`.

The simulation kernels write the raw outputs (relative or absolute acceleration, or
displacement) channel by channel; one pass per channel then does what
``UpdateProblem.prediction`` and ``Objective`` do with arrays — the causal high-pass of the data
(``scipy.signal.sosfilt``'s recurrence: transposed direct form II per second-order section, zero
initial state), two trapezoidal integrations from zero (``cumulative_trapezoid``'s rule,
``v_k = v_{k-1} + dt (a_k + a_{k-1}) / 2``), the difference with the measured channel and, with
experimental parameters, its projection on span{1, t} — and a second pass sums the squared
residual (two passes, not ``‖d‖² − ‖Qᵀd‖²``, which would cancel when the fitted constants carry
most of ``d``). φ is Eq. 1.

A trial scored over a ``score_window`` (samples ``start`` to ``stop`` of the record) is processed
from the record's first sample, as the step-by-step path processes the whole prediction before
it slices it, up to the window's last (a causal filter and the integrations never look ahead);
only the window's samples are compared, their differences written to the front of the channel's
row (sample ``start + j`` to place ``j``, already read).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

__all__ = ["Post", "integrate_rows", "process_and_compare"]

# Reassociated sums (vectorised reductions; their order is fixed when the kernel compiles, so
# results repeat bit for bit); no 'nnan'/'ninf': φ must come out inf for a NaN prediction.
_FASTMATH = {"contract", "reassoc"}


class Post(NamedTuple):
    """How a simulated channel becomes a prediction, and what it is compared with.

    Attributes
    ----------
    sos : ndarray (n_sections, 6)
        The causal high-pass applied to the prediction (no rows: none).
    integrate : bool
        Integrate twice (trapezoidal rule, zero initial values).
    dt : float
        Sample interval, s.
    target : ndarray (n_channels, n_samples)
        The measured target, channel by channel.
    q : ndarray (2, n_samples)
        Orthonormal basis of span{1, t} (``Objective._q`` transposed), when ``projected``.
    qty : ndarray (2, n_channels)
        ``Qᵀ y`` of the target.
    energy : ndarray (n_channels,)
        ``Σ y²`` per channel, or with ``projected`` ``‖P⊥ y‖²``.
    weights : ndarray (n_channels,)
    projected : bool
        Fit two integration constants per channel (experimental parameters).
    start, stop : int
        The scored samples of the record (``stop - start`` of them: the target's length).
    """

    sos: np.ndarray
    integrate: bool
    dt: float
    target: np.ndarray
    q: np.ndarray
    qty: np.ndarray
    energy: np.ndarray
    weights: np.ndarray
    projected: bool
    start: int
    stop: int


@njit(cache=True, fastmath=_FASTMATH)
def _channel(y: np.ndarray, sos: np.ndarray, integrate: bool, dt: float, target: np.ndarray,
             q: np.ndarray, projected: bool, zi: np.ndarray, start: int, stop: int
             ) -> tuple[float, float, float]:
    """One channel in place: filter, integrate, ``d = ŷ − y`` over samples ``start:stop``
    (written to ``y[:stop - start]``); returns (Σd², Qᵀd)."""
    zi[:] = 0.0
    n_sections = sos.shape[0]
    prev = 0.0
    vel = 0.0
    disp = 0.0
    ss = 0.0
    c0 = 0.0
    c1 = 0.0
    for k in range(stop):
        x = y[k]
        for s in range(n_sections):
            x_new = sos[s, 0] * x + zi[2 * s]
            zi[2 * s] = sos[s, 1] * x - sos[s, 4] * x_new + zi[2 * s + 1]
            zi[2 * s + 1] = sos[s, 2] * x - sos[s, 5] * x_new
            x = x_new
        if integrate:
            if k == 0:
                prev = x
                x = 0.0
            else:
                v_new = vel + dt * (x + prev) / 2.0
                disp = disp + dt * (v_new + vel) / 2.0
                vel = v_new
                prev = x
                x = disp
        if k < start:
            continue
        j = k - start
        d = x - target[j]
        y[j] = d
        if projected:
            c0 += q[0, j] * d
            c1 += q[1, j] * d
        else:
            ss += d * d
    return ss, c0, c1


@njit(cache=True, fastmath=_FASTMATH)
def _projected_residual(d: np.ndarray, q: np.ndarray, c0: float, c1: float) -> float:
    """``‖d − Q c‖²`` (the second pass)."""
    s = 0.0
    for k in range(d.shape[0]):
        r = d[k] - (q[0, k] * c0 + q[1, k] * c1)
        s += r * r
    return s


@njit(cache=True)
def process_and_compare(post: Post, y: np.ndarray, per_channel: np.ndarray,
                        zi: np.ndarray) -> float:
    """φ of the raw outputs ``y`` (n_channels, n_samples; the scored samples' ``ŷ − y``
    written to ``y[:, :stop - start]``).

    Also fills each channel's error into ``per_channel``; ``zi`` is scratch (2 n_sections).
    Returns inf when the prediction holds NaN or inf.
    """
    nc = y.shape[0]
    scored = post.stop - post.start
    num = 0.0
    den = 0.0
    for o in range(nc):
        ss, c0, c1 = _channel(y[o], post.sos, post.integrate, post.dt, post.target[o], post.q,
                              post.projected, zi, post.start, post.stop)
        if post.projected:
            ss = _projected_residual(y[o, :scored], post.q, c0, c1)
            e0 = c0 + post.qty[0, o]
            e1 = c1 + post.qty[1, o]
            per_channel[o] = ss / (post.energy[o] + (e0 * e0 + e1 * e1))
        else:
            per_channel[o] = ss / post.energy[o]
        num += post.weights[o] * per_channel[o]
        den += post.weights[o]
    phi = num / den
    if not np.isfinite(phi):
        return np.inf
    return phi


@njit(cache=True)
def integrate_rows(y: np.ndarray, dt: float) -> None:
    """Two trapezoidal integrations from zero of every row, in place."""
    for o in range(y.shape[0]):
        prev = y[o, 0]
        vel = 0.0
        disp = 0.0
        y[o, 0] = 0.0
        for k in range(1, y.shape[1]):
            x = y[o, k]
            v_new = vel + dt * (x + prev) / 2.0
            disp = disp + dt * (v_new + vel) / 2.0
            vel = v_new
            prev = x
            y[o, k] = disp

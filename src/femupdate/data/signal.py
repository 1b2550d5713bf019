"""Signal processing of measured records (the paper's §5.2; docs/method.md §7), as pure
functions on arrays.

Samples are on axis 0 throughout: a signal is (n,) or (n, n_channels).

The paper's chain, absolute accelerations to relative displacements::

    a_rel = relative(acc, table)                       # channel minus table
    a_f   = highpass(a_rel, fs, cutoff=5.0, order=4) # removes drifting offsets
    d     = integrate_twice(a_f, dt)                   # trapezoidal, zero initial values
    d_fine = substeps(d, 10)                           # each interval in 10 substeps

The sampling is given as scipy gives it: ``fs`` (Hz) to the frequency-domain functions
(filters, spectra, transfer functions, delays), as ``scipy.signal``; ``dt`` (s) to the
time-domain integration, as ``scipy.integrate``'s ``dx``. (``rate=`` is the former name of
``fs``: still accepted, deprecated.)

A channel recorded late (a sensor's latency) is realigned before that chain::

    tau = estimate_delay(table, roof, fs, band=(1.0, 10.0))  # phase slope, below resonance
    roof = advance(roof, tau, fs)                            # band-limited fractional shift
"""

from __future__ import annotations

import functools
import math
import warnings
from collections.abc import Callable
from typing import Literal

import numpy as np
import scipy.integrate
import scipy.signal

from femupdate.errors import ConfigError, DataError

__all__ = [
    "advance",
    "detrend",
    "estimate_delay",
    "fourier_amplitude",
    "highpass",
    "integrate",
    "integrate_twice",
    "peak_frequency",
    "relative",
    "remove_polynomial",
    "substep_times",
    "substeps",
    "transfer_function",
]


def _rate_renamed(fn: Callable[..., object]) -> Callable[..., object]:
    """Accept ``rate=``, the former name of ``fs`` (with a DeprecationWarning)."""

    @functools.wraps(fn)
    def wrapper(*args: object, **kwargs: object) -> object:
        if "rate" in kwargs:
            warnings.warn(f"{fn.__name__}(rate=...) is deprecated: the sampling rate is fs=, "
                          "as in scipy.signal", DeprecationWarning, stacklevel=2)
            kwargs["fs"] = kwargs.pop("rate")
        return fn(*args, **kwargs)

    return wrapper


def _as_signal(y: np.ndarray, name: str = "y") -> np.ndarray:
    y = np.asarray(y, dtype=float)
    if y.ndim not in (1, 2) or y.shape[0] < 2:
        raise DataError(f"{name} must have shape (n,) or (n, channels) with n >= 2, "
                        f"got {y.shape}")
    return y


def _check_rate(fs: float) -> None:
    if not (np.isfinite(fs) and fs > 0):
        raise ConfigError(f"fs must be a positive sampling rate in Hz, got {fs!r}")


def _check_dt(dt: float) -> None:
    if not (np.isfinite(dt) and dt > 0):
        raise ConfigError(f"dt must be a positive time step in s, got {dt!r}")


@functools.lru_cache(maxsize=16)
def _butter_highpass(order: int, cutoff: float, fs: float) -> np.ndarray:
    """Second-order sections of a Butterworth high-pass (cached: a model's prediction is
    filtered at every evaluation)."""
    return scipy.signal.butter(order, cutoff, btype="highpass", fs=fs, output="sos")


@_rate_renamed
def highpass(y: np.ndarray, fs: float, cutoff: float, *, order: int = 4,
             zero_phase: bool = True) -> np.ndarray:
    """Butterworth high-pass filter along axis 0.

    Parameters
    ----------
    y : ndarray, shape (n,) or (n, k)
        Signal.
    fs : float
        Sampling rate, Hz.
    cutoff : float
        -3 dB frequency of the designed filter, Hz, in (0, fs/2).
    order : int
        Filter order, 1–20.
    zero_phase : bool
        True: forward-backward (`sosfiltfilt`), no delay, the magnitude response squared
        (gain 0.5 at ``cutoff``, effective order doubled). False: causal `sosfilt`.
    """
    y = _as_signal(y)
    _check_rate(fs)
    _check_cutoff("cutoff", cutoff, fs)
    _check_order(order)
    return _filtered(_butter_highpass(order, float(cutoff), float(fs)), y, zero_phase)


def _check_cutoff(what: str, cutoff: float, fs: float) -> None:
    if not 0 < cutoff < fs / 2:
        raise ConfigError(f"{what} must be in (0, {fs / 2:g}) Hz (below Nyquist), "
                          f"got {cutoff!r}")


def _check_order(order: int) -> None:
    if not 1 <= order <= 20:
        raise ConfigError(f"order must be an integer in 1..20, got {order!r}")


def _filtered(sos: np.ndarray, y: np.ndarray, zero_phase: bool) -> np.ndarray:
    """``y`` through the sections ``sos``: forward-backward or causal."""
    if zero_phase:
        return scipy.signal.sosfiltfilt(sos, y, axis=0)
    return scipy.signal.sosfilt(sos, y, axis=0)


@functools.lru_cache(maxsize=16)
def band_sos(fs: float, highpass_hz: float, highpass_order: int, lowpass_hz: float | None,
             lowpass_order: int) -> np.ndarray:
    """Second-order sections of the preprocessing's filter: the Butterworth high-pass (when
    ``highpass_hz`` > 0) then the Butterworth low-pass (when ``lowpass_hz`` is given), in
    cascade (cached: a model's prediction is filtered at every evaluation). Without a
    low-pass they are the high-pass's own, so the results are those of :func:`highpass`."""
    parts = []
    if highpass_hz > 0.0:
        parts.append(_butter_highpass(highpass_order, float(highpass_hz), float(fs)))
    if lowpass_hz is not None:
        parts.append(scipy.signal.butter(lowpass_order, float(lowpass_hz), btype="lowpass",
                                         fs=fs, output="sos"))
    return np.vstack(parts) if parts else np.zeros((0, 6))


def band(y: np.ndarray, fs: float, highpass_hz: float, lowpass_hz: float | None = None, *,
         highpass_order: int = 4, lowpass_order: int = 4,
         zero_phase: bool = True) -> np.ndarray:
    """The preprocessing's filter along axis 0: a Butterworth high-pass at ``highpass_hz``
    (0: none) and a Butterworth low-pass at ``lowpass_hz`` (None: none), each in (0, fs/2).

    ``zero_phase`` as in :func:`highpass`. With no low-pass this is :func:`highpass` (the same
    bits); with neither filter, ``y`` unchanged.
    """
    y = _as_signal(y)
    _check_rate(fs)
    if highpass_hz != 0.0:
        _check_cutoff("highpass cutoff", highpass_hz, fs)
    if lowpass_hz is not None:
        _check_cutoff("lowpass cutoff", lowpass_hz, fs)
    _check_order(highpass_order)
    _check_order(lowpass_order)
    sos = band_sos(float(fs), float(highpass_hz), int(highpass_order),
                   None if lowpass_hz is None else float(lowpass_hz), int(lowpass_order))
    return _filtered(sos, y, zero_phase) if sos.shape[0] else y


def relative(acceleration: np.ndarray, table: np.ndarray) -> np.ndarray:
    """Acceleration relative to the table: each channel minus the table acceleration.

    ``acceleration`` is (n,) or (n, k); ``table`` is (n,).
    """
    a = _as_signal(acceleration, "acceleration")
    g = np.asarray(table, dtype=float)
    if g.shape != (a.shape[0],):
        raise DataError(f"table acceleration must have shape ({a.shape[0]},) like the "
                        f"channels, got {g.shape}")
    return a - (g if a.ndim == 1 else g[:, None])


def integrate(y: np.ndarray, dt: float) -> np.ndarray:
    """Cumulative trapezoidal integral along axis 0, starting at 0."""
    y = _as_signal(y)
    _check_dt(dt)
    return scipy.integrate.cumulative_trapezoid(y, dx=dt, axis=0, initial=0.0)


def integrate_twice(acceleration: np.ndarray, dt: float) -> np.ndarray:
    """Displacement from acceleration by two trapezoidal integrations, zero initial values.

    The unknown initial displacement and velocity are the two "experimental parameters"
    that the objective fits (`femupdate.problem.objective.ErrorFunction`).
    """
    return integrate(integrate(acceleration, dt), dt)


def substep_times(t: np.ndarray, n: int) -> np.ndarray:
    """Times of `substeps`: each interval of ``t`` split into ``n`` equal substeps."""
    return substeps(t, n)


def substeps(y: np.ndarray, n: int) -> np.ndarray:
    """Split each sample interval into ``n`` substeps, linearly interpolated.

    Returns ``(len(y) - 1) * n + 1`` samples; every ``n``-th is an original sample.
    """
    y = _as_signal(y)
    if not (isinstance(n, int | np.integer) and n >= 1):
        raise ConfigError(f"n (substeps per interval) must be an integer >= 1, got {n!r}")
    frac = np.arange(n) / n
    shape = (1, n) if y.ndim == 1 else (1, n, 1)
    steps = y[:-1, None] + frac.reshape(shape) * (y[1:] - y[:-1])[:, None]
    out = steps.reshape((-1, *y.shape[1:]))
    return np.concatenate([out, y[-1:]], axis=0)


def detrend(y: np.ndarray, kind: Literal["constant", "linear"] = "linear") -> np.ndarray:
    """Remove the mean ("constant") or the least-squares line ("linear") along axis 0."""
    y = _as_signal(y)
    if kind not in ("constant", "linear"):
        raise ConfigError(f"kind must be 'constant' or 'linear', got {kind!r}")
    return scipy.signal.detrend(y, axis=0, type=kind)


def remove_polynomial(y: np.ndarray, order: int, *, fit: slice | None = None) -> np.ndarray:
    """Subtract a least-squares polynomial of the sample index, degree ``order``.

    Parameters
    ----------
    fit : slice, optional
        Samples the polynomial is fitted to (e.g. a pre-event window ``slice(0, 200)`` with
        ``order=0`` removes the pre-event offset); it is subtracted from all samples.
    """
    y = _as_signal(y)
    if not (isinstance(order, int | np.integer) and 0 <= order <= 10):
        raise ConfigError(f"order must be an integer in 0..10, got {order!r}")
    x = np.linspace(-1.0, 1.0, y.shape[0])  # scaled for a well-conditioned fit
    basis = np.polynomial.legendre.legvander(x, order)
    rows = np.arange(y.shape[0])[fit if fit is not None else slice(None)]
    if rows.size <= order:
        raise DataError(f"fit window holds {rows.size} samples, need more than order={order}")
    coef, *_ = np.linalg.lstsq(basis[rows], y[rows], rcond=None)
    return y - basis @ coef


def fourier_amplitude(y: np.ndarray, dt: float | None = None, *,
                      fs: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Fourier amplitude spectrum ``|Y(f)| = |Σ y_k e^{-2πi f k/fs}| / fs`` (units·s).

    Returns the frequencies 0..Nyquist, Hz, and the amplitudes (same trailing shape as y).
    The sampling rate is ``fs`` (Hz); a sample interval ``dt`` in its place is deprecated.
    """
    y = _as_signal(y)
    if dt is not None:
        warnings.warn("fourier_amplitude(y, dt) is deprecated: give the sampling rate, "
                      "fourier_amplitude(y, fs=1/dt)", DeprecationWarning, stacklevel=2)
        _check_dt(dt)
        fs = 1.0 / dt
    if fs is None:
        raise ConfigError("fourier_amplitude needs the sampling rate fs (Hz)")
    _check_rate(fs)
    return np.fft.rfftfreq(y.shape[0], 1.0 / fs), np.abs(np.fft.rfft(y, axis=0)) / fs


@_rate_renamed
def transfer_function(x: np.ndarray, y: np.ndarray, fs: float, *,
                      nperseg: int | None = None,
                      window: str = "hann") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """H1 estimate of the transfer function from input ``x`` to output(s) ``y``.

    ``H1(f) = S_xy(f) / S_xx(f)`` (Welch averages; `scipy.signal.csd` and `welch`), with the
    magnitude-squared coherence ``|S_xy|² / (S_xx S_yy)``.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Input, e.g. the table acceleration.
    y : ndarray, shape (n,) or (n, k)
        Output(s), e.g. absolute accelerations of the structure.
    fs : float
        Sampling rate, Hz.
    nperseg : int, optional
        Welch segment length; default n // 8 (at least 16 samples, at most n).

    Returns
    -------
    f : ndarray, shape (m,)
    H : ndarray, complex, shape (m,) or (m, k)
    coherence : ndarray, shape like H
    """
    x = _as_signal(x, "x")
    y = _as_signal(y, "y")
    _check_rate(fs)
    if x.ndim != 1 or y.shape[0] != x.shape[0]:
        raise DataError(f"x must be (n,) and y (n,) or (n, k) with the same n; got {x.shape} "
                        f"and {y.shape}")
    n = x.shape[0]
    seg = nperseg if nperseg is not None else min(n, max(16, n // 8))
    if not 2 <= seg <= n:
        raise ConfigError(f"nperseg must be in 2..{n} (the signal length), got {seg}")
    yy = y if y.ndim == 2 else y[:, None]
    f, sxx = scipy.signal.welch(x, fs=fs, window=window, nperseg=seg)
    _, sxy = scipy.signal.csd(x[:, None], yy, fs=fs, window=window, nperseg=seg, axis=0)
    _, syy = scipy.signal.welch(yy, fs=fs, window=window, nperseg=seg, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        h = sxy / sxx[:, None]
        coh = np.abs(sxy) ** 2 / (sxx[:, None] * syy)
    if y.ndim == 1:
        h, coh = h[:, 0], coh[:, 0]
    return f, h, coh


def peak_frequency(f: np.ndarray, h: np.ndarray,
                   band: tuple[float, float] | None = None) -> float | np.ndarray:
    """Frequency of the largest ``|h|`` within ``band`` (Hz), refined by a parabola.

    The parabola through the log magnitudes of the peak bin and its neighbours gives the
    peak between bins. Returns a float for 1-D ``h``, an array (k,) for ``h`` (m, k).
    """
    f = np.asarray(f, dtype=float)
    mag = np.abs(np.asarray(h))
    if mag.shape[0] != f.size:
        raise DataError(f"h has {mag.shape[0]} frequencies on axis 0 but f has {f.size}")
    lo, hi = band if band is not None else (f[0], f[-1])
    inside = np.flatnonzero((f >= lo) & (f <= hi))
    if inside.size < 1:
        raise ConfigError(f"band [{lo}, {hi}] Hz holds no frequency of f "
                          f"([{f[0]:.6g}, {f[-1]:.6g}] Hz)")
    cols = mag if mag.ndim == 2 else mag[:, None]
    out = np.empty(cols.shape[1])
    df = f[1] - f[0] if f.size > 1 else 0.0
    for j in range(cols.shape[1]):
        k = inside[np.argmax(cols[inside, j])]
        out[j] = f[k]
        if 0 < k < f.size - 1 and np.all(cols[k - 1:k + 2, j] > 0):
            a, b, c = np.log(cols[k - 1:k + 2, j])
            denom = a - 2 * b + c
            if denom < 0:
                out[j] = f[k] + 0.5 * (a - c) / denom * df
    return float(out[0]) if mag.ndim == 1 else out


def _delay_nperseg(fs: float, band: tuple[float, float], n: int) -> int:
    """Welch segment for `estimate_delay`: bins of at most 1/16 of the band, at most ``n``."""
    target = 16.0 * fs / (band[1] - band[0])
    return int(min(n, 2 ** math.ceil(math.log2(max(target, 16.0)))))


@_rate_renamed
def estimate_delay(x: np.ndarray, y: np.ndarray, fs: float, *,
                   band: tuple[float, float] = (1.0, 10.0),
                   nperseg: int | None = None,
                   full_output: bool = False) -> float | tuple[float, float]:
    """Delay of ``y`` behind ``x`` (s) from the phase slope of their transfer function.

    Fits ``phase(f) = −2π f τ`` (a line through the origin) to the unwrapped phase of the H1
    estimate (`transfer_function`) in ``band``, each frequency weighted by ``γ²/(1 − γ²)``
    (γ² the coherence), the inverse of the variance of the phase estimate.

    Valid where ``y`` follows ``x`` with a negligible phase of its own: a structure well below
    its first resonance (a storey of natural frequency f_n and damping ζ adds a phase of about
    −2ζ (f/f_n)³ there, an apparent delay ζ f² / (π f_n³)), and for delays shorter than
    half a period of the band's low end (``|τ| < 1/(2 band[0])``: the phase is unwrapped from
    there, so a whole number of periods more would not be seen).

    Parameters
    ----------
    x, y : ndarray, shape (n,)
        Input and output records, same sampling.
    fs : float
        Sampling rate, Hz.
    band : (float, float)
        Frequencies used, Hz, ``0 < low < high < fs/2``.
    nperseg : int, optional
        Welch segment length; default: the power of 2 that makes the frequency bins at most
        1/16 of the band (256 samples for 1–10 Hz at 120 Hz), at most ``n``.
    full_output : bool
        Also return the median coherence γ² in the band (how much the estimate can be
        trusted).

    Returns
    -------
    float, or (float, float)
        τ in seconds, positive when ``y`` lags ``x``; with ``full_output`` also the median
        coherence.

    Raises
    ------
    ConfigError
        A band outside (0, Nyquist) or holding fewer than 2 frequencies of the estimate.
    DataError
        Records of different lengths, or no coherent signal in the band.
    """
    x = _as_signal(x, "x")
    y = _as_signal(y, "y")
    _check_rate(fs)
    lo, hi = (float(b) for b in band)
    if not 0.0 < lo < hi < fs / 2:
        raise ConfigError(f"band = [{lo:g}, {hi:g}] Hz: need 0 < low < high < {fs / 2:g} Hz "
                          "(the Nyquist frequency)")
    if x.ndim != 1 or y.shape != x.shape:
        raise DataError(f"x and y must both have shape (n,), got {x.shape} and {y.shape}")
    seg = _delay_nperseg(fs, (lo, hi), x.size) if nperseg is None else nperseg
    f, h, coh = transfer_function(x, y, fs, nperseg=seg)
    inside = (f >= lo) & (f <= hi)
    if np.count_nonzero(inside) < 2:
        raise ConfigError(f"band = [{lo:g}, {hi:g}] Hz holds {np.count_nonzero(inside)} "
                          f"frequencies of the Welch estimate (resolution {f[1]:.3g} Hz, "
                          f"{seg}-sample segments): widen it, or give longer records")
    omega = 2.0 * np.pi * f[inside]
    phase = np.unwrap(np.angle(h[inside]))
    gamma2 = np.clip(coh[inside], 0.0, 1.0 - 1e-9)
    w = gamma2 / (1.0 - gamma2)
    if not (np.all(np.isfinite(phase)) and np.all(np.isfinite(w)) and w.sum() > 0.0):
        raise DataError(f"no coherent signal between {lo:g} and {hi:g} Hz: the delay cannot be "
                        "estimated")
    tau = float(-np.sum(w * omega * phase) / np.sum(w * omega * omega))
    return (tau, float(np.median(gamma2))) if full_output else tau


@_rate_renamed
def advance(y: np.ndarray, delay: float, fs: float) -> np.ndarray:
    """``y(t + delay)``: the record shifted earlier by ``delay`` s (later for ``delay < 0``).

    A band-limited (Fourier) fractional shift along axis 0, exact for signals below the
    Nyquist frequency. The least-squares line through each channel is removed first and added
    back at the shifted times, and the record is extended by its mirror image (a continuous
    periodic extension), so that the ends do not ring as a jump would make them. The last
    (first, for a negative delay) ``ceil(|delay| · fs)`` samples lie beyond the record and
    the few next to them, at both ends, are approximate: trim them.

    Parameters
    ----------
    y : ndarray, shape (n,) or (n, k)
        Record(s), uniformly sampled.
    delay : float
        Shift, s: how late ``y`` was recorded.
    fs : float
        Sampling rate, Hz.
    """
    y = _as_signal(y)
    _check_rate(fs)
    if not math.isfinite(delay):
        raise ConfigError(f"delay must be a finite number of seconds, got {delay!r}")
    if delay == 0.0:
        return y.copy()
    n = y.shape[0]
    t = np.arange(n) / fs
    slope, intercept = np.polyfit(t, y, 1)
    rest = y - (np.multiply.outer(t, slope) + intercept)
    even = np.concatenate([rest, rest[::-1]], axis=0)
    f = np.fft.rfftfreq(even.shape[0], 1.0 / fs)
    phasor = np.exp(2j * np.pi * f * delay)
    spectrum = np.fft.rfft(even, axis=0) * (phasor if y.ndim == 1 else phasor[:, None])
    shifted = np.fft.irfft(spectrum, even.shape[0], axis=0)[:n]
    return shifted + np.multiply.outer(t + delay, slope) + intercept

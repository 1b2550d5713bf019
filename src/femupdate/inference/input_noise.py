"""Errors in the variables: the table's record is measured with noise too (error model ``"eiv"``).

A shake-table model is driven by the table's *measured* acceleration, so the noise n_u of that
sensor reaches every channel's residual through the model. For a linear model and a linear
processing of the records (high-pass, integration to displacement), a trial's residual is, to
first order in the noise,

    r = G n_y − T n_u + (what the fit absorbs),

G the processing of each output sensor's own noise n_y (its residual block only), T the
model's response to the table's noise through the same processing: narrow-band at the
resonances, where the parameters' sensitivities are, and one signal in every channel of the
trial. A per-channel AR filter (the lab's kind ``"arp"``) whitens G n_y but not T n_u, which
is why ``"arp"`` is calibrated when the table's record is clean and too confident when it is
not (docs/history.md, "Posterior").

This module gives the likelihood of that structure in the frequency domain (Whittle 1953).
Each block is first prewhitened by a fixed AR filter A_c of ``"arp"``'s order, fitted to the
impulse response of the channel's own noise path G_c (it flattens the steep spectrum of
displacement noise, so that the transform of a finite record leaks little from one frequency
to another, without notching the resonances as a filter fitted to the residual would) and
tapered by a split cosine bell h (:func:`taper`: a line above the band weighed, which the
prewhitening amplifies, would otherwise leak into it through the rectangular window's slow
sidelobes); then, at each frequency ω_k = 2πk/n of the n prewhitened samples, the C channels'
coefficients E_k = rfft(h · A r)(ω_k) are complex Gaussian with

    S_k = n [ diag(σ_c² |A_c(ω_k) G_c(ω_k)|²) + σ_u² t_k t_kᴴ ],   t_k,c = A_c(ω_k) T_c(ω_k),

independent across frequencies. G and T are not modelled by hand: they are the transforms of
the responses of the case's own processing (:func:`femupdate.trials.experiment.process`) and model
(:meth:`~femupdate.problem.update.TrialProblem.prediction_driven_by`) to a unit impulse in each raw
record, at the best fit, folded onto the n-point grid (so they hold whatever the case's
processing and model are, as long as both are linear). The noise levels σ_c (each output
sensor) and σ_u (the table's sensor), in the records' units, are fitted by maximising Whittle's
likelihood of the residual at the best fit (:func:`fit_noise_levels`). Then everything is fixed
and the likelihood of a residual vector is that of its whitened coefficients
w_k = W_k E_k, W_k = (I − β u uᴴ) D_k^{−1/2} (D_k the diagonal part, g = D_k^{−1/2} t_k,
u = g/‖g‖, β = 1 − (1 + nσ_u²‖g‖²)^{−1/2}, so that W_kᴴ W_k = S_k⁻¹), real and imaginary parts
each scaled by √2 to unit variance: a fixed linear map of r, so the Laplace Gaussian and
TMCMC treat it as any error model. Frequencies 0 and n/2 are left out (real coefficients), and
so are those where the processing's gain to a channel's own noise is below :data:`GAIN_RANGE`
of its largest (they carry only rounding, which their whitening would amplify: on the bridge,
the few next to the Nyquist frequency, where the trapezoidal integration's gain is 0), and
those where the record's finite length moves the expected periodogram more than
:data:`LEAKAGE_TOLERANCE` from S_k (:func:`expected_periodogram`: on the bridge, the lowest
six, deep in the high-pass's stop band, where their neighbours' power leaks in, and a few
dozen at its sharpest resonances, narrower than the tapered record resolves).

Within the band the case trusts (``trusted_band``, error model ``"eiv"``) two more are left
out. The frequencies above the trial's ``[preprocess] lowpass_hz``: the whitening divides a
low-pass back out, so without this the band a user trusts would not bound what the
likelihood weighs. And the *lines* the best fit leaves (:func:`line_bins`): frequencies whose
whitened power the fitted noise gives with a probability below :data:`LINE_FALSE_ALARM` over
all those weighed. A line is a mode the fit misplaces, not noise (on the viscous bridge the
abutments' mode at 226 Hz, which rings through the record: a fit one ripple of kp1's valley
from the truth leaves there up to 10⁵ times the noise's power); weighed, it makes the
likelihood a needle about 1e-5 of kp1's range wide at the truth, which no sampler finds from
the fit.

Two more things real records have. Accelerometers have offsets and drifts, which the high-pass
turns into transients at the record's start; on the table's record they drive the model at its
resonances. The responses of the residual to a constant and to a ramp in each raw record
(:func:`offset_regressors`) are projected out of the whitened values, their amplitudes being
unknown. And the resonances are narrow enough that neighbouring frequencies of a short record
are correlated, which Whittle's likelihood ignores: its curvature then overstates what the
record determines. The covariance of its score under the fitted noise model is computed
exactly (:func:`score_covariance`, from the transpose of the whitening,
:func:`whitening_adjoint`), and gives the likelihood its magnitude
(:func:`magnitude_adjusted`).

Why this file is long (about 770 lines): it is one error model. Its whitening and the exact
variance of its score are built from the same noise paths (the impulse responses of the case's
processing and model), and the score's variance needs the whitening's transpose line by line;
split, each half would carry the other's conventions (bins, prewhitening, nuisance projection).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import minimize

from femupdate.data.measurement import Measurement
from femupdate.errors import ConfigError, DataError

#: Frequencies where a channel's output-noise gain is below this share of its largest are left
#: out (near 0 Hz the high-pass, near the Nyquist frequency the trapezoidal integration, whose
#: gain is 0 there, leave only rounding in the residual).
GAIN_RANGE = 1e-4
#: Frequencies where the record's finite length moves the expected periodogram of a channel by
#: more than this share from the spectrum there are left out (leakage rules them).
LEAKAGE_TOLERANCE = 0.1
#: Offset and drift responses whose whitened singular value is below this share of the largest
#: add nothing to the span projected out.
NUISANCE_RANK_TOLERANCE = 1e-8
#: The impulse responses are computed over this many times the trial's samples, then longer
#: (doubling, up to :data:`MAX_LENGTH_FACTOR`) until they have decayed.
LENGTH_FACTOR = 4
MAX_LENGTH_FACTOR = 64
#: Decayed: the record's first and last tenths hold less than this share of the response's
#: energy.
DECAY_TOLERANCE = 1e-8
#: The largest order of the AR prewhitening (the bridge's residuals choose 20–32).
AR_MAX_ORDER = 32
#: A frequency whose whitened power the fitted noise gives with a probability below this, over
#: all the frequencies weighed (Bonferroni), is a line the best fit leaves (:func:`line_bins`).
LINE_FALSE_ALARM = 1e-3
#: Passes of :func:`line_bins` at most: each refits the noise levels without the lines found,
#: which shows a strong line's sidelobes.
MAX_LINE_PASSES = 20
#: The share of the prewhitened record under the cosine halves of its split cosine bell taper
#: (Tukey's; half at each end), applied before the transform (:func:`taper`).
TAPER_FRACTION = 0.2


@functools.lru_cache(maxsize=16)
def taper(n: int, fraction: float = TAPER_FRACTION) -> np.ndarray:
    """The split cosine bell taper (n,) of ``fraction`` (0: none), scaled to a mean square of
    1 so that the tapered transform's expected power is the spectrum's, n S(ω). Read-only and
    kept per (n, fraction): every sampler batch's whitening applies the same one.

    Without it, a line above the trusted band (on the bridge the abutments' mode, whose
    frequency moves with kp1) leaks into every frequency weighed through the sidelobes of the
    record's rectangular window, which fall only as 1/Δf; its phase over the record turns
    with kp1, so the likelihood along kp1 swings by tens of units within 1e-3 of its range,
    a comb of needles that no sampler weighs. The cosine ends make the sidelobes fall as
    1/Δf³ (Percival & Walden 1993, ch. 6)."""
    from scipy.signal import windows

    window = windows.tukey(n, fraction, sym=False) if fraction > 0.0 else np.ones(n)
    window = window / math.sqrt(np.mean(window ** 2))
    window.flags.writeable = False
    return window


def ar_fit(r: np.ndarray, order: int) -> tuple[np.ndarray, float]:
    """(a, BIC) of an AR(``order``) model r_t = Σ_k a_k r_{t−k} + e_t fitted by least squares
    (the conditional maximum likelihood; unlike Yule–Walker, exact enough for the nearly
    unit-root residuals of a displacement record, lag-1 autocorrelation 0.999);
    BIC = n log(‖e‖²/n) + order · log n over the n = N − order innovations."""
    r = np.asarray(r, dtype=float)
    n = r.size - order
    if order < 1 or n <= 2 * order:
        raise ConfigError(f"error model 'arp': order {order} for a block of {r.size} samples "
                          f"(allowed: 1 to {max((r.size - 1) // 3, 1)})")
    lagged = np.column_stack([r[order - k - 1:r.size - k - 1] for k in range(order)])
    a = np.linalg.lstsq(lagged, r[order:], rcond=None)[0]
    e = r[order:] - lagged @ a
    return a, float(n * math.log(max(float(e @ e), 1e-300) / n) + order * math.log(n))


def ar_order(r: np.ndarray, max_order: int = AR_MAX_ORDER) -> int:
    """The order of least BIC among 1 … ``max_order`` (fewer for a short block), every order
    fitted on the same samples t ≥ ``max_order``: one QR factorisation of the lagged matrix
    gives them all, since its first p columns are the regressors of order p."""
    r = np.asarray(r, dtype=float)
    top = max(1, min(max_order, (r.size - 1) // 3))
    n = r.size - top
    lagged = np.column_stack([r[top - k - 1:r.size - k - 1] for k in range(top)])
    q, _ = np.linalg.qr(lagged)
    z = q.T @ r[top:]
    rss = float(r[top:] @ r[top:]) - np.cumsum(z ** 2)
    orders = np.arange(1, top + 1)
    bic = n * np.log(np.maximum(rss, 1e-300) / n) + orders * math.log(n)
    return int(orders[np.argmin(bic)])


@dataclass(frozen=True)
class TrialWhitening:
    """The fixed spectral whitening of one trial's residual blocks (module docstring).

    Attributes
    ----------
    blocks : tuple of int
        The residual blocks (channels) of the trial, in order.
    bins : ndarray of int (F,)
        The frequencies k of the n-point transform that are kept.
    matrices : ndarray of complex (F, C, C)
        W_k.
    sigma_outputs : ndarray (C,)
        The fitted noise standard deviation of each output sensor (records' units).
    sigma_input : float
        The fitted noise standard deviation of the table's sensor.
    input_share : float
        The share of the residual's modelled variance that the table's noise explains.
    nuisance : ndarray (size, q) or None
        Orthonormal basis of the whitened responses to each sensor's offset and drift
        (:func:`offset_regressors`), projected out of the whitened values.
    lines_hz : tuple of float
        The frequencies (Hz) left out as lines the best fit leaves (:func:`line_bins`).
    taper_fraction : float
        The taper applied to the prewhitened blocks before their transform (:func:`taper`;
        0 in the plain data of a whitening built before it).
    """

    blocks: tuple[int, ...]
    bins: np.ndarray
    matrices: np.ndarray
    sigma_outputs: np.ndarray
    sigma_input: float
    input_share: float
    nuisance: np.ndarray | None = None
    lines_hz: tuple[float, ...] = ()
    taper_fraction: float = TAPER_FRACTION

    @property
    def size(self) -> int:
        """The whitened values: real and imaginary parts of C channels at F frequencies."""
        return 2 * self.matrices.shape[0] * self.matrices.shape[1]

    def apply(self, blocks: list[np.ndarray]) -> np.ndarray:
        """The whitened rows (k, :attr:`size`) of the trial's prewhitened blocks, each
        (k, n)."""
        stacked = np.stack(blocks, axis=1)
        coefficients = np.fft.rfft(stacked * taper(stacked.shape[2], self.taper_fraction),
                                   axis=2)[:, :, self.bins]
        white = np.einsum("fij,kjf->kif", self.matrices, coefficients)
        rows = white.shape[0]
        out = math.sqrt(2.0) * np.concatenate(
            [white.real.reshape(rows, -1), white.imag.reshape(rows, -1)], axis=1)
        if self.nuisance is not None:
            out -= (out @ self.nuisance) @ self.nuisance.T
        return out

    def adjoint(self, rows: np.ndarray, n: int) -> np.ndarray:
        """The transpose of :meth:`apply`: rows (k, :attr:`size`) of whitened values to rows
        (k, C, n) of prewhitened blocks of n samples, with ⟨apply(x), v⟩ = ⟨x, adjoint(v)⟩."""
        rows = np.atleast_2d(np.asarray(rows, dtype=float))
        if self.nuisance is not None:  # the projection is symmetric
            rows = rows - (rows @ self.nuisance) @ self.nuisance.T
        k, (n_bins, n_channels, _) = rows.shape[0], self.matrices.shape
        half = n_channels * n_bins
        z = (rows[:, :half] + 1j * rows[:, half:]).reshape(k, n_channels, n_bins)
        spectrum = np.zeros((k, n_channels, n // 2 + 1), dtype=complex)
        spectrum[:, :, self.bins] = math.sqrt(2.0) * np.einsum(
            "fij,kif->kjf", np.conj(self.matrices), z)
        # Re Σ_f q_f e^{iω_f t} over bins 0 < f < n/2 is n/2 · irfft
        return 0.5 * n * np.fft.irfft(spectrum, n, axis=2) * taper(n, self.taper_fraction)

    def to_dict(self) -> dict[str, Any]:
        """Plain data (:meth:`from_dict` rebuilds it bit for bit)."""
        return {"blocks": list(self.blocks), "bins": self.bins.tolist(),
                "matrices_real": self.matrices.real.tolist(),
                "matrices_imag": self.matrices.imag.tolist(),
                "sigma_outputs": self.sigma_outputs.tolist(), "sigma_input": self.sigma_input,
                "input_share": self.input_share,
                "nuisance": None if self.nuisance is None else self.nuisance.tolist(),
                "lines_hz": list(self.lines_hz), "taper_fraction": self.taper_fraction}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TrialWhitening:
        matrices = (np.asarray(data["matrices_real"], dtype=float)
                    + 1j * np.asarray(data["matrices_imag"], dtype=float))
        nuisance = data.get("nuisance")
        return cls(tuple(int(b) for b in data["blocks"]), np.asarray(data["bins"], dtype=int),
                   matrices, np.asarray(data["sigma_outputs"], dtype=float),
                   float(data["sigma_input"]), float(data["input_share"]),
                   None if nuisance is None else np.asarray(nuisance, dtype=float),
                   tuple(float(f) for f in data.get("lines_hz", ())),
                   float(data.get("taper_fraction", 0.0)))


def folded_transfer(response: np.ndarray, centre: int, n: int) -> np.ndarray:
    """The transfer function (n//2 + 1, C) on the n-point grid of the impulse responses
    ``response`` (L, C) to an impulse at sample ``centre``: Σ_j h_j e^{−iω_k j} over every lag
    j (negative ones too, for a zero-phase filter), the lags folded modulo n."""
    response = np.asarray(response, dtype=float)
    lags = (np.arange(response.shape[0]) - centre) % n
    folded = np.zeros((n, response.shape[1]))
    np.add.at(folded, lags, response)
    return np.fft.rfft(folded, axis=0)


def _filtered(responses: np.ndarray, ar: np.ndarray) -> np.ndarray:
    """Each column of ``responses`` (L, C) through its AR prewhitening filter 1 − Σ a_j z^−j
    (rows of ``ar``, (C, p))."""
    from scipy.signal import lfilter

    return np.column_stack([lfilter(np.concatenate([[1.0], -a]), [1.0], column)
                            for column, a in zip(responses.T, ar, strict=True)])


def expected_periodogram(responses: np.ndarray, variances: np.ndarray, n: int,
                         window: np.ndarray | None = None) -> np.ndarray:
    """E|rfft(h x)_k|² (n//2 + 1,) of n consecutive samples of the stationary sum x of
    independent white noises of ``variances`` (m,) through the filters ``responses`` (L, m),
    tapered by ``window`` h (n,) (None: none): Σ_{|τ|<n} w(τ) γ(τ) e^{−iω_k τ}, γ the
    autocovariance of x and w(τ) = Σ_t h_t h_{t+|τ|} (n − |τ| untapered), the spectrum smoothed
    by the record's finite length (Fejér's kernel untapered), which the spectrum at ω_k alone
    ignores."""
    length = responses.shape[0]
    size = 1 << math.ceil(math.log2(length + n))
    power = np.abs(np.fft.rfft(responses, size, axis=0)) ** 2 @ variances
    autocovariance = np.fft.irfft(power, size)
    lags = np.arange(-(n - 1), n)
    if window is None:
        overlap = n - np.abs(lags)
    else:
        spectrum = np.fft.rfft(window, 2 * n)
        overlap = np.fft.irfft(np.abs(spectrum) ** 2, 2 * n)[np.abs(lags)]
    weighted = overlap * autocovariance[lags % size]
    folded = np.zeros(n)
    np.add.at(folded, lags % n, weighted)
    return np.fft.rfft(folded).real


def whittle_nll(log_sigma: np.ndarray, power: np.ndarray, coefficients: np.ndarray,
                output_gain: np.ndarray, input_transfer: np.ndarray, n: int) -> float:
    """−log of Whittle's likelihood (constants dropped) of the coefficients (F, C) under the
    spectra of the module docstring, ``log_sigma`` = (ln σ_1 … ln σ_C, ln σ_u); ``power`` is
    |coefficients|², ``output_gain`` |A G|² (F, C), ``input_transfer`` A T (F, C)."""
    d = n * np.exp(2.0 * log_sigma[:-1]) * output_gain
    v = n * math.exp(2.0 * log_sigma[-1])
    gamma = np.sum(np.abs(input_transfer) ** 2 / d, axis=1)
    projection = np.sum(np.conj(input_transfer) * coefficients / d, axis=1)
    return float(np.sum(np.log(d)) + np.sum(np.log1p(v * gamma)) + np.sum(power / d)
                 - np.sum(v * np.abs(projection) ** 2 / (1.0 + v * gamma)))


def fit_noise_levels(coefficients: np.ndarray, output_gain: np.ndarray,
                     input_transfer: np.ndarray, n: int) -> tuple[np.ndarray, float]:
    """(σ_outputs (C,), σ_u): the noise levels of greatest Whittle likelihood
    (:func:`whittle_nll`), from a start that gives every channel's power to its own sensor
    and the best of a few table noise levels from 10⁻⁴ to 10 times theirs."""
    power = np.abs(coefficients) ** 2
    own = 0.5 * np.log(np.mean(power / (n * output_gain), axis=0))
    args = (power, coefficients, output_gain, input_transfer, n)
    starts = [np.append(own, own.max() + math.log(ratio))
              for ratio in (1e-4, 1e-3, 1e-2, 1e-1, 1.0, 10.0)]
    start = min(starts, key=lambda s: whittle_nll(s, *args))
    lowest = own.min() + math.log(1e-8)
    bounds = [(o - 10.0, o + 10.0) for o in own] + [(lowest, own.max() + 10.0)]
    result = minimize(whittle_nll, start, args=args, method="L-BFGS-B", bounds=bounds)
    return np.exp(result.x[:-1]), float(math.exp(result.x[-1]))


def whitening_matrices(output_gain: np.ndarray, input_transfer: np.ndarray,
                       sigma_outputs: np.ndarray, sigma_input: float, n: int) -> np.ndarray:
    """W_k (F, C, C) with W_kᴴ W_k = S_k⁻¹ (module docstring)."""
    d = n * sigma_outputs ** 2 * output_gain
    scaled = input_transfer / np.sqrt(d)
    norm2 = np.sum(np.abs(scaled) ** 2, axis=1)
    v = n * sigma_input ** 2
    beta = 1.0 - 1.0 / np.sqrt(1.0 + v * norm2)
    with np.errstate(invalid="ignore", divide="ignore"):
        u = np.where(norm2[:, None] > 0.0, scaled / np.sqrt(norm2)[:, None], 0.0)
    inv_root = 1.0 / np.sqrt(d)
    eye = np.eye(d.shape[1])
    return (eye[None, :, :] - beta[:, None, None] * u[:, :, None] * np.conj(u)[:, None, :]
            ) * inv_root[:, None, :]


def _processed(trial: Any, raw_input: np.ndarray, raw_outputs: np.ndarray) -> Any:
    """The trial's processing (filters, relative motion, integration) of raw records."""
    from femupdate.trials.experiment import process

    if trial.model.groups:
        raise ConfigError(f"{trial.case.label}: the input-noise error model takes one table "
                          "record; this case has [[model.support_groups]] (allowed: another "
                          "error model)")
    experiment, pre = trial.experiment, trial.case.preprocess
    length = raw_input.size
    channels = {"input": raw_input, **dict(zip(experiment.channels, raw_outputs.T,
                                               strict=True))}
    measurement = Measurement(np.arange(length) * experiment.dt, channels)
    return process(measurement, experiment.channels, np.ones(len(experiment.channels)),
                   quantity=experiment.quantity, highpass_hz=pre.highpass_hz,
                   highpass_order=pre.highpass_order, zero_phase=pre.zero_phase,
                   influence=trial.model.influence, lowpass_hz=pre.lowpass_hz,
                   lowpass_order=pre.lowpass_order)


def path_responses(trial: Any, values: dict[str, float], record: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """(input path (L, C), output paths (L, C)): the change of the trial's prediction − target
    (every sample, unscaled) when the table's raw record is ``record`` (L,) and the others are
    zero, and, column c, when output channel c's raw record is ``record`` and the others are
    zero (its own channel only: the others do not change)."""
    n_channels = len(trial.experiment.channels)
    length = record.size
    zeros = np.zeros((length, n_channels))
    driven = _processed(trial, record, zeros)
    ag = record if trial.filter else driven.ag
    input_path = trial.prediction_driven_by(values, ag) - driven.target
    output_paths = np.empty((length, n_channels))
    for c in range(n_channels):
        raw = zeros.copy()
        raw[:, c] = record
        output_paths[:, c] = -_processed(trial, np.zeros(length), raw).target[:, c]
    return input_path, output_paths


def impulse_responses(trial: Any, values: dict[str, float], length: int
                      ) -> tuple[np.ndarray, np.ndarray, int]:
    """(input path, output paths, centre): :func:`path_responses` to a unit impulse at sample
    ``centre`` of a record of ``length`` samples."""
    centre = length // 2  # a zero-phase high-pass responds before the impulse too
    impulse = np.zeros(length)
    impulse[centre] = 1.0
    return (*path_responses(trial, values, impulse), centre)


def offset_regressors(trial: Any, values: dict[str, float], scales: np.ndarray,
                      samples: int) -> np.ndarray:
    """(N, C, 2 (C + 1)): each residual block's response (scaled, projected as the residual
    is) to a constant and to a linear drift in each raw record, the table's and each output
    channel's: the offsets and drifts of real accelerometers, which the high-pass leaves as
    transients at the record's start that no white noise explains (on the table's record they
    drive the model at its resonances). Their amplitudes are unknown: the likelihood projects
    them out."""
    score = trial.experiment.score
    start = 0 if score.start is None else int(score.start)
    stop = start + samples
    time = np.arange(stop) * trial.experiment.dt
    columns = []
    for record in (np.ones(stop), time):
        input_path, output_paths = path_responses(trial, values, record)
        columns.append(input_path)
        for c in range(output_paths.shape[1]):
            own = np.zeros_like(output_paths)
            own[:, c] = output_paths[:, c]
            columns.append(own)
    regressors = np.stack(columns, axis=2)[start:stop] * scales[None, :, None]
    if trial.objective.with_experimental_parameters:
        for q in range(regressors.shape[2]):
            regressors[:, :, q] = _projected_out(regressors[:, :, q], trial.objective.t)
    return regressors


def _decayed(response: np.ndarray, centre: int) -> bool:
    """Whether the responses (L, C) are negligible at both ends of the record."""
    energy = float(np.sum(response ** 2))
    tail = max(1, response.shape[0] // 10)
    ends = float(np.sum(response[:tail] ** 2) + np.sum(response[-tail:] ** 2))
    return energy > 0.0 and ends <= DECAY_TOLERANCE * energy


def decayed_impulse_responses(trial: Any, values: dict[str, float]
                              ) -> tuple[np.ndarray, np.ndarray, int]:
    """:func:`impulse_responses` over a record long enough for them to decay, at most
    :data:`MAX_LENGTH_FACTOR` times the trial's: a mode with next to no damping (a damper at
    its bound 0) rings longer, and is cut there, its line in the spectrum then far sharper
    than the record's frequency resolution."""
    samples = trial.objective.target.shape[0]
    factor = LENGTH_FACTOR
    while True:
        paths = impulse_responses(trial, values, factor * samples)
        if factor >= MAX_LENGTH_FACTOR or (_decayed(paths[0], paths[2])
                                           and _decayed(paths[1], paths[2])):
            return paths
        factor *= 2


def _projected_out(d: np.ndarray, t: np.ndarray) -> np.ndarray:
    """d (n, C) less its least-squares fit by a + b t, per column."""
    basis = np.column_stack([np.ones_like(t), t - t.mean()])
    return d - basis @ np.linalg.lstsq(basis, d, rcond=None)[0]


def block_scales(trial: Any, values: dict[str, float], residuals: np.ndarray) -> np.ndarray:
    """The constant by which each of the trial's residual blocks (``residuals`` (n, C), from
    the case's residual vector) scales the trial's prediction − target (with experimental
    parameters, its part off span{1, t})."""
    prediction = trial.scored(trial.prediction(trial.simulate(values)))
    d = prediction - trial.objective.target
    if trial.objective.with_experimental_parameters:
        d = _projected_out(d, trial.objective.t)
    norms = np.linalg.norm(d, axis=0)
    if np.any(norms == 0.0):
        raise DataError(f"error model 'eiv': trial {trial.name!r}: a channel is fitted "
                        "exactly: no noise to model")
    return np.linalg.norm(residuals, axis=0) / norms


def _prewhitened(blocks: np.ndarray, ar: np.ndarray) -> np.ndarray:
    """Blocks (N, C) through their AR filters, the first p samples dropped: (N − p, C)."""
    return _filtered(blocks, ar)[ar.shape[1]:]


def trial_whitening(trial: Any, values: dict[str, float], blocks: list[int],
                    residuals: np.ndarray, order: int, trusted_band: bool = True
                    ) -> tuple[TrialWhitening, np.ndarray]:
    """The whitening of one trial (module docstring) from its residual blocks at the best
    fit, ``residuals`` (N, C), and the AR prewhitening filters (C, ``order``) it uses: those
    that flatten the processing of each channel's own noise (least squares on the impulse
    response of that path), so that they do not notch the resonances, where the table's noise
    and the information are. With ``trusted_band`` only the frequencies up to the trial's
    ``[preprocess] lowpass_hz`` are kept, less the best fit's lines (:func:`line_bins`)."""
    structure = trial.model.structure
    if structure is None:
        raise ConfigError(f"error model 'eiv': trial {trial.name!r} runs an external model, "
                          "whose response to the table's noise femupdate cannot compute "
                          "(allowed: femupdate's own models; another error_model)")
    nonlinear = structure.nonlinear_elements()
    if nonlinear:
        raise ConfigError(f"error model 'eiv': the model of trial {trial.name!r} has "
                          f"nonlinear elements ({', '.join(nonlinear)}): its response to the "
                          "table's noise is not a transfer function (allowed: linear models; "
                          "another error_model)")
    samples, n_channels = residuals.shape
    scales = block_scales(trial, values, residuals)
    input_path, output_paths, centre = decayed_impulse_responses(trial, values)
    ar = np.array([ar_fit(output_paths[:, c], order)[0] for c in range(n_channels)])
    regressors = offset_regressors(trial, values, scales, samples)
    # the noise levels are fitted to the residual less its offsets' and drifts' transients
    prewhitened = without_offsets(residuals, regressors, ar)
    n = prewhitened.shape[0]
    input_path, output_paths, input_transfer, output_gain = noise_transfers(
        input_path, output_paths, centre, scales, ar, n)
    window = taper(n)
    coefficients = np.fft.rfft(prewhitened * window[:, None], axis=0)
    bins = np.arange(1, (n + 1) // 2)  # not 0 nor n/2: their coefficients are real
    relative_gain = output_gain[bins] / output_gain[bins].max(axis=0)
    bins = bins[np.all(relative_gain >= GAIN_RANGE, axis=1)]
    lowpass_hz = trial.case.preprocess.lowpass_hz if trusted_band else None
    if lowpass_hz is not None:
        bins = bins[bins / (n * trial.experiment.dt) <= lowpass_hz]

    def leaked(bins: np.ndarray, sigma_outputs: np.ndarray, sigma_input: float
               ) -> np.ndarray:
        """Whether leakage rules each frequency of ``bins`` under those noise levels."""
        modelled = n * (sigma_outputs ** 2 * output_gain + sigma_input ** 2
                        * np.abs(input_transfer) ** 2)
        expected = np.column_stack([
            expected_periodogram(np.column_stack([output_paths[:, c], input_path[:, c]]),
                                 np.array([sigma_outputs[c] ** 2, sigma_input ** 2]), n,
                                 window)
            for c in range(n_channels)])
        return np.any(np.abs(expected[bins] / modelled[bins] - 1.0) > LEAKAGE_TOLERANCE,
                      axis=1)

    def levels(bins: np.ndarray) -> tuple[np.ndarray, float]:
        return fit_noise_levels(coefficients[bins], output_gain[bins], input_transfer[bins], n)

    # the lines first, from levels fitted over every frequency: where leakage rules depends on
    # the levels, and a line taken for table noise makes the levels far too high
    lines = bins[:0]
    for _ in range(MAX_LINE_PASSES if trusted_band else 0):
        rest = np.setdiff1d(bins, lines)
        found = line_bins(coefficients[rest], output_gain[rest], input_transfer[rest],
                          *levels(rest), n)
        if not found.any():
            break
        lines = np.union1d(lines, rest[found])
    bins = np.setdiff1d(bins, lines)
    # twice: fit the noise levels, then leave out the frequencies where, with those levels,
    # leakage rules (the second pass refits without the first's)
    for _ in range(2):
        sigma_outputs, sigma_input = levels(bins)
        bins = bins[~leaked(bins, sigma_outputs, sigma_input)]
    if lines.size:  # a frequency leakage rules anyway is not called a line
        lines = lines[~leaked(lines, sigma_outputs, sigma_input)]
    from_outputs = np.sum(sigma_outputs ** 2 * output_gain[bins])
    from_input = sigma_input ** 2 * np.sum(np.abs(input_transfer[bins]) ** 2)
    share = float(from_input / (from_input + from_outputs))
    matrices = whitening_matrices(output_gain[bins], input_transfer[bins], sigma_outputs,
                                  sigma_input, n)
    whitening = TrialWhitening(tuple(blocks), bins, matrices, sigma_outputs, sigma_input,
                               share, lines_hz=tuple(
                                   float(k / (n * trial.experiment.dt)) for k in lines))
    nuisance, _ = whitened_nuisance(whitening, regressors, ar)
    # C order, as its plain data rebuilds it: the products' rounding follows the layout, and
    # a resumed posterior must give the same values bit for bit
    return dataclasses.replace(whitening, nuisance=None if nuisance is None
                               else np.ascontiguousarray(nuisance)), ar


def line_bins(coefficients: np.ndarray, output_gain: np.ndarray, input_transfer: np.ndarray,
              sigma_outputs: np.ndarray, sigma_input: float, n: int,
              false_alarm: float = LINE_FALSE_ALARM) -> np.ndarray:
    """Whether each frequency of the coefficients (F, C) is a line: its whitened power, χ²
    of 2C degrees of freedom under the fitted noise, beyond the level that all F of them stay
    below with probability 1 − ``false_alarm`` (Bonferroni)."""
    from scipy.stats import chi2

    matrices = whitening_matrices(output_gain, input_transfer, sigma_outputs, sigma_input, n)
    power = 2.0 * np.sum(np.abs(np.einsum("fij,fj->fi", matrices, coefficients)) ** 2, axis=1)
    dof = 2 * coefficients.shape[1]
    return power > chi2.isf(false_alarm / max(coefficients.shape[0], 1), dof)


def without_offsets(residuals: np.ndarray, regressors: np.ndarray, ar: np.ndarray
                    ) -> np.ndarray:
    """The prewhitened blocks (N − p, C) of ``residuals`` (N, C) less their least-squares fit
    by the offset and drift responses ``regressors`` (N, C, q) (:func:`offset_regressors`)."""
    samples, n_channels = residuals.shape
    flat = regressors.reshape(samples * n_channels, -1)
    amplitudes = np.linalg.lstsq(flat, residuals.reshape(-1), rcond=None)[0]
    return _prewhitened(residuals - (flat @ amplitudes).reshape(samples, n_channels), ar)


def noise_transfers(input_path: np.ndarray, output_paths: np.ndarray, centre: int,
                    scales: np.ndarray, ar: np.ndarray, n: int
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(input path, output paths, input transfer (n//2 + 1, C), output gains |·|²): the
    impulse responses of :func:`decayed_impulse_responses` as the prewhitened residual of
    n samples sees them, scaled, then through each block's AR filter, and their transforms."""
    input_path = _filtered(input_path * scales, ar)
    output_paths = _filtered(output_paths * scales, ar)
    return (input_path, output_paths, folded_transfer(input_path, centre, n),
            np.abs(folded_transfer(output_paths, centre, n)) ** 2)


def whitened_nuisance(whitening: TrialWhitening, regressors: np.ndarray, ar: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """(orthonormal basis (size, r), singular values (r,)) of the whitened offset and drift
    responses ``regressors`` (N, C, q), those below :data:`NUISANCE_RANK_TOLERANCE` of the
    largest left out."""
    prewhitened = np.stack([_prewhitened(regressors[:, :, q], ar)
                            for q in range(regressors.shape[2])])  # (q, n, C)
    white = whitening.apply([prewhitened[:, :, c] for c in range(prewhitened.shape[2])])
    basis, singular, _ = np.linalg.svd(white.T, full_matrices=False)
    kept = singular > NUISANCE_RANK_TOLERANCE * singular[0]
    return basis[:, kept], singular[kept]


def trial_groups(problem: Any) -> list[list[int]]:
    """The blocks of an UpdateProblem's residual vector grouped by trial (its channels share
    the table's record, hence its noise), in the order of
    :func:`~femupdate.inference.likelihood.residual_blocks`."""
    groups, start = [], 0
    for trial in problem.fitted:
        channels = trial.objective.target.shape[1]
        groups.append(list(range(start, start + channels)))
        start += channels
    return groups


def input_noise_whitening(problem: Any, point: np.ndarray, residuals: np.ndarray,
                          starts: np.ndarray, stops: np.ndarray, order: int,
                          trusted_band: bool = True
                          ) -> tuple[tuple[TrialWhitening, ...], np.ndarray]:
    """The spectral whitening of every fitted trial of an UpdateProblem at search point
    ``point`` (the best fit) and its residual vector there ``residuals`` (blocks ``starts``
    to ``stops``), and the blocks' AR prewhitening filters (c, ``order``); with
    ``trusted_band``, over the band each trial trusts (:func:`trial_whitening`)."""
    values = problem.values(np.asarray(point, dtype=float))
    r = np.asarray(residuals, dtype=float)
    whitenings, filters = [], np.zeros((len(starts), order))
    for trial, group in zip(problem.fitted, trial_groups(problem), strict=True):
        raw = np.column_stack([r[starts[b]:stops[b]] for b in group])
        whitening, ar = trial_whitening(trial, values, group, raw, order, trusted_band)
        whitenings.append(whitening)
        filters[group] = ar
    return tuple(whitenings), filters


def ar_adjoint(rows: np.ndarray, ar: np.ndarray, length: int) -> np.ndarray:
    """The transpose of a block's AR prewhitening (filter by 1 − Σ a_j z^−j, drop the first p
    samples): rows (k, length − p) to rows (k, length)."""
    from scipy.signal import lfilter

    rows = np.atleast_2d(np.asarray(rows, dtype=float))
    padded = np.zeros((rows.shape[0], length))
    padded[:, length - rows.shape[1]:] = rows
    return lfilter(np.concatenate([[1.0], -ar]), [1.0], padded[:, ::-1], axis=1)[:, ::-1]


def whitening_adjoint(model: Any, rows: np.ndarray) -> np.ndarray:
    """The transpose of ``model.whiten`` (kind ``"eiv"``): rows (k, whitened size) to rows
    (k, m) of residual vectors."""
    rows = np.atleast_2d(np.asarray(rows, dtype=float))
    out = np.zeros((rows.shape[0], model.size))
    start = 0
    for trial in model.spectral:
        part = rows[:, start:start + trial.size]
        start += trial.size
        first = trial.blocks[0]
        n = int(model.stops[first] - model.starts[first]) - model.lag
        blocks = trial.adjoint(part, n)
        for j, b in enumerate(trial.blocks):
            a, z = int(model.starts[b]), int(model.stops[b])
            out[:, a:z] = ar_adjoint(blocks[:, j], model.ar[b], z - a)
    return out


def _correlated(rows: np.ndarray, response: np.ndarray, centre: int, start: int,
                stop: int) -> np.ndarray:
    """Σ_t rows[:, t] h(start + t − s) for s in [0, stop): how each noise sample of the record
    reaches the rows' inner product with the residual, h the impulse response (lag 0 at
    ``centre``)."""
    from scipy.signal import fftconvolve

    embedded = np.zeros((rows.shape[0], stop))
    embedded[:, start:] = rows
    full = fftconvolve(embedded, response[None, ::-1], axes=1)
    first = response.shape[0] - 1 - centre
    return full[:, first:first + stop]


def score_covariance(problem: Any, model: Any, point: np.ndarray, residuals: np.ndarray,
                     directions: np.ndarray) -> np.ndarray:
    """Var(Dᵀ r) (n, n) of the residual vector r under the fitted noise model, exactly: each
    sensor's white noise over its record, from rest, through the case's processing and model
    at search ``point`` (where ``model`` was built; ``residuals`` r there), with the projection
    off span{1, t} of experimental parameters; ``directions`` D (m, n).

    The Whittle likelihood takes the frequencies of a finite record independent; where the
    spectrum has features as narrow as the record's resolution (a lightly damped mode) they are
    not, and its curvature overstates what the record determines. The score of the error model
    is Dᵀr with D = Mᵀ W M J (M its whitening, W its weights), so this gives the covariance of
    the score, the meat of the sandwich (:func:`magnitude_adjusted`).
    """
    values = problem.values(np.asarray(point, dtype=float))
    r = np.asarray(residuals, dtype=float)
    directions = np.asarray(directions, dtype=float).T  # (n, m)
    meat = np.zeros((directions.shape[0], directions.shape[0]))
    for trial, group, fitted in zip(problem.fitted, trial_groups(problem), model.spectral,
                                    strict=True):
        raw = np.column_stack([r[model.starts[b]:model.stops[b]] for b in group])
        scales = block_scales(trial, values, raw)
        input_path, output_paths, centre = decayed_impulse_responses(trial, values)
        score = trial.experiment.score
        start = 0 if score.start is None else int(score.start)
        stop = start + raw.shape[0]
        through_input = np.zeros((directions.shape[0], stop))
        for j, b in enumerate(group):
            rows = directions[:, model.starts[b]:model.stops[b]]
            if trial.objective.with_experimental_parameters:
                rows = _projected_out(rows.T, trial.objective.t).T
            through_input += _correlated(rows, input_path[:, j] * scales[j], centre, start,
                                         stop)
            own = _correlated(rows, output_paths[:, j] * scales[j], centre, start, stop)
            meat += fitted.sigma_outputs[j] ** 2 * own @ own.T
        meat += fitted.sigma_input ** 2 * through_input @ through_input.T
    return 0.5 * (meat + meat.T)


def score_meats(problem: Any, model: Any, point: np.ndarray, point_residuals: np.ndarray,
                at: Sequence[tuple[np.ndarray, np.ndarray]]
                ) -> list[tuple[np.ndarray, np.ndarray]]:
    """(H, Var(score)) at each (residuals, Jacobian) pair of ``at`` (the mode, by differences
    over one or more steps): H the likelihood's Gauss–Newton precision J_wᵀ W J_w, Var(score)
    that of its score J_wᵀ W w under the fitted noise model (:func:`score_covariance`, one
    pass for all the pairs; ``model`` built at search ``point``, ``point_residuals`` its
    residuals there)."""
    from femupdate.inference.laplace import gaussian_precision

    precisions, directions = [], []
    for residuals, jac in at:
        precisions.append(gaussian_precision(jac, residuals, model)[0])
        weighted = model.weights(residuals)[:, None] * model.whiten(np.asarray(jac).T).T
        directions.append(whitening_adjoint(model, weighted.T).T)
    meat = score_covariance(problem, model, point, point_residuals, np.hstack(directions))
    n = precisions[0].shape[0]
    return [(precision, meat[i * n:(i + 1) * n, i * n:(i + 1) * n])
            for i, precision in enumerate(precisions)]


def magnitude_adjusted(problem: Any, model: Any, point: np.ndarray,
                       point_residuals: np.ndarray, jac: np.ndarray,
                       residuals: np.ndarray) -> Any:
    """``model`` with its likelihood raised to k = n / tr(H⁻¹ Var(score)) (:func:`score_meats`
    at the mode: ``jac``, ``residuals``), the magnitude adjustment of Ribatet, Cooley & Davison
    (2012) with the score's exact variance under the fitted noise model: the curvature that
    TMCMC samples then matches the sandwich's on average over the parameters (the likelihood
    whose neighbouring frequencies Whittle takes independent is otherwise too sharp where they
    are not). Its counts carry k."""
    ((precision, meat),) = score_meats(problem, model, point, point_residuals,
                                       [(residuals, jac)])
    inflation = float(np.trace(np.linalg.pinv(precision, hermitian=True) @ meat))
    if not inflation > 0.0 or not math.isfinite(inflation):
        raise DataError("error model 'eiv': the variance of its score is not positive at the "
                        "mode: no magnitude adjustment")
    return dataclasses.replace(model, counts=model.counts * (precision.shape[0] / inflation))

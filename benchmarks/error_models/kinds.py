"""The error models measured and set aside (docs/history.md, "Posterior"), as plug-ins.

``"neff-integrated"`` (``"neff"``'s counts, the variance integrated out), ``"iid"``
(N_c = N), ``"tau"`` (N/τ, τ the integrated autocorrelation time), ``"ar1"`` (the innovations
of a fixed AR(1)), ``"arp"`` (of a fixed AR(p), p by BIC), ``"adjusted"`` (the i.i.d.
likelihood tempered by the sandwich's magnitude adjustment), ``"adjusted-least"`` (tempered by
the largest power nowhere sharper than the sandwich), ``"eiv"`` (errors in the variables: the
table's noise whitened in the frequency domain, :mod:`input_noise`), ``"eiv-band"`` (the same
up to the case's low-pass) and ``"spectral"`` (the
periodogram's degrees of freedom as the count).
:func:`registry` adds them, explicitly, to a copy of the product's registry; nothing here is
registered by importing it.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.signal import lfilter

from femupdate.errors import ConfigError
from femupdate.inference.error_models import ERROR_MODELS
from femupdate.inference.likelihood import ErrorModel, ErrorModelKind, FitResiduals, Registry
from femupdate.inference.neff import effective_count

#: The largest order kind ``"arp"`` considers (the bridge's residuals choose 20–32).
AR_MAX_ORDER = 32
#: The kinds here, in the order the benchmark prints them.
KINDS: tuple[str, ...] = ("neff-integrated", "tau", "iid", "ar1", "arp", "adjusted",
                          "adjusted-least", "eiv", "eiv-band", "spectral")


def autocorrelation_count(r: np.ndarray) -> float:
    """N/τ of a residual block: its effective sample size by ArviZ (``method="mean"``:
    Geyer's initial monotone sequence on the autocorrelation), at most N."""
    from femupdate._optional import require

    arviz = require("arviz", "posterior")
    r = np.asarray(r, dtype=float)
    return float(min(arviz.ess(r[None, :], method="mean"), r.size))


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
class WhitenedModel(ErrorModel):
    """An error model that whitens each block (AR filter), and for ``"eiv"`` each trial's
    blocks together in the frequency domain.

    Attributes
    ----------
    ar : ndarray (c, p) or None
        AR coefficients a_1 … a_p of each block (``"arp"``, ``"eiv"``); None for ``"ar1"``,
        whose filter is 1 − ρ_c z⁻¹.
    spectral : tuple of TrialWhitening or None
        ``"eiv"``: each fitted trial's whitening of its AR-prewhitened blocks
        (:mod:`input_noise`); ``counts`` then has one entry per trial.
    """

    ar: np.ndarray | None = None
    spectral: tuple[Any, ...] | None = None

    @property
    def lag(self) -> int:
        """The samples each block loses to whitening."""
        return 1 if self.ar is None else int(self.ar.shape[1])

    def whiten(self, rows: np.ndarray) -> np.ndarray:
        rows = np.atleast_2d(np.asarray(rows, dtype=float))
        if self.ar is None:
            return np.concatenate([rows[:, a + 1:b] - rho * rows[:, a:b - 1] for a, b, rho
                                   in zip(self.starts, self.stops, self.rho, strict=True)],
                                  axis=1)
        p = self.lag
        blocks = [lfilter(np.concatenate([[1.0], -a]), [1.0], rows[:, s:b], axis=1)[:, p:]
                  for s, b, a in zip(self.starts, self.stops, self.ar, strict=True)]
        if self.spectral is None:
            return np.concatenate(blocks, axis=1)
        return np.concatenate([trial.apply([blocks[b] for b in trial.blocks])
                               for trial in self.spectral], axis=1)

    def _white_lengths(self) -> np.ndarray:
        if self.spectral is not None:
            return np.array([trial.size for trial in self.spectral])
        return self.stops - self.starts - self.lag

    def to_dict(self) -> dict[str, Any]:
        out = super().to_dict()
        if self.ar is not None:
            out["ar"] = self.ar.tolist()
        if self.spectral is not None:
            out["noise"] = [{"sigma_outputs": t.sigma_outputs.tolist(),
                             "sigma_input": t.sigma_input, "input_share": t.input_share,
                             "frequencies": int(t.bins.size)} for t in self.spectral]
        return out

    def data(self) -> dict[str, Any]:
        return {**super().data(), "ar": None if self.ar is None else self.ar.tolist(),
                "spectral": None if self.spectral is None else [t.to_dict()
                                                                for t in self.spectral]}

    @classmethod
    def from_data(cls, data: Mapping[str, Any]) -> WhitenedModel:
        from error_models.input_noise import TrialWhitening

        base = ErrorModel.from_data(data)
        ar, spectral = data.get("ar"), data.get("spectral")
        return cls(**{f.name: getattr(base, f.name) for f in dataclasses.fields(ErrorModel)},
                   ar=None if ar is None else np.asarray(ar, float),
                   spectral=None if spectral is None else tuple(
                       TrialWhitening.from_dict(t) for t in spectral))


def _unknown_variance(kind: str, fit: FitResiduals) -> None:
    if fit.sigma is not None:
        raise ConfigError(f"error model {kind!r}: sigma is only for kind 'known'")


class IID(ErrorModelKind):
    """N_c = N − removed: every sample independent."""

    name = "iid"

    def build(self, fit: FitResiduals) -> ErrorModel:
        _unknown_variance(self.name, fit)
        counts = np.maximum((fit.lengths - fit.removed).astype(float), 1.0)
        return ErrorModel(self.name, fit.starts, fit.stops, counts, np.zeros(fit.starts.size))


class NEffIntegrated(ErrorModelKind):
    """``"neff"``'s counts N_c = N(1 − ρ_c)/(1 + ρ_c), each block's variance integrated out
    under Jeffreys' prior (a Student-t of N_c values: wider than ``"neff"``'s plug-in where
    N_c is a handful; docs/history.md, "Posterior")."""

    name = "neff-integrated"

    def build(self, fit: FitResiduals) -> ErrorModel:
        _unknown_variance(self.name, fit)
        r = fit.need_residuals(self.name)
        rho = fit.rho(r)
        counts = np.array([effective_count(int(n - k), p)
                           for n, k, p in zip(fit.lengths, fit.removed, rho, strict=True)])
        return ErrorModel(self.name, fit.starts, fit.stops, np.maximum(counts, 1.0), rho)


class Tau(ErrorModelKind):
    """N_c = N/τ_c (ArviZ's ESS of the block) less the removed share."""

    name = "tau"

    def build(self, fit: FitResiduals) -> ErrorModel:
        _unknown_variance(self.name, fit)
        r = fit.need_residuals(self.name)
        counts = np.array([autocorrelation_count(r[a:b]) * (1.0 - k / (b - a))
                           for a, b, k in zip(fit.starts, fit.stops, fit.removed, strict=True)])
        return ErrorModel(self.name, fit.starts, fit.stops, np.maximum(counts, 1.0), fit.rho(r))


class AR1(ErrorModelKind):
    """The innovations r_t − ρ_c r_{t−1}, ρ_c fixed at the best fit."""

    name = "ar1"
    model = WhitenedModel

    def build(self, fit: FitResiduals) -> ErrorModel:
        _unknown_variance(self.name, fit)
        r = fit.need_residuals(self.name)
        counts = np.maximum((fit.lengths - 1 - fit.removed).astype(float), 1.0)
        return WhitenedModel(self.name, fit.starts, fit.stops, counts, fit.rho(r))


class ARp(ErrorModelKind):
    """The innovations of an AR(p) per block, fitted at the best fit, p (one for every
    block) the largest of the blocks' BIC orders up to option ``ar_max_order``."""

    name = "arp"
    model = WhitenedModel

    def build(self, fit: FitResiduals) -> ErrorModel:
        _unknown_variance(self.name, fit)
        r = fit.need_residuals(self.name)
        top = int(fit.options.get("ar_max_order", AR_MAX_ORDER))
        pairs = list(zip(fit.starts, fit.stops, strict=True))
        order = max(ar_order(r[a:b], top) for a, b in pairs)
        ar = np.array([ar_fit(r[a:b], order)[0] for a, b in pairs])
        counts = np.maximum((fit.lengths - order - fit.removed).astype(float), 1.0)
        return WhitenedModel(self.name, fit.starts, fit.stops, counts, fit.rho(r), ar=ar)


class Adjusted(ErrorModelKind):
    """N_c = k·(N − removed), k = n / tr(H⁻¹M) the sandwich's magnitude adjustment (needs
    the Jacobian at the best fit)."""

    name = "adjusted"

    @staticmethod
    def adjustment(jac: np.ndarray, r: np.ndarray, blocks: list[slice]) -> float:
        """k, the power of the i.i.d. likelihood: the counts are k·(N − removed)."""
        from error_models.sandwich import magnitude_adjustment

        return magnitude_adjustment(jac, r, blocks)

    def build(self, fit: FitResiduals) -> ErrorModel:
        _unknown_variance(self.name, fit)
        r = fit.need_residuals(self.name)
        if fit.jacobian is None or np.shape(fit.jacobian)[0] != fit.stops[-1]:
            raise ConfigError(f"error model 'adjusted' needs the Jacobian at the best fit "
                              f"({fit.stops[-1]} rows), got "
                              f"{None if fit.jacobian is None else np.shape(fit.jacobian)}")
        blocks = [slice(int(a), int(b)) for a, b in zip(fit.starts, fit.stops, strict=True)]
        k = self.adjustment(fit.jacobian, r, blocks)
        counts = np.maximum((fit.lengths - fit.removed) * k, 1.0)
        return ErrorModel(self.name, fit.starts, fit.stops, counts, fit.rho(r))


class AdjustedLeast(Adjusted):
    """``"adjusted"`` with k = 1/λ_max(H⁻¹M): the sharpest scalar power nowhere narrower than
    the sandwich (:func:`~error_models.sandwich.least_adjustment`)."""

    name = "adjusted-least"

    @staticmethod
    def adjustment(jac: np.ndarray, r: np.ndarray, blocks: list[slice]) -> float:
        from error_models.sandwich import least_adjustment

        return least_adjustment(jac, r, blocks)


class EIV(ErrorModelKind):
    """Errors in the variables: ``"arp"``'s prewhitening, then each trial's blocks whitened
    together by the spectrum of output noise plus the model's response to table noise
    (:mod:`input_noise`; needs the problem and the best fit's search point)."""

    name = "eiv"
    model = WhitenedModel

    def build(self, fit: FitResiduals) -> ErrorModel:
        from error_models.input_noise import input_noise_whitening

        if fit.problem is None:
            raise ConfigError("error model 'eiv' needs the case's model and processing: build "
                              "it with problem_error_model(problem, r, 'eiv', point=x)")
        if fit.point is None:
            raise ConfigError("error model 'eiv' needs the best fit's search point (point)")
        pre = typing.cast(WhitenedModel, ARp().build(fit))
        r = fit.need_residuals(self.name)
        spectral, ar = input_noise_whitening(fit.problem, fit.point, r, pre.starts, pre.stops,
                                             pre.lag, self.band(fit.problem))
        counts = np.array([max(t.size - fit.removed[list(t.blocks)].sum()
                               - (0 if t.nuisance is None else t.nuisance.shape[1]), 1.0)
                           for t in spectral])
        return dataclasses.replace(pre, kind=self.name, counts=counts, ar=ar,
                                   spectral=spectral)

    def band(self, problem: Any) -> float | None:
        """The highest frequency the likelihood weighs: every one the processing passes."""
        return None


class EIVBand(EIV):
    """``"eiv"`` over the frequencies up to the case's ``[preprocess] lowpass_hz`` only: the
    whitening divides a low-pass back out, so without this the band a user trusts does not
    bound what the likelihood weighs (on the viscous bridge, the abutment modes' line at
    226 Hz: docs/history.md, "What the records say about kp1")."""

    name = "eiv-band"

    def band(self, problem: Any) -> float | None:
        bands = {trial.case.preprocess.lowpass_hz for trial in problem.fitted}
        if None in bands or len(bands) != 1:
            given = ", ".join("none" if b is None else f"{b:g} Hz" for b in bands)
            raise ConfigError("error model 'eiv-band' needs one [preprocess] lowpass_hz for "
                              f"every fitted trial, got {given} (allowed: a frequency in Hz; "
                              "or error model 'eiv')")
        return float(bands.pop())


def spectral_count(r: np.ndarray, half_width: int = 3) -> float:
    """ν = 2 (Σ_j S_j)² / Σ_j S_j² over the one-sided frequencies: the degrees of freedom of
    ‖r‖² as a scaled χ² (its mean and variance matched, Satterthwaite 1946), S_j the
    periodogram smoothed over 2·half_width + 1 bins (Daniell), its own variance taken out of
    Σ S_j²; N for white noise, about 2·B·T for noise of bandwidth B over T."""
    r = np.asarray(r, dtype=float)
    periodogram = np.abs(np.fft.rfft(r - r.mean()))[1:] ** 2
    width = 2 * half_width + 1
    smoothed = np.convolve(np.pad(periodogram, half_width, mode="reflect"),
                           np.full(width, 1.0 / width), mode="valid")
    nu = 2.0 * smoothed.sum() ** 2 / (smoothed @ smoothed) * (1.0 + 1.0 / width)
    return float(min(nu, r.size))


class Spectral(ErrorModelKind):
    """N_c = :func:`spectral_count` of the block less the removed values; each block's
    variance fixed at the best fit's (:class:`~femupdate.inference.neff.PlugInModel`)."""

    name = "spectral"

    def build(self, fit: FitResiduals) -> ErrorModel:
        from femupdate.inference.neff import PlugInModel

        _unknown_variance(self.name, fit)
        r = fit.need_residuals(self.name)
        counts = np.array([spectral_count(r[a:b]) - k
                           for a, b, k in zip(fit.starts, fit.stops, fit.removed, strict=True)])
        reference = np.array([float(r[a:b] @ r[a:b])
                              for a, b in zip(fit.starts, fit.stops, strict=True)])
        return PlugInModel(self.name, fit.starts, fit.stops, np.maximum(counts, 1.0),
                           fit.rho(r), reference=reference)


def registry() -> Registry:
    """The product's registry with the kinds here added."""
    out = ERROR_MODELS.copy()
    for kind in (NEffIntegrated(), Tau(), IID(), AR1(), ARp(), Adjusted(), AdjustedLeast(),
                 EIV(), EIVBand(), Spectral()):
        out.register(kind)
    return out


def error_model(blocks: Any, kind: str, **options: Any) -> ErrorModel:
    """:func:`femupdate.inference.error_models.error_model` over :func:`registry`."""
    from femupdate.inference.error_models import error_model as build

    return build(blocks, kind, registry=registry(), **options)


def problem_error_model(problem: Any, r: np.ndarray, kind: str,
                        jacobian: np.ndarray | None = None, **options: Any) -> ErrorModel:
    """:func:`femupdate.inference.error_models.problem_error_model` over :func:`registry`."""
    from femupdate.inference.error_models import problem_error_model as build

    return build(problem, r, kind, jacobian, registry=registry(), **options)

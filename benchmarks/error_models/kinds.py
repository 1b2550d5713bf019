"""The error models measured and set aside (docs/history.md, "Posterior"), as plug-ins.

``"neff-integrated"`` (``"neff"``'s counts, the variance integrated out), ``"iid"``
(N_c = N), ``"tau"`` (N/τ, τ the integrated autocorrelation time), ``"ar1"`` (the innovations
of a fixed AR(1)), ``"arp"`` (of a fixed AR(p), p by BIC), ``"adjusted"`` (the i.i.d.
likelihood tempered by the sandwich's magnitude adjustment), ``"adjusted-least"`` (tempered by
the largest power nowhere sharper than the sandwich), ``"eiv-all"`` (the product's errors in the
variables, :mod:`femupdate.inference.eiv`, over every frequency, the best fit's lines kept) and
``"spectral"`` (the periodogram's degrees of freedom as the count).
:func:`registry` adds them, explicitly, to a copy of the product's registry; nothing here is
registered by importing it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from femupdate.errors import ConfigError
from femupdate.inference.eiv import EIV, WhitenedModel
from femupdate.inference.error_models import ERROR_MODELS
from femupdate.inference.input_noise import AR_MAX_ORDER, ar_fit, ar_order
from femupdate.inference.likelihood import ErrorModel, ErrorModelKind, FitResiduals, Registry
from femupdate.inference.neff import effective_count

#: The kinds here, in the order the benchmark prints them.
KINDS: tuple[str, ...] = ("neff-integrated", "tau", "iid", "ar1", "arp", "adjusted",
                          "adjusted-least", "eiv-all", "spectral")


def autocorrelation_count(r: np.ndarray) -> float:
    """N/τ of a residual block: its effective sample size by ArviZ (``method="mean"``:
    Geyer's initial monotone sequence on the autocorrelation), at most N."""
    from femupdate._optional import require

    arviz = require("arviz", "posterior")
    r = np.asarray(r, dtype=float)
    return float(min(arviz.ess(r[None, :], method="mean"), r.size))


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


class EIVAll(EIV):
    """``"eiv"`` over every frequency the processing passes, the best fit's lines kept: as
    ``"eiv"`` was measured before it weighed only the band the case trusts (docs/history.md,
    "What the records say about kp1")."""

    name = "eiv-all"
    trusted_band = False


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
                 EIVAll(), Spectral()):
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

"""Error model ``"neff"`` (the default): each block's effective count of independent values,
and its variance fixed at the best fit's.

The residuals of sampled time histories are strongly correlated in time (a band-limited record
has far fewer independent values than samples), so taking N_c as the block length makes
credible intervals far too narrow. ``"neff"`` takes the effective count of an AR(1) process
with the block's lag-1 autocorrelation ρ_c at the best fit, N_c = N·(1 − ρ_c)/(1 + ρ_c), and
the block's error variance as the best fit's ‖r_c*‖²/N_c, both measured once and then held
fixed (the likelihood is one fixed function of the parameters, :class:`PlugInModel`). Its 90 %
intervals hold the truth in the share of noise replicates docs/posterior.md measures.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from femupdate.errors import ConfigError
from femupdate.inference.likelihood import ErrorModel, ErrorModelKind, FitResiduals


def effective_count(n: int, rho: float) -> float:
    """N·(1 − ρ)/(1 + ρ): the number of independent values an AR(1) series of N samples and
    lag-1 autocorrelation ρ carries about its mean (ρ clipped to [0, 1): a negatively
    correlated residual is not credited with more than N values)."""
    rho = min(max(rho, 0.0), 1.0 - 1e-12)
    return n * (1.0 - rho) / (1.0 + rho)


@dataclass(frozen=True)
class PlugInModel(ErrorModel):
    """N_c independent Gaussian errors per block whose variance is the best fit's
    ‖r_c*‖²/N_c, fixed (a plug-in), instead of integrated out::

        log L = Σ_c −(N_c/2) · [ ‖r_c‖²/‖r_c*‖² + log(2π ‖r_c*‖²/N_c) ]

    (N_c Gaussian values of variance ‖r_c*‖²/N_c). At the best fit its curvature is the
    integrated variance's (log L = Σ_c log Γ(N_c/2) − (N_c/2) log(π‖r_c‖²)); away from it the
    integrated variance's log ‖r_c‖² grows far more slowly when N_c is a handful (the
    Student-t tails of a variance learnt from a few values), where the data, thousands of
    samples, fix the variance well: only the parameters' information is that of N_c values.
    Its constant is the same function of ‖r_c*‖² for every model class, so their evidences
    compare as profile likelihoods.
    """

    reference: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def loglike_of_squares(self, squares: np.ndarray) -> np.ndarray:
        squares = np.atleast_2d(squares)
        return (-0.5 * self.counts * (squares / self.reference
                                      + np.log(2.0 * math.pi * self.reference / self.counts))
                ).sum(axis=1)

    def log_squares_slope(self, squares: np.ndarray) -> np.ndarray:
        return -0.5 * self.counts * np.atleast_2d(squares) / self.reference

    def of_sums(self) -> ErrorModel:
        c = self.counts.size
        return dataclasses.replace(self, starts=np.arange(c), stops=np.arange(1, c + 1))

    def weights(self, r: np.ndarray) -> np.ndarray:
        return np.concatenate([np.full(b - a, w) for (a, b), w in zip(
            self._white_blocks(), self.counts / self.reference, strict=True)])

    def data(self) -> dict[str, Any]:
        return super().data() | {"reference": self.reference.tolist()}

    def to_dict(self) -> dict[str, Any]:
        return super().to_dict() | {"reference": self.reference.tolist()}

    @classmethod
    def from_data(cls, data: Mapping[str, Any]) -> ErrorModel:
        base = ErrorModel.from_data(data)
        return cls(base.kind, base.starts, base.stops, base.counts, base.rho,
                   reference=np.asarray(data["reference"], dtype=float))


class NEff(ErrorModelKind):
    """N_c = (N − removed)·(1 − ρ_c)/(1 + ρ_c), at least 1; each block's variance fixed at the
    best fit's (:class:`PlugInModel`)."""

    name = "neff"
    model = PlugInModel

    def build(self, fit: FitResiduals) -> ErrorModel:
        if fit.sigma is not None:
            raise ConfigError(f"error model {self.name!r}: sigma is only for kind 'known'")
        r = fit.need_residuals(self.name)
        rho = fit.rho(r)
        counts = np.array([effective_count(int(n - k), p)
                           for n, k, p in zip(fit.lengths, fit.removed, rho, strict=True)])
        reference = np.array([float(r[a:b] @ r[a:b]) for a, b in zip(fit.starts, fit.stops,
                                                                     strict=True)])
        return PlugInModel(self.name, fit.starts, fit.stops, np.maximum(counts, 1.0), rho,
                           reference=reference)

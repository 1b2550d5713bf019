"""Error model ``"neff"`` (the default): each block's effective count of independent values.

The residuals of sampled time histories are strongly correlated in time (a band-limited record
has far fewer independent values than samples), so taking N_c as the block length makes
credible intervals far too narrow. ``"neff"`` takes the effective count of an AR(1) process
with the block's lag-1 autocorrelation ρ_c at the best fit, N_c = N·(1 − ρ_c)/(1 + ρ_c),
measured once and then held fixed (the likelihood is one fixed function of the parameters).
Its 90 % intervals hold the truth in the share of noise replicates docs/posterior.md
measures, on the viscous bridge at its own truth and at truths drawn from the prior.
"""

from __future__ import annotations

import numpy as np

from femupdate.errors import ConfigError
from femupdate.inference.likelihood import ErrorModel, ErrorModelKind, FitResiduals


def effective_count(n: int, rho: float) -> float:
    """N·(1 − ρ)/(1 + ρ): the number of independent values an AR(1) series of N samples and
    lag-1 autocorrelation ρ carries about its mean (ρ clipped to [0, 1): a negatively
    correlated residual is not credited with more than N values)."""
    rho = min(max(rho, 0.0), 1.0 - 1e-12)
    return n * (1.0 - rho) / (1.0 + rho)


class NEff(ErrorModelKind):
    """N_c = (N − removed)·(1 − ρ_c)/(1 + ρ_c), at least 1; unknown variance per block."""

    name = "neff"

    def build(self, fit: FitResiduals) -> ErrorModel:
        if fit.sigma is not None:
            raise ConfigError(f"error model {self.name!r}: sigma is only for kind 'known'")
        r = fit.need_residuals(self.name)
        rho = fit.rho(r)
        counts = np.array([effective_count(int(n - k), p)
                           for n, k, p in zip(fit.lengths, fit.removed, rho, strict=True)])
        return ErrorModel(self.name, fit.starts, fit.stops, np.maximum(counts, 1.0), rho)

"""Error model ``"known"``: Gaussian errors of a given standard deviation per block.

For a user who knows the noise of the records (a sensor's calibrated noise floor, a virtual
experiment) and for the closed-form checks (:mod:`femupdate.inference.analytic`): no
variance is learnt from the residuals, every sample counts.
"""

from __future__ import annotations

import numpy as np

from femupdate.errors import ConfigError
from femupdate.inference.likelihood import ErrorModel, ErrorModelKind, FitResiduals


class Known(ErrorModelKind):
    """σ_c given (one value for every block, or one per block), > 0 and finite."""

    name = "known"
    in_case = False  # a case file has no field for σ

    def build(self, fit: FitResiduals) -> ErrorModel:
        if fit.sigma is None:
            raise ConfigError("error model 'known' needs sigma (the error standard deviation)")
        sigma = np.asarray(fit.sigma, dtype=float)
        if sigma.ndim > 1 or sigma.size not in (1, fit.starts.size):
            raise ConfigError(f"error model 'known': sigma has {sigma.size} values for "
                              f"{fit.starts.size} blocks (allowed: one, or one per block)")
        sig = np.broadcast_to(sigma.reshape(-1), (fit.starts.size,)).copy()
        if not np.all(np.isfinite(sig)) or np.any(sig <= 0):
            raise ConfigError(f"error model: sigma must be > 0 and finite, got {fit.sigma!r}")
        counts = np.maximum((fit.lengths - fit.removed).astype(float), 1.0)
        return ErrorModel(self.name, fit.starts, fit.stops, counts,
                          np.zeros(fit.starts.size), sig)

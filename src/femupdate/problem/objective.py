"""The error function φ (the paper's Eq. 1 and §5.2; docs/method.md): normalised mean squared
error over channels.

    φ = Σ_i w_i [ Σ_j (ŷ_ij − y_ij)² / Σ_j y_ij² ] / Σ_i w_i          (Eq. 1; w_i = 1)

Samples are on axis 0, channels on axis 1. With ``experimental_parameters=True`` each
measured displacement channel, obtained by integrating accelerations twice, carries two
unknown integration constants: the true displacement is y_i + c0_i + c1_i t. They are
found at every evaluation by linear least squares (variable projection): with Q an
orthonormal basis of span{1, t}, the residual is P⊥(ŷ − y) = d − Q(Qᵀd), d = ŷ − y, for all
channels at once.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np

from femupdate.errors import ConfigError, DataError
from femupdate.simulate.response import Response

__all__ = ["ErrorFunction", "nmse"]


def _sum_squares(y: np.ndarray) -> np.ndarray:
    """Σ_j y_ij² per channel (einsum: 3–4× faster than a strided ``sum(y**2, axis=0)``)."""
    return np.einsum("ij,ij->j", y, y)


def _as_2d(y: np.ndarray, name: str) -> np.ndarray:
    y = np.asarray(y, dtype=float)
    if y.ndim == 1:
        y = y[:, None]
    if y.ndim != 2 or y.shape[0] < 1 or y.shape[1] < 1:
        raise DataError(f"{name} must have shape (n_samples,) or (n_samples, n_channels), "
                        f"got {np.shape(y)}")
    return y


def _check_weights(weights: Sequence[float] | np.ndarray | None, n_channels: int) -> np.ndarray:
    if weights is None:
        return np.ones(n_channels)
    w = np.asarray(weights, dtype=float)
    if w.shape != (n_channels,):
        raise ConfigError(f"weights must have one value per channel ({n_channels}), got shape "
                          f"{w.shape}")
    if not np.all(np.isfinite(w)) or np.any(w < 0) or w.sum() <= 0:
        raise ConfigError(f"weights must be finite, >= 0 and not all 0, got {w.tolist()}")
    return w


def nmse(prediction: np.ndarray, target: np.ndarray,
         weights: Sequence[float] | np.ndarray | None = None) -> float:
    """Normalised mean squared error, Eq. 1 (a fraction: 100·φ is the paper's %).

    Parameters
    ----------
    prediction, target : ndarray, shape (n_samples,) or (n_samples, n_channels)
        Model prediction ŷ and measurement y.
    weights : array_like, shape (n_channels,), optional
        Per-channel weights; φ is their weighted mean of the channel errors.

    Returns
    -------
    float
        φ; ``inf`` when the prediction holds NaN or inf.
    """
    y = _as_2d(target, "target")
    yhat = _as_2d(prediction, "prediction")
    if yhat.shape != y.shape:
        raise DataError(f"prediction has shape {yhat.shape}, target {y.shape}")
    energy = _sum_squares(y)
    if np.any(energy == 0) or not np.all(np.isfinite(energy)):
        bad = np.flatnonzero((energy == 0) | ~np.isfinite(energy)).tolist()
        raise DataError(f"target channels {bad} are all zero or not finite: NMSE undefined")
    w = _check_weights(weights, y.shape[1])
    if not np.all(np.isfinite(yhat)):
        return float("inf")
    d = yhat - y
    per_channel = _sum_squares(d) / energy
    return float(w @ per_channel / w.sum())


class ErrorFunction:
    """The error function φ(prediction) against a fixed measured target, configured once
    (picklable).

    Parameters
    ----------
    target : ndarray, shape (n_samples,) or (n_samples, n_channels)
        Measured displacements or accelerations.
    t : ndarray, shape (n_samples,), optional
        Sample times, s (default: the sample index); fixes the units of c1.
    kind : {"displacement", "acceleration"}
        Which quantity the target is; a `Response` passed to ``__call__`` gives that field.
    weights : array_like, shape (n_channels,), optional
        Per-channel weights.
    experimental_parameters : bool
        Fit c0 + c1·t per channel (displacement only: docs/method.md §7).

    Notes
    -----
    With experimental parameters the normalising Σy² of each channel uses the measured
    channel corrected by its fitted constants, y + c0 + c1 t: the best estimate of the true
    displacement, and the choice that makes φ invariant to any a + b t added to the
    measurement. Since the corrected channel is P⊥y + QQᵀŷ and the two parts are orthogonal,
    Σ(y + c0 + c1 t)² = ‖P⊥y‖² + ‖Qᵀŷ‖²: cheap at every evaluation. A zero prediction then
    gives φ = 1, as without experimental parameters.
    """

    def __init__(self, target: np.ndarray, t: np.ndarray | None = None, *,
                 kind: Literal["displacement", "acceleration"] = "displacement",
                 weights: Sequence[float] | np.ndarray | None = None,
                 experimental_parameters: bool = False) -> None:
        if kind not in ("displacement", "acceleration"):
            raise ConfigError(f"kind must be 'displacement' or 'acceleration', got {kind!r}")
        if experimental_parameters and kind != "displacement":
            raise ConfigError("experimental_parameters (integration constants) apply to "
                              "displacements integrated from accelerations: use "
                              "kind='displacement'")
        y = _as_2d(target, "target")
        if not np.all(np.isfinite(y)):
            raise DataError("target holds NaN or inf samples")
        n = y.shape[0]
        tt = np.arange(n, dtype=float) if t is None else np.asarray(t, dtype=float)
        if tt.shape != (n,) or not np.all(np.isfinite(tt)):
            raise DataError(f"t must be finite with shape ({n},) like the target, got "
                            f"{tt.shape}")
        if experimental_parameters and (n < 3 or np.ptp(tt) == 0):
            raise DataError("experimental parameters need at least 3 samples at distinct times")
        self.kind = kind
        self.with_experimental_parameters = bool(experimental_parameters)
        self.weights = _check_weights(weights, y.shape[1])
        self.target = y
        self.t = tt
        self._squeeze = np.ndim(target) == 1
        if self.with_experimental_parameters:
            # orthonormal basis of span{1, t}; t centred and scaled for conditioning
            centre, scale = tt.mean(), np.ptp(tt) / 2.0
            basis = np.column_stack([np.ones(n), (tt - centre) / scale])
            self._q, r = np.linalg.qr(basis)
            # coefficients on Q -> (c0, c1) on (1, t)
            to_c = np.linalg.solve(r, np.eye(2))
            self._to_c = np.array([[1.0, -centre / scale], [0.0, 1.0 / scale]]) @ to_c
            self._qty = self._q.T @ y
            self._perp_energy = _sum_squares(y - self._q @ self._qty)
            bad = self._perp_energy <= 1e-24 * np.maximum(_sum_squares(y), 1e-300)
            if np.any(bad):
                raise DataError(f"target channels {np.flatnonzero(bad).tolist()} are straight "
                                f"lines (a + b t): nothing is left once the integration "
                                f"constants are fitted")
        else:
            energy = _sum_squares(y)
            if np.any(energy == 0):
                raise DataError(f"target channels {np.flatnonzero(energy == 0).tolist()} are "
                                f"all zero: NMSE undefined")
            self._energy = energy

    @property
    def n_channels(self) -> int:
        return int(self.target.shape[1])

    def _prediction(self, prediction: np.ndarray | Response) -> np.ndarray | None:
        """The prediction as (n_samples, n_channels), or None if it is not finite."""
        if isinstance(prediction, Response):
            if prediction.diverged:
                return None
            prediction = getattr(prediction, self.kind)
        yhat = np.asarray(prediction, dtype=float)
        if yhat.ndim == 1:
            yhat = yhat[:, None]
        if yhat.shape != self.target.shape:
            raise DataError(f"prediction has shape {yhat.shape}, the target "
                            f"{self.target.shape} (n_samples, n_channels)")
        if not np.all(np.isfinite(yhat)):
            return None
        return yhat

    def per_channel(self, prediction: np.ndarray | Response) -> np.ndarray:
        """Error of each channel, Σ residual² / Σ target² (inf for a non-finite prediction)."""
        yhat = self._prediction(prediction)
        if yhat is None:
            return np.full(self.n_channels, np.inf)
        d = yhat - self.target
        if not self.with_experimental_parameters:
            return _sum_squares(d) / self._energy
        qtd = self._q.T @ d
        d -= self._q @ qtd  # the residual P⊥(ŷ − y), in place
        energy = self._perp_energy + np.sum((qtd + self._qty) ** 2, axis=0)
        return _sum_squares(d) / energy

    def residuals(self, prediction: np.ndarray | Response) -> np.ndarray:
        """The residual vector r with φ = ‖r‖² (to rounding), samples of each channel in turn.

        Channel c contributes its residual (with experimental parameters: the part the
        integration constants cannot explain, P⊥(ŷ − y)) scaled by √(w_c / (Σw · E_c)), E_c
        the energy φ normalises it by. A non-finite prediction gives an all-inf vector.
        """
        yhat = self._prediction(prediction)
        if yhat is None:
            return np.full(self.target.size, np.inf)
        d = yhat - self.target
        if self.with_experimental_parameters:
            qtd = self._q.T @ d
            d -= self._q @ qtd
            energy = self._perp_energy + np.sum((qtd + self._qty) ** 2, axis=0)
        else:
            energy = self._energy
        scale = np.sqrt(self.weights / (self.weights.sum() * energy))
        return (d * scale).ravel(order="F")

    def __call__(self, prediction: np.ndarray | Response) -> float:
        """φ: the weighted mean of `per_channel` (inf for a non-finite prediction)."""
        errors = self.per_channel(prediction)
        if not np.all(np.isfinite(errors)):
            return float("inf")
        return float(self.weights @ errors / self.weights.sum())

    def experimental_parameters(self, prediction: np.ndarray | Response) -> np.ndarray:
        """Fitted integration constants (n_channels, 2): columns c0 and c1 (per unit of t).

        The measured channel y_i + c0_i + c1_i t is the least-squares fit to the prediction.
        Zeros when the objective has no experimental parameters; NaN for a non-finite
        prediction.
        """
        if not self.with_experimental_parameters:
            return np.zeros((self.n_channels, 2))
        yhat = self._prediction(prediction)
        if yhat is None:
            return np.full((self.n_channels, 2), np.nan)
        return (self._to_c @ (self._q.T @ (yhat - self.target))).T

    def corrected_target(self, prediction: np.ndarray | Response) -> np.ndarray:
        """The measurement plus its fitted constants (what the prediction is compared to)."""
        c = self.experimental_parameters(prediction)
        out = self.target + c[:, 0] + self.t[:, None] * c[:, 1]
        return out[:, 0] if self._squeeze else out


def __getattr__(name: str) -> type:
    if name == "Objective":  # renamed: three different things were called Objective
        import warnings

        warnings.warn("femupdate.problem.objective.Objective is now ErrorFunction; the old name "
                      "will be "
                      "removed", DeprecationWarning, stacklevel=2)
        return ErrorFunction
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

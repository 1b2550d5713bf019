"""Error model ``"eiv"``: errors in the variables, for a noisy table record.

A shake-table model is driven by the table's *measured* acceleration, so the noise of that
sensor reaches every channel's residual through the structure, narrow-band at the
resonances where the parameters' sensitivities are. ``"eiv"`` whitens each trial's residual
blocks together in the frequency domain by the spectrum of the outputs' own noise plus the
model's response to the table's noise (:mod:`femupdate.inference.input_noise`), over the band
the case trusts: the frequencies up to each trial's ``[preprocess] lowpass_hz`` (every one
its processing passes when it has none), less the lines the best fit leaves that its noise
cannot explain. Given the Jacobian at the best fit, its likelihood is raised to the
magnitude adjustment of Ribatet, Cooley & Davison (2012) with the exact variance of its
score, the likelihood ``femupdate posterior`` samples. Linear models of femupdate's own, one
table record per trial; anything else is refused in one line naming the error model.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from scipy.signal import lfilter

from femupdate.errors import ConfigError
from femupdate.inference.input_noise import (
    AR_MAX_ORDER,
    TrialWhitening,
    ar_order,
    input_noise_whitening,
    magnitude_adjusted,
)
from femupdate.inference.likelihood import ErrorModel, ErrorModelKind, FitResiduals


@dataclass(frozen=True)
class WhitenedModel(ErrorModel):
    """An error model that whitens each block (AR filter), and for ``"eiv"`` each trial's
    blocks together in the frequency domain.

    Attributes
    ----------
    ar : ndarray (c, p) or None
        AR coefficients a_1 … a_p of each block (``"eiv"``, and the lab's ``"arp"``); None for
        the lab's ``"ar1"``, whose filter is 1 − ρ_c z⁻¹.
    spectral : tuple of TrialWhitening or None
        ``"eiv"``: each fitted trial's whitening of its AR-prewhitened blocks
        (:mod:`femupdate.inference.input_noise`); ``counts`` then has one entry per trial.
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

    def notes(self) -> list[str]:
        """The lines each trial's whitening left out (:func:`line_ranges`), in words."""
        return [f"error model {self.kind!r} left out {line_ranges(trial.lines_hz)} of fitted "
                f"trial {number} ({len(trial.lines_hz)} of "
                f"{trial.bins.size + len(trial.lines_hz)} frequencies): the best fit leaves "
                "lines there that the fitted noise cannot explain (a mode the model "
                "misplaces); their leakage reaches the frequencies around them, where the "
                "intervals can be too narrow: set [preprocess] lowpass_hz below "
                f"{min(trial.lines_hz):.4g} Hz if the modes updated lie below it, or use "
                "error model 'neff'"
                for number, trial in enumerate(self.spectral or (), start=1) if trial.lines_hz]

    def to_dict(self) -> dict[str, Any]:
        out = super().to_dict()
        if self.ar is not None:
            out["ar"] = self.ar.tolist()
        if self.spectral is not None:
            out["noise"] = [{"sigma_outputs": t.sigma_outputs.tolist(),
                             "sigma_input": t.sigma_input, "input_share": t.input_share,
                             "frequencies": int(t.bins.size), "lines_hz": list(t.lines_hz)}
                            for t in self.spectral]
        return out

    def data(self) -> dict[str, Any]:
        return {**super().data(), "ar": None if self.ar is None else self.ar.tolist(),
                "spectral": None if self.spectral is None else [t.to_dict()
                                                                for t in self.spectral]}

    @classmethod
    def from_data(cls, data: Mapping[str, Any]) -> WhitenedModel:
        base = ErrorModel.from_data(data)
        ar, spectral = data.get("ar"), data.get("spectral")
        return cls(**{f.name: getattr(base, f.name) for f in dataclasses.fields(ErrorModel)},
                   ar=None if ar is None else np.asarray(ar, float),
                   spectral=None if spectral is None else tuple(
                       TrialWhitening.from_dict(t) for t in spectral))


def line_ranges(frequencies: tuple[float, ...] | list[float], gap_hz: float = 1.0) -> str:
    """Sorted frequencies as ranges ("225.3–226.4 Hz, 310.0 Hz"), those less than ``gap_hz``
    apart joined."""
    groups: list[list[float]] = []
    for f in sorted(frequencies):
        if groups and f - groups[-1][-1] < gap_hz:
            groups[-1].append(f)
        else:
            groups.append([f])
    return ", ".join(f"{g[0]:.1f} Hz" if len(g) == 1 else f"{g[0]:.1f}–{g[-1]:.1f} Hz"
                     for g in groups)


class EIV(ErrorModelKind):
    """Errors in the variables (module docstring): each block prewhitened by an AR filter of
    the blocks' largest BIC order (up to option ``ar_max_order``), then each trial's blocks
    whitened together (:func:`~femupdate.inference.input_noise.input_noise_whitening`); needs
    the problem and the best fit's search point, and takes the Jacobian there, when given,
    for its magnitude adjustment."""

    name = "eiv"
    model = WhitenedModel
    #: Weigh the frequencies up to each trial's low-pass only, and leave out the best fit's
    #: lines (the lab's ``"eiv-all"`` weighs every one, as ``"eiv"`` did before).
    trusted_band: ClassVar[bool] = True

    def build(self, fit: FitResiduals) -> ErrorModel:
        if fit.sigma is not None:
            raise ConfigError(f"error model {self.name!r}: sigma is only for kind 'known'")
        if fit.problem is None:
            raise ConfigError(f"error model {self.name!r} needs the case's model and "
                              "processing: build it with problem_error_model(problem, r, "
                              f"{self.name!r}, point=x)")
        if fit.point is None:
            raise ConfigError(f"error model {self.name!r} needs the best fit's search point "
                              "(point)")
        r = fit.need_residuals(self.name)
        top = int(fit.options.get("ar_max_order", AR_MAX_ORDER))
        order = max(ar_order(r[a:b], top) for a, b in zip(fit.starts, fit.stops, strict=True))
        spectral, ar = input_noise_whitening(fit.problem, fit.point, r, fit.starts, fit.stops,
                                             order, trusted_band=self.trusted_band)
        counts = np.array([max(t.size - fit.removed[list(t.blocks)].sum()
                               - (0 if t.nuisance is None else t.nuisance.shape[1]), 1.0)
                           for t in spectral])
        model = WhitenedModel(self.name, fit.starts, fit.stops, counts, fit.rho(r), ar=ar,
                              spectral=spectral)
        if fit.jacobian is None:
            return model
        return magnitude_adjusted(fit.problem, model, fit.point, r, fit.jacobian, r)

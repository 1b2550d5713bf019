"""The error model's interface and registry: the likelihood of a case's residual vector.

The residual vector r (m,) of an :class:`~femupdate.problem.update.UpdateProblem` is made of blocks,
one per fitted trial × channel (each channel's samples in turn, the trials in order), each
scaled by a constant (its share of φ over its energy). Within a block the prediction errors
are modelled as Gaussian (Beck & Katafygiotis 1998 for the prediction-error model): here,
:class:`ErrorModel`, with an unknown variance σ_c² integrated out under Jeffreys' prior
p(σ²) ∝ 1/σ²::

    log L = Σ_c [ log Γ(N_c/2) − (N_c/2) · log(π · ‖r_c‖²) ]

or, when σ_c is known, the Gaussian of that variance; the default kind fixes σ_c at the best
fit's (:class:`femupdate.inference.neff.PlugInModel`). ``N_c`` is the number of *independent*
values in the block: what an error model measures at the best fit, once, so that the
likelihood is one fixed function of the parameters.

The kinds plug in as emcee's moves do: a small :class:`ErrorModelKind` per file (the default
``"neff"`` in :mod:`femupdate.inference.neff`, ``"known"`` in
:mod:`femupdate.inference.known`), collected by name in a :class:`Registry`; the product's
registry is :data:`femupdate.inference.error_models.ERROR_MODELS`, and the kinds measured
and set aside live in ``benchmarks/error_models`` (``benchmarks/posterior.py`` registers
them in a registry of its own). This module imports none of them.

Every function takes residual rows (k, m), so that a population is one call; a row with a
non-finite value (a failed evaluation) has log L = −inf.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from scipy.special import gammaln

from femupdate.errors import ConfigError, DataError


def residual_blocks(problem: Any) -> tuple[tuple[slice, ...], tuple[int, ...]]:
    """The slices of r of each fitted trial × channel of an UpdateProblem, in the order of
    :meth:`~femupdate.problem.update.UpdateProblem.residuals`, and the number of degrees of freedom
    each block loses to fitted constants (2 per channel with experimental parameters: the
    residual is projected off span{1, t}, else 0)."""
    slices: list[slice] = []
    removed: list[int] = []
    start = 0
    for trial in problem.fitted:
        objective = trial.objective
        n_samples, n_channels = objective.target.shape
        lost = 2 if objective.with_experimental_parameters else 0
        for _ in range(n_channels):
            slices.append(slice(start, start + n_samples))
            removed.append(lost)
            start += n_samples
    return tuple(slices), tuple(removed)


def lag1_autocorrelation(r: np.ndarray) -> float:
    """The lag-1 autocorrelation Σ r_t r_{t−1} / Σ r_t² of a residual block (about zero, not
    about its mean: the residual of a good fit has none)."""
    r = np.asarray(r, dtype=float)
    energy = float(r @ r)
    if r.size < 2 or energy == 0.0:
        return 0.0
    return float(r[1:] @ r[:-1]) / energy


@dataclass(frozen=True)
class ErrorModel:
    """A fixed likelihood of residual vectors (picklable: plain arrays).

    A kind that whitens the residual before weighing it subclasses this and overrides
    :meth:`whiten`, :meth:`_white_lengths` and :meth:`data`.

    Attributes
    ----------
    kind : str
        The registry name of the kind that built it.
    starts, stops : ndarray of int (c,)
        The blocks of r.
    counts : ndarray (c,)
        N_c, the independent values per block.
    rho : ndarray (c,)
        Lag-1 autocorrelation of each block at the best fit (zeros when not measured).
    sigma : ndarray (c,) or None
        Known error standard deviation per block, in units of r (None: unknown, integrated
        out).
    """

    kind: str
    starts: np.ndarray
    stops: np.ndarray
    counts: np.ndarray
    rho: np.ndarray
    sigma: np.ndarray | None = None

    @property
    def size(self) -> int:
        """m, the length of the residual vector."""
        return int(self.stops[-1])

    def whiten(self, rows: np.ndarray) -> np.ndarray:
        """The rows (k, m) as the errors the model weighs: themselves here. A linear map
        (apply it to a Jacobian's columns too: ``whiten(J.T).T``)."""
        return np.atleast_2d(np.asarray(rows, dtype=float))

    @property
    def whitens(self) -> bool:
        """Whether :meth:`whiten` is a kind's own (the residuals weighed through a whitening,
        so its mode is not the least-squares fit, and each model class's likelihood its own)."""
        return type(self).whiten is not ErrorModel.whiten

    def _white_lengths(self) -> np.ndarray:
        """The lengths of the blocks of :meth:`whiten`'s output."""
        return self.stops - self.starts

    def _white_blocks(self) -> list[tuple[int, int]]:
        lengths = self._white_lengths()
        ends = np.cumsum(lengths)
        return [(int(e - n), int(e)) for e, n in zip(ends, lengths, strict=True)]

    def sums_of_squares(self, rows: np.ndarray) -> np.ndarray:
        """‖r_c‖² of each (whitened) block of each row: shape (k, c)."""
        white = self.whiten(rows)
        return np.column_stack([np.einsum("ij,ij->i", white[:, a:b], white[:, a:b])
                                for a, b in self._white_blocks()])

    def loglike_rows(self, rows: np.ndarray) -> np.ndarray:
        """log L of each residual row (k, m): shape (k,); −inf for a row with a non-finite
        value (a failed evaluation) or an exactly zero block under an unknown variance."""
        rows = np.atleast_2d(np.asarray(rows, dtype=float))
        if rows.shape[1] != self.size:
            raise ConfigError(f"error model: residual rows of length {rows.shape[1]}, the "
                              f"model was built for {self.size}")
        finite = np.all(np.isfinite(rows), axis=1)
        # a diverged run's residuals (states up to 1e150) may square beyond the floats: its
        # log L is then -inf (its true value lies below -1000 anyway), without an overflow
        # warning per row
        with np.errstate(over="ignore"):
            squares = self.sums_of_squares(np.where(finite[:, None], rows, 0.0))
        out = self.loglike_of_squares(squares)
        out[~finite] = -np.inf
        return out

    def loglike_of_squares(self, squares: np.ndarray) -> np.ndarray:
        """log L of rows (k, c) of the blocks' sums of squares ‖r_c‖²: shape (k,)."""
        squares = np.atleast_2d(squares)
        with np.errstate(divide="ignore", over="ignore"):
            if self.sigma is not None:
                sigma2 = self.sigma ** 2
                lengths = self._white_lengths()
                return (-0.5 * squares / sigma2
                        - 0.5 * lengths * np.log(2.0 * math.pi * sigma2)).sum(axis=1)
            half = 0.5 * self.counts
            return (gammaln(half) - half * np.log(math.pi * squares)).sum(axis=1)

    def log_squares_slope(self, squares: np.ndarray) -> np.ndarray:
        """∂ log L / ∂ log ‖r_c‖² at rows (k, c) of sums of squares: shape (k, c)."""
        squares = np.atleast_2d(squares)
        if self.sigma is not None:
            return -0.5 * squares / self.sigma ** 2
        return np.broadcast_to(-0.5 * self.counts, squares.shape).copy()

    def of_sums(self) -> ErrorModel:
        """A model of c one-value blocks whose log L of rows √‖r_c‖² is this model's of the
        residuals (an unknown variance; the surrogate posterior samples with it)."""
        c = self.counts.size
        return ErrorModel("iid", np.arange(c), np.arange(1, c + 1), self.counts.copy(),
                          np.zeros(c))

    def loglike(self, r: np.ndarray) -> float:
        """log L of one residual vector."""
        return float(self.loglike_rows(np.asarray(r, dtype=float)[None, :])[0])

    def weights(self, r: np.ndarray) -> np.ndarray:
        """Gauss–Newton weights w (one per whitened residual) at a residual vector r: the
        Hessian of −log L is ≈ J_wᵀ diag(w) J_w, with J_w = ``whiten(J.T).T``; so the Laplace
        covariance at the best fit is inv(J_wᵀ diag(w) J_w) (plus the prior's curvature).
        Unknown variance: w = N_c / ‖r_c‖² (the term in (Jᵀr)(rᵀJ), zero at an unconstrained
        best fit, is dropped); known: 1/σ_c²."""
        if self.sigma is not None:
            per_block = 1.0 / self.sigma ** 2
        else:
            squares = self.sums_of_squares(np.asarray(r, dtype=float)[None, :])[0]
            if np.any(squares <= 0.0) or not np.all(np.isfinite(squares)):
                raise DataError("error model: a residual block is zero or not finite at the "
                                "best fit: no variance to estimate")
            per_block = self.counts / squares
        return np.concatenate([np.full(b - a, w) for (a, b), w in
                               zip(self._white_blocks(), per_block, strict=True)])

    def notes(self) -> list[str]:
        """What the model left out of the records, in words (none here)."""
        return []

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready description for the summary (kind, N_c, ρ_c, σ_c)."""
        return {"kind": self.kind, "counts": self.counts.tolist(), "rho": self.rho.tolist(),
                "block_lengths": (self.stops - self.starts).tolist(),
                **({} if self.sigma is None else {"sigma": self.sigma.tolist()})}

    def data(self) -> dict[str, Any]:
        """The model as plain data (:meth:`Registry.from_data` rebuilds it bit for bit)."""
        return {"kind": self.kind, "starts": self.starts.tolist(),
                "stops": self.stops.tolist(), "counts": self.counts.tolist(),
                "rho": self.rho.tolist(),
                "sigma": None if self.sigma is None else self.sigma.tolist()}

    @classmethod
    def from_data(cls, data: Mapping[str, Any]) -> ErrorModel:
        """The inverse of :meth:`data`."""
        sigma = data.get("sigma")
        return cls(str(data["kind"]), np.asarray(data["starts"], dtype=int),
                   np.asarray(data["stops"], dtype=int), np.asarray(data["counts"], float),
                   np.asarray(data["rho"], float),
                   None if sigma is None else np.asarray(sigma, float))


@dataclass(frozen=True)
class FitResiduals:
    """What a kind measures its model on: the residual blocks and, at the best fit, the
    residuals, the Jacobian and the problem (each None where the caller has none).

    Attributes
    ----------
    starts, stops : ndarray of int (c,)
        Contiguous blocks covering r from 0.
    removed : ndarray (c,)
        Degrees of freedom each block lost to fitted constants.
    residuals : ndarray (m,) or None
        r at the best fit, finite, no block all zero (checked by :meth:`need_residuals`).
    jacobian : ndarray (m, n) or None
        ∂r/∂θ at the best fit, in any coordinates of θ.
    sigma : float or ndarray (c,) or None
        A known error standard deviation, in units of r.
    problem, point : the UpdateProblem and its search point at the best fit, or None.
    options : mapping
        Options of one kind (e.g. an AR order), empty for the product's.
    """

    starts: np.ndarray
    stops: np.ndarray
    removed: np.ndarray
    residuals: np.ndarray | None = None
    jacobian: np.ndarray | None = None
    sigma: Any = None
    problem: Any = None
    point: np.ndarray | None = None
    options: Mapping[str, Any] = field(default_factory=dict)

    @property
    def lengths(self) -> np.ndarray:
        return self.stops - self.starts

    def need_residuals(self, kind: str) -> np.ndarray:
        """The best fit's residuals, or a ConfigError / DataError saying why there are none."""
        if self.residuals is None:
            raise ConfigError(f"error model {kind!r} needs the residuals at the best fit "
                              "(best_residuals)")
        r = np.asarray(self.residuals, dtype=float).reshape(-1)
        if r.size != self.stops[-1] or not np.all(np.isfinite(r)):
            raise DataError(f"error model: best_residuals must be {self.stops[-1]} finite "
                            f"values, got {r.size}")
        if any(not np.any(r[a:b]) for a, b in zip(self.starts, self.stops, strict=True)):
            raise DataError("error model: a residual block is all zero at the best fit (a "
                            "perfect fit or a zero record): its error variance is not defined")
        return r

    def rho(self, r: np.ndarray) -> np.ndarray:
        """Each block's lag-1 autocorrelation in ``r``."""
        return np.array([lag1_autocorrelation(r[a:b])
                         for a, b in zip(self.starts, self.stops, strict=True)])


class ErrorModelKind:
    """One kind of error model: how it is measured at a best fit. Subclasses set
    :attr:`name` (the registry's key), :attr:`model` (the :class:`ErrorModel` class it
    builds, and rebuilds from data) and implement :meth:`build`; :attr:`in_case` says whether
    a case file may name it (``[posterior] error_model``)."""

    name: ClassVar[str] = ""
    model: ClassVar[type[ErrorModel]] = ErrorModel
    in_case: ClassVar[bool] = True

    def build(self, fit: FitResiduals) -> ErrorModel:
        raise NotImplementedError


class Registry:
    """Error model kinds by name, registered explicitly (:meth:`register`)."""

    def __init__(self, *kinds: ErrorModelKind) -> None:
        self._kinds: dict[str, ErrorModelKind] = {}
        for kind in kinds:
            self.register(kind)

    def register(self, kind: ErrorModelKind) -> None:
        """Add ``kind`` under its name (a name already taken is a ConfigError)."""
        if not kind.name or kind.name in self._kinds:
            raise ConfigError(f"error model registry: name {kind.name!r} is empty or taken "
                              f"(taken: {', '.join(self._kinds)})")
        self._kinds[kind.name] = kind

    def copy(self) -> Registry:
        return Registry(*self._kinds.values())

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self._kinds)

    def __contains__(self, name: object) -> bool:
        return name in self._kinds

    def __getitem__(self, name: str) -> ErrorModelKind:
        if name not in self._kinds:
            raise ConfigError(f"error model kind: got {name!r} (allowed: "
                              f"{', '.join(self._kinds)})")
        return self._kinds[name]

    def from_data(self, data: Mapping[str, Any]) -> ErrorModel:
        """An error model rebuilt from :meth:`ErrorModel.data`, by its kind's class."""
        return self[str(data["kind"])].model.from_data(data)


def fit_residuals(blocks: tuple[slice, ...] | list[slice], *,
                  best_residuals: np.ndarray | None = None,
                  dof_removed: tuple[int, ...] | list[int] | None = None,
                  sigma: Any = None, jacobian: np.ndarray | None = None,
                  problem: Any = None, point: np.ndarray | None = None,
                  options: Mapping[str, Any] | None = None) -> FitResiduals:
    """The :class:`FitResiduals` of ``blocks`` (contiguous from 0, each ≥ 3 samples:
    ConfigError otherwise)."""
    blocks = list(blocks)
    if not blocks:
        raise ConfigError("error model: no residual block (allowed: at least one)")
    starts = np.array([b.start for b in blocks], dtype=int)
    stops = np.array([b.stop for b in blocks], dtype=int)
    if starts[0] != 0 or np.any(starts[1:] != stops[:-1]) or np.any(stops - starts < 3):
        raise ConfigError("error model: blocks must be contiguous from 0, each of at least 3 "
                          "samples")
    removed = np.zeros(len(blocks)) if dof_removed is None else np.asarray(dof_removed, float)
    return FitResiduals(starts, stops, removed, best_residuals, jacobian, sigma, problem,
                        None if point is None else np.asarray(point, dtype=float),
                        dict(options or {}))

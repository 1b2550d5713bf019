"""The error model: the likelihood of a case's residual vector, honest about time histories.

The residual vector r (m,) of an :class:`~femupdate.update.UpdateProblem` is made of blocks,
one per fitted trial × channel (each channel's samples in turn, the trials in order), each
scaled by a constant (its share of φ over its energy). Within a block the prediction errors
are modelled as Gaussian with an unknown variance σ_c², integrated out under Jeffreys' prior
p(σ²) ∝ 1/σ²::

    log L = Σ_c [ log Γ(N_c/2) − (N_c/2) · log(π · ‖r_c‖²) ]

(Beck & Katafygiotis 1998 for the prediction-error model). The block's constant scale only
shifts log L by a constant, and the unknown variance absorbs it.

``N_c`` is the number of *independent* values in the block. The residuals of sampled time
histories are strongly correlated in time (a band-limited record has far fewer independent
values than samples), so taking N_c as the block length (kind ``"iid"``) makes credible
intervals far too narrow. Kind ``"neff"`` (the default) takes the effective count of an AR(1)
process with the residuals' lag-1 autocorrelation ρ_c, N_c = N·(1 − ρ_c)/(1 + ρ_c), measured
once at the best fit and then held fixed, so the likelihood is one fixed function of the
parameters. Kind ``"tau"`` takes N_c = N/τ_c with τ_c the residuals' integrated
autocorrelation time (Geyer's initial monotone sequence, as ArviZ's effective sample size
computes it), which, unlike the AR(1) count, credits the oscillating (band-limited) residual
of a structure's response with the many cycles it holds. Kind ``"ar1"`` models the errors as
an AR(1) process of that fixed ρ_c instead (the conditional likelihood of the innovations
r_t − ρ r_{t−1}). Kind ``"arp"`` models them as an AR(p) process per block, its
coefficients fitted by least squares to the block's residuals at the best fit and then held
fixed, the order p (the same for every block) the largest of the blocks' orders chosen by the
Bayesian information criterion up to :data:`AR_MAX_ORDER`: the conditional likelihood of the
innovations r_t − Σ_k a_k r_{t−k}, which a high enough order makes white, so that every
innovation counts. Kind ``"adjusted"`` takes N_c = k·N, the i.i.d. likelihood tempered by the
magnitude adjustment k = n / tr(H⁻¹M) of :func:`femupdate.posterior.sandwich.magnitude_adjustment`
(Ribatet, Cooley & Davison 2012): k is the one power that matches, on average over the
parameters, the likelihood's curvature to the sandwich covariance of the least-squares best fit,
the covariance the residuals' own autocorrelation gives it with no model of that correlation;
it needs the Jacobian at the best fit (in any coordinates: k does not depend on them). Kind
``"eiv"`` (errors in the variables) models the noise of the table's record too, which reaches
every channel through the model: each block prewhitened by an AR filter (``"arp"``'s order) of
its own noise path, each trial's blocks are whitened together in the frequency domain by the
spectrum of output noise plus the model's response to table noise, each sensor's offset and
drift projected out (:mod:`femupdate.posterior.input_noise`; linear models of femupdate's own,
built by :func:`problem_error_model` at the best fit). Kind
``"known"``: Gaussian errors of a given standard deviation per block (analytic checks).

Every function takes residual rows (k, m), so that a population is one call; a row with a
non-finite value (a failed evaluation) has log L = −inf.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.special import gammaln

from femupdate.errors import ConfigError, DataError

if TYPE_CHECKING:
    from femupdate.posterior.input_noise import TrialWhitening

#: The kinds of error model, the default first.
KINDS: tuple[str, ...] = ("neff", "tau", "iid", "ar1", "arp", "adjusted", "known", "eiv")
#: The error model of the Laplace record at a search's best fit when the case names none: wide
#: enough to span the minima a search can end in (docs/posterior.md, section 6).
DEFAULT_KIND = "neff"
#: The error model of the sampled posterior when the case names none: calibrated in
#: ``femupdate posterior``'s flow, which checks its start and samples again from a better fit
#: (docs/posterior.md, section 6).
SAMPLED_KIND = "adjusted"
#: The largest order kind ``"arp"`` considers (the bridge's residuals choose 20–32).
AR_MAX_ORDER = 32


def residual_blocks(problem: Any) -> tuple[tuple[slice, ...], tuple[int, ...]]:
    """The slices of r of each fitted trial × channel of an UpdateProblem, in the order of
    :meth:`~femupdate.update.UpdateProblem.residuals`, and the number of degrees of freedom
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


def effective_count(n: int, rho: float) -> float:
    """N·(1 − ρ)/(1 + ρ): the number of independent values an AR(1) series of N samples and
    lag-1 autocorrelation ρ carries about its mean (ρ clipped to [0, 1): a negatively
    correlated residual is not credited with more than N values)."""
    rho = min(max(rho, 0.0), 1.0 - 1e-12)
    return n * (1.0 - rho) / (1.0 + rho)


@dataclass(frozen=True)
class ErrorModel:
    """A fixed likelihood of residual vectors (picklable: plain arrays).

    Attributes
    ----------
    kind : str
        One of :data:`KINDS` (module docstring).
    starts, stops : ndarray of int (c,)
        The blocks of r.
    counts : ndarray (c,)
        N_c, the independent values per block (of the innovations for ``"ar1"``).
    rho : ndarray (c,)
        Lag-1 autocorrelation of each block at the best fit (zeros when not measured).
    sigma : ndarray (c,) or None
        Known error standard deviation per block (kind ``"known"``), in units of r.
    ar : ndarray (c, p) or None
        AR coefficients a_1 … a_p of each block (kinds ``"arp"`` and ``"eiv"``).
    spectral : tuple of TrialWhitening or None
        Kind ``"eiv"``: each fitted trial's whitening of its AR-prewhitened blocks in the
        frequency domain (:mod:`femupdate.posterior.input_noise`); ``counts`` then has one
        entry per trial.
    """

    kind: str
    starts: np.ndarray
    stops: np.ndarray
    counts: np.ndarray
    rho: np.ndarray
    sigma: np.ndarray | None = None
    ar: np.ndarray | None = None
    spectral: tuple[TrialWhitening, ...] | None = None

    @property
    def size(self) -> int:
        """m, the length of the residual vector."""
        return int(self.stops[-1])

    @property
    def lag(self) -> int:
        """The samples each block loses to whitening: 1 for ``"ar1"``, p for ``"arp"`` and
        ``"eiv"``."""
        if self.kind == "ar1":
            return 1
        return 0 if self.ar is None else int(self.ar.shape[1])

    def whiten(self, rows: np.ndarray) -> np.ndarray:
        """The rows (k, m) as the errors the model takes independent: themselves, or for
        ``"ar1"`` each block's innovations r_t − ρ_c r_{t−1} (the first sample dropped), for
        ``"arp"`` r_t − Σ_k a_k r_{t−k} (the first p dropped), for ``"eiv"`` those of each
        trial whitened across its channels and frequencies
        (:meth:`~femupdate.posterior.input_noise.TrialWhitening.apply`). A linear map: apply
        it to a Jacobian's columns too (``whiten(J.T).T``)."""
        rows = np.atleast_2d(np.asarray(rows, dtype=float))
        if self.ar is not None:
            from scipy.signal import lfilter

            p = self.lag
            blocks = [lfilter(np.concatenate([[1.0], -a]), [1.0], rows[:, s:b], axis=1)[:, p:]
                      for s, b, a in zip(self.starts, self.stops, self.ar, strict=True)]
            if self.spectral is None:
                return np.concatenate(blocks, axis=1)
            return np.concatenate([trial.apply([blocks[b] for b in trial.blocks])
                                   for trial in self.spectral], axis=1)
        if self.kind != "ar1":
            return rows
        parts = [rows[:, a + 1:b] - rho * rows[:, a:b - 1]
                 for a, b, rho in zip(self.starts, self.stops, self.rho, strict=True)]
        return np.concatenate(parts, axis=1)

    def _white_blocks(self) -> list[tuple[int, int]]:
        """The blocks of :meth:`whiten`'s output (for ``"eiv"``, one per trial)."""
        lengths = (self.stops - self.starts - self.lag if self.spectral is None
                   else np.array([trial.size for trial in self.spectral]))
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
        safe = np.where(finite[:, None], rows, 0.0)
        squares = self.sums_of_squares(safe)
        with np.errstate(divide="ignore"):
            if self.kind == "known":
                sigma2 = self.sigma ** 2
                lengths = np.array([b - a for a, b in self._white_blocks()])
                out = (-0.5 * squares / sigma2
                       - 0.5 * lengths * np.log(2.0 * math.pi * sigma2)).sum(axis=1)
            else:
                half = 0.5 * self.counts
                out = (gammaln(half) - half * np.log(math.pi * squares)).sum(axis=1)
        out[~finite] = -np.inf
        return out

    def loglike(self, r: np.ndarray) -> float:
        """log L of one residual vector."""
        return float(self.loglike_rows(np.asarray(r, dtype=float)[None, :])[0])

    def weights(self, r: np.ndarray) -> np.ndarray:
        """Gauss–Newton weights w (one per whitened residual) at a residual vector r: the
        Hessian of −log L is ≈ J_wᵀ diag(w) J_w and its gradient −J_wᵀ diag(w) r_w, with
        J_w = ``whiten(J.T).T`` and r_w = ``whiten(r)``; so the Laplace covariance at the best
        fit is inv(J_wᵀ diag(w) J_w) (plus the prior's curvature). Unknown variance: w = N_c
        / ‖r_c‖² (the term in (Jᵀr)(rᵀJ), zero at an unconstrained best fit, is dropped);
        known: 1/σ_c²."""
        blocks = self._white_blocks()
        if self.kind == "known":
            per_block = 1.0 / self.sigma ** 2
        else:
            squares = self.sums_of_squares(np.asarray(r, dtype=float)[None, :])[0]
            if np.any(squares <= 0.0) or not np.all(np.isfinite(squares)):
                raise DataError("error model: a residual block is zero or not finite at the "
                                "best fit: no variance to estimate")
            per_block = self.counts / squares
        return np.concatenate([np.full(b - a, w) for (a, b), w in
                               zip(blocks, per_block, strict=True)])

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready description (kind, N_c, ρ_c, σ_c)."""
        return {"kind": self.kind, "counts": self.counts.tolist(), "rho": self.rho.tolist(),
                "block_lengths": (self.stops - self.starts).tolist(),
                **({} if self.sigma is None else {"sigma": self.sigma.tolist()}),
                **({} if self.ar is None else {"ar": self.ar.tolist()}),
                **({} if self.spectral is None else
                   {"noise": [{"sigma_outputs": t.sigma_outputs.tolist(),
                               "sigma_input": t.sigma_input, "input_share": t.input_share,
                               "frequencies": int(t.bins.size)} for t in self.spectral]})}


def error_model(blocks: tuple[slice, ...] | list[slice], kind: str = DEFAULT_KIND, *,
                best_residuals: np.ndarray | None = None,
                dof_removed: tuple[int, ...] | list[int] | None = None,
                sigma: float | np.ndarray | None = None,
                jacobian: np.ndarray | None = None,
                ar_max_order: int = AR_MAX_ORDER) -> ErrorModel:
    """Build an error model over the residual ``blocks`` (:func:`residual_blocks`).

    Parameters
    ----------
    blocks : sequence of slice
        Contiguous blocks covering r from 0, in order.
    kind : {"neff", "tau", "iid", "ar1", "arp", "adjusted", "known"}
        See the module docstring.
    best_residuals : ndarray (m,), optional
        r at the best fit: needed by every kind but ``"iid"`` and ``"known"`` (measured on it,
        once).
    dof_removed : sequence of int, optional
        Degrees of freedom each block lost to fitted constants (subtracted from N_c).
    sigma : float or ndarray (c,), optional
        The known error standard deviation (kind ``"known"`` only), in units of r.
    jacobian : ndarray (m, n), optional
        ∂r/∂θ at the best fit (kind ``"adjusted"`` only), in any coordinates of θ.
    ar_max_order : int
        The largest AR order kind ``"arp"`` considers (by BIC).
    """
    if kind not in KINDS:
        raise ConfigError(f"error model kind: got {kind!r} (allowed: {', '.join(KINDS)})")
    if kind == "eiv":
        raise ConfigError("error model 'eiv' needs the case's model and processing: build it "
                          "with problem_error_model(problem, r, 'eiv', point=x)")
    blocks = list(blocks)
    if not blocks:
        raise ConfigError("error model: no residual block (allowed: at least one)")
    starts = np.array([b.start for b in blocks], dtype=int)
    stops = np.array([b.stop for b in blocks], dtype=int)
    if starts[0] != 0 or np.any(starts[1:] != stops[:-1]) or np.any(stops - starts < 3):
        raise ConfigError("error model: blocks must be contiguous from 0, each of at least 3 "
                          "samples")
    lengths = stops - starts
    removed = np.zeros(len(blocks)) if dof_removed is None else np.asarray(dof_removed, float)
    rho = np.zeros(len(blocks))
    sig = None
    ar = None
    if kind in ("neff", "tau", "ar1", "arp", "adjusted"):
        if best_residuals is None:
            raise ConfigError(f"error model {kind!r} needs the residuals at the best fit "
                              "(best_residuals)")
        r = np.asarray(best_residuals, dtype=float).reshape(-1)
        if r.size != stops[-1] or not np.all(np.isfinite(r)):
            raise DataError(f"error model: best_residuals must be {stops[-1]} finite values, "
                            f"got {r.size}")
        if np.any([not np.any(r[a:b]) for a, b in zip(starts, stops, strict=True)]):
            raise DataError("error model: a residual block is all zero at the best fit (a "
                            "perfect fit or a zero record): its error variance is not defined")
        rho = np.array([lag1_autocorrelation(r[a:b]) for a, b in zip(starts, stops,
                                                                      strict=True)])
    if kind == "neff":
        counts = np.array([effective_count(int(n - k), p)
                           for n, k, p in zip(lengths, removed, rho, strict=True)])
    elif kind == "tau":
        counts = np.array([autocorrelation_count(r[a:b]) * (1.0 - k / (b - a))
                           for a, b, k in zip(starts, stops, removed, strict=True)])
    elif kind == "ar1":
        counts = (lengths - 1 - removed).astype(float)
    elif kind == "adjusted":
        from femupdate.posterior.sandwich import magnitude_adjustment

        if jacobian is None or np.shape(jacobian)[0] != stops[-1]:
            raise ConfigError(f"error model 'adjusted' needs the Jacobian at the best fit "
                              f"({stops[-1]} rows), got "
                              f"{None if jacobian is None else np.shape(jacobian)}")
        k = magnitude_adjustment(jacobian, r, blocks)
        counts = (lengths - removed) * k
    elif kind == "arp":
        order = max(ar_order(r[a:b], ar_max_order) for a, b in zip(starts, stops, strict=True))
        ar = np.array([ar_fit(r[a:b], order)[0] for a, b in zip(starts, stops, strict=True)])
        counts = (lengths - order - removed).astype(float)
    else:
        counts = (lengths - removed).astype(float)
    if kind == "known":
        if sigma is None:
            raise ConfigError("error model 'known' needs sigma (the error standard deviation)")
        sig = np.broadcast_to(np.asarray(sigma, dtype=float), (len(blocks),)).copy()
        if not np.all(np.isfinite(sig)) or np.any(sig <= 0):
            raise ConfigError(f"error model: sigma must be > 0 and finite, got {sigma!r}")
    elif sigma is not None:
        raise ConfigError(f"error model {kind!r}: sigma is only for kind 'known'")
    counts = np.maximum(counts, 1.0)
    return ErrorModel(kind, starts, stops, counts, rho, sig, ar)


def problem_error_model(problem: Any, best_residuals: np.ndarray,
                        kind: str = DEFAULT_KIND, jacobian: np.ndarray | None = None,
                        ar_max_order: int = AR_MAX_ORDER, *,
                        point: np.ndarray | None = None) -> ErrorModel:
    """The error model of an UpdateProblem, fixed at its best fit's residuals (and, for kind
    ``"adjusted"``, its Jacobian there; for ``"eiv"``, the model at that search ``point``:
    :mod:`femupdate.posterior.input_noise`)."""
    blocks, removed = residual_blocks(problem)
    if kind != "eiv":
        return error_model(blocks, kind, best_residuals=best_residuals, dof_removed=removed,
                           jacobian=jacobian, ar_max_order=ar_max_order)
    if point is None:
        raise ConfigError("error model 'eiv' needs the best fit's search point (point)")
    from femupdate.posterior.input_noise import input_noise_whitening

    prewhitening = error_model(blocks, "arp", best_residuals=best_residuals,
                               dof_removed=removed, ar_max_order=ar_max_order)
    spectral, ar = input_noise_whitening(problem, point, best_residuals, prewhitening.starts,
                                         prewhitening.stops, prewhitening.ar.shape[1])
    lost = np.asarray(removed, dtype=float)
    counts = np.array([max(t.size - lost[list(t.blocks)].sum()
                           - (0 if t.nuisance is None else t.nuisance.shape[1]), 1.0)
                       for t in spectral])
    return dataclasses.replace(prewhitening, kind="eiv", counts=counts, ar=ar,
                               spectral=spectral)

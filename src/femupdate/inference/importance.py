"""Importance sampling at β = 1: TMCMC's last stage without Markov moves.

Once the tempering has reached the posterior π, its resampled population is a set of copies of
a few hundred distinct particles: Metropolis–Hastings moves (``final_steps`` sweeps of
independent proposals) are what made them independent, at one population of evaluations per
sweep. Drawing instead from a proposal q fitted to that population and weighing each draw by
w = π/q gives independent weighted samples of π at once, and their worth is known: for the
self-normalised estimate of the mean of parameter j, with normalised weights w̄_i,

    Var(μ̂_j) ≈ Σ_i w̄_i² (x_ij − μ_j)²,    ESS_j = σ_j² / Var(μ̂_j)

(the delta method; with a constant function in place of x_j it is Kish's (Σw)²/Σw²). Batches
are drawn until every parameter has the ESS asked for.

The proposal is *defensive* (Hesterberg 1995): the Gaussian mixture of the population's
k-means clusters (:func:`femupdate.inference.proposals.fit_mixture`) beside one wider Gaussian
of the whole population, so that π/q stays bounded where the clusters put little mass (a
ripple of a valley, a tail against a bound): importance weights without that are unbounded
and their ESS a guess.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.special import gammaln, logsumexp

from femupdate.inference.proposals import fit_mixture

#: The share of the defensive component (a Student-t of the whole population).
DEFENSIVE_SHARE = 0.3
#: Its scale: the population's standard deviations times this.
DEFENSIVE_WIDTH = 1.5
#: Its degrees of freedom: tails heavier than any posterior's the product samples (a Gaussian
#: likelihood's, or a power law where a kind integrates each channel's variance out), so that
#: π/q stays bounded far out.
DEFENSIVE_DOF = 4.0


@dataclass(frozen=True)
class TMixture:
    """Σ_k w_k t_ν(m_k, L_k L_kᵀ) on R^n: a mixture of multivariate Student-t densities of
    ν degrees of freedom (scale matrices L_k L_kᵀ).

    Attributes
    ----------
    log_weights : ndarray (K,)
        log w_k, Σ w_k = 1.
    means : ndarray (K, n)
    chols : ndarray (K, n, n)
        Lower Cholesky factors of the components' scale matrices.
    dof : float
    """

    log_weights: np.ndarray
    means: np.ndarray
    chols: np.ndarray
    dof: float

    def sample(self, rng: np.random.Generator, k: int) -> np.ndarray:
        """``k`` draws (k, n): a component by its weight, then its t (a Gaussian over the
        square root of a χ²_ν/ν draw)."""
        n = self.means.shape[1]
        which = rng.choice(self.log_weights.size, size=k, p=np.exp(self.log_weights))
        z = rng.standard_normal((k, n))
        g = rng.chisquare(self.dof, k) / self.dof
        return self.means[which] + np.einsum("kij,kj->ki", self.chols[which], z) / np.sqrt(
            g)[:, None]

    def logpdf(self, x: np.ndarray) -> np.ndarray:
        """log q(x) of rows x (k, n)."""
        n, nu = self.means.shape[1], self.dof
        const = gammaln(0.5 * (nu + n)) - gammaln(0.5 * nu) - 0.5 * n * math.log(nu * math.pi)
        parts = np.empty((self.log_weights.size, x.shape[0]))
        for c in range(self.log_weights.size):
            z = np.linalg.solve(self.chols[c], (x - self.means[c]).T)
            parts[c] = (self.log_weights[c] + const - np.log(np.diag(self.chols[c])).sum()
                        - 0.5 * (nu + n) * np.log1p(np.sum(z * z, axis=0) / nu))
        return logsumexp(parts, axis=0)


def defensive_mixture(x: np.ndarray, components: int, inflate: float,
                      rng: np.random.Generator,
                      cholesky: Callable[[np.ndarray], np.ndarray],
                      share: float = DEFENSIVE_SHARE, width: float = DEFENSIVE_WIDTH,
                      dof: float = DEFENSIVE_DOF) -> TMixture:
    """A mixture of Student-t densities of ``dof`` degrees of freedom: one per k-means cluster
    of the population (:func:`fit_mixture`'s clusters, their scales inflated by ``inflate``),
    weight 1 − ``share`` in all, and one of the whole population, its standard deviations
    times ``width``, weight ``share``.

    Parameters
    ----------
    x : ndarray (N, n)
        An equally weighted population of π.
    components, inflate, rng, cholesky
        As :func:`~femupdate.inference.proposals.fit_mixture`.
    share : float
        Weight of the whole population's t, in (0, 1).
    width : float
        Its scale's standard deviations over the population's.
    dof : float
        Degrees of freedom of every component.
    """
    clusters = fit_mixture(x, components, inflate, rng, cholesky)
    n = x.shape[1]
    wide = width * cholesky(np.cov(x.T).reshape(n, n))
    return TMixture(np.append(clusters.log_weights + math.log1p(-share), math.log(share)),
                    np.vstack([clusters.means, x.mean(axis=0)]),
                    np.concatenate([clusters.chols, wide[None, :, :]]), dof)


def normalised_weights(log_w: np.ndarray) -> np.ndarray:
    """exp(log w) / Σ exp(log w), with −inf (a draw outside the cube, a failed evaluation)
    as weight 0; all zeros when no weight is finite."""
    log_w = np.where(np.isfinite(log_w), log_w, -np.inf)
    if not np.any(np.isfinite(log_w)):
        return np.zeros(log_w.shape)
    w = np.exp(log_w - np.max(log_w))
    return w / w.sum()


def importance_ess(x: np.ndarray, log_w: np.ndarray) -> np.ndarray:
    """Per parameter, the effective sample size of the self-normalised importance estimate of
    its mean from draws ``x`` (M, n) with log-weights ``log_w`` (M,) (module docstring); 0
    where no weight is positive."""
    w = normalised_weights(log_w)
    if not np.any(w > 0):
        return np.zeros(x.shape[1])
    d = x - w @ x
    var = w @ (d * d)
    var_mean = (w * w) @ (d * d)
    with np.errstate(invalid="ignore", divide="ignore"):
        ess = var / var_mean
    # a parameter with no spread among the weighted draws: Kish's count
    return np.where(np.isfinite(ess), ess, 1.0 / np.sum(w * w))


def kish_ess(log_w: np.ndarray) -> float:
    """(Σw)²/Σw² of the weights exp(``log_w``)."""
    w = normalised_weights(log_w)
    return float(1.0 / np.sum(w * w)) if np.any(w > 0) else 0.0


def resampled_ess(ess: np.ndarray, draws: int) -> np.ndarray:
    """The effective samples left after the weighted draws are resampled into ``draws``
    equally weighted copies: the resampling adds at most the variance of ``draws`` independent
    samples (multinomial; systematic resampling adds less), so 1/ESS grows by 1/draws."""
    ess = np.asarray(ess, dtype=float)
    with np.errstate(divide="ignore"):
        return np.where(ess > 0, 1.0 / (1.0 / ess + 1.0 / max(draws, 1)), 0.0)

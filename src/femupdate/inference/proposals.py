"""Independent proposals for TMCMC's moves that fit a population better than one Gaussian.

A Metropolis–Hastings step with an independent proposal q accepts a move x → y with
probability min(1, π(y) q(x) / (π(x) q(y))): it mixes as well as q covers π, and particles
where π/q is large stay put. On the viscous bridge the parameters the data barely determine
(an abutment spring, two dampers) have posteriors that fill most of their prior range with
ripples; one Gaussian of the population puts too little mass at their edges and much outside
the cube. A mixture of Gaussians, one per cluster of the population (k-means in the
population's whitened coordinates, scipy's ``kmeans2``), follows their shape.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.cluster.vq import kmeans2
from scipy.special import logsumexp

#: Members a mixture component needs per parameter, for its own covariance
MEMBERS_PER_PARAMETER = 5


@dataclass(frozen=True)
class GaussianMixture:
    """Σ_k w_k N(m_k, L_k L_kᵀ) on R^n.

    Attributes
    ----------
    log_weights : ndarray (K,)
        log w_k, Σ w_k = 1.
    means : ndarray (K, n)
    chols : ndarray (K, n, n)
        Lower Cholesky factors of the components' covariances.
    """

    log_weights: np.ndarray
    means: np.ndarray
    chols: np.ndarray

    def sample(self, rng: np.random.Generator, k: int) -> np.ndarray:
        """``k`` draws (k, n): a component by its weight, then its Gaussian."""
        n = self.means.shape[1]
        which = rng.choice(self.log_weights.size, size=k, p=np.exp(self.log_weights))
        z = rng.standard_normal((k, n))
        return self.means[which] + np.einsum("kij,kj->ki", self.chols[which], z)

    def logpdf(self, x: np.ndarray) -> np.ndarray:
        """log q(x) of rows x (k, n)."""
        n = self.means.shape[1]
        parts = np.empty((self.log_weights.size, x.shape[0]))
        for c in range(self.log_weights.size):
            z = np.linalg.solve(self.chols[c], (x - self.means[c]).T)
            parts[c] = (self.log_weights[c] - 0.5 * np.sum(z * z, axis=0)
                        - np.log(np.diag(self.chols[c])).sum())
        return logsumexp(parts, axis=0) - 0.5 * n * math.log(2 * math.pi)


def fit_mixture(x: np.ndarray, components: int, inflate: float, rng: np.random.Generator,
                cholesky: Callable[[np.ndarray], np.ndarray]) -> GaussianMixture:
    """A Gaussian mixture fitted to the equally weighted rows of ``x`` (N, n).

    k-means (``components`` clusters, k-means++ start, seeded from ``rng``) on the rows
    whitened by the population's own mean and Cholesky factor, so that no parameter's units
    decide the clusters; each cluster gives a component with its members' share as weight,
    their mean, and their covariance times ``inflate``². Clusters with fewer than
    ``MEMBERS_PER_PARAMETER`` · n members join the nearest other cluster (by centroid), so
    that every covariance is estimated from enough members; with too few rows for two such
    clusters the mixture is one Gaussian.

    Parameters
    ----------
    x : ndarray (N, n)
    components : int
        Clusters asked of k-means (fewer may remain).
    inflate : float
        Each component's covariance is multiplied by inflate².
    rng : numpy.random.Generator
        The k-means++ start's randomness.
    cholesky : callable
        Cholesky factor of a covariance that tolerates a near-singular one
        (:func:`femupdate.inference.tmcmc.safe_cholesky`).
    """
    n_rows, n = x.shape
    minimum = MEMBERS_PER_PARAMETER * n
    # no more clusters than distinct rows (a resampled population repeats its particles)
    k = max(1, min(components, n_rows // minimum, np.unique(x, axis=0).shape[0]))
    mean = x.mean(axis=0)
    whole = cholesky(np.cov(x.T).reshape(n, n))
    if k == 1:
        return GaussianMixture(np.zeros(1), mean[None, :], (inflate * whole)[None, :, :])
    z = np.linalg.solve(whole, (x - mean).T).T
    with warnings.catch_warnings():  # an empty cluster is dropped below: no need to say so
        warnings.filterwarnings("ignore", message="One of the clusters is empty")
        centroids, labels = kmeans2(z, k, minit="++", rng=rng)
    counts = np.bincount(labels, minlength=k)
    # small clusters join their nearest large one, smallest first
    for c in np.argsort(counts):
        if counts[c] >= minimum or np.sum(counts >= minimum) == 0:
            continue
        big = np.flatnonzero((counts >= minimum) & (np.arange(k) != c))
        target = big[np.argmin(np.sum((centroids[big] - centroids[c]) ** 2, axis=1))]
        labels[labels == c] = target
        counts[target] += counts[c]
        counts[c] = 0
    kept = np.flatnonzero(counts)
    means = np.array([x[labels == c].mean(axis=0) for c in kept])
    chols = np.array([inflate * component_cholesky(x[labels == c], whole, cholesky)
                      for c in kept])
    log_weights = np.log(counts[kept] / n_rows)
    return GaussianMixture(log_weights, means, chols)


def component_cholesky(members: np.ndarray, whole: np.ndarray,
                       cholesky: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """The Cholesky factor of a cluster's covariance, or the population's (``whole``) when the
    cluster has too few distinct members (n or fewer) to span the space: copies of a few
    particles would give a component of zero width."""
    n = members.shape[1]
    if np.unique(members, axis=0).shape[0] <= n:
        return whole
    return cholesky(np.cov(members.T).reshape(n, n))

"""The dynamics-oblivious baseline observer: k-means clusters of the rest configuration.

Particles are clustered once, by Euclidean distance of their rest positions (seeded k-means++
initialization, then Lloyd iterations). At every step the observer's features are the mean position
and the mean velocity of each cluster along each axis, as in the paper's baseline. Where co-design
changes the body, `refit_kmeans` reclusters it by its material (`observer.kmeans.recluster`).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct


@struct.dataclass
class KMeansObserver:
    """Cluster membership as a fixed linear map.

    Attributes:
      averaging: (k, n) row-normalized membership: row c averages the particles of cluster c.
      centers: (k, d) cluster centres of the rest configuration.
    """

    averaging: jnp.ndarray
    centers: jnp.ndarray

    @property
    def n_features(self) -> int:
        k, d = self.centers.shape
        return 2 * k * d


def fit_kmeans(positions, k: int, seed: int = 0, iterations: int = 100) -> KMeansObserver:
    """Cluster rest positions (n, d) into k clusters; deterministic for a given seed."""
    x = np.asarray(positions, np.float64)
    if x.ndim != 2 or x.shape[1] not in (2, 3):
        raise ValueError(f"positions must have shape (n_particles, 2 or 3), got {x.shape}")
    if not isinstance(k, int) or not 1 <= k <= len(x):
        raise ValueError(f"k must be an integer in [1, n_particles={len(x)}], got {k!r}")
    rng = np.random.default_rng(seed)
    picked = [x[rng.integers(len(x))]]
    for _ in range(1, k):  # k-means++: next centre with probability ~ squared distance
        distance = np.min(((x[:, None] - np.asarray(picked)[None]) ** 2).sum(-1), axis=1)
        total = distance.sum()
        pick = rng.choice(len(x), p=distance / total) if total > 0 else rng.integers(len(x))
        picked.append(x[pick])
    centers = np.asarray(picked)
    for _ in range(iterations):
        labels = np.argmin(((x[:, None] - centers[None]) ** 2).sum(-1), axis=1)
        updated = np.stack([x[labels == c].mean(0) if np.any(labels == c) else centers[c] for c in range(k)])
        if np.allclose(updated, centers):
            break
        centers = updated
    labels = np.argmin(((x[:, None] - centers[None]) ** 2).sum(-1), axis=1)
    membership = (labels[None, :] == np.arange(k)[:, None]).astype(np.float64)
    counts = membership.sum(1, keepdims=True)
    averaging = np.divide(membership, counts, out=np.zeros_like(membership), where=counts > 0)
    dtype = jnp.asarray(positions).dtype
    return KMeansObserver(averaging=jnp.asarray(averaging, dtype), centers=jnp.asarray(centers, dtype))


def refit_kmeans(observer: KMeansObserver, positions, weights, iterations: int = 20):
    """The clusters refitted to a body whose material has changed: weighted Lloyd iterations from
    the current centres (so that cluster c stays cluster c, the controller's c-th input).

    Args:
      observer: the current clusters.
      positions: (n, d) rest positions of the particles.
      weights: (n,) each particle's material (its mass over its mass in the robot as built):
        a particle without material neither pulls a centre nor counts in a cluster's mean; a
        cluster left without material restarts at the material farthest from every centre.
      iterations: Lloyd iterations (a fixed count: jittable and vmappable over seeds).

    Returns:
      (clusters, relabelled): the refitted `KMeansObserver` (membership rows weighted by
      material) and () the share of the body's material whose cluster changed.
    """
    k = observer.centers.shape[0]
    weights = jnp.maximum(weights, 0.0)

    def labels_of(centers):
        return jnp.argmin(jnp.sum((positions[:, None] - centers[None]) ** 2, axis=-1), axis=1)

    def lloyd(_, centers):
        member = (labels_of(centers)[None, :] == jnp.arange(k)[:, None]) * weights[None, :]
        mass = member.sum(1, keepdims=True)
        moved = member @ positions / jnp.where(mass > 0, mass, 1.0)
        # A cluster left without material restarts at the material farthest from every centre
        # (k-means' usual remedy), so that none of the controller's inputs goes dead.
        distance = jnp.min(jnp.sum((positions[:, None] - centers[None]) ** 2, axis=-1), axis=1)
        farthest = positions[jnp.argmax(jnp.where(weights > 0, distance, -1.0))]
        return jnp.where(mass > 0, moved, farthest[None, :])

    before = jnp.argmax(observer.averaging, axis=0)  # each particle's cluster (its nonzero row)
    centers = jax.lax.fori_loop(0, iterations, lloyd, observer.centers)
    labels = labels_of(centers)
    member = (labels[None, :] == jnp.arange(k)[:, None]) * weights[None, :]
    mass = member.sum(1, keepdims=True)
    averaging = member / jnp.where(mass > 0, mass, 1.0)
    total = jnp.maximum(weights.sum(), jnp.finfo(weights.dtype).tiny)
    relabelled = jnp.sum(jnp.where(labels != before, weights, 0.0)) / total
    return KMeansObserver(averaging=averaging.astype(observer.averaging.dtype), centers=centers), relabelled


def kmeans_features(observer: KMeansObserver, state, grid_velocity=None):
    """(2 k d,) features: every cluster's mean position, then every cluster's mean velocity."""
    del grid_velocity  # dynamics-oblivious: reads particles only
    positions = observer.averaging @ state.x
    velocities = observer.averaging @ state.v
    return jnp.concatenate([positions.reshape(-1), velocities.reshape(-1)])

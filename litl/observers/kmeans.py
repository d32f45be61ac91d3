"""The k-means observer (`kmeans`): the paper's baseline, fixed at the start of a run.

The particles of the robot's rest configuration are clustered once per seed; the features are the
clusters' mean positions and velocities. It does not learn; its picture is the clusters
(clusters.png, Fig. 7).
"""

from __future__ import annotations

import dataclasses
import pathlib
from dataclasses import dataclass

from litl.models.kmeans import fit_kmeans, kmeans_features
from litl.observers.interface import Observer, ObserverContext
from litl.settings import Settings, SettingsError


@dataclass(frozen=True)
class KMeansSettings(Settings):
    """The k-means baseline (`observer=kmeans`). Attributes: clusters, k clusters of the rest
    shape (features: each cluster's mean position and velocity)."""

    clusters: int = dataclasses.field(default=6, metadata={"short": "k"})  # k in reports' labels

    def check(self) -> None:
        self._positive_ints("clusters")


def kmeans(robot, settings: KMeansSettings, context: ObserverContext) -> Observer:
    """The k-means baseline: clusters of the rest configuration, fitted once per seed."""
    clusters, sim_config, dtype = settings.clusters, context.sim, context.dtype
    if clusters > robot.layout.n_particles:
        raise SettingsError(
            f"observer.kmeans.clusters={clusters} exceeds the robot's {robot.layout.n_particles} particles",
            "observer.kmeans.clusters",
        )
    rest = robot.own(robot.initial_state(dtype)).x  # the robot's particles, not its scenery's
    return Observer(
        n_features=2 * clusters * sim_config.dim,
        init=lambda key, seed: fit_kmeans(rest, clusters, seed=seed),
        features=kmeans_features,
        pictures=pictures,
    )


def pictures(robot, algorithm, state, run_dir: pathlib.Path, stride: int) -> list[pathlib.Path]:
    """clusters.png: the robot's particles coloured by cluster."""
    import matplotlib.pyplot as plt

    from litl.viz.latent import draw_clusters

    figure = plt.figure(figsize=(6, 5))
    ax = figure.add_subplot(111, projection="3d" if robot.dim == 3 else None)
    draw_clusters(robot, state.observer, ax=ax)
    figure.savefig(run_dir / "clusters.png", dpi=100)
    plt.close(figure)
    return [run_dir / "clusters.png"]

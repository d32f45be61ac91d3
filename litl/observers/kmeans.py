"""The k-means observer (`kmeans`): the paper's baseline, fixed at the start of a run.

The particles of the robot's rest configuration are clustered once per seed; the features are the
clusters' mean positions and velocities. It does not learn; its picture is the clusters
(clusters.png, Fig. 7). Where co-design changes the body (`design=geometry`, `all`),
``observer.kmeans.recluster=true`` reclusters it at every learning phase by where its material
now is (weighted Lloyd iterations from the current centres, so that each cluster keeps its place
among the controller's inputs), and records ``kmeans/relabelled`` (the share of the material
whose cluster changed). Off by default: the paper's baseline keeps its clusters, and the paper's
argument is that they cannot follow the design.
"""

from __future__ import annotations

import dataclasses
import pathlib
from dataclasses import dataclass

import jax.numpy as jnp

from litl.models.kmeans import fit_kmeans, kmeans_features, refit_kmeans
from litl.observers.interface import BodyFollower, Observer, ObserverContext
from litl.settings import Settings, SettingsError


@dataclass(frozen=True)
class KMeansSettings(Settings):
    """The k-means baseline (`observer=kmeans`).

    Attributes:
      clusters: k clusters of the rest shape (features: each cluster's mean position and velocity).
      recluster: recluster the body by its material at every learning phase (where co-design
        changes it); False: keep the clusters of the robot as built, as the paper's baseline does.
    """

    clusters: int = dataclasses.field(default=6, metadata={"short": "k"})  # k in reports' labels
    recluster: bool = False

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
        follower=following(robot, rest) if settings.recluster else None,
    )


def following(robot, rest) -> BodyFollower:
    """Reclustering by material: a particle's weight is its mass over its mass in the robot as
    built (the geometry's occupancy, through its interpolation of mass)."""
    n = rest.shape[0]
    built = robot.scene(rest.dtype).design.density[:n]

    def refit(params, design):
        clusters, relabelled = refit_kmeans(params, rest, design.density[:n] / built)
        return clusters, {"kmeans/relabelled": relabelled}

    return BodyFollower(
        refit=refit, empty_statistics=lambda dtype: {"kmeans/relabelled": jnp.zeros((), dtype)}
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

"""The PCA observer (`pca`): a linear projection of the windowed grid field, fitted on the buffer.

The controller reads the field's coordinates along its first r principal components, each divided
by its standard deviation over the snapshots it was fitted on. Every learning phase fits the
components afresh on the training half of the replay buffer (an SVD of the centred snapshots) and
reports how much of the held-out half's energy the projection keeps (``recon_explained``, the
autoencoder's statistic): against the VAE, the baseline that tells whether the autoencoder's
nonlinearity matters. It is the worked example of the observers guide: one module and one YAML
file (`litl/conf/observer/pca.yaml`).

A refitted component's sign is arbitrary; each is turned to agree with the current one before
the loop's soft update moves Θ toward the refit, so the controller's inputs do not flip.
"""

from __future__ import annotations

import dataclasses
import pathlib
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Self

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from litl.models.replay_buffer import ReplayBuffer, newest
from litl.models.window import Window
from litl.observers.autoencoder_learning import random_split
from litl.observers.interface import GridField, LatentCodec, Learner, Observer, ObserverContext
from litl.settings import Settings, SettingsError

SNAPSHOTS = 6  # the newest snapshots its picture reconstructs
STD_FLOOR = 1e-6  # a component that never varied keeps unit scale instead of dividing by ~0


@struct.dataclass
class PCAParams:
    """Θ of the PCA observer.

    Attributes:
      mean: (D,) the mean flattened windowed field (D = window nodes x d).
      components: (D, r) the principal directions, as columns.
      std: (r,) each component's standard deviation over the fitted snapshots (the features'
        scale).
    """

    mean: jnp.ndarray
    components: jnp.ndarray
    std: jnp.ndarray

    if TYPE_CHECKING:  # flax.struct adds `replace` at run time; declared for the type checker

        def replace(self, **changes: Any) -> Self: ...


@dataclass(frozen=True)
class PCASettings(Settings):
    """The PCA observer (`observer=pca`): a linear projection of the windowed grid field, fitted
    on the replay buffer in every learning phase (`litl.observers.pca`).

    Attributes:
      components: r, principal components (the controller's features).
      window: side (domain units) of the grid window it sees, as `observer.vae.window`.
      field: what it sees of the grid and the replay buffer stores (`GridField`), as
        `observer.vae.field` (runs from before this key read the VAE's).
    """

    components: int = dataclasses.field(default=8, metadata={"short": "r"})  # r in reports' labels
    window: float | None = 0.5
    field: GridField = GridField.mass_weighted

    def check(self) -> None:
        self._positive_ints("components")
        self._positive_numbers("window", optional=("window",))


def pca(robot, settings: PCASettings, context: ObserverContext) -> Observer:
    """The PCA observer: `observer.pca.components` features of a window around the robot."""
    sim_config, dtype = context.sim, context.dtype
    window = Window.around(sim_config.grid_shape, sim_config.dx, settings.window)
    size = int(np.prod(window.shape)) * sim_config.dim
    rank = settings.components
    if rank > size:
        raise SettingsError(
            f"observer.pca.components={rank} exceeds the {size} values of the windowed field",
            "observer.pca.components",
        )

    def init(key, seed) -> PCAParams:
        # A placeholder: the bootstrap's phase replaces it whole.
        return PCAParams(
            mean=jnp.zeros((size,), dtype),
            components=jnp.zeros((size, rank), dtype),
            std=jnp.ones((rank,), dtype),
        )

    def features(params: PCAParams, state, grid_velocity):
        field = grid_velocity if window.whole_grid else window.crop(grid_velocity, jnp.mean(state.x, axis=0))
        return project(params, field.reshape(-1))

    learner = Learner(
        window=window,
        phase=lambda params, buffer, key: fit(params, buffer, key, rank),
        step=None,
        optimizer_init=lambda params: (),
        empty_statistics=empty_statistics,
        reconstruct=reconstruct,
        latent=LatentCodec(
            encode=encode,
            decode=lambda params, latents: decode(params, latents).reshape(
                latents.shape[0], *window.shape, sim_config.dim
            ),
        ),
    )
    return Observer(
        n_features=rank,
        init=init,
        features=features,
        learner=learner,
        pictures=pictures,
        field=settings.field,
    )


def project(params: PCAParams, flat):
    """(r,) the features of a flattened field (D,): coordinates along the components over their
    standard deviations."""
    return (flat - params.mean) @ params.components / params.std


def encode(params: PCAParams, fields):
    """(B, r) the features of fields (B, *window, d)."""
    return project(params, fields.reshape(fields.shape[0], -1))


def decode(params: PCAParams, latents):
    """Fields (B, D) from features (B, r): back along the components, in the fields' units; the
    caller reshapes them to (B, *window, d) (`LatentCodec.decode` does)."""
    return params.mean + (latents * params.std) @ params.components.T


def reconstruct(params: PCAParams, fields):
    """(B, *window, d) fields projected onto the components and back (in the fields' units);
    flattened fields (B, D) come back flattened."""
    flat = fields.reshape(fields.shape[0], -1)
    coordinates = (flat - params.mean) @ params.components
    return (params.mean + coordinates @ params.components.T).reshape(fields.shape)


def empty_statistics(dtype, dim: int) -> dict[str, Any]:
    """Before the first phase: no snapshots fitted, the losses unknown."""
    nan = jnp.full((), jnp.nan, dtype)
    return {
        "snapshots": jnp.zeros((), jnp.int32),
        "recon_loss_train": nan,
        "recon_loss_val": nan,
        "recon_explained": nan,
    }


def fit(params: PCAParams, buffer: ReplayBuffer, key, rank: int) -> tuple[PCAParams, dict[str, Any]]:
    """The learning phase: components fitted on the training half of the buffer's valid
    snapshots (an even random split), scored on the validation half (pure; vmappable over
    seeds). With fewer than two training snapshots Θ′ is Θ."""
    dtype = params.mean.dtype
    capacity = buffer.fields.shape[0]
    split = random_split(buffer.count, capacity, key)
    train = jnp.zeros((capacity,), bool).at[split.train].max(split.train_mask)
    validation = jnp.zeros((capacity,), bool).at[split.validation].max(split.validation_mask)
    # Slots outside the halves may hold anything (stale or non-finite values): zero them first.
    flat = jnp.where((train | validation)[:, None], buffer.fields.reshape(capacity, -1).astype(dtype), 0.0)
    n_train = jnp.sum(train)
    weight = train.astype(dtype)[:, None]
    mean = jnp.sum(flat * weight, axis=0) / jnp.maximum(n_train, 1).astype(dtype)
    _, singular, directions = jnp.linalg.svd((flat - mean) * weight, full_matrices=False)
    components = directions[:rank].T
    # Keep each direction's sign where it was (Θ is moved toward the refit, not replaced).
    agree = jnp.sign(jnp.sum(components * params.components, axis=0))
    components = components * jnp.where(agree == 0, 1.0, agree)
    std = jnp.maximum(singular[:rank] / jnp.sqrt(jnp.maximum(n_train, 1).astype(dtype)), STD_FLOOR)
    fitted = PCAParams(mean=mean, components=components, std=std)
    fitted = jax.tree.map(lambda new, old: jnp.where(n_train >= 2, new, old), fitted, params)

    def scores(mask):
        """(mean squared reconstruction error, mean squared value) over the `mask`ed snapshots."""
        kept = jnp.where(mask[:, None], flat, 0.0)
        error = jnp.where(mask[:, None], (reconstruct(fitted, kept) - kept) ** 2, 0.0)
        values = jnp.maximum(jnp.sum(mask), 1).astype(dtype) * flat.shape[1]
        return jnp.sum(error) / values, jnp.sum(kept**2) / values

    train_mse, _ = scores(train)
    val_mse, val_energy = scores(validation)
    return fitted, {
        "snapshots": n_train.astype(jnp.int32),
        "recon_loss_train": train_mse,
        "recon_loss_val": val_mse,
        "recon_explained": 1.0 - val_mse / val_energy,
    }


def pictures(robot, algorithm, state, run_dir: pathlib.Path, stride: int) -> list[pathlib.Path]:
    """pca.png: the first components' speed (top row) and the newest snapshots' speed with
    their reconstructions (lower rows); 3D fields are shown in their middle slice."""
    import matplotlib.pyplot as plt

    window = algorithm.observer.learner.window
    params = state.observer
    components = np.asarray(params.components).T.reshape(-1, *window.shape, robot.dim)
    snapshots = newest(state.buffer, SNAPSHOTS)
    rows = [("component", components[:SNAPSHOTS])]
    if len(snapshots):
        rows += [("snapshot", snapshots), ("reconstruction", np.asarray(reconstruct(params, snapshots)))]
    columns = max(len(images) for _, images in rows)
    figure, axes = plt.subplots(len(rows), columns, figsize=(2 * columns, 2 * len(rows)), squeeze=False)
    for row, (name, images) in enumerate(rows):
        for column in range(columns):
            ax = axes[row][column]
            ax.set_axis_off()
            if column < len(images):
                speed = np.linalg.norm(images[column], axis=-1)
                if speed.ndim == 3:
                    speed = speed[:, :, speed.shape[2] // 2]
                ax.imshow(speed.T, origin="lower", cmap="viridis")
                ax.set_title(f"{name} {column + 1}", fontsize=8)
    figure.tight_layout()
    figure.savefig(run_dir / "pca.png", dpi=100)
    plt.close(figure)
    return [run_dir / "pca.png"]

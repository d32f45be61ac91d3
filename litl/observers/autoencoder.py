"""The autoencoder observers (`vae`, `ae`): the paper's learned representation of the grid field.

A convolutional (variational) autoencoder of the grid velocity field in a window around the robot;
the controller reads its encoder means. Its learning phase (`autoencoder_learning`) trains a copy
on the replay buffer with early stopping; its statistics are `LearningStats`'s values; its pictures
are snapshots with their codes and reconstructions (Fig. 1), decoded latent sweeps (Fig. 8) and a
saliency animation.
"""

from __future__ import annotations

import dataclasses
import enum
import pathlib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import jax.numpy as jnp
import numpy as np
import optax

from litl.models import vae
from litl.models.replay_buffer import newest
from litl.models.window import Window
from litl.observers.autoencoder_learning import LearningStats, make_learning_phase
from litl.observers.interface import GridField, LatentCodec, Learner, Observer, ObserverContext
from litl.settings import Settings

SNAPSHOTS = 6  # the newest snapshots the pictures show


class Activation(enum.StrEnum):
    elu = "elu"  # keeps units alive on the mostly empty field
    relu = "relu"  # the paper's


@dataclass(frozen=True)
class AutoencoderSettings(Settings):
    """The (V)AE observers' network and what it sees (`observer=vae` and `observer=ae`).

    Attributes:
      latent_dim: r, latent variables (the controller's features).
      window: side (domain units) of the grid window it sees, centred on the robot's particle
        centroid and rounded up to a multiple of 32 nodes (`litl.models.window`); None: the
        whole grid (the paper's).
      channels: widths of the five encoder convolutions.
      activation: the network's activation (`Activation`; the paper's: relu).
      field: what it sees of the grid and the replay buffer stores (`GridField`): node
        velocities (the paper's), or velocities weighted by the node's mass relative to a full
        cell, which fades the light boundary nodes whose velocity is mostly numerical noise.
      beta: weight of the KL term in the VAE's loss (the plain autoencoder has none).
      momentum_weight: weight of a linear head from the encoder means to the field's mean over
        the window (the robot's momentum), trained with the reconstruction (`vae.loss_terms`),
        so the latents carry the bulk motion linearly; 0: the paper's loss.
    """

    latent_dim: int = dataclasses.field(default=8, metadata={"short": "r"})  # r in reports' labels
    window: float | None = 0.5
    channels: tuple[int, ...] = (8, 16, 32, 32, 64)
    activation: Activation = Activation.elu
    field: GridField = GridField.mass_weighted
    beta: float = 1.0
    momentum_weight: float = 0.3

    def check(self) -> None:
        self._positive_ints("latent_dim")
        self._positive_numbers("beta", "momentum_weight", zero=True)
        self._positive_numbers("window", optional=("window",))
        if len(self.channels) != 5 or not all(isinstance(c, int) and c >= 1 for c in self.channels):
            self._invalid("channels", "needs 5 positive integer widths")


def autoencoder(
    robot, settings: AutoencoderSettings, context: ObserverContext, variational: bool = True
) -> Observer:
    """The (variational) autoencoder observer (`vae`, `ae`): a window around the robot."""
    sim_config, dtype, learning = context.sim, context.dtype, context.learning
    window = Window.around(sim_config.grid_shape, sim_config.dx, settings.window)
    model = vae.ConvAutoencoder(
        window.shape,
        latent_dim=settings.latent_dim,
        channels=settings.channels,
        activation=settings.activation.value,
        variational=variational,
    )
    adam = optax.adam(learning.learning_rate)
    learner = Learner(
        window=window,
        phase=make_learning_phase(
            model, learning, beta=settings.beta, momentum_weight=settings.momentum_weight
        ),
        step=vae.make_train_step(model, adam, settings.beta, settings.momentum_weight),
        optimizer_init=lambda params: adam.init(params.network),
        empty_statistics=lambda dtype, dim: dict(empty_statistics(dtype, learning.max_epochs, dim)),
        records=records,
        reconstruct=lambda params, fields: reconstruct(model, params, fields),
        model=model,
        latent=LatentCodec(
            encode=lambda params, fields: encode(model, params, fields),
            decode=lambda params, latents: decode(model, params, latents),
        ),
    )
    return Observer(
        n_features=settings.latent_dim,
        init=lambda key, seed: vae.init_autoencoder(model, key, dtype),
        features=vae.make_observer(model, window),
        learner=learner,
        pictures=pictures,
        field=settings.field,
    )


def empty_statistics(dtype, max_epochs: int, dim: int) -> LearningStats:
    """The statistics before the first learning phase: NaN losses, no epochs."""
    nan = jnp.full((), jnp.nan, dtype)
    zero = jnp.zeros((), jnp.int32)
    return LearningStats(
        recon_loss_train=nan,
        recon_loss_val=nan,
        recon_explained=nan,
        active_units=zero,
        velocity_r2=jnp.full((dim,), jnp.nan, dtype),
        kl=nan,
        val_loss=nan,
        epochs_used=zero,
        best_epoch=zero,
        val_recon_history=jnp.full((max_epochs,), jnp.nan, dtype),
        val_distance_history=jnp.full((max_epochs,), jnp.nan, dtype),
        steps_per_epoch=zero,
        update_accepted=jnp.ones((), bool),
    )


# What every metrics.jsonl record repeats of the phase whose observer is in use, and learning.jsonl
# of each phase (with its epochs and history).
_REPEATED = ("recon_loss_train", "recon_loss_val", "recon_explained", "active_units", "velocity_r2", "kl")


def records(statistics: Mapping[str, Any]) -> tuple[dict, dict]:
    """(learning.jsonl's record of a phase, what each metrics.jsonl record repeats of it), from
    one seed's statistics (numpy values)."""
    used = int(statistics["epochs_used"])
    steps_per_epoch = int(statistics["steps_per_epoch"])
    repeated = {name: statistics[name] for name in (*_REPEATED, "update_accepted")}
    phase = {
        "epochs_used": used,
        "best_epoch": int(statistics["best_epoch"]),
        "steps_per_epoch": steps_per_epoch,
        "sgd_steps": used * steps_per_epoch,
        **repeated,
        "val_recon_history": np.asarray(statistics["val_recon_history"])[:used],
        "val_distance_history": np.asarray(statistics["val_distance_history"])[:used],
    }
    return phase, {**repeated, "learning_epochs": statistics["epochs_used"]}


def encode(model: vae.ConvAutoencoder, params: vae.AutoencoderParams, fields):
    """(B, r) the encoder means of raw fields (B, *window, d): the features the controller reads."""
    return model.apply(params.network, fields / params.scale, method="encode")[0]


def decode(model: vae.ConvAutoencoder, params: vae.AutoencoderParams, latents):
    """(B, *window, d) latents (B, r) decoded, in the fields' units."""
    return model.apply(params.network, latents, method="decode") * params.scale


def reconstruct(model: vae.ConvAutoencoder, params: vae.AutoencoderParams, fields):
    """(B, *window, d) the reconstructions of raw fields (encoder means decoded, in the fields'
    units)."""
    return decode(model, params, encode(model, params, fields))


def pictures(robot, algorithm, state, run_dir: pathlib.Path, stride: int) -> list[pathlib.Path]:
    """snapshots.png (Fig. 1), latent_sweeps.png (Fig. 8) and saliency.gif of one seed's final
    state (nothing while its buffer is empty)."""
    import matplotlib.pyplot as plt

    from litl.viz.latent import draw_latent_sweeps, draw_snapshots
    from litl.viz.saliency import animate_saliency

    model = algorithm.observer.learner.model
    snapshots = newest(state.buffer, SNAPSHOTS)
    if len(snapshots) == 0:
        return []
    written = []
    for name, make in (
        ("snapshots.png", lambda path: draw_snapshots(model, state.observer, snapshots, path)),
        ("latent_sweeps.png", lambda path: draw_latent_sweeps(model, state.observer, path=path)),
    ):
        figure = make(run_dir / name)
        plt.close(figure)
        written.append(run_dir / name)
    times = None
    if algorithm.controller.period is not None:
        # The newest snapshots are the latest rollout's last ones: snapshot k of a rollout is the
        # field after step (k + 1) * stride, which the policy reads at that time.
        stride = min(stride, algorithm.steps)
        last = algorithm.steps // stride
        times = (last - len(snapshots) + 1 + np.arange(len(snapshots))) * stride * robot.config.dt
    written.append(
        animate_saliency(
            model,
            state.observer,
            algorithm.controller,
            state.controller,
            snapshots,
            run_dir / "saliency.gif",
            times=times,
        )
    )
    return written


def plain_autoencoder(robot, settings: AutoencoderSettings, context: ObserverContext) -> Observer:
    """The plain (non-variational) autoencoder observer (`ae`, the ablation)."""
    return autoencoder(robot, settings, context, variational=False)

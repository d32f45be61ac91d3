"""A latent model to plan with: z' = f(z, a) and a linear readout of the robot's velocity from z.

A planner in the observer's latent space needs two things the observer alone does not give: how
the latent moves under an action (a dynamics model, `litl.latent.dynamics`), and what the task
cares about as a function of the latent. The latents are codes of the grid's velocity field, so
what they hold of a task is the velocity of the point it steers (`Robot.task_point`: a walker's
centroid, the arm's tip): the replay buffer keeps that velocity beside every snapshot
(`ReplayBuffer.point_velocities`), and a ridge least-squares readout v ≈ Wᵀ z + b fitted on them
(the VAE is trained with a linear momentum head for a similar reason) turns a predicted latent
trajectory into a predicted displacement, Δx = Σ_t control_dt · v(z_{t+1}).

`fit_model(codec, params, buffer, key, settings, ...)` encodes one seed's buffer in the order its
snapshots were stored (`encode_buffer`, shared with the in-loop measurement), fits the chosen
dynamics model on every transition, and the readout on every valid snapshot. `fit_sequence`
fits the same on any chronological data, e.g. exploratory episodes
(`litl.latent.exploration`). Jittable and vmappable over seeds.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Self

import jax.numpy as jnp
from flax import struct

from litl.latent.dynamics import LinearDynamics, Transitions, fit_linear, fit_mlp
from litl.latent.exploration import Sequence
from litl.models.replay_buffer import ReplayBuffer, chronological
from litl.settings.dynamics import DynamicsConfig

MODELS = ("mlp", "linear")


@struct.dataclass
class Encoded:
    """One seed's buffer in stored order, encoded (`encode_buffer`).

    Attributes:
      fields: (T, *window, d) the snapshots, oldest first (zero past `valid`).
      latents: (T, r) their latents (zero past `valid`).
      actions: (T, m) the action that led to each from the one before.
      velocities: (T, d) the task point's velocity at each (`ReplayBuffer.point_velocities`: the
        robot's mean particle velocity for a walker, the arm's tip's).
      links: (T,) bool, where (latents[t-1], actions[t], latents[t]) is a transition.
      valid: (T,) bool, the slots that hold snapshots.
    """

    fields: jnp.ndarray
    latents: jnp.ndarray
    actions: jnp.ndarray
    velocities: jnp.ndarray
    links: jnp.ndarray
    valid: jnp.ndarray


def encode_buffer(codec, params, buffer: ReplayBuffer) -> Encoded:
    """The buffer's snapshots in the order they were stored, encoded by `codec` under `params`."""
    order, links = chronological(buffer)
    valid = jnp.arange(links.shape[0]) < buffer.count
    fields = buffer.fields[order]
    dtype = fields.dtype
    # Stale slots may hold anything: zero them before they reach the encoder.
    fields = jnp.where(valid.reshape((-1,) + (1,) * (fields.ndim - 1)), fields, 0)
    latents = jnp.where(valid[:, None], codec.encode(params, fields).astype(dtype), 0)
    return Encoded(
        fields=fields,
        latents=latents,
        actions=buffer.actions[order].astype(dtype),
        velocities=jnp.where(valid[:, None], buffer.point_velocities[order].astype(dtype), 0),
        links=links,
        valid=valid,
    )


@struct.dataclass
class LatentModel:
    """What a latent planner predicts with.

    Attributes:
      dynamics: a `LinearDynamics` or `MLPDynamics` (``step(z, a) -> z'``, one control step).
      readout: (r, d) W of the task point's velocity readout v(z) = Wᵀ z + b.
      offset: (d,) its b.
      control_dt: seconds per control step (the snapshot stride times the simulation's dt).
    """

    dynamics: Any
    readout: jnp.ndarray
    offset: jnp.ndarray
    control_dt: float = struct.field(pytree_node=False)

    if TYPE_CHECKING:  # flax.struct adds `replace` at run time; declared for the type checker

        def replace(self, **changes: Any) -> Self: ...

    @property
    def latent_size(self) -> int:
        return self.readout.shape[0]

    def step(self, latent, action):
        """(r,) z, (m,) a -> (r,) z' one control step later."""
        return self.dynamics.step(latent, action)

    def velocity(self, latent):
        """(d,) the task point's velocity read from the (r,) latent."""
        return latent @ self.readout + self.offset


def fit_readout(latents, velocities, mask, ridge: float = 1e-6):
    """(W (r, d), b (d,), R² per axis (d,)) of the ridge least-squares fit v ≈ Wᵀ z + b over the
    rows in `mask` (the offset is not penalized); R² is on the same rows (NaN where the velocity
    does not vary)."""
    weight = mask.astype(latents.dtype)[:, None]
    count = jnp.maximum(jnp.sum(weight), 1)
    inputs = jnp.concatenate([latents, jnp.ones_like(latents[:, :1])], axis=1) * weight
    targets = velocities * weight
    r = latents.shape[1]
    penalty = jnp.concatenate([jnp.ones(r), jnp.zeros(1)]).astype(inputs.dtype)
    gram = inputs.T @ inputs / count + ridge * jnp.diag(penalty)
    theta = jnp.linalg.solve(gram, inputs.T @ targets / count)
    residual = (inputs @ theta - targets) * weight
    mean = jnp.sum(targets, axis=0) / count
    spread = jnp.sum(((velocities - mean) * weight) ** 2, axis=0)
    r2 = jnp.where(spread > 0, 1 - jnp.sum(residual**2, axis=0) / jnp.maximum(spread, 1e-30), jnp.nan)
    return theta[:r], theta[r], r2


def fit_model(
    codec, params, buffer: ReplayBuffer, key, settings: DynamicsConfig, control_dt: float, kind: str = "mlp"
) -> tuple[LatentModel, dict]:
    """(the model, its fit's statistics) from one seed's buffer under the observer's `params`:
    `fit_sequence` of `buffer_sequence`.

    Args:
      codec: the observer's `LatentCodec` (`Learner.latent`).
      settings: the dynamics models' settings (`loop.dynamics`: `.linear`, `.mlp`).
      control_dt: seconds per control step (`loop.snapshot_stride` times the simulation's dt).
      kind: ``"mlp"`` (z' = z + g(z, a)) or ``"linear"`` (z' = A z + B a + c).
    """
    return fit_sequence(buffer_sequence(codec, params, buffer), key, settings, control_dt, kind)


def buffer_sequence(codec, params, buffer: ReplayBuffer) -> Sequence:
    """One seed's buffer, encoded, as the chronological `Sequence` a model is fitted on."""
    encoded = encode_buffer(codec, params, buffer)
    return Sequence(encoded.latents, encoded.actions, encoded.velocities, encoded.links, encoded.valid)


def fit_sequence(
    data: Sequence, key, settings: DynamicsConfig, control_dt: float, kind: str = "mlp"
) -> tuple[LatentModel, dict]:
    """(the model, its fit's statistics) from chronological data: a buffer's (`buffer_sequence`),
    exploratory episodes' (`litl.latent.exploration.explore`) or both (`exploration.join`). The
    dynamics model is fitted on every transition, the readout on every valid row.

    Returns:
      statistics: ``readout_r2`` (d,) on the data, ``transitions``, and for the MLP its
      ``epochs`` and ``best_epoch`` (-1 for the linear model).
    """
    if kind not in MODELS:
        raise ValueError(f"kind={kind!r}: a latent model is one of {MODELS}")
    transitions = Transitions.from_sequence(data.latents, data.actions, data.links)
    if kind == "linear":
        dynamics: Any = fit_linear(transitions, settings.linear)
        epochs = best = jnp.array(-1, jnp.int32)
    else:
        dynamics, fit = fit_mlp(key, transitions, settings.mlp)
        epochs, best = fit.epochs, fit.best_epoch
    readout, offset, r2 = fit_readout(data.latents, data.velocities, data.valid, settings.linear.ridge)
    stats = {
        "readout_r2": r2,
        "transitions": jnp.sum(transitions.mask).astype(jnp.int32),
        "epochs": epochs,
        "best_epoch": best,
    }
    return LatentModel(dynamics, readout, offset, float(control_dt)), stats


def linear_part(model: LatentModel) -> LinearDynamics:
    """The model's `LinearDynamics` (LQR needs one); a ValueError for any other model."""
    if not isinstance(model.dynamics, LinearDynamics):
        raise ValueError(
            f"LQR needs the linear latent model; this one is {type(model.dynamics).__name__} "
            f"(fit it with kind='linear')"
        )
    return model.dynamics


__all__ = [
    "MODELS",
    "Encoded",
    "LatentModel",
    "buffer_sequence",
    "encode_buffer",
    "fit_model",
    "fit_readout",
    "fit_sequence",
    "linear_part",
]

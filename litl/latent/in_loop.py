"""The latent dynamics model learned beside the observer, at every learning phase (`loop.dynamics`).

After a phase has adopted Θ, `measure` encodes the replay buffer's snapshots with Θ in the order
they were stored (`litl.models.replay_buffer.chronological`), holds out whole rollouts at random
(`DynamicsConfig.validation_fraction` of them, at least one, at most all but one), fits the
linear model and the MLP on the transitions of the others (`litl.latent.dynamics`), and rolls
both forward over the held-out rollouts under their recorded actions. It reports, per horizon h:

* ``dynamics/latent/<model>/h=<h>``: the RMS error per latent of the h-step prediction, for
  ``linear``, ``mlp`` and the ``constant`` baseline (z_{t+h} ≈ z_t), in latent units;
* ``dynamics/decoded/<model>/h=<h>``: the same predictions decoded by the observer and compared
  with the snapshot x_{t+h}, RMS per grid value in the snapshots' units, beside ``floor``, the
  observer's own reconstruction of x_{t+h} (no model decodes better than Θ reconstructs);
* ``dynamics/starts/h=<h>``: how many held-out starts have h steps ahead in their rollout;

and ``dynamics/field_rms`` (the held-out snapshots' RMS, the decoded errors' scale), the fits'
statistics (``dynamics/linear/train_rms``: the linear model's one-step RMS on its own training
transitions; ``dynamics/mlp/epochs``, ``/best_epoch``) and the rollouts on each side. A value
with nothing to measure (the bootstrap's phase holds one rollout: none is left to fit on) is NaN.

Whole rollouts, not the observer's random split of snapshots: consecutive snapshots of a rollout
are close, so a held-out snapshot between two training ones is no test of an h-step prediction.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp

from litl.latent.dynamics import Transitions, fit_linear, fit_mlp
from litl.latent.model import encode_buffer
from litl.latent.prediction import predict
from litl.models.replay_buffer import ReplayBuffer
from litl.observers.interface import LatentCodec
from litl.settings import SettingsError
from litl.settings.dynamics import DynamicsConfig

MODELS = ("linear", "mlp", "constant")


def statistic_names(settings: DynamicsConfig) -> tuple[str, ...]:
    """The names `measure` returns, in order."""
    names = ["dynamics/rollouts_train", "dynamics/rollouts_validation", "dynamics/field_rms"]
    names += ["dynamics/linear/train_rms", "dynamics/mlp/epochs", "dynamics/mlp/best_epoch"]
    for h in settings.horizons:
        names += [f"dynamics/latent/{model}/h={h}" for model in MODELS]
        names += [f"dynamics/decoded/{model}/h={h}" for model in (*MODELS, "floor")]
        names.append(f"dynamics/starts/h={h}")
    return tuple(names)


def _is_count(name: str) -> bool:
    return name.startswith(("dynamics/rollouts", "dynamics/starts", "dynamics/mlp/"))


def empty_statistics(settings: DynamicsConfig, dtype) -> dict[str, jax.Array]:
    """Before the first phase: NaN errors, zero counts (the keys of `measure`)."""
    return {
        name: jnp.zeros((), jnp.int32) if _is_count(name) else jnp.full((), jnp.nan, dtype)
        for name in statistic_names(settings)
    }


def held_out_rollouts(links, count, key, fraction: float):
    """(T,) bool: the positions (in chronological order) of the rollouts held out for validation.

    Rollouts are the runs of positions joined by `links`; round(fraction · n) of the n rollouts
    among the first `count` positions (at least 1, at most n - 1, so one rollout is all held out)
    are drawn at random."""
    positions = jnp.arange(links.shape[0])
    valid = positions < count
    rollout = jnp.cumsum(~links) - 1  # position 0 is never linked: rollout 0
    n = jnp.where(count > 0, jnp.max(jnp.where(valid, rollout, -1)) + 1, 0)
    n_held = jnp.clip(jnp.round(fraction * n), 1, jnp.maximum(n - 1, 1))
    draws = jnp.where(positions < n, jax.random.uniform(key, links.shape), jnp.inf)
    rank = jnp.argsort(jnp.argsort(draws))  # rollouts 0 ... n - 1 get ranks 0 ... n - 1
    held = rank < n_held
    return valid & held[jnp.clip(rollout, 0, links.shape[0] - 1)], n, n_held


@functools.partial(jax.jit, static_argnums=(0, 4))
def measure(codec: LatentCodec, params, buffer: ReplayBuffer, key, settings: DynamicsConfig) -> dict:
    """The statistics named by `statistic_names`, for one seed's buffer under Θ = `params`
    (jit-compiled; vmappable over seeds; a NaN where nothing could be measured)."""
    encoded = encode_buffer(codec, params, buffer)
    fields, latents, actions, links = encoded.fields, encoded.latents, encoded.actions, encoded.links
    dtype = fields.dtype
    split_key, fit_key = jax.random.split(key)
    held, n_rollouts, n_held = held_out_rollouts(links, buffer.count, split_key, settings.validation_fraction)
    train_links, validation_links = links & ~held, links & held
    train = Transitions.from_sequence(latents, actions, train_links)
    linear = fit_linear(train, settings.linear)
    mlp, fit = fit_mlp(fit_key, train, settings.mlp)
    one_step = jax.vmap(linear.step)(train.latents, train.actions) - train.next_latents
    stats = {
        "dynamics/rollouts_train": (n_rollouts - jnp.minimum(n_held, n_rollouts)).astype(jnp.int32),
        "dynamics/rollouts_validation": jnp.minimum(n_held, n_rollouts).astype(jnp.int32),
        "dynamics/field_rms": _rms(fields, held),
        "dynamics/linear/train_rms": _rms(one_step, train.mask),
        "dynamics/mlp/epochs": fit.epochs,
        "dynamics/mlp/best_epoch": fit.best_epoch,
    }
    decode = lambda z: codec.decode(params, z).astype(dtype)
    decoded = decode(latents)  # every snapshot's reconstruction: the floor's and the baseline's
    for h in settings.horizons:
        linear_guess, usable = predict(linear.step, latents, actions, validation_links, h)
        mlp_guess, _ = predict(mlp.step, latents, actions, validation_links, h)  # the same `usable`
        guesses = {"linear": linear_guess, "mlp": mlp_guess}
        target, target_field = latents[h:], fields[h:]
        for name, guess in guesses.items():
            stats[f"dynamics/latent/{name}/h={h}"] = _rms(guess - target, usable)
            stats[f"dynamics/decoded/{name}/h={h}"] = _rms(decode(guess) - target_field, usable)
        stats[f"dynamics/latent/constant/h={h}"] = _rms(latents[:-h] - target, usable)
        stats[f"dynamics/decoded/constant/h={h}"] = _rms(decoded[:-h] - target_field, usable)
        stats[f"dynamics/decoded/floor/h={h}"] = _rms(decoded[h:] - target_field, usable)
        stats[f"dynamics/starts/h={h}"] = jnp.sum(usable).astype(jnp.int32)
    return {name: stats[name] for name in statistic_names(settings)}


def _rms(values, rows):
    """() the RMS of `values` (N, ...) over its `rows` (N,) bool; NaN where no row is chosen."""
    rows = rows.reshape((-1,) + (1,) * (values.ndim - 1))
    squared = jnp.sum(jnp.where(rows, values**2, 0))
    size = jnp.sum(rows) * (values[0].size if values.ndim > 1 else 1)
    return jnp.where(size > 0, jnp.sqrt(squared / jnp.maximum(size, 1)), jnp.nan)


def check_horizons(settings: DynamicsConfig, capacity: int) -> None:
    """`SettingsError` unless every horizon is below the buffer's capacity."""
    too_long = [h for h in settings.horizons if h >= capacity]
    if too_long:
        raise SettingsError(
            f"loop.dynamics.horizons={list(settings.horizons)}: {too_long} reach past the replay "
            f"buffer's {capacity} snapshots (loop.buffer_capacity); choose horizons below it",
            "loop.dynamics.horizons",
        )

"""Exploratory episodes for a latent model: data the trained controller's buffer does not hold.

A trained run's replay buffer holds what its own controller did: one behaviour, tuned to one goal.
A model fitted on it predicts that behaviour and little else, and a planner steering toward
another goal leaves the data it knows (the fifth and sixth rounds of issue 78 measured this).
`explore` runs `Exploration.episodes` episodes of the robot (its co-designed body, observed by
its observer, as `litl.envs` steps it) under random actions: each actuator's activation drawn
uniformly in [-1, 1] and held for `Exploration.hold` control steps, and returns them as a
sequence the latent model is fitted on (`litl.latent.model.fit_sequence`): the observer's
features after every control step (the latent a planner reads), the action that led there, the
task point's velocity, and links that break at every episode's start and after a step that left
the domain or was not finite.

The features are the environment's observation (`Observer.features`), so any observer with
features gives a model this way: the VAE's and PCA's latents, and the k-means clusters' positions
and velocities, which have no buffer codec to encode snapshots with.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from litl.errors import UserError


class ExplorationError(UserError, ValueError):
    """Exploration settings litl cannot run; the message names the setting and its range."""


@dataclasses.dataclass(frozen=True)
class Exploration:
    """Random-action episodes for the latent model's data.

    Attributes:
      episodes: how many (each as long as the planner's episode).
      hold: control steps each random action is held (1: a new action every control step).
    """

    episodes: int = 32
    hold: int = 4

    def __post_init__(self):
        for name in ("episodes", "hold"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ExplorationError(f"exploration {name}={value!r}: a positive whole number")


@jax.tree_util.register_dataclass
@dataclasses.dataclass
class Sequence:
    """Chronological data for a latent model (`litl.latent.model.Encoded` without the fields).

    Attributes:
      latents: (T, r) the observer's features.
      actions: (T, m) the action that led to each from the one before.
      velocities: (T, d) the task point's velocity at each.
      links: (T,) bool, where (latents[t-1], actions[t], latents[t]) is a transition.
      valid: (T,) bool, the rows that hold data.
    """

    latents: jax.Array
    actions: jax.Array
    velocities: jax.Array
    links: jax.Array
    valid: jax.Array


def explore(env, env_params, key, settings: Exploration, steps: int) -> Sequence:
    """`settings.episodes` episodes of `steps` control steps under held random actions (see the
    module docstring), as one `Sequence` of episodes × (steps + 1) rows. Pure and jittable."""
    r = env.observer.n_features
    m = env.num_actions
    blocks = -(-steps // settings.hold)

    def episode(key):
        drawn = jax.random.uniform(key, (blocks, m), minval=-1.0, maxval=1.0)
        actions = jnp.repeat(drawn, settings.hold, axis=0)[:steps].astype(env.dtype)
        obs, state = env.reset(key, env_params)

        def one(carry, action):
            obs, state, alive = carry
            obs, state, _, done, info = env.step_env(key, state, action, env_params)
            # A step that escaped the domain or was not finite ends the episode's transitions.
            alive = alive & ~info["nonfinite"] & ~info["escaped"]
            velocity = env.robot.task_point_velocity(state.sim)
            return (obs, state, alive), (obs[:r], velocity, alive)

        _, (latents, velocities, alive) = jax.lax.scan(one, (obs, state, jnp.array(True)), actions)
        start_velocity = env.robot.task_point_velocity(state.sim)
        return Sequence(
            latents=jnp.concatenate([obs[None, :r], latents]),
            actions=jnp.concatenate([jnp.zeros((1, m), env.dtype), actions]),
            velocities=jnp.concatenate([start_velocity[None], velocities]).astype(env.dtype),
            links=jnp.concatenate([jnp.zeros(1, bool), alive]),
            valid=jnp.concatenate([jnp.ones(1, bool), alive]),
        )

    episodes = jax.vmap(episode)(jax.random.split(key, settings.episodes))
    return jax.tree.map(lambda leaf: leaf.reshape((-1, *leaf.shape[2:])), episodes)


def join(*sequences) -> Sequence:
    """One sequence of several, end to end (each one's first row has no link to the one before)."""
    first = lambda leaf: leaf.at[0].set(False)
    parts = [s if i == 0 else dataclasses.replace(s, links=first(s.links)) for i, s in enumerate(sequences)]
    return jax.tree.map(lambda *leaves: jnp.concatenate(leaves), *parts)


__all__ = ["Exploration", "ExplorationError", "Sequence", "explore", "join"]

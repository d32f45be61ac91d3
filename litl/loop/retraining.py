"""Learn and adopt: the observer's learning phase of Algorithm 1 for one seed, and its adoption.

A learning phase trains a copy Θ′ of the observer on the replay buffer (the observer's own
`Learner.phase`); adoption then moves Θ softly toward it, Θ ← α·Θ′ + (1 − α)·Θ (α: `loop.alpha`),
and keeps the move only if the controller does no worse with it
(`loop.safeguards.update_tolerance`). After the bootstrap's phase Θ takes Θ′ whole: a random Θ has
nothing worth keeping.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import optax

from litl.config import LoopConfig
from litl.latent import in_loop
from litl.loop.simulation import Simulation
from litl.loop.state import LoopState, keep_if, skip_reason, split_key
from litl.models.replay_buffer import add

DYNAMICS_STREAM = 78  # the latent dynamics measurement's key: folded from the seed's, never drawn


def soft_update(target, online, alpha):
    """Target update Θ ← α·Θ′ + (1 − α)·Θ over every leaf (network weights and scale).

    Args:
      target: Θ, the observer used during episodes.
      online: Θ′, the copy trained in the learning phase.
      alpha: step size in [0, 1] (a Python number is checked; an array, e.g. per seed, is not).
        α = 1 returns `online`, α = 0 returns `target`.
    """
    if isinstance(alpha, (int, float)) and not 0.0 <= alpha <= 1.0:
        raise ValueError(f"alpha must be in [0, 1], got {alpha!r}")
    # Polyak averaging, alpha * new + (1 - alpha) * old: exact at alpha = 1 (and at 0).
    return optax.incremental_update(online, target, alpha)


@dataclasses.dataclass(frozen=True)
class Retraining:
    """The learning phase and the adoption of its result, for one seed (vmap it over seeds).

    Attributes:
      simulation: the rollouts (the buffer's first snapshots; the check of an update).
      loop: the loop's settings (`alpha`, `safeguards.update_tolerance`).
    """

    simulation: Simulation
    loop: LoopConfig

    @property
    def learner(self):
        return self.simulation.observer.learner

    def fill(self, state: LoopState) -> LoopState:
        """One rollout of the current controller fills the buffer (the bootstrap's first half)."""
        simulation = self.simulation
        total, (_, trajectory) = simulation.simulate(state.controller, state.design, state.observer)
        # A failed rollout's snapshots never enter the buffer.
        healthy = skip_reason(trajectory.health, total, jnp.zeros((), simulation.dtype)) == 0
        return state.replace(
            buffer=keep_if(
                healthy,
                add(
                    state.buffer,
                    trajectory.snapshots,
                    simulation.snapshot_velocities(trajectory),
                    simulation.snapshot_actions(trajectory),
                    simulation.snapshot_velocities(trajectory, point=True),
                ),
                state.buffer,
            )
        )

    def learn(self, state: LoopState, first=False):
        """A learning phase on a copy Θ′, then its adoption (`adopt`).

        `first`: a () bool array, or a value `jnp.asarray` makes one: whether this is the
        bootstrap's phase (Θ ← Θ′ whole). As an array, so that the bootstrap's phase and the later
        ones are one compiled program (the run shell passes it so)."""
        state, followed = self.follow(state)
        if self.learner is None:
            return self.with_statistics(state, state.stats, followed)
        state, key = split_key(state)
        trained, stats = self.learner.phase(state.observer, state.buffer, key)
        adopted, stats = self.adopt(state, trained, stats, first)
        adopted, stats = self.measure_dynamics(adopted, stats)
        return self.with_statistics(adopted, stats, followed)

    def measure_dynamics(self, state: LoopState, stats):
        """(state, stats with the latent dynamics model's statistics) under the adopted Θ, where
        `loop.dynamics` is enabled (`litl.latent.in_loop`); else both as they are. Its key is
        folded from the seed's without advancing it: measuring changes no random stream of
        the run, so a run with it optimizes as the same run without it."""
        dynamics = self.loop.dynamics
        if not dynamics.enabled:
            return state, stats
        key = jax.random.fold_in(jax.random.wrap_key_data(state.key), DYNAMICS_STREAM)
        measured = in_loop.measure(self.learner.latent, state.observer, state.buffer, key, dynamics)
        stats = {**dict(stats), **measured}
        return state.replace(stats=stats), stats

    def follow(self, state: LoopState):
        """The observer refitted to the body's current design, where it follows the body
        (`Observer.follower`), and the refit's statistics ({} where it does not)."""
        follower = self.simulation.observer.follower
        if follower is None:
            return state, {}
        design = self.simulation.robot.design_space.to_design(state.design)
        refitted, statistics = follower.refit(state.observer, design)
        return state.replace(observer=refitted), dict(statistics)

    @staticmethod
    def with_statistics(state: LoopState, statistics, followed):
        """(state, its statistics): a phase's `statistics` with a refit's `followed` merged in."""
        merged = {**dict(statistics), **followed}
        return state.replace(stats=merged), merged

    def learn_seeds(self, states: LoopState, at_once: int, first=False):
        """`learn` for a batch of seeds (every leaf's leading axis): the learning phases run
        `at_once` seeds at a time (vmapped within a group, the groups one after another), the
        rest vmapped. A vmapped phase runs until its slowest seed stops; one seed at a time
        stops each at its own epoch. The results are `jax.vmap(learn)`'s (up to rounding)."""
        if at_once >= jax.tree.leaves(states)[0].shape[0]:  # every seed together: the plain vmap
            return jax.vmap(lambda state: self.learn(state, first))(states)
        states, followed = jax.vmap(self.follow)(states)
        if self.learner is None:
            return jax.vmap(lambda state, refit: self.with_statistics(state, state.stats, refit))(
                states, followed
            )
        states, keys = jax.vmap(split_key)(states)
        trained, stats = jax.lax.map(
            lambda seed: self.learner.phase(*seed), (states.observer, states.buffer, keys), batch_size=at_once
        )

        def adopt(state, phase, phase_stats, refit):
            adopted, adopted_stats = self.adopt(state, phase, phase_stats, first)
            adopted, adopted_stats = self.measure_dynamics(adopted, adopted_stats)
            return self.with_statistics(adopted, adopted_stats, refit)

        return jax.vmap(adopt)(states, trained, stats, followed)

    def adopt(self, state: LoopState, trained, stats, first=False):
        """Θ ← α·Θ′ + (1 − α)·Θ from a learning phase's `trained` Θ′ and its `stats` (a mapping
        of named values), kept only if the controller does no worse with it; Θ ← Θ′ where
        `first` (a () bool array). The statistics come back as a dict with ``update_accepted``."""
        first = jnp.asarray(first, bool)
        updated = soft_update(state.observer, trained, self.loop.alpha)
        tolerance = self.loop.safeguards.update_tolerance
        accepted = jnp.ones((), bool)
        if tolerance is not None:
            accepted = self.update_is_safe(state, updated, tolerance) | first
            updated = keep_if(accepted, updated, state.observer)
        updated = keep_if(first, trained, updated)
        stats = {**dict(stats), "update_accepted": accepted}
        return state.replace(observer=updated, stats=stats), stats

    def update_is_safe(self, state: LoopState, updated, tolerance: float):
        """() bool: the current controller and design, simulated with the `updated` observer,
        reach a task loss within tolerance * |loss| of the one they reach with the current
        observer (and a finite one)."""
        before, _ = self.simulation.simulate(state.controller, state.design, state.observer)
        after, _ = self.simulation.simulate(state.controller, state.design, updated)
        return jnp.isfinite(after) & (~jnp.isfinite(before) | (after <= before + tolerance * jnp.abs(before)))

    def bootstrap(self, state: LoopState):
        """One rollout of the untrained controller fills the buffer; Θ takes the trained copy."""
        return self.learn(self.fill(state), first=True)

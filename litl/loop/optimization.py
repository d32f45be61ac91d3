"""Optimize: one optimization iteration of Algorithm 1 for one seed.

A rollout with the fixed observer Θ, the task loss, its gradients with respect to the controller θ
and the design φ through the whole simulation, Adam (its step size on a cosine schedule), the
projection of φ into its bounds, and the rollout's snapshots into the replay buffer (or replacing
it without replay; or one observer step on them in the simultaneous ablation). An iteration whose
rollout or gradient failed keeps nothing of its own (`skip_reason`); one that is much worse than
the last accepted iterate, or that failed, steps back to that iterate at half the step (`Anchor`),
so that a step too long for the simulation is retried shorter instead of failing again.
"""

from __future__ import annotations

import dataclasses
import functools

import jax
import jax.numpy as jnp
import optax

from litl.config import LoopConfig
from litl.loop.schedule import LearningSchedule
from litl.loop.simulation import Simulation
from litl.loop.state import MAX_STEP_BACKS, Anchor, Best, LoopState, keep_if, skip_reason, split_key
from litl.models.replay_buffer import add, replace_with


def adam(learning_rate: float, clip: float | None) -> optax.GradientTransformation:
    """Adam, after clipping the gradient's global norm (None: no clipping)."""
    return optax.chain(*([optax.clip_by_global_norm(clip)] if clip else []), optax.adam(learning_rate))


@dataclasses.dataclass(frozen=True)
class Optimization:
    """θ's and φ's updates from gradients through one seed's rollouts.

    Attributes:
      simulation: the rollouts to differentiate.
      loop: the loop's settings (step sizes, the replay buffer, co-design, the safeguards).
      learning_rate: the controller's Adam step size (`controller.learning_rate`).
      schedule: `loop.schedule` as the algorithm resolved it (`LearningSchedule.fixed` for an
        observer that does not learn).
    """

    simulation: Simulation
    loop: LoopConfig
    learning_rate: float
    schedule: LearningSchedule

    @functools.cached_property
    def controller_adam(self) -> optax.GradientTransformation:
        return adam(self.learning_rate, self.loop.safeguards.gradient_clip)

    @functools.cached_property
    def design_adam(self) -> optax.GradientTransformation:
        return adam(self.loop.design_learning_rate, self.loop.safeguards.gradient_clip)

    def optimize(self, state: LoopState, iterations_in_run=None):
        """One optimization iteration (see the module docstring); returns (state, metrics).

        `iterations_in_run`: the run's K x M iterations, the length of the step sizes' cosine (an
        int or a () integer array, so that runs of other lengths share one program); None: the
        config's `loop.episodes` x `loop.iterations`."""
        value_and_grad = jax.value_and_grad(self.simulation.simulate, argnums=(0, 1), has_aux=True)
        (total, (components, trajectory)), (controller_grad, design_grad) = value_and_grad(
            state.controller, state.design, state.observer
        )
        controller_grad_norm = optax.tree.norm(controller_grad)
        design_grad_norm = optax.tree.norm(design_grad)
        reason = skip_reason(trajectory.health, total, controller_grad_norm + design_grad_norm)
        healthy = reason == 0
        before = state
        improved = healthy & (total < state.best.task_loss)
        best = keep_if(
            improved,
            Best(
                task_loss=total,
                step=state.iteration,
                controller=state.controller,
                design=state.design,
                observer=state.observer,
            ),
            state.best,
        )
        step_back = healthy & self.falls_back(state.anchor, total)
        # A failed rollout or gradient comes from the last step's parameters: retake that step
        # at half its size (with the step backs on, and while it may still be halved).
        retry = ~healthy & self.may_step_back(state.anchor)
        state = self.take_step(
            state, total, controller_grad, design_grad, step_back | retry, iterations_in_run
        )
        moved = state
        state, recon = self.record(state, trajectory)
        # A failed iteration keeps nothing of its own (no snapshots, no observer step), only the
        # retaken step if there is one, the key and the counters (and says why).
        retried = before.replace(
            controller=moved.controller,
            design=moved.design,
            controller_optimizer=moved.controller_optimizer,
            design_optimizer=moved.design_optimizer,
            anchor=moved.anchor,
        )
        state = keep_if(healthy, state, keep_if(retry, retried, before)).replace(
            key=state.key,
            best=best,
            iteration=state.iteration + 1,
            consecutive_skips=jnp.where(healthy, 0, state.consecutive_skips + 1),
        )
        space = self.simulation.robot.design_space
        modulus = space.modulus(state.design)
        metrics = {
            "task_loss": total,
            **{f"task/{name}": value for name, value in components.items()},
            "design_mean": jnp.mean(modulus),
            "design_min": jnp.min(modulus),
            "design_max": jnp.max(modulus),
            **space.summary(state.design),
            "controller_grad_norm": controller_grad_norm,
            "design_grad_norm": design_grad_norm,
            "skipped": reason,
            "consecutive_skips": state.consecutive_skips,
            "stepped_back": step_back | retry,
            "step_scale": state.anchor.step_scale,
            "simultaneous_recon_loss": recon,
            "first_nonfinite_step": trajectory.health.first_nonfinite_step,
            "first_escape_step": trajectory.health.first_escape_step,
        }
        return state, metrics

    def record(self, state: LoopState, trajectory):
        """The rollout's snapshots (with its velocities and the actions that led to them) into the
        replay buffer (or in its place, without one) and, on
        the simultaneous schedule, the observer's one step on them; returns (state, that step's
        reconstruction loss, NaN on the other schedules)."""
        snapshots = trajectory.snapshots
        keep = add if self.loop.replay_buffer else replace_with
        state = state.replace(
            buffer=keep(
                state.buffer,
                snapshots,
                self.simulation.snapshot_velocities(trajectory),
                self.simulation.snapshot_actions(trajectory),
                self.simulation.snapshot_velocities(trajectory, point=True),
            )
        )
        recon = jnp.full((), jnp.nan, self.simulation.dtype)
        if self.schedule is LearningSchedule.simultaneous:
            learner = self.simulation.observer.learner
            # make_algorithm allows the simultaneous schedule only for an observer with a step
            assert learner is not None and learner.step is not None
            state, key = split_key(state)
            observer_params, observer_optimizer, losses = learner.step(
                state.observer, state.observer_optimizer, snapshots, key
            )
            state = state.replace(observer=observer_params, observer_optimizer=observer_optimizer)
            recon = losses["recon"]
        return state, recon

    def may_step_back(self, anchor: Anchor) -> jnp.ndarray:
        """() bool: step backs are on (`loop.safeguards.step_back_tolerance` not None), there is
        an accepted iterate to return to, and its step may still be halved."""
        if self.loop.safeguards.step_back_tolerance is None:
            return jnp.zeros((), bool)
        return jnp.isfinite(anchor.task_loss) & (anchor.step_scale > 0.5**MAX_STEP_BACKS)

    def falls_back(self, anchor: Anchor, total) -> jnp.ndarray:
        """() bool: the rollout's task loss is worse than the anchor's by more than
        `loop.safeguards.step_back_tolerance` x |anchor's loss|, and the step may still be halved."""
        tolerance = self.loop.safeguards.step_back_tolerance
        if tolerance is None:
            return jnp.zeros((), bool)
        limit = anchor.task_loss + tolerance * jnp.abs(anchor.task_loss)
        return self.may_step_back(anchor) & (total > limit)

    def take_step(
        self, state: LoopState, total, controller_grad, design_grad, step_back, iterations_in_run=None
    ) -> LoopState:
        """The iteration's parameter update. Normally a full Adam step from the current θ, φ,
        which become the anchor; on a step back (`step_back`), the anchor's step again at half
        its last size, from the anchor's parameters, gradients and optimizer states."""
        anchor = state.anchor
        accepted = Anchor(
            controller=state.controller,
            design=state.design,
            controller_optimizer=state.controller_optimizer,
            design_optimizer=state.design_optimizer,
            controller_grad=controller_grad,
            design_grad=design_grad,
            task_loss=total,
            step_scale=jnp.ones_like(anchor.step_scale),
        )
        retried = anchor.replace(step_scale=anchor.step_scale / 2)
        anchor = keep_if(step_back, retried, accepted)
        state = state.replace(
            controller=anchor.controller,
            design=anchor.design,
            controller_optimizer=anchor.controller_optimizer,
            design_optimizer=anchor.design_optimizer,
            anchor=anchor,
        )
        return self.step_parameters(
            state,
            anchor.controller_grad,
            anchor.design_grad,
            anchor.step_scale * self.step_size_factor(state.iteration, iterations_in_run),
        )

    def step_size_factor(self, iteration, iterations_in_run=None) -> jnp.ndarray:
        """() the fraction of θ's and φ's configured Adam step sizes at this global iteration:
        a cosine from 1 at the first to `loop.safeguards.final_learning_rate_fraction` at the
        last of the run's K x M iterations (`iterations_in_run`; None: the config's) (constant 1
        when that is 1, the paper's setting)."""
        loop = self.loop
        final = loop.safeguards.final_learning_rate_fraction
        total = loop.episodes * loop.iterations if iterations_in_run is None else iterations_in_run
        last = jnp.maximum(jnp.asarray(total) - 1, 1).astype(self.simulation.dtype)
        progress = jnp.clip(jnp.asarray(iteration, self.simulation.dtype) / last, 0.0, 1.0)
        return jnp.asarray(
            final + (1.0 - final) * 0.5 * (1.0 + jnp.cos(jnp.pi * progress)), self.simulation.dtype
        )

    def step_parameters(self, state: LoopState, controller_grad, design_grad, scale=1.0) -> LoopState:
        """Adam on θ, and on φ then its projection into the bounds (unless control only); the
        updates multiplied by `scale`."""
        shrink = lambda updates: jax.tree.map(lambda u: u * scale, updates)
        updates, controller_optimizer = self.controller_adam.update(
            controller_grad, state.controller_optimizer, state.controller
        )
        state = state.replace(
            controller=optax.apply_updates(state.controller, shrink(updates)),
            controller_optimizer=controller_optimizer,
        )
        if self.loop.codesign:
            updates, design_optimizer = self.design_adam.update(
                design_grad, state.design_optimizer, state.design
            )
            space = self.simulation.robot.design_space
            # A part of φ with a step size of its own (in its units): Adam's update rescaled to it.
            own = space.step_sizes(self.loop.design_learning_rate)
            if own:
                updates = {part: u * own.get(part, 1.0) for part, u in updates.items()}
            design = space.project(optax.apply_updates(state.design, shrink(updates)))
            state = state.replace(design=design, design_optimizer=design_optimizer)
        return state

"""Simulate: one seed's differentiable rollout under Algorithm 1, with the observer in the loop.

`Simulation` holds what a rollout needs (the robot, the controller, the observer, the grid field
the policy reads) and gives the task loss and trajectory of one rollout of θ, φ, Θ; the
optimization differentiates it, the retraining compares observers with it.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any

import jax
import jax.numpy as jnp

from litl.config import RolloutConfig
from litl.controllers import Controller
from litl.loop.state import LoopState
from litl.models.window import Window
from litl.observers import GridField, Observer
from litl.robots.robot import Robot
from litl.sim import make_rollout
from litl.sim.fields import full_cell_mass, grid_velocity, mass_weighted_velocity
from litl.sim.memory import default_budget_bytes
from litl.sim.rollout import centroid


@dataclasses.dataclass(frozen=True)
class Simulation:
    """One seed's rollouts: the robot under the controller fed by the observer's features.

    Attributes:
      robot: the robot and its task.
      sim: the rollout's settings (its memory budget and checkpointing).
      seeds: the seeds vmapped together (each gets its share of the memory budget).
      dtype: the simulation's float dtype.
      steps: steps per rollout.
      stride: the snapshot stride (a snapshot of the grid field every `stride` steps).
      scene: the robot's `Scene` in `dtype` (config, body, design, initial state).
      observer: the observer (its features feed the controller at every step).
      controller: the controller (its module, and whether the task loss's gradient flows
        through the features).
    """

    robot: Robot
    sim: RolloutConfig
    seeds: int
    dtype: Any
    steps: int
    stride: int
    scene: Any
    observer: Observer
    controller: Controller

    @property
    def window(self) -> Window:
        """The grid window a learned observer's snapshots are cropped to (else the whole grid)."""
        if self.observer.learner is not None:
            return self.observer.learner.window
        return Window.around(self.scene.config.grid_shape, self.scene.config.dx, None)

    def policy(self, params, state, grid_velocity):
        """Actuation from the observer's features of the grid (and the clock)."""
        controller_params, observer_params = params
        state = self.robot.own(state)  # observers read the robot's particles, not the scenery's
        features = self.observer.features(jax.lax.stop_gradient(observer_params), state, grid_velocity)
        if not self.controller.feature_gradient:
            features = jax.lax.stop_gradient(features)
        time = state.step.astype(self.dtype) * self.scene.config.dt
        return self.controller.module.apply(controller_params, features.astype(self.dtype), time=time)

    @functools.cached_property
    def field(self):
        """field(grid): what the policy reads of the grid and the snapshots record (the
        observer's `field`)."""
        if self.observer.field == GridField.mass_weighted:
            scene = self.scene
            return mass_weighted_velocity(full_cell_mass(scene.config, scene.body, scene.design))
        return grid_velocity

    @property
    def centroid(self):
        """centroid(state): the robot's particles' mean position (the scenery's left out)."""
        if not self.robot.scenery:
            return centroid
        return lambda state: centroid(self.robot.own(state))

    def observe(self, state):
        """(2, d) what a rollout records after every step: the robot's centroid, and the point
        its task steers (`Robot.task_point`: the arm's tip; the centroid again for a walker)."""
        return jnp.stack([self.centroid(state), self.robot.task_point(state)])

    @functools.cached_property
    def rollout(self):
        """One seed's rollout; the seeds run vmapped, so each gets its share of the budget."""
        sim, seeds = self.sim, self.seeds
        budget = sim.budget_bytes(seeds)
        if budget is None:
            budget = default_budget_bytes() // seeds
        config = dataclasses.replace(self.scene.config, particle_to_grid=sim.particle_to_grid)
        return make_rollout(
            config,
            self.scene.body,
            self.policy,
            self.steps,
            snapshot_stride=self.stride,
            observe=self.observe,
            field=self.field,
            checkpoint_every=sim.checkpoint_every,
            memory_budget=budget,
        )

    def simulate(self, controller_params, design, observer, initial=None):
        """(task loss, (its components, the trajectory)) of one rollout from the robot's initial
        state, or from `initial` (a `SimState` like it, e.g. with other velocities)."""
        initial = self.scene.state if initial is None else initial
        final, trajectory = self.rollout(
            (controller_params, observer), self.robot.design_space.to_design(design), initial
        )
        total, components = self.robot.task_loss()(initial, final)
        penalty = self.robot.design_space.penalty(design)  # a design constraint's cost, if any
        if penalty:
            total = total + sum(penalty.values())
            components = {**components, **penalty}
        if self.observer.learner is not None and not self.window.whole_grid:
            # Snapshot k is the field after step (k + 1) * stride - 1, read by the policy together
            # with the state after that step: crop both around that state's centroid.
            stride = self.stride
            centres = trajectory.observations[stride - 1 :: stride, 0][: trajectory.snapshots.shape[0]]
            trajectory = trajectory.replace(
                snapshots=jax.vmap(self.window.crop)(trajectory.snapshots, centres)
            )
        return total, (components, trajectory)

    def snapshot_velocities(self, trajectory, point: bool = False):
        """(n_snapshots, d) the robot's mean particle velocity at each snapshot (`point`: the
        task point's, `observe`), from the positions recorded before and after the step that
        produced it (x += dt v, so the difference is exact for free particles)."""
        which = int(point)
        start = self.observe(self.scene.state)[which]
        centres = jnp.concatenate([start[None], trajectory.observations[:, which]])
        velocity = (centres[1:] - centres[:-1]) / self.scene.config.dt
        stride = self.stride
        return velocity[stride - 1 :: stride][: trajectory.snapshots.shape[0]]

    def snapshot_actions(self, trajectory):
        """(n_snapshots, m) the mean actuation over the `stride` steps that produced each
        snapshot from the previous one (from the initial state for the first): snapshot k is the
        field after step (k + 1) * stride - 1, so steps k * stride ... (k + 1) * stride - 1 led to
        it, the first of them acting on what the policy read of snapshot k - 1. The replay
        buffer's `actions` (`litl.models.replay_buffer`)."""
        n, stride = trajectory.snapshots.shape[0], self.stride
        actuation = trajectory.actuation[: n * stride]
        # Explicit sizes: -1 is ambiguous for a passive body's (steps, 0) actuation.
        return actuation.reshape((n, stride, actuation.shape[-1])).mean(axis=1)

    def evaluate(self, state: LoopState):
        """The task loss of the current θ, φ, Θ (no gradient)."""
        total, _ = self.simulate(state.controller, state.design, state.observer)
        return total

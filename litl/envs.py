"""A litl robot as a reinforcement-learning environment, in gymnax's shape.

    env, params = litl.envs.make("biped", dx=1 / 32)  # or make(litl.robots.get("biped", dx=1 / 32))
    obs, state = env.reset(key, params)
    obs, state, reward, done, info = env.step(key, state, action, params)

`reset` and `step` are pure and jittable, and vmap over keys and states (a batch of environments
is `jax.vmap(env.step, in_axes=(0, 0, 0, None))`). The interface is gymnax's
(`reset(key, params) -> (obs, state)`, `step(key, state, action, params) -> (obs, state, reward,
done, info)`, `observation_space(params)`, `action_space(params)`, `default_params`; `step` resets
an environment that is done, as gymnax's does), so RL libraries that take gymnax environments
(rejax, purejaxrl-style loops) can train on any litl robot, 2D or 3D, in any world.

* **Action**: the actuators' activations, (m,) in [-1, 1] (clipped), held for `hold` simulation
  steps (one environment step).
* **Observation** (``"particles"``, the default): the robot's centroid velocity (d), each
  actuator's mean strain along its fiber (m; |F f| − 1 averaged over the actuator's particles) and
  (sin, cos) of a clock of period `period`: d + m + 2 values. ``"observer"``: a litl observer's
  features of the grid field after the step (a trained VAE's latent, k-means clusters, ...; its
  parameters in `params.observer`) and the clock: n_features + 2 values. `litl.replay.environment`
  makes the environment of a trained litl run: its robot with the co-designed design, observed
  by its observer.
* **Reward**: the task's progress over the step, so that an episode's return equals minus the
  robot's task loss at its end (``loss(initial, final)``, `Robot.task_loss`): the first step's
  reward is −loss(s0, s1), every later one loss(s0, s_t) − loss(s0, s_t+1).
* **Done**: after `max_steps` environment steps (by default the robot's rollout, `Robot.steps`
  simulation steps), or when the state stops being finite (``info["nonfinite"]``; a non-finite
  action counts, ``info["nonfinite_action"]``), or a particle's stencil leaves the grid
  (``info["escaped"]``).

An action of the wrong shape is refused when the step is traced (`ValueError` naming both shapes).
"""

from __future__ import annotations

import math
from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

import litl.robots
from litl.sim import Design, SimState, rasterize
from litl.sim.fields import GridField, full_cell_mass, grid_velocity, mass_weighted_velocity
from litl.sim.step import Components, make_component_step

OBSERVATIONS = ("particles", "observer")


@struct.dataclass
class Box:
    """A box-shaped space (gymnax's `spaces.Box`): `low`, `high`, `shape`, `dtype`."""

    low: float = struct.field(pytree_node=False)
    high: float = struct.field(pytree_node=False)
    shape: tuple[int, ...] = struct.field(pytree_node=False)
    dtype: Any = struct.field(pytree_node=False, default=jnp.float32)

    def sample(self, key: jax.Array) -> jax.Array:
        low = -1e3 if math.isinf(self.low) else self.low
        high = 1e3 if math.isinf(self.high) else self.high
        return jax.random.uniform(key, self.shape, self.dtype, low, high)

    def contains(self, x) -> jax.Array:
        x = jnp.asarray(x)
        return jnp.logical_and(jnp.all(x >= self.low), jnp.all(x <= self.high)) & (x.shape == self.shape)


@struct.dataclass
class EnvParams:
    """What an episode depends on: the robot's design (Young's modulus per particle, ...), the
    episode's length in environment steps, the simulation steps each action is held for, and the
    observer's parameters (``observation="observer"``; else None)."""

    design: Design
    max_steps: int = struct.field(pytree_node=False)
    hold: int = struct.field(pytree_node=False)
    observer: Any = None

    @property
    def max_steps_in_episode(self) -> int:
        """gymnax's name for `max_steps` (rejax's evaluation reads it)."""
        return self.max_steps


@struct.dataclass
class EnvState:
    """The simulation state, the episode's initial state (the task loss's reference), the task
    loss now, and the environment steps taken."""

    sim: SimState
    initial: SimState
    loss: jax.Array
    time: jax.Array


class Environment:
    """A litl robot as a gymnax-style environment (see the module docstring); made by `make`."""

    def __init__(self, robot, hold: int, period: float, observation: str, dtype, observer=None):
        self.robot = robot
        self.hold = hold
        self.period = period
        self.observation = observation
        self.observer = observer
        self._observer_params = None  # `make` sets them
        self.dtype = dtype
        scene = robot.scene(dtype)
        self._scene = scene
        self._field: GridField = grid_velocity
        if observer is not None and observer.field == "mass_weighted":  # litl.observers.GridField
            self._field = mass_weighted_velocity(full_cell_mass(scene.config, scene.body, scene.design))
        self._step = make_component_step(scene.config, scene.body)
        self._loss = robot.task_loss()
        layout = robot.layout
        one_hot = jax.nn.one_hot(jnp.asarray(layout.actuator), robot.n_actuators, dtype=dtype)
        self._members = one_hot / jnp.maximum(one_hot.sum(axis=0), 1.0)  # (n, m) averaging weights
        self._fiber = jnp.asarray(layout.fiber, dtype)

    @property
    def name(self) -> str:
        return f"litl-{self.robot.name}"

    @property
    def num_actions(self) -> int:
        return self.robot.n_actuators

    @property
    def default_params(self) -> EnvParams:
        return EnvParams(
            design=self._scene.design,
            max_steps=max(self.robot.steps // self.hold, 1),
            hold=self.hold,
            observer=self._observer_params,
        )

    def action_space(self, params: EnvParams | None = None) -> Box:
        return Box(-1.0, 1.0, (self.robot.n_actuators,), self.dtype)

    def observation_space(self, params: EnvParams | None = None) -> Box:
        if self.observer is not None:
            return Box(-math.inf, math.inf, (self.observer.n_features + 2,), self.dtype)
        size = self.robot.dim + self.robot.n_actuators + 2
        return Box(-math.inf, math.inf, (size,), self.dtype)

    def reset(self, key: jax.Array, params: EnvParams | None = None) -> tuple[jax.Array, EnvState]:
        """The robot at rest in its initial configuration (`key` is unused: the start is fixed)."""
        params = params or self.default_params
        initial = self._scene.state
        loss = self._task_loss(initial, initial)
        state = EnvState(sim=initial, initial=initial, loss=loss, time=jnp.zeros((), jnp.int32))
        config, body = self._scene.config, self._scene.body
        field = self._field(rasterize(config, body, initial, params.design)) if self.observer else None
        return self._observe(state, field, params), state

    def step(self, key, state: EnvState, action, params: EnvParams | None = None):
        """One environment step (`hold` simulation steps), then a reset if the episode is done:
        ``(obs, state, reward, done, info)``."""
        params = params or self.default_params
        obs, stepped, reward, done, info = self.step_env(key, state, action, params)
        obs_reset, state_reset = self.reset(key, params)
        state = jax.tree.map(lambda r, s: jnp.where(done, r, s), state_reset, stepped)
        obs = jnp.where(done, obs_reset, obs)
        return obs, state, reward, done, info

    def step_env(self, key, state: EnvState, action, params: EnvParams):
        """The step without the automatic reset."""
        action = jnp.asarray(action)
        wanted = (self.robot.n_actuators,)
        if action.shape != wanted:
            raise ValueError(
                f"{self.name}: an action is the actuators' activations, shape {wanted}, got shape "
                f"{action.shape}"
            )
        nonfinite_action = ~jnp.all(jnp.isfinite(action))
        actuation = jnp.clip(jnp.where(jnp.isfinite(action), action, 0.0), -1.0, 1.0).astype(self.dtype)

        # The held steps carry the state as components, each step given the scan's counter as its
        # buffering token (as litl's rollouts do): a step that packs and unpacks (n, d) arrays
        # differentiates ~300x slower on XLA:CPU (81.7 ms against 0.27 ms, `benchmarks/env_step.py`).
        def one(carry, counter):
            components, _field = carry
            components, grid = self._step(components, actuation, params.design, counter)
            return (components, self._field(grid) if self.observer else None), None

        start = (Components.unpack(state.sim), self._field_placeholder() if self.observer else None)
        # Rematerialized in reverse mode (as litl's rollouts are): measured faster, not only leaner.
        (components, field), _ = jax.lax.scan(jax.checkpoint(one), start, jnp.arange(params.hold))
        sim = components.pack()
        loss = self._task_loss(state.initial, sim)
        # The first step's reward counts from 0, so that the return is minus the final loss.
        reward = jnp.where(state.time == 0, -loss, state.loss - loss)
        finite = jnp.all(jnp.isfinite(sim.x)) & jnp.all(jnp.isfinite(sim.v)) & jnp.isfinite(loss)
        config = self._scene.config
        cells = sim.x / config.dx - 0.5  # the next stencil starts at floor(cells), in [0, n - 3]
        escaped = ~jnp.all((cells >= 0) & (cells < jnp.asarray(config.grid_shape) - 2))
        time = state.time + 1
        done = (time >= params.max_steps) | ~finite | escaped | nonfinite_action
        info = {"nonfinite": ~finite, "nonfinite_action": nonfinite_action, "escaped": escaped, "loss": loss}
        new = EnvState(sim=sim, initial=state.initial, loss=loss, time=time)
        return self._observe(new, field, params), new, jnp.where(finite, reward, 0.0), done, info

    def _task_loss(self, initial: SimState, state: SimState) -> jax.Array:
        total, _ = self._loss(initial, state)
        return jnp.asarray(total, self.dtype)

    def _field_placeholder(self) -> jax.Array:
        config = self._scene.config
        return jnp.zeros((*config.grid_shape, config.dim), self.dtype)

    def _observe(self, state: EnvState, field, params: EnvParams) -> jax.Array:
        sim = self.robot.own(state.sim)  # the robot's particles (not its scenery's)
        t = sim.step.astype(self.dtype) * self._scene.config.dt
        phase = 2 * math.pi * t / self.period
        clock = jnp.stack([jnp.sin(phase), jnp.cos(phase)])
        if self.observer is not None:
            features = self.observer.features(params.observer, sim, field).astype(self.dtype)
            obs = jnp.concatenate([features, clock])
        else:
            velocity = jnp.mean(sim.v, axis=0)
            stretched = jnp.linalg.norm(jnp.einsum("nij,mj->nmi", sim.F, self._fiber), axis=-1) - 1.0
            strain = jnp.sum(self._members * stretched, axis=0)  # (m,)
            obs = jnp.concatenate([velocity, strain, clock])
        return jnp.where(jnp.isfinite(obs), obs, 0.0).astype(self.dtype)


def make(
    robot,
    hold: int = 8,
    period: float | None = None,
    observation: str = "particles",
    dtype=jnp.float32,
    observer=None,
    observer_params=None,
    dx: float | None = None,
):
    """`(env, env_params)` for `robot` (any litl robot, 2D or 3D, in any world).

    Args:
      robot: a `litl.robots.Robot`, or a registered robot's name (``make("biped")``, as
        ``gymnax.make("CartPole-v1")`` takes one): ``litl.robots.get(robot, dx)``'s robot.
      hold: simulation steps each action is held for (one environment step), >= 1.
      period: the observation's clock period in seconds (default: the MLP controller's,
        `litl.controllers.mlp.CLOCK_PERIOD`).
      observation: ``"particles"`` (centroid velocity, actuator strains, clock) or
        ``"observer"`` (`observer`'s features and the clock).
      observer: a `litl.observers.Observer` (``observation="observer"``), e.g.
        ``litl.loop.make_algorithm(robot, config.algorithm).observer``.
      observer_params: its parameters (Θ; `params.observer`), e.g. a trained run's.
      dx: with a robot's name, the grid spacing to sample it at (default: the robot's own, the
        paper's resolution); a `Robot` is already sampled and takes none.

    Raises:
      litl.robots.catalog.UnknownRobotError: an unknown robot name (the message lists the known
        ones).
      SimConfigError: a bad setting (the message names it).
    """
    from litl.controllers.mlp import CLOCK_PERIOD
    from litl.sim import SimConfigError

    if isinstance(robot, str):
        robot = litl.robots.get(robot, dx=dx)
    elif dx is not None:
        raise SimConfigError(
            f"dx={dx!r}: only a robot's name takes dx (make('biped', dx=...)); a Robot is already "
            "sampled (litl.robots.get(name, dx=...))"
        )

    if isinstance(hold, bool) or not isinstance(hold, int) or hold < 1:
        raise SimConfigError(f"hold={hold!r}: the simulation steps per action must be a positive integer")
    if observation not in OBSERVATIONS:
        raise SimConfigError(f"observation={observation!r}: choose one of {list(OBSERVATIONS)}")
    if (observation == "observer") != (observer is not None) or (observer is None) != (
        observer_params is None
    ):
        raise SimConfigError(
            "observation='observer' needs an observer and its parameters (observer=..., "
            "observer_params=...; or litl.replay.environment(run_dir)), and only it takes them"
        )
    period = CLOCK_PERIOD if period is None else period
    if not (isinstance(period, (int, float)) and math.isfinite(period) and period > 0):
        raise SimConfigError(f"period={period!r}: the clock's period must be a positive number of seconds")
    env = Environment(robot, hold, float(period), observation, dtype, observer)
    env._observer_params = observer_params
    return env, env.default_params

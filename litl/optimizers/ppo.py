"""PPO from rejax on the robot as an environment (`litl.envs`): the RL baseline.

The agent is rejax's PPO (a Gaussian policy and a value network, each an MLP of two 64-wide
layers, swish), on `litl.envs.make(robot, hold=optimizer.ppo.hold)`: it observes the particle
summary (centroid velocity, actuator strains, a clock), acts with the actuators' activations, and
is rewarded with the task's progress, so an episode's return is minus the task loss. It learns
the controller only: the design stays at the robot's initial design (PPO has no handle on it).

A round is ``ceil(updates / evaluations)`` PPO updates (each `envs` x `rollout` environment
steps, `epochs` passes of `minibatches` minibatches), then one evaluation: an episode with the
policy's mean action, whose task loss is the round's ``task_loss`` (``episode_return`` is the
training episodes' mean return in the round, stochastic actions). Round 0 is the evaluation of
the initial policy. Every environment step costs `hold` simulation steps, the evaluation an
episode's; the network updates simulate nothing and are not counted (their time is in
``wall_s``). One agent per seed, all seeds vmapped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import jax
import jax.numpy as jnp

from litl.config import RunContext, SettingsError
from litl.optimizers.rounds import Cost, RoundsOptimizer, seed_keys
from litl.robots.robot import Robot
from litl.settings import Settings, number


@dataclass(frozen=True)
class PPOSettings(Settings):
    """``optimizer.ppo``: PPO (rejax) on the robot as an environment.

    Attributes:
      timesteps: environment steps per seed, the budget (each is `hold` simulation steps).
      envs: environments each seed's agent steps at once.
      rollout: environment steps each of them takes between two updates.
      epochs: passes over each update's batch (envs x rollout steps).
      minibatches: minibatches each pass splits the batch into (must divide envs x rollout).
      hold: simulation steps an action is held for (one environment step).
      evaluations: times the policy's mean action is evaluated (one episode each; the curve's
        points, and the run's checkpoints).
      gamma: the discount.
      normalize: running normalization of observations and rewards (rejax's).
      learning_rate: Adam's step size (rejax's default, 3e-4).
    """

    timesteps: int = 65536
    envs: int = 16
    rollout: int = 64
    epochs: int = 8
    minibatches: int = 8
    hold: int = 8
    evaluations: int = 20
    gamma: float = 0.99
    normalize: bool = True
    learning_rate: float = 3.0e-4

    def check(self) -> None:
        self._positive_ints("timesteps", "envs", "rollout", "epochs", "minibatches", "hold", "evaluations")
        if (self.envs * self.rollout) % self.minibatches:
            self._invalid(
                "minibatches",
                f"must divide an update's batch, envs x rollout = {self.envs * self.rollout}",
            )
        if self.timesteps < self.envs * self.rollout:
            self._invalid(
                "timesteps",
                f"is less than one update's batch (envs x rollout = {self.envs * self.rollout}); raise it "
                f"or lower optimizer.ppo.envs / optimizer.ppo.rollout",
            )
        if not (number(self.gamma) and 0 < self.gamma <= 1):
            self._invalid("gamma", "must lie in (0, 1]")
        self._positive_numbers("learning_rate")


def mean_action(module, obs):
    return module._action_dist(obs).mean()


class PPOBaseline:
    """`litl.optimizers.rounds.Method` for ppo."""

    algorithm: Any = None  # the loop's algorithm for this robot and config: what run.json records

    def __init__(self, robot: Robot, context: RunContext, settings: PPOSettings):
        import litl.envs

        try:
            from rejax import PPO
        except ImportError as error:  # pragma: no cover - rejax is a declared dependency
            raise SettingsError(
                f"optimizer=ppo needs rejax ({error}); install litl with its test or rl extra: "
                f'pip install -e ".[rl]"',
                "optimizer.kind",
            ) from error
        sim, observer = context.algorithm.sim, context.algorithm.observer
        if observer.kind != "none":
            raise SettingsError(
                f"optimizer=ppo observes the environment's particle summary, not an observer's features; "
                f"observer={observer.kind} is not used by it (drop the override, or set "
                f"observer=none)",
                "observer.kind",
            )
        if robot.design is not None:
            raise SettingsError(
                f"optimizer=ppo controls only (the design stays at its start), so the design space "
                f"{type(robot.design_space).__name__} would never move; use design=modulus, or "
                f"optimizer=litl to co-design it",
                "design.kind",
            )
        self.name = "ppo"
        self.seeds = context.seed_ids
        env, params = litl.envs.make(robot, hold=settings.hold, dtype=jnp.dtype(sim.dtype.value))
        steps = sim.steps or robot.steps
        params = params.replace(max_steps=max(steps // settings.hold, 1))
        self.env, self.env_params = env, params
        batch = settings.envs * settings.rollout
        updates = settings.timesteps // batch
        self._per_round = math.ceil(updates / settings.evaluations)
        self.rounds = 1 + math.ceil(updates / self._per_round)  # round 0: the initial policy
        self._episode_steps = params.max_steps * settings.hold
        self._train_steps = self._per_round * batch * settings.hold
        self._robot_steps = steps
        algo = PPO.create(
            env=env,
            env_params=params,
            total_timesteps=self._per_round * batch,
            eval_freq=self._per_round * batch,
            skip_initial_evaluation=True,
            num_envs=settings.envs,
            num_steps=settings.rollout,
            num_epochs=settings.epochs,
            num_minibatches=settings.minibatches,
            learning_rate=settings.learning_rate,
            gamma=settings.gamma,
            normalize_observations=settings.normalize,
            normalize_rewards=settings.normalize,
            agent_kwargs={"hidden_layer_sizes": (64, 64)},
        )
        # rejax's evaluation (128 stochastic episodes) gives way to one episode of the mean action.
        self.algo = algo = algo.replace(eval_callback=lambda algo, ts, rng: self._episode(algo, ts))

        def evaluated(ts):
            return ts, self._figures(algo, ts, self._episode(algo, ts))

        def trained(ts):
            ts, evaluation = algo.train(train_state=ts)
            return ts, self._figures(algo, ts, evaluation[-1])

        self._evaluated = jax.jit(jax.vmap(evaluated))
        self._trained = jax.jit(jax.vmap(trained))

    def _episode(self, algo, ts):
        """Minus the return of one episode with the policy's mean action: its task loss
        (deterministic: the environment's start is fixed)."""
        env, params = self.env, self.env_params

        def act(obs):
            if algo.normalize_observations:
                obs = algo.normalize_obs(ts.obs_rms_state, obs)
            mean = algo.actor.apply(ts.actor_ts.params, obs[None], method=mean_action)[0]
            return jnp.clip(mean, -1.0, 1.0)

        obs, state = env.reset(jax.random.key(0), params)

        def one(carry, _):
            obs, state, total, over = carry
            obs, state, reward, done, _ = env.step_env(jax.random.key(0), state, act(obs), params)
            total = total + jnp.where(over, 0.0, reward)
            return (obs, state, total, over | done), None

        start = (obs, state, jnp.zeros((), obs.dtype), jnp.zeros((), bool))
        (_, _, total, _), _ = jax.lax.scan(one, start, None, length=params.max_steps)
        return -total

    @staticmethod
    def _figures(algo, ts, loss):
        log_std = ts.actor_ts.params["params"]["action_log_std"]
        return {
            "task_loss": loss,
            "environment_steps": ts.global_step,
            "action_std": jnp.mean(jnp.exp(log_std)),
        }

    def init(self):
        keys = seed_keys(self.seeds)
        return jax.vmap(lambda k: self.algo.init_state(jax.random.wrap_key_data(k)))(keys)

    def advance(self, state, round_index: int):
        return (self._evaluated if round_index == 0 else self._trained)(state)

    def cost(self, round_index: int) -> Cost:
        steps = self._episode_steps + (0 if round_index == 0 else self._train_steps)
        return Cost(steps, steps / self._robot_steps)


def ppo(robot: Robot, settings: PPOSettings, context: RunContext) -> RoundsOptimizer:
    """`optimizer=ppo`: rejax's PPO on `litl.envs`, controlling only."""
    from litl.loop.algorithm import make_algorithm

    method = PPOBaseline(robot, context, settings)
    method.algorithm = make_algorithm(robot, context.algorithm)  # what run.json records of the run
    budget = f"ppo, {settings.timesteps} environment steps of {settings.hold} simulation steps"
    return RoundsOptimizer(method, robot, context.record, budget)

"""Algorithm 1 (learning-in-the-loop co-optimization) as pure functions of one seed's `LoopState`.

`make_algorithm(robot, config.algorithm)` returns an `Algorithm` whose functions are written for one seed and
batched over seeds with `jax.vmap` by the caller (`litl.loop.run`):

* `init(seed)`: random controller θ and observer Θ, design φ0, optimizer states, empty buffer.
* `bootstrap(state)`: one rollout of the untrained controller fills the buffer (`fill`); the
  observer is trained on it and Θ takes the trained copy whole (a random Θ has nothing worth
  keeping): `learn(fill(state), first=True)`.
* `optimize(state)`: one optimization iteration — rollout with the fixed observer Θ, task loss,
  gradients w.r.t. θ and φ through the whole simulation, Adam, projection of φ into its bounds,
  snapshots into the replay buffer (or replacing it without replay; or one observer step on them
  in the simultaneous ablation).
* `learn(state)`: the learning phase on a copy Θ′ (even train/validation split, minibatch epochs,
  early stopping), then Θ ← α·Θ′ + (1 − α)·Θ.
  `learn_seeds(states, at_once)` is `learn` for a batch of seeds whose phases run `at_once` seeds
  at a time (`loop.learning_seeds_at_once`).
* `evaluate(state)`: the task loss of the current θ, φ, Θ without a gradient (Table 1's "before").

An iteration whose rollout blew up or lost particles, or whose loss or gradient is not finite, is
skipped: parameters, optimizer states and the replay buffer stay as they were, and the metrics say
why (`SKIP_REASONS`). Each seed also keeps the parameters of its best rollout so far (`Best`).

The pieces, one concern each: `litl.loop.state` (`LoopState` and its helpers),
`litl.loop.simulation` (simulate: a rollout with the observer in the loop),
`litl.loop.optimization` (optimize: θ's and φ's updates), `litl.loop.retraining` (learn and
adopt: the observer's learning phase and its soft update); this module wires them together.

Stepping back (`loop.safeguards.step_back_tolerance`): an iteration whose task loss is worse than the last
accepted iterate's (the `Anchor`) by more than the tolerance x |its loss| returns to that iterate
and takes its step again at half the size (from its gradients and optimizer states, so no
simulation is repeated), up to `MAX_STEP_BACKS` times in a row; the metrics say `stepped_back`.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp

from litl import controllers, observers
from litl.config import AlgorithmSettings, SettingsError
from litl.controllers import ControllerContext
from litl.latent import in_loop
from litl.loop.optimization import Optimization
from litl.loop.retraining import Retraining
from litl.loop.schedule import LearningSchedule
from litl.loop.simulation import Simulation
from litl.loop.state import (  # noqa: F401  (re-exported: the loop's state and helpers, where they were)
    MAX_STEP_BACKS,
    SKIP_REASONS,
    Anchor,
    Best,
    LoopState,
    keep_if,
    seed_slice,
    skip_reason,
    stack_seeds,
)
from litl.models.replay_buffer import ReplayBuffer
from litl.observers import Observer, ObserverContext
from litl.robots.robot import Robot
from litl.settings.dynamics import DynamicsConfig
from litl.sim.memory import CheckpointPlan


@dataclasses.dataclass(frozen=True)
class Algorithm:
    """The pure pieces of one seed's run; see the module docstring."""

    init: Callable[[int], LoopState]
    bootstrap: Callable[[LoopState], tuple[LoopState, dict]]
    # fill(state): the bootstrap's rollout into the buffer; bootstrap(state) is
    # learn(fill(state), first=True).
    fill: Callable[[LoopState], LoopState]
    # optimize(state, iterations_in_run=None): one iteration; iterations_in_run, the run's K x M
    # (the step sizes' cosine), as a value (None: the config's).
    optimize: Callable[..., tuple[LoopState, dict]]
    # learn(state, first=False); first: the bootstrap's phase (Θ takes Θ′ whole, unchecked).
    learn: Callable[..., tuple[LoopState, dict]]
    # learn_seeds(states, at_once, first=False): `learn` for a batch of seeds, `at_once` phases
    # at a time.
    learn_seeds: Callable[..., tuple[LoopState, dict]]
    evaluate: Callable[[LoopState], jnp.ndarray]
    steps: int
    observer: Observer
    # How learning alternates with optimization (`loop.schedule`, the paper's ablations):
    # alternating (Algorithm 1: a learning phase after every episode), one_shot (learned once,
    # at the start), simultaneous (one observer step per optimization iteration, no phases) or
    # fixed (an observer that does not learn); see `LearningSchedule`.
    schedule: LearningSchedule
    # For pictures and replays of one seed: policy((controller, observer), state, grid_field),
    # the controller module, and field(grid), the grid field the policy reads
    # (`litl.sim.fields`; pass it to `make_rollout`).
    policy: Callable
    controller: Any  # the registered controller's module (`litl.controllers.Controller.module`)
    field: Callable
    # simulate(controller, design, observer, initial=None) -> (task loss, (components,
    # trajectory)): one differentiable rollout, from the robot's initial state or `initial`.
    simulate: Callable
    # checkpoint_plan() -> `litl.sim.memory.CheckpointPlan` of one seed's rollout under
    # `optimize`: whether its backward pass uses segments to fit the memory budget. From shapes
    # alone (nothing is compiled or run); raises `litl.sim.memory.MemoryBudgetError` where the
    # rollout would.
    checkpoint_plan: Callable[[], CheckpointPlan]
    # The robot's design space (`Robot.design_space`): what φ is, and `modulus(φ)`, the Young's
    # modulus per region the metrics record.
    design_space: Any = None

    @property
    def n_features(self) -> int:
        return self.observer.n_features

    @property
    def model(self):
        """The learned observer's network (None for an observer that does not learn)."""
        return self.observer.learner.model if self.observer.learned else None

    @property
    def retrains(self) -> bool:
        """Whether a learning phase follows every episode (the run shell calls `learn`)."""
        return self.schedule is LearningSchedule.alternating


def empty_statistics(observer: Observer, dtype, dim: int, dynamics: DynamicsConfig | None = None) -> dict:
    """A seed's statistics before its first learning phase: the observer's (none for one that
    does not learn), its follower's (`BodyFollower`), the latent dynamics model's where
    `dynamics` is enabled (`litl.latent.in_loop`) and the loop's own ``update_accepted``."""
    learner, follower = observer.learner, observer.follower
    return {
        **(learner.empty_statistics(dtype, dim) if learner is not None else {}),
        **(follower.empty_statistics(dtype) if follower is not None else {}),
        **(in_loop.empty_statistics(dynamics, dtype) if dynamics is not None and dynamics.enabled else {}),
        "update_accepted": True,
    }


def make_algorithm(robot: Robot, settings: AlgorithmSettings, on_epoch=None) -> Algorithm:
    """Build the pure functions of Algorithm 1 for `robot` under `settings` (its observer,
    controller, sim and loop sections and the number of seeds: ``config.algorithm``).

    `on_epoch(epoch, validation_loss)`, if given, is called from inside every learning phase
    after each epoch (numpy values, one per seed under vmap; `Learner.reporting_epochs`)."""
    if not isinstance(settings, AlgorithmSettings):
        raise TypeError(
            f"make_algorithm takes Algorithm 1's settings (litl.config.AlgorithmSettings), not "
            f"{type(settings).__name__}: pass config.algorithm"
        )
    dtype = jnp.dtype(settings.sim.dtype)
    if dtype == jnp.float64 and not jax.config.jax_enable_x64:  # type: ignore[attr-defined]  # a flag
        raise ValueError("dtype float64 needs 64-bit JAX: wrap the run in jax.enable_x64(True)")
    steps = settings.sim.steps or robot.steps
    scene = robot.scene(dtype)
    observer = observers.make(
        settings.observer, robot, ObserverContext(scene.config, dtype, settings.loop.learning)
    )
    if on_epoch is not None and observer.learner is not None:
        observer = dataclasses.replace(observer, learner=observer.learner.reporting_epochs(on_epoch))
    # An observer that follows the body (k-means reclustering) has phases, as one that learns.
    learns = observer.learner is not None or observer.follower is not None
    schedule = LearningSchedule.of(settings.loop.schedule, learns=learns)
    stride = min(settings.loop.snapshot_stride, steps)
    _check_learning_data(settings.loop, observer, schedule, steps, stride)
    _check_dynamics(settings, observer, schedule)
    simultaneous = schedule is LearningSchedule.simultaneous
    if simultaneous and observer.learner is not None and observer.learner.step is None:
        raise SettingsError(
            f"observer {settings.observer.kind!r} learns in phases only (it has no single SGD step): "
            f"loop.schedule=simultaneous needs one; use loop.schedule=alternating or one_shot",
            "loop.schedule",
        )
    every = settings.sim.checkpoint_every
    if isinstance(every, int) and every % stride:
        raise SettingsError(
            f"sim.checkpoint_every={every} must be a multiple of the snapshot "
            f"stride, {stride} (loop.snapshot_stride); or auto, or null",
            "sim.checkpoint_every",
        )
    simulation = Simulation(
        robot=robot,
        sim=settings.sim,
        seeds=settings.seeds,
        dtype=dtype,
        steps=steps,
        stride=stride,
        scene=scene,
        observer=observer,
        controller=controllers.make(settings.controller, robot, ControllerContext(dtype)),
    )
    optimization = Optimization(simulation, settings.loop, settings.controller.learning_rate, schedule)
    retraining = Retraining(simulation, settings.loop)
    return Algorithm(
        init=functools.partial(
            _init, simulation.observer, jax.jit(functools.partial(_initial_state, simulation, optimization))
        ),
        bootstrap=retraining.bootstrap,
        fill=retraining.fill,
        optimize=optimization.optimize,
        learn=retraining.learn,
        learn_seeds=retraining.learn_seeds,
        evaluate=simulation.evaluate,
        steps=steps,
        observer=observer,
        schedule=schedule,
        policy=simulation.policy,
        controller=simulation.controller.module,
        field=simulation.field,
        simulate=simulation.simulate,
        checkpoint_plan=functools.cache(functools.partial(_checkpoint_plan, simulation, optimization)),
        design_space=robot.design_space,
    )


def _check_learning_data(loop, observer: Observer, schedule: LearningSchedule, steps: int, stride: int):
    """A learning phase splits the buffer into a training and a validation half: with fewer than
    two snapshots it can learn nothing, and would say so only as epochs_used 0."""
    if schedule in (LearningSchedule.fixed, LearningSchedule.simultaneous):
        return
    capacity = loop.buffer_capacity
    held = capacity if loop.replay_buffer else min(capacity, steps // stride)
    if held < 2:
        raise SettingsError(
            f"the learning phase needs at least 2 snapshots in the replay buffer, but it can "
            f"hold {held} (loop.buffer_capacity={capacity}, "
            f"{steps // stride} snapshot(s) per rollout of {steps} steps every "
            f"loop.snapshot_stride={loop.snapshot_stride}, "
            f"loop.replay_buffer={loop.replay_buffer}); raise loop.buffer_capacity or lower "
            f"loop.snapshot_stride"
        )


def _check_dynamics(settings: AlgorithmSettings, observer: Observer, schedule: LearningSchedule) -> None:
    """`loop.dynamics.enabled` needs a latent space to learn in, and learning phases to learn at."""
    dynamics = settings.loop.dynamics
    if not dynamics.enabled:
        return
    if observer.learner is None or observer.learner.latent is None:
        latent = [name for name in ("vae", "ae", "pca") if name in observers.names()]
        raise SettingsError(
            f"loop.dynamics.enabled=true: observer {settings.observer.kind!r} has no latent space "
            f"that encodes and decodes the grid field; choose observer= one of {latent}, or "
            f"loop.dynamics.enabled=false",
            "loop.dynamics.enabled",
        )
    if schedule is not LearningSchedule.alternating:
        raise SettingsError(
            f"loop.dynamics.enabled=true is measured at the learning phases after every episode; "
            f"loop.schedule={settings.loop.schedule.value} has none (use loop.schedule=alternating)",
            "loop.dynamics.enabled",
        )
    in_loop.check_horizons(dynamics, settings.loop.buffer_capacity)


def _checkpoint_plan(simulation: Simulation, optimization: Optimization) -> CheckpointPlan:
    """The memory plan of `simulation.simulate`'s rollout, from the shapes of a seed's state."""
    state = jax.eval_shape(
        functools.partial(
            _init, simulation.observer, functools.partial(_initial_state, simulation, optimization), 0
        )
    )
    design = jax.eval_shape(simulation.robot.design_space.to_design, state.design)
    return simulation.rollout.plan((state.controller, state.observer), design, simulation.scene.state)


def _init(observer: Observer, initial_state: Callable, seed: int) -> LoopState:
    """Random θ and Θ for `seed`, φ0, optimizer states, an empty buffer.

    The observer's Θ is made outside any jit (an observer may fit it on the host from the seed,
    as k-means does); the rest in one compiled program (`initial_state`: `_initial_state`,
    jitted), which computes the same values as running it op by op and, where there are many
    layers, compiles in a fraction of the time (a fresh process's two VAE seeds: 5.3 s -> 1 s)."""
    key = jax.random.key(seed)
    key, controller_key, observer_key = jax.random.split(key, 3)
    return initial_state(jax.random.key_data(key), controller_key, observer.init(observer_key, seed))


def _initial_state(
    simulation: Simulation, optimization: Optimization, key_data, controller_key, observer_params
) -> LoopState:
    """`_init`'s state around the observer's parameters (`key_data`: the seed's key after the split)."""
    dtype, observer = simulation.dtype, simulation.observer
    features = jnp.zeros((observer.n_features,), dtype)
    controller_params = simulation.controller.module.init(controller_key, features, time=jnp.zeros((), dtype))
    observer_optimizer = (
        observer.learner.optimizer_init(observer_params) if observer.learner is not None else ()
    )
    design = simulation.robot.design_space.initial(dtype)
    dim = simulation.scene.config.dim
    return LoopState(
        controller=controller_params,
        design=design,
        controller_optimizer=optimization.controller_adam.init(controller_params),
        design_optimizer=optimization.design_adam.init(design),
        observer=observer_params,
        observer_optimizer=observer_optimizer,
        buffer=ReplayBuffer.empty(
            optimization.loop.buffer_capacity,
            simulation.window.shape,
            dim,
            dtype,
            n_actions=simulation.robot.n_actuators,
        ),
        key=key_data,
        stats=empty_statistics(observer, dtype, dim, optimization.loop.dynamics),
        best=Best(
            task_loss=jnp.full((), jnp.inf, dtype),
            step=jnp.full((), -1, jnp.int32),
            controller=controller_params,
            design=design,
            observer=observer_params,
        ),
        anchor=Anchor(
            controller=controller_params,
            design=design,
            controller_optimizer=optimization.controller_adam.init(controller_params),
            design_optimizer=optimization.design_adam.init(design),
            controller_grad=jax.tree.map(jnp.zeros_like, controller_params),
            design_grad=jax.tree.map(jnp.zeros_like, design),
            task_loss=jnp.full((), jnp.inf, dtype),
            step_scale=jnp.ones((), dtype),
        ),
        iteration=jnp.zeros((), jnp.int32),
        consecutive_skips=jnp.zeros((), jnp.int32),
    )

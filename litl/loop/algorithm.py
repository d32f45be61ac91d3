"""Algorithm 1 (learning-in-the-loop co-optimization) as pure functions of one seed's `LoopState`.

`make_algorithm(robot, config)` returns an `Algorithm` whose functions are written for one seed and
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

Stepping back (`loop.safeguards.step_back_tolerance`): an iteration whose task loss is worse than the last
accepted iterate's (the `Anchor`) by more than the tolerance x |its loss| returns to that iterate
and takes its step again at half the size (from its gradients and optimizer states, so no
simulation is repeated), up to `MAX_STEP_BACKS` times in a row; the metrics say `stepped_back`.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Self

import jax
import jax.numpy as jnp
import optax
from flax import struct

from litl.config import Config, ControllerKind, FeatureGradient, GridField, Schedule, SettingsError
from litl.loop import observers
from litl.loop.learning import LearningStats, soft_update
from litl.loop.observers import Observer
from litl.loop.replay_buffer import ReplayBuffer, add, replace_with
from litl.models.controller import MLPController
from litl.models.open_loop import SinusoidController
from litl.models.window import Window
from litl.robots.robot import Robot
from litl.sim import make_rollout
from litl.sim.fields import full_cell_mass, grid_velocity, mass_weighted_velocity
from litl.sim.memory import default_budget_bytes
from litl.sim.rollout import centroid

# Codes of the `skipped` metric: why an iteration changed nothing (0: it did not skip).
SKIP_REASONS = {
    1: "particles_escaped",
    2: "simulation_nonfinite",
    3: "loss_nonfinite",
    4: "gradient_nonfinite",
}


@struct.dataclass
class Best:
    """The parameters whose rollout had the lowest task loss so far (one seed).

    Attributes:
      task_loss: () that loss (+inf before the first healthy rollout).
      step: () int32 global optimization iteration of that rollout (-1 before it).
      controller, design, observer: θ, φ (R,), Θ used in that rollout.
    """

    task_loss: jnp.ndarray
    step: jnp.ndarray
    controller: Any
    design: jnp.ndarray
    observer: Any


@struct.dataclass
class Anchor:
    """The last accepted optimization iterate, for stepping back (`loop.safeguards.step_back_tolerance`).

    Attributes:
      controller, design: θ, φ at that iterate.
      controller_optimizer, design_optimizer: their Adam states before its step.
      controller_grad, design_grad: the task-loss gradients there.
      task_loss: () its task loss (+inf before the first healthy iteration).
      step_scale: () the fraction of a full Adam step taken from it (halved at every step back).
    """

    controller: Any
    design: jnp.ndarray
    controller_optimizer: Any
    design_optimizer: Any
    controller_grad: Any
    design_grad: jnp.ndarray
    task_loss: jnp.ndarray
    step_scale: jnp.ndarray

    if TYPE_CHECKING:  # flax.struct adds `replace` at run time; declared for the type checker

        def replace(self, **changes: Any) -> Self: ...


# A step is halved at most this many times in a row; the next result is accepted whatever it is.
MAX_STEP_BACKS = 3


@struct.dataclass
class LoopState:
    """Everything one seed's run carries from iteration to iteration (a pytree; vmappable).

    Attributes:
      controller: θ, flax parameters of the MLP controller.
      design: φ, (R,) Young's modulus of each design region.
      controller_optimizer: Adam state of θ.
      design_optimizer: Adam state of φ.
      observer: Θ, `AutoencoderParams` (vae/ae), `KMeansObserver` (kmeans) or a () zero (none).
      observer_optimizer: Adam state of Θ's network for the simultaneous ablation (else empty).
      buffer: the replay buffer of grid velocity snapshots.
      key: (2,) uint32 raw PRNG key data (plain arrays checkpoint and compare bitwise).
      stats: `LearningStats` of the latest learning phase (NaN before the first).
      best: the `Best` parameters so far.
      anchor: the last accepted iterate (`Anchor`), which a step back returns to.
      iteration: () int32 optimization iterations run so far (skipped ones included).
      consecutive_skips: () int32 iterations skipped in a row up to now.
    """

    controller: Any
    design: jnp.ndarray
    controller_optimizer: Any
    design_optimizer: Any
    observer: Any
    observer_optimizer: Any
    buffer: ReplayBuffer
    key: jnp.ndarray
    stats: LearningStats
    best: Best
    anchor: Anchor
    iteration: jnp.ndarray
    consecutive_skips: jnp.ndarray

    if TYPE_CHECKING:  # flax.struct adds `replace` at run time; declared for the type checker

        def replace(self, **changes: Any) -> Self: ...


def skip_reason(health, total, gradient_norm) -> jnp.ndarray:
    """() int32 code in `SKIP_REASONS` (0: the iteration may update parameters)."""
    nonfinite, escaped = health.first_nonfinite_step, health.first_escape_step
    # The earlier failure is the cause (particles outside the grid turn to NaN a step later).
    escaped_first = (escaped >= 0) & ((nonfinite < 0) | (escaped < nonfinite))
    return jnp.select(
        [escaped_first, nonfinite >= 0, ~jnp.isfinite(total), ~jnp.isfinite(gradient_norm)], [1, 2, 3, 4], 0
    ).astype(jnp.int32)


def keep_if(condition, new, old):
    """`new` where the () bool `condition` holds, else `old`, leaf by leaf (a select, vmappable)."""
    return jax.tree.map(lambda a, b: jnp.where(condition, a, b), new, old)


@dataclasses.dataclass(frozen=True)
class Algorithm:
    """The pure pieces of one seed's run; see the module docstring."""

    init: Callable[[int], LoopState]
    bootstrap: Callable[[LoopState], tuple[LoopState, LearningStats]]
    # fill(state): the bootstrap's rollout into the buffer; bootstrap(state) is
    # learn(fill(state), first=True).
    fill: Callable[[LoopState], LoopState]
    optimize: Callable[[LoopState], tuple[LoopState, dict]]
    # learn(state, first=False); first: the bootstrap's phase (Θ takes Θ′ whole, unchecked).
    learn: Callable[..., tuple[LoopState, LearningStats]]
    # learn_seeds(states, at_once, first=False): `learn` for a batch of seeds, `at_once` phases
    # at a time.
    learn_seeds: Callable[..., tuple[LoopState, LearningStats]]
    evaluate: Callable[[LoopState], jnp.ndarray]
    steps: int
    observer: Observer
    # How learning alternates with optimization (`loop.schedule`, the paper's ablations):
    # "alternating" (Algorithm 1: a learning phase after every episode), "one_shot" (learned once,
    # at the start), "simultaneous" (one observer step per optimization iteration, no phases) or
    # "fixed" (an observer that does not learn).
    schedule: str
    # For pictures and replays of one seed: policy((controller, observer), state, grid_field),
    # the controller module, and field(grid), the grid field the policy reads
    # (`litl.sim.fields`; pass it to `make_rollout`).
    policy: Callable
    controller: MLPController | SinusoidController
    field: Callable
    # simulate(controller, design, observer, initial=None) -> (task loss, (components,
    # trajectory)): one differentiable rollout, from the robot's initial state or `initial`.
    simulate: Callable
    # checkpoint_plan() -> `litl.sim.memory.CheckpointPlan` of the rollout (None until it has
    # been traced): whether its backward pass uses segments to fit the memory budget.
    checkpoint_plan: Callable

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
        return self.schedule == "alternating"


def empty_stats(dtype, max_epochs: int, dim: int) -> LearningStats:
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
        steps_per_epoch=zero,
        update_accepted=jnp.ones((), bool),
    )


def make_algorithm(robot: Robot, config: Config, on_epoch=None) -> Algorithm:
    """Build the pure functions of Algorithm 1 for `robot` under `config` (its observer,
    controller, sim and loop settings).

    `on_epoch(epoch, validation_loss)`, if given, is called from inside every learning phase
    after each epoch (numpy values, one per seed under vmap; `Learner.reporting_epochs`)."""
    observers.check_kind(config)
    dtype = jnp.dtype(config.sim.dtype)
    if dtype == jnp.float64 and not jax.config.jax_enable_x64:  # type: ignore[attr-defined]  # a flag
        raise ValueError("dtype float64 needs 64-bit JAX: wrap the run in jax.enable_x64(True)")
    steps = config.sim.steps or robot.steps
    scene = robot.scene(dtype)
    observer = observers.make(config.observer.kind, robot, config, scene.config, dtype)
    if on_epoch is not None and observer.learner is not None:
        observer = dataclasses.replace(observer, learner=observer.learner.reporting_epochs(on_epoch))
    schedule = "fixed" if observer.learner is None else config.loop.schedule.value
    stride = min(config.loop.snapshot_stride, steps)
    _check_learning_data(config.loop, observer, schedule, steps, stride)
    every = config.sim.checkpoint_every
    if isinstance(every, int) and every % stride:
        raise SettingsError(
            f"sim.checkpoint_every={every} must be a multiple of the snapshot "
            f"stride, {stride} (loop.snapshot_stride); or auto, or null",
            "sim.checkpoint_every",
        )
    pieces = _Pieces(
        robot=robot,
        config=config,
        dtype=dtype,
        steps=steps,
        stride=stride,
        scene=scene,
        observer=observer,
        schedule=schedule,
        controller=_make_controller(robot, config.controller),
    )
    return Algorithm(
        init=pieces.init,
        bootstrap=pieces.bootstrap,
        fill=pieces.fill,
        optimize=pieces.optimize,
        learn=pieces.learn,
        learn_seeds=pieces.learn_seeds,
        evaluate=pieces.evaluate,
        steps=steps,
        observer=observer,
        schedule=schedule,
        policy=pieces.policy,
        controller=pieces.controller,
        field=pieces.field,
        simulate=pieces.simulate,
        checkpoint_plan=lambda: pieces.rollout.plan,
    )


def _make_controller(robot: Robot, settings) -> MLPController | SinusoidController:
    if settings.kind == ControllerKind.sinusoid:
        return SinusoidController(robot.n_actuators, omega=settings.sinusoid.omega)
    mlp = settings.mlp
    return MLPController(robot.n_actuators, mlp.widths, period=mlp.period, feature_scale=mlp.feature_scale)


def _check_learning_data(loop, observer: Observer, schedule: str, steps: int, stride: int):
    """A learning phase splits the buffer into a training and a validation half: with fewer than
    two snapshots it can learn nothing, and would say so only as epochs_used 0."""
    if observer.learner is None or schedule == Schedule.simultaneous:
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


def _optimizer(learning_rate: float, clip: float | None) -> optax.GradientTransformation:
    """Adam, after clipping the gradient's global norm (None: no clipping)."""
    return optax.chain(*([optax.clip_by_global_norm(clip)] if clip else []), optax.adam(learning_rate))


@dataclasses.dataclass(frozen=True)
class _Pieces:
    """The static parts of one run's Algorithm 1 and its pure per-seed functions (`Algorithm`'s
    init, bootstrap, optimize, learn, evaluate and policy are these methods)."""

    robot: Robot
    config: Config
    dtype: Any
    steps: int
    stride: int
    scene: Any
    observer: Observer
    schedule: str
    controller: MLPController | SinusoidController

    @property
    def learner(self):
        return self.observer.learner

    @property
    def window(self) -> Window:
        """The grid window a learned observer's snapshots are cropped to (else the whole grid)."""
        if self.learner is not None:
            return self.learner.window
        return Window.around(self.scene.config.grid_shape, self.scene.config.dx, None)

    @property
    def controller_adam(self) -> optax.GradientTransformation:
        return _optimizer(self.config.controller.learning_rate, self.config.loop.safeguards.gradient_clip)

    @property
    def design_adam(self) -> optax.GradientTransformation:
        return _optimizer(self.config.loop.design_learning_rate, self.config.loop.safeguards.gradient_clip)

    def policy(self, params, state, grid_velocity):
        """Actuation from the observer's features of the grid (and the clock)."""
        controller_params, observer_params = params
        features = self.observer.features(jax.lax.stop_gradient(observer_params), state, grid_velocity)
        if self.config.controller.mlp.feature_gradient == FeatureGradient.stop:
            features = jax.lax.stop_gradient(features)
        time = state.step.astype(self.dtype) * self.scene.config.dt
        return self.controller.apply(controller_params, features.astype(self.dtype), time=time)

    @functools.cached_property
    def field(self):
        """field(grid): what the policy reads of the grid and the snapshots record."""
        if self.config.observer.vae.field == GridField.mass_weighted:
            scene = self.scene
            return mass_weighted_velocity(full_cell_mass(scene.config, scene.body, scene.design))
        return grid_velocity

    @functools.cached_property
    def rollout(self):
        """One seed's rollout; the seeds run vmapped, so each gets its share of the budget."""
        sim, seeds = self.config.sim, self.config.seeds
        budget = sim.budget_bytes(seeds)
        if budget is None:
            budget = default_budget_bytes() // seeds
        return make_rollout(
            self.scene.config,
            self.scene.body,
            self.policy,
            self.steps,
            snapshot_stride=self.stride,
            observe=centroid,
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
        if self.learner is not None and not self.window.whole_grid:
            # Snapshot k is the field after step (k + 1) * stride - 1, read by the policy together
            # with the state after that step: crop both around that state's centroid.
            stride = self.stride
            centres = trajectory.observations[stride - 1 :: stride][: trajectory.snapshots.shape[0]]
            trajectory = trajectory.replace(
                snapshots=jax.vmap(self.window.crop)(trajectory.snapshots, centres)
            )
        return total, (components, trajectory)

    def snapshot_velocities(self, trajectory):
        """(n_snapshots, d) the robot's mean particle velocity at each snapshot, from the
        centroids recorded before and after the step that produced it (x += dt v, so the
        difference is exact for free particles)."""
        centres = jnp.concatenate([centroid(self.scene.state)[None], trajectory.observations])
        velocity = (centres[1:] - centres[:-1]) / self.scene.config.dt
        stride = self.stride
        return velocity[stride - 1 :: stride][: trajectory.snapshots.shape[0]]

    def init(self, seed: int) -> LoopState:
        """Random θ and Θ for `seed`, φ0, optimizer states, an empty buffer."""
        dtype, observer = self.dtype, self.observer
        key = jax.random.key(seed)
        key, controller_key, observer_key = jax.random.split(key, 3)
        features = jnp.zeros((observer.n_features,), dtype)
        controller_params = self.controller.init(controller_key, features, time=jnp.zeros((), dtype))
        observer_params = observer.init(observer_key, seed)
        observer_optimizer = self.learner.optimizer_init(observer_params) if self.learner is not None else ()
        design = self.robot.design_space.initial(dtype)
        dim = self.scene.config.dim
        return LoopState(
            controller=controller_params,
            design=design,
            controller_optimizer=self.controller_adam.init(controller_params),
            design_optimizer=self.design_adam.init(design),
            observer=observer_params,
            observer_optimizer=observer_optimizer,
            buffer=ReplayBuffer.empty(self.config.loop.buffer_capacity, self.window.shape, dim, dtype),
            key=jax.random.key_data(key),
            stats=empty_stats(dtype, self.config.loop.learning.max_epochs, dim),
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
                controller_optimizer=self.controller_adam.init(controller_params),
                design_optimizer=self.design_adam.init(design),
                controller_grad=jax.tree.map(jnp.zeros_like, controller_params),
                design_grad=jnp.zeros_like(design),
                task_loss=jnp.full((), jnp.inf, dtype),
                step_scale=jnp.ones((), dtype),
            ),
            iteration=jnp.zeros((), jnp.int32),
            consecutive_skips=jnp.zeros((), jnp.int32),
        )

    @staticmethod
    def split_key(state: LoopState):
        key, sub = jax.random.split(jax.random.wrap_key_data(state.key))
        return state.replace(key=jax.random.key_data(key)), sub

    def learn(self, state: LoopState, first=False):
        """A learning phase on a copy Θ′, then Θ ← α·Θ′ + (1 − α)·Θ (α: `loop.alpha`), kept only
        if the controller does no worse with it (`loop.safeguards.update_tolerance`).

        `first`: the bootstrap's phase, after which Θ takes Θ′ whole, unchecked (a random Θ has
        nothing worth keeping). A Python bool, or a traced () bool so that the bootstrap's phase
        and the later ones are one compiled program (the run shell passes it so)."""
        if self.learner is None:
            return state, state.stats
        state, key = self.split_key(state)
        trained, stats = self.learner.phase(state.observer, state.buffer, key)
        return self.adopt(state, trained, stats, first)

    def learn_seeds(self, states: LoopState, at_once: int, first=False):
        """`learn` for a batch of seeds (every leaf's leading axis): the learning phases run
        `at_once` seeds at a time (vmapped within a group, the groups one after another), the
        rest vmapped. A vmapped phase runs until its slowest seed stops; one seed at a time
        stops each at its own epoch. The results are `jax.vmap(learn)`'s (up to rounding)."""
        if at_once >= jax.tree.leaves(states)[0].shape[0]:  # every seed together: the plain vmap
            return jax.vmap(lambda state: self.learn(state, first))(states)
        if self.learner is None:
            return states, states.stats
        states, keys = jax.vmap(self.split_key)(states)
        trained, stats = jax.lax.map(
            lambda seed: self.learner.phase(*seed), (states.observer, states.buffer, keys), batch_size=at_once
        )
        return jax.vmap(lambda state, phase, phase_stats: self.adopt(state, phase, phase_stats, first))(
            states, trained, stats
        )

    def adopt(self, state: LoopState, trained, stats: LearningStats, first=False):
        """Θ ← α·Θ′ + (1 − α)·Θ from a learning phase's `trained` Θ′ and its `stats`, kept only
        if the controller does no worse with it; after the `first` phase Θ ← Θ′ (see `learn`)."""
        updated = soft_update(state.observer, trained, self.config.loop.alpha)
        tolerance = self.config.loop.safeguards.update_tolerance
        if first is not True and tolerance is not None:
            accepted = self.update_is_safe(state, updated, tolerance)
            if first is not False:
                accepted = accepted | first
            updated = keep_if(accepted, updated, state.observer)
            stats = stats.replace(update_accepted=accepted)
        if first is True:
            updated = trained
        elif first is not False:
            updated = keep_if(first, trained, updated)
        return state.replace(observer=updated, stats=stats), stats

    def update_is_safe(self, state: LoopState, updated, tolerance: float):
        """() bool: the current controller and design, simulated with the `updated` observer,
        reach a task loss within tolerance * |loss| of the one they reach with the current
        observer (and a finite one)."""
        before, _ = self.simulate(state.controller, state.design, state.observer)
        after, _ = self.simulate(state.controller, state.design, updated)
        return jnp.isfinite(after) & (~jnp.isfinite(before) | (after <= before + tolerance * jnp.abs(before)))

    def fill(self, state: LoopState):
        """One rollout of the current controller fills the buffer (the bootstrap's first half)."""
        total, (_, trajectory) = self.simulate(state.controller, state.design, state.observer)
        # A failed rollout's snapshots never enter the buffer.
        healthy = skip_reason(trajectory.health, total, jnp.zeros((), self.dtype)) == 0
        return state.replace(
            buffer=keep_if(
                healthy,
                add(state.buffer, trajectory.snapshots, self.snapshot_velocities(trajectory)),
                state.buffer,
            )
        )

    def bootstrap(self, state: LoopState):
        """One rollout of the untrained controller fills the buffer; Θ takes the trained copy."""
        return self.learn(self.fill(state), first=True)

    def optimize(self, state: LoopState):
        """One optimization iteration (see the module docstring); returns (state, metrics)."""
        value_and_grad = jax.value_and_grad(self.simulate, argnums=(0, 1), has_aux=True)
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
        state = self.take_step(state, total, controller_grad, design_grad, step_back)
        snapshots = trajectory.snapshots
        keep = add if self.config.loop.replay_buffer else replace_with
        state = state.replace(buffer=keep(state.buffer, snapshots, self.snapshot_velocities(trajectory)))
        recon = jnp.full((), jnp.nan, self.dtype)
        if self.schedule == Schedule.simultaneous:
            state, key = self.split_key(state)
            observer_params, observer_optimizer, losses = self.learner.step(
                state.observer, state.observer_optimizer, snapshots, key
            )
            state = state.replace(observer=observer_params, observer_optimizer=observer_optimizer)
            recon = losses["recon"]
        # A failed iteration changes nothing but the key and the counters (and says why).
        state = keep_if(healthy, state, before).replace(
            key=state.key,
            best=best,
            iteration=state.iteration + 1,
            consecutive_skips=jnp.where(healthy, 0, state.consecutive_skips + 1),
        )
        metrics = {
            "task_loss": total,
            **{f"task/{name}": value for name, value in components.items()},
            "design_mean": jnp.mean(state.design),
            "design_min": jnp.min(state.design),
            "design_max": jnp.max(state.design),
            "controller_grad_norm": controller_grad_norm,
            "design_grad_norm": design_grad_norm,
            "skipped": reason,
            "consecutive_skips": state.consecutive_skips,
            "stepped_back": step_back,
            "step_scale": state.anchor.step_scale,
            "simultaneous_recon_loss": recon,
            "first_nonfinite_step": trajectory.health.first_nonfinite_step,
            "first_escape_step": trajectory.health.first_escape_step,
        }
        return state, metrics

    def falls_back(self, anchor: Anchor, total) -> jnp.ndarray:
        """() bool: the rollout's task loss is worse than the anchor's by more than
        `loop.safeguards.step_back_tolerance` x |anchor's loss|, and the step may still be halved."""
        tolerance = self.config.loop.safeguards.step_back_tolerance
        if tolerance is None:
            return jnp.zeros((), bool)
        limit = anchor.task_loss + tolerance * jnp.abs(anchor.task_loss)
        return jnp.isfinite(anchor.task_loss) & (total > limit) & (anchor.step_scale > 0.5**MAX_STEP_BACKS)

    def take_step(self, state: LoopState, total, controller_grad, design_grad, step_back) -> LoopState:
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
            anchor.step_scale * self.step_size_factor(state.iteration),
        )

    def step_size_factor(self, iteration) -> jnp.ndarray:
        """() the fraction of θ's and φ's configured Adam step sizes at this global iteration:
        a cosine from 1 at the first to `loop.safeguards.final_learning_rate_fraction` at the
        last of the run's K x M iterations (constant 1 when that is 1, the paper's setting)."""
        loop = self.config.loop
        final = loop.safeguards.final_learning_rate_fraction
        total = loop.episodes * loop.iterations
        progress = jnp.clip(jnp.asarray(iteration, self.dtype) / max(total - 1, 1), 0.0, 1.0)
        return jnp.asarray(final + (1.0 - final) * 0.5 * (1.0 + jnp.cos(jnp.pi * progress)), self.dtype)

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
        if self.config.loop.codesign:
            updates, design_optimizer = self.design_adam.update(
                design_grad, state.design_optimizer, state.design
            )
            design = self.robot.design_space.project(optax.apply_updates(state.design, shrink(updates)))
            state = state.replace(design=design, design_optimizer=design_optimizer)
        return state

    def evaluate(self, state: LoopState):
        """The task loss of the current θ, φ, Θ (no gradient)."""
        total, _ = self.simulate(state.controller, state.design, state.observer)
        return total


def stack_seeds(states: list[LoopState]) -> LoopState:
    """Stack per-seed states along a new leading axis (the seed axis)."""
    return jax.tree.map(lambda *leaves: jnp.stack(leaves), *states)


def seed_slice(states: LoopState, index: int) -> LoopState:
    """One seed's state out of a stacked one."""
    return jax.tree.map(lambda leaf: leaf[index], states)

"""One seed's state of Algorithm 1 (`LoopState`) and the small pure helpers on it.

The loop's pieces (`litl.loop.simulation`, `optimization`, `retraining`) read and return these;
`litl.loop.algorithm` wires them into an `Algorithm`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Self

import jax
import jax.numpy as jnp
from flax import struct

from litl.models.replay_buffer import ReplayBuffer

# Codes of the `skipped` metric: why an iteration kept nothing of its own (0: it did not skip).
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
      observer: Θ, the observer's parameters (a pytree its `init` made).
      observer_optimizer: Adam state of Θ's network for the simultaneous ablation (else empty).
      buffer: the replay buffer of grid velocity snapshots.
      key: (2,) uint32 raw PRNG key data (plain arrays checkpoint and compare bitwise).
      stats: the observer's statistics of its latest learning phase (NaN before the first).
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
    stats: Any
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


def split_key(state: LoopState) -> tuple[LoopState, jax.Array]:
    """(state with its key advanced, a fresh subkey)."""
    key, sub = jax.random.split(jax.random.wrap_key_data(state.key))
    return state.replace(key=jax.random.key_data(key)), sub


def stack_seeds(states: list[LoopState]) -> LoopState:
    """Stack per-seed states along a new leading axis (the seed axis): one compiled program for
    the whole tree, where stacking leaf by leaf would compile one for each leaf's shape."""
    return _stack(*states)


@jax.jit
def _stack(*states):
    return jax.tree.map(lambda *leaves: jnp.stack(leaves), *states)


def seed_slice(states: LoopState, index: int) -> LoopState:
    """One seed's state out of a stacked one."""
    return jax.tree.map(lambda leaf: leaf[index], states)

"""Experience replay buffer of grid velocity snapshots (paper Sec. 4, Alg. 1 line "Store Υ_j in I").

Beside each snapshot the buffer keeps the robot's velocity at that moment (the particles' mean
velocity), which the learning phase uses to score its codes (the autoencoder's ``velocity_r2``) and
never trains on, and the actuation that led to it from the rollout's previous snapshot (the mean of
the controller's outputs over the `stride` steps between them), with whether that previous snapshot
is the one in the slot before (`follows`). Consecutive snapshots of one rollout and the action
between them are then the transitions (z_t, a_t, z_{t+1}) a latent dynamics model learns from
(`chronological`, `litl.latent`). Actuation enters the stress linearly (tau += F·A·Fᵀ, A = a·d⊗d),
so over a few steps the mean is the held action with the same first-order effect; a controller that
holds its action for the stride records exactly that action.

A fixed-capacity ring buffer held as a pytree, so that adding snapshots is jittable and a batch of
seeds is one `jax.vmap`. Its arrays keep a static shape; how many slots hold data is the dynamic
`count`. Slots fill in order 0, 1, ..., so before the buffer is full the valid slots are exactly
`[0, count)`, and once full every slot is valid and `cursor` points at the oldest entry.

It lives here, below the observers that learn from it and the loop that fills it, so that neither
imports the other for it (`litl.loop.replay_buffer` re-exports it for older code).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Self

import jax
import jax.numpy as jnp
from flax import struct


@struct.dataclass
class ReplayBuffer:
    """Ring buffer of velocity snapshots for one seed.

    Attributes:
      fields: (capacity, *grid_shape, d) stored snapshots; slots outside the valid ones hold stale
        or zero data and must be masked (`valid_mask`).
      velocities: (capacity, d) the robot's mean particle velocity at each snapshot.
      point_velocities: (capacity, d) the velocity of the point the task steers at each snapshot
        (`litl.robots.Robot.task_point`: the arm's tip's centroid; for a walker the same as
        `velocities`), what a latent planner's readout is fitted on (`litl.latent.model`).
      actions: (capacity, m) the mean actuation over the steps that led to each snapshot from its
        rollout's previous one (m actuators; m = 0 for a buffer that records none); zero where
        none was recorded.
      follows: (capacity,) bool, True where the snapshot's previous one in its rollout sits in
        the slot before (ring order) and `actions` holds what led from it: a transition. False for
        a rollout's first snapshot and for snapshots added without actions.
      count: () int32 number of valid entries, at most capacity.
      cursor: () int32 slot the next snapshot is written to (the oldest entry once full).
    """

    fields: jnp.ndarray
    velocities: jnp.ndarray
    point_velocities: jnp.ndarray
    actions: jnp.ndarray
    follows: jnp.ndarray
    count: jnp.ndarray
    cursor: jnp.ndarray

    @property
    def n_actions(self) -> int:
        """m, the number of values of each recorded action (0: the buffer records none)."""
        return self.actions.shape[-1]

    @property
    def capacity(self) -> int:
        """B, the number of slots (for one seed; under an outer vmap call it inside the vmap)."""
        return self.fields.shape[0]

    @classmethod
    def empty(
        cls, capacity: int, grid_shape, dim: int, dtype=jnp.float32, n_actions: int = 0
    ) -> ReplayBuffer:
        """An empty buffer of `capacity` snapshots of shape (*grid_shape, dim), each with an
        action of `n_actions` values (the robot's actuators; 0: no actions recorded).

        For several seeds, build one per seed under `jax.vmap` or broadcast its leaves.
        """
        if isinstance(capacity, bool) or not isinstance(capacity, int) or capacity < 1:
            raise ValueError(f"capacity must be a positive int, got {capacity!r}")
        grid_shape = tuple(grid_shape)
        if len(grid_shape) not in (2, 3) or any(int(n) < 1 for n in grid_shape):
            raise ValueError(f"grid_shape must be 2 or 3 positive sizes, got {grid_shape!r}")
        if dim != len(grid_shape):
            raise ValueError(f"dim must equal the number of grid axes ({len(grid_shape)}), got {dim!r}")
        if isinstance(n_actions, bool) or not isinstance(n_actions, int) or n_actions < 0:
            raise ValueError(f"n_actions must be a non-negative int (the actuators), got {n_actions!r}")
        return cls(
            fields=jnp.zeros((capacity,) + grid_shape + (dim,), dtype),
            velocities=jnp.zeros((capacity, dim), dtype),
            point_velocities=jnp.zeros((capacity, dim), dtype),
            actions=jnp.zeros((capacity, n_actions), dtype),
            follows=jnp.zeros((capacity,), bool),
            count=jnp.zeros((), jnp.int32),
            cursor=jnp.zeros((), jnp.int32),
        )

    if TYPE_CHECKING:  # flax.struct adds `replace` at run time; declared for the type checker

        def replace(self, **changes: Any) -> Self: ...


def _check_snapshots(buffer: ReplayBuffer, snapshots) -> jnp.ndarray:
    snapshots = jnp.asarray(snapshots)
    expected = tuple(buffer.fields.shape[1:])
    if snapshots.ndim != buffer.fields.ndim or tuple(snapshots.shape[1:]) != expected:
        raise ValueError(
            f"snapshots must have shape (k, {', '.join(map(str, expected))}) to fit this buffer, "
            f"got {tuple(snapshots.shape)}"
        )
    return snapshots.astype(buffer.fields.dtype)


def occupied_mean(snapshots) -> jnp.ndarray:
    """(k, *grid, d) fields -> (k, d) mean over each field's nonzero nodes (0 if none): the
    velocity stored for snapshots recorded without the robot's own."""
    axes = tuple(range(1, snapshots.ndim - 1))
    occupied = jnp.any(snapshots != 0, axis=-1, keepdims=True)
    count = jnp.maximum(jnp.sum(occupied, axis=axes), 1)
    return jnp.sum(jnp.where(occupied, snapshots, 0), axis=axes) / count


def add(
    buffer: ReplayBuffer, snapshots, velocities=None, actions=None, point_velocities=None
) -> ReplayBuffer:
    """Append k snapshots of one rollout, overwriting the oldest entries once the buffer is full.

    The result is the same as writing the snapshots one at a time: if k exceeds the capacity only
    the newest `capacity` snapshots survive. Jittable; k is static.

    Args:
      buffer: the buffer to add to.
      snapshots: (k, *grid_shape, d) velocity fields, oldest first, consecutive in one rollout.
      velocities: (k, d) the robot's velocity at each snapshot; None: `occupied_mean` of the
        snapshots.
      actions: (k, m) the actuation that led to each snapshot from the previous one (see
        `ReplayBuffer.actions`); None: zeros, and these snapshots form no transitions.
      point_velocities: (k, d) the task point's velocity at each (`ReplayBuffer.point_velocities`);
        None: `velocities` (a task that steers the whole body).

    Returns:
      The buffer with count = min(count + k, capacity) and cursor advanced by k (mod capacity);
      `follows` is True for the added snapshots but the first (with actions).
    """
    snapshots = _check_snapshots(buffer, snapshots)
    capacity, k = buffer.capacity, snapshots.shape[0]
    if k == 0:
        return buffer
    if velocities is None:
        velocities = occupied_mean(snapshots)
    velocities = jnp.asarray(velocities, buffer.velocities.dtype)
    if velocities.shape != (k, buffer.velocities.shape[1]):
        raise ValueError(
            f"velocities must have shape ({k}, {buffer.velocities.shape[1]}), one "
            f"per snapshot, got {velocities.shape}"
        )
    points = velocities if point_velocities is None else jnp.asarray(point_velocities, velocities.dtype)
    if points.shape != velocities.shape:
        raise ValueError(
            f"point_velocities must have shape {velocities.shape}, one per snapshot, got {points.shape}"
        )
    m = buffer.n_actions
    if actions is None:
        actions, follows = jnp.zeros((k, m), buffer.actions.dtype), jnp.zeros((k,), bool)
    else:
        actions = jnp.asarray(actions, buffer.actions.dtype)
        if actions.shape != (k, m):
            raise ValueError(
                f"actions must have shape ({k}, {m}), one per snapshot with this buffer's "
                f"n_actions={m} values, got {actions.shape}"
            )
        follows = jnp.arange(k) > 0
    # Earlier snapshots of an oversize add would be overwritten by later ones; skip writing them so
    # that the scatter has unique slots (duplicate slots in a scatter are written in no set order).
    skipped = max(k - capacity, 0)
    kept = snapshots[skipped:]
    slots = (buffer.cursor + skipped + jnp.arange(kept.shape[0])) % capacity
    return buffer.replace(
        fields=buffer.fields.at[slots].set(kept, unique_indices=True),
        velocities=buffer.velocities.at[slots].set(velocities[skipped:], unique_indices=True),
        point_velocities=buffer.point_velocities.at[slots].set(points[skipped:], unique_indices=True),
        actions=buffer.actions.at[slots].set(actions[skipped:], unique_indices=True),
        follows=buffer.follows.at[slots].set(follows[skipped:], unique_indices=True),
        count=jnp.minimum(buffer.count + k, capacity).astype(jnp.int32),
        cursor=((buffer.cursor + k) % capacity).astype(jnp.int32),
    )


def clear(buffer: ReplayBuffer) -> ReplayBuffer:
    """The same buffer emptied: zero fields, velocities, actions, count and cursor."""
    return buffer.replace(
        fields=jnp.zeros_like(buffer.fields),
        velocities=jnp.zeros_like(buffer.velocities),
        point_velocities=jnp.zeros_like(buffer.point_velocities),
        actions=jnp.zeros_like(buffer.actions),
        follows=jnp.zeros_like(buffer.follows),
        count=jnp.zeros_like(buffer.count),
        cursor=jnp.zeros_like(buffer.cursor),
    )


def replace_with(
    buffer: ReplayBuffer, snapshots, velocities=None, actions=None, point_velocities=None
) -> ReplayBuffer:
    """Keep only `snapshots` (k, *grid_shape, d) (and their `velocities`, `actions` and
    `point_velocities`, see `add`): the "no replay buffer" ablation.

    Each learning phase then sees only the latest rollout (its newest `capacity` snapshots).
    """
    return add(clear(buffer), snapshots, velocities, actions, point_velocities)


def valid_mask(buffer: ReplayBuffer) -> jnp.ndarray:
    """(capacity,) bool, True where a slot holds a stored snapshot."""
    # Slots fill from 0 upwards and never empty again, so the valid ones are a prefix.
    return jnp.arange(buffer.capacity) < buffer.count


def chronological(buffer: ReplayBuffer) -> tuple[jnp.ndarray, jnp.ndarray]:
    """The slots in the order their snapshots were stored, and which of them are transitions.

    Jittable (static shapes).

    Returns:
      order: (capacity,) int32 slots, oldest snapshot first; the first `count` are valid.
      links: (capacity,) bool, links[t] True where the snapshot in slot order[t] follows the one
        in slot order[t - 1] in its rollout under the action `buffer.actions[order[t]]`: the
        transition (fields[order[t-1]], actions[order[t]], fields[order[t]]). False at t = 0, at
        a rollout's first snapshot, past `count`, and where no action was recorded.
    """
    capacity = buffer.capacity
    full = buffer.count >= capacity
    start = jnp.where(full, buffer.cursor, 0)  # once full, the cursor's slot holds the oldest
    order = ((start + jnp.arange(capacity)) % capacity).astype(jnp.int32)
    position = jnp.arange(capacity)
    links = buffer.follows[order] & (position > 0) & (position < buffer.count)
    return order, links


def valid_fields(buffer: ReplayBuffer) -> jax.Array:
    """(count, *grid_shape, d) the stored snapshots in slot order; not jittable (dynamic shape)."""
    return buffer.fields[: int(buffer.count)]


def newest(buffer: ReplayBuffer, k: int):
    """(min(k, count), *grid_shape, d) numpy: one seed's k newest snapshots, oldest first (they
    sit just before the ring buffer's cursor)."""
    import numpy as np

    count = int(buffer.count)
    slots = (int(buffer.cursor) - 1 - np.arange(min(count, k))[::-1]) % max(count, 1)
    return np.asarray(buffer.fields)[slots]


# What buffers written by earlier versions of litl lack, oldest first: the actions (and whether
# each snapshot follows the one before) were recorded from 2026-12-05, the task point's velocity
# from 2026-12-07.
ADDED_LATER = ("actions", "follows", "point_velocities")


def saved_layout(saved_keys, template: ReplayBuffer) -> dict | None:
    """A template for a buffer checkpointed with the leaves `saved_keys` (an older litl's: some of
    `ADDED_LATER` missing): `template`'s leaves under those keys; None where it holds them all."""
    saved = set(saved_keys)
    if not saved >= {"fields", "velocities", "count", "cursor"} or saved >= set(ADDED_LATER):
        return None
    return {name: leaf for name, leaf in vars(template).items() if name in saved}


def upgrade(saved: dict, template: ReplayBuffer) -> ReplayBuffer:
    """The current buffer from an older one's leaves (`saved_layout`): without recorded actions,
    zero actions shaped as `template`'s and no transitions (`follows` False: what led to the
    snapshots was not recorded); without the task point's velocity, the robot's (`velocities`,
    which it is for a walker; a reach planner on such a buffer steers the centroid)."""
    leaves = dict(saved)
    if "actions" not in leaves:
        leaves["actions"] = jnp.zeros(jnp.shape(template.actions), template.actions.dtype)
        leaves["follows"] = jnp.zeros(jnp.shape(template.follows), bool)
    leaves.setdefault("point_velocities", leaves["velocities"])
    return ReplayBuffer(**leaves)

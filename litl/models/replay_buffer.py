"""Experience replay buffer of grid velocity snapshots (paper Sec. 4, Alg. 1 line "Store Υ_j in I").

Beside each snapshot the buffer keeps the robot's velocity at that moment (the particles' mean
velocity), which the learning phase uses to score its codes (the autoencoder's ``velocity_r2``) and
never trains on.

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
      count: () int32 number of valid entries, at most capacity.
      cursor: () int32 slot the next snapshot is written to (the oldest entry once full).
    """

    fields: jnp.ndarray
    velocities: jnp.ndarray
    count: jnp.ndarray
    cursor: jnp.ndarray

    @property
    def capacity(self) -> int:
        """B, the number of slots (for one seed; under an outer vmap call it inside the vmap)."""
        return self.fields.shape[0]

    @classmethod
    def empty(cls, capacity: int, grid_shape, dim: int, dtype=jnp.float32) -> ReplayBuffer:
        """An empty buffer of `capacity` snapshots of shape (*grid_shape, dim).

        For several seeds, build one per seed under `jax.vmap` or broadcast its leaves.
        """
        if isinstance(capacity, bool) or not isinstance(capacity, int) or capacity < 1:
            raise ValueError(f"capacity must be a positive int, got {capacity!r}")
        grid_shape = tuple(grid_shape)
        if len(grid_shape) not in (2, 3) or any(int(n) < 1 for n in grid_shape):
            raise ValueError(f"grid_shape must be 2 or 3 positive sizes, got {grid_shape!r}")
        if dim != len(grid_shape):
            raise ValueError(f"dim must equal the number of grid axes ({len(grid_shape)}), got {dim!r}")
        return cls(
            fields=jnp.zeros((capacity,) + grid_shape + (dim,), dtype),
            velocities=jnp.zeros((capacity, dim), dtype),
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


def add(buffer: ReplayBuffer, snapshots, velocities=None) -> ReplayBuffer:
    """Append k snapshots, overwriting the oldest entries once the buffer is full.

    The result is the same as writing the snapshots one at a time: if k exceeds the capacity only
    the newest `capacity` snapshots survive. Jittable; k is static.

    Args:
      buffer: the buffer to add to.
      snapshots: (k, *grid_shape, d) velocity fields, oldest first.
      velocities: (k, d) the robot's velocity at each snapshot; None: `occupied_mean` of the
        snapshots.

    Returns:
      The buffer with count = min(count + k, capacity) and cursor advanced by k (mod capacity).
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
    # Earlier snapshots of an oversize add would be overwritten by later ones; skip writing them so
    # that the scatter has unique slots (duplicate slots in a scatter are written in no set order).
    skipped = max(k - capacity, 0)
    kept = snapshots[skipped:]
    slots = (buffer.cursor + skipped + jnp.arange(kept.shape[0])) % capacity
    return buffer.replace(
        fields=buffer.fields.at[slots].set(kept, unique_indices=True),
        velocities=buffer.velocities.at[slots].set(velocities[skipped:], unique_indices=True),
        count=jnp.minimum(buffer.count + k, capacity).astype(jnp.int32),
        cursor=((buffer.cursor + k) % capacity).astype(jnp.int32),
    )


def clear(buffer: ReplayBuffer) -> ReplayBuffer:
    """The same buffer emptied: zero fields, velocities, count and cursor."""
    return buffer.replace(
        fields=jnp.zeros_like(buffer.fields),
        velocities=jnp.zeros_like(buffer.velocities),
        count=jnp.zeros_like(buffer.count),
        cursor=jnp.zeros_like(buffer.cursor),
    )


def replace_with(buffer: ReplayBuffer, snapshots, velocities=None) -> ReplayBuffer:
    """Keep only `snapshots` (k, *grid_shape, d) (and their `velocities`, see `add`): the "no
    replay buffer" ablation.

    Each learning phase then sees only the latest rollout (its newest `capacity` snapshots).
    """
    return add(clear(buffer), snapshots, velocities)


def valid_mask(buffer: ReplayBuffer) -> jnp.ndarray:
    """(capacity,) bool, True where a slot holds a stored snapshot."""
    # Slots fill from 0 upwards and never empty again, so the valid ones are a prefix.
    return jnp.arange(buffer.capacity) < buffer.count


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

"""Ring-buffer replay of velocity snapshots."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.models import replay_buffer
from litl.models.replay_buffer import ReplayBuffer

GRID = (4, 3)


def snapshots(start, k):
    """(k, *GRID, 2) snapshots whose every value is its index start, start+1, ... (identifiable)."""
    ids = jnp.arange(start, start + k, dtype=jnp.float32)
    return jnp.broadcast_to(ids[:, None, None, None], (k,) + GRID + (2,))


def stored_ids(buffer):
    """Set of snapshot ids in the valid slots."""
    return set(np.asarray(replay_buffer.valid_fields(buffer))[:, 0, 0, 0].astype(int).tolist())


def test_empty_buffer():
    buffer = ReplayBuffer.empty(5, GRID, 2)
    assert buffer.fields.shape == (5,) + GRID + (2,)
    assert buffer.capacity == 5 and int(buffer.count) == 0 and int(buffer.cursor) == 0
    assert not np.any(replay_buffer.valid_mask(buffer))


def test_keeps_newest_across_wraparound():
    add = jax.jit(replay_buffer.add)
    buffer = ReplayBuffer.empty(5, GRID, 2)
    buffer = add(buffer, snapshots(0, 3))
    assert (int(buffer.count), int(buffer.cursor)) == (3, 3)
    assert stored_ids(buffer) == {0, 1, 2}
    np.testing.assert_array_equal(replay_buffer.valid_mask(buffer), [1, 1, 1, 0, 0])
    buffer = add(buffer, snapshots(3, 3))  # wraps: 0 is overwritten
    assert (int(buffer.count), int(buffer.cursor)) == (5, 1)
    assert stored_ids(buffer) == {1, 2, 3, 4, 5}
    buffer = add(buffer, snapshots(6, 3))
    assert (int(buffer.count), int(buffer.cursor)) == (5, 4)
    assert stored_ids(buffer) == {4, 5, 6, 7, 8}
    assert np.all(replay_buffer.valid_mask(buffer))


def test_oversize_add_keeps_newest_like_one_at_a_time():
    buffer = replay_buffer.add(ReplayBuffer.empty(4, GRID, 2), snapshots(0, 2))
    oversize = jax.jit(replay_buffer.add)(buffer, snapshots(2, 11))
    assert (int(oversize.count), int(oversize.cursor)) == (4, (2 + 11) % 4)
    assert stored_ids(oversize) == {9, 10, 11, 12}
    one_at_a_time = buffer
    for i in range(2, 13):
        one_at_a_time = replay_buffer.add(one_at_a_time, snapshots(i, 1))
    np.testing.assert_array_equal(oversize.fields, one_at_a_time.fields)
    assert int(one_at_a_time.cursor) == int(oversize.cursor)


def test_replace_with_keeps_only_latest_and_clear_empties():
    buffer = replay_buffer.add(ReplayBuffer.empty(6, GRID, 2), snapshots(0, 5))
    latest = jax.jit(replay_buffer.replace_with)(buffer, snapshots(100, 2))
    assert int(latest.count) == 2 and stored_ids(latest) == {100, 101}
    assert stored_ids(replay_buffer.replace_with(buffer, snapshots(200, 9))) == set(range(203, 209))
    cleared = replay_buffer.clear(buffer)
    empty = ReplayBuffer.empty(6, GRID, 2)
    for a, b in zip(jax.tree.leaves(cleared), jax.tree.leaves(empty), strict=True):
        np.testing.assert_array_equal(a, b)


def test_vmapped_over_seeds_equals_separate_buffers():
    buffers = jax.vmap(lambda _: ReplayBuffer.empty(3, GRID, 2))(jnp.arange(2))
    batch = jnp.stack([snapshots(0, 4), snapshots(10, 4)])
    added = jax.jit(jax.vmap(replay_buffer.add))(buffers, batch)
    for seed in range(2):
        single = replay_buffer.add(ReplayBuffer.empty(3, GRID, 2), batch[seed])
        for a, b in zip(jax.tree.leaves(added), jax.tree.leaves(single), strict=True):
            np.testing.assert_array_equal(a[seed], b)


def test_bad_inputs():
    for capacity in (0, -3, 2.5, True):
        with pytest.raises(ValueError, match="capacity must be a positive int"):
            ReplayBuffer.empty(capacity, GRID, 2)
    with pytest.raises(ValueError, match="dim must equal"):
        ReplayBuffer.empty(4, GRID, 3)
    with pytest.raises(ValueError, match="grid_shape"):
        ReplayBuffer.empty(4, (8,), 1)
    buffer = ReplayBuffer.empty(4, GRID, 2)
    with pytest.raises(ValueError, match=r"snapshots must have shape \(k, 4, 3, 2\)"):
        replay_buffer.add(buffer, jnp.zeros((2, 4, 4, 2)))
    with pytest.raises(ValueError, match="snapshots must have shape"):
        replay_buffer.replace_with(buffer, jnp.zeros(GRID + (2,)))  # a single field without the k axis


def test_velocities_are_kept_beside_their_snapshots():
    buffer = ReplayBuffer.empty(4, GRID, 2)
    given = jnp.asarray([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]])
    buffer = jax.jit(replay_buffer.add)(buffer, snapshots(0, 3), given)
    buffer = replay_buffer.add(buffer, snapshots(3, 3), given + 10)  # wraps: slots 3, 0, 1
    np.testing.assert_array_equal(buffer.velocities, [[13.0, 14.0], [15.0, 16.0], [5.0, 6.0], [11.0, 12.0]])
    # Without velocities a snapshot's own occupied-node mean stands in.
    field = np.zeros((1,) + GRID + (2,), np.float32)
    field[0, 1:3, 0] = (1.0, -2.0)
    alone = replay_buffer.add(ReplayBuffer.empty(2, GRID, 2), field)
    np.testing.assert_allclose(alone.velocities[0], [1.0, -2.0])
    with pytest.raises(ValueError, match="velocities must have shape"):
        replay_buffer.add(alone, snapshots(0, 2), given)
    assert not np.any(replay_buffer.clear(buffer).velocities)


def test_the_loops_old_import_path_gives_the_same_buffer():
    from litl.loop import replay_buffer as old_path

    assert old_path.ReplayBuffer is ReplayBuffer and old_path.add is replay_buffer.add


def test_actions_are_kept_beside_their_snapshots_and_link_one_rollouts_snapshots():
    buffer = ReplayBuffer.empty(5, GRID, 2, n_actions=3)
    assert buffer.actions.shape == (5, 3) and buffer.n_actions == 3 and not np.any(buffer.follows)
    actions = jnp.arange(9.0).reshape(3, 3)
    buffer = jax.jit(replay_buffer.add)(buffer, snapshots(0, 3), None, actions)
    np.testing.assert_array_equal(buffer.actions[:3], actions)
    np.testing.assert_array_equal(buffer.follows, [False, True, True, False, False])
    order, links = jax.jit(replay_buffer.chronological)(buffer)
    np.testing.assert_array_equal(order, [0, 1, 2, 3, 4])
    np.testing.assert_array_equal(links, [False, True, True, False, False])
    # A second rollout wraps around: slots 3, 4, 0, 1 hold ids 3..6, slot 2 the oldest (id 2).
    buffer = replay_buffer.add(buffer, snapshots(3, 4), None, 10 + jnp.arange(12.0).reshape(4, 3))
    order, links = replay_buffer.chronological(buffer)
    np.testing.assert_array_equal(order, [2, 3, 4, 0, 1])
    ids = np.asarray(buffer.fields)[np.asarray(order), 0, 0, 0]
    np.testing.assert_array_equal(ids, [2, 3, 4, 5, 6])
    # id 2 is the oldest (its predecessor was overwritten); id 3 starts the second rollout.
    np.testing.assert_array_equal(links, [False, False, True, True, True])
    np.testing.assert_array_equal(buffer.actions[np.asarray(order)][2], [13.0, 14.0, 15.0])


def test_snapshots_added_without_actions_form_no_transitions():
    buffer = replay_buffer.add(ReplayBuffer.empty(4, GRID, 2, n_actions=2), snapshots(0, 3))
    assert not np.any(buffer.actions) and not np.any(replay_buffer.chronological(buffer)[1])
    full = replay_buffer.add(
        ReplayBuffer.empty(3, GRID, 2, n_actions=1), snapshots(0, 7), None, jnp.ones((7, 1))
    )
    np.testing.assert_array_equal(replay_buffer.chronological(full)[1], [False, True, True])
    cleared = replay_buffer.clear(full)
    assert not np.any(cleared.follows) and not np.any(cleared.actions)


def test_bad_actions():
    buffer = ReplayBuffer.empty(4, GRID, 2, n_actions=2)
    with pytest.raises(ValueError, match=r"actions must have shape \(3, 2\).*n_actions=2"):
        replay_buffer.add(buffer, snapshots(0, 3), None, jnp.zeros((3, 1)))
    for n_actions in (-1, 1.5, True):
        with pytest.raises(ValueError, match="n_actions must be a non-negative int"):
            ReplayBuffer.empty(4, GRID, 2, n_actions=n_actions)

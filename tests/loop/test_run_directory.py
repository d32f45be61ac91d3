"""A run directory belongs to one process at a time, and a damaged checkpoint loses no run."""

import json
import os
import pathlib
import signal
import subprocess
import sys

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.loop.checkpoint import CheckpointError, Checkpoints
from litl.loop.run import RunDirectoryError, RunDirectoryLock, run
from tests.loop.tiny import tiny_config, tiny_robot
from tests.processes import child_environment

ROOT = pathlib.Path(__file__).resolve().parents[2]
HOLD = """
import pathlib, sys, time
from litl.loop.run import RunDirectoryLock
lock = RunDirectoryLock(pathlib.Path(sys.argv[1])).__enter__()
print("locked", flush=True)
time.sleep(120)
"""


def test_a_second_process_on_a_run_directory_stops_at_once_and_touches_nothing(tmp_path):
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLD, str(tmp_path)],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        text=True,
        env=child_environment(),
    )
    try:
        assert holder.stdout.readline().strip() == "locked"
        with pytest.raises(
            RunDirectoryError,
            match=f"in use by another litl run \\(process {holder.pid}\\).*Nothing was changed",
        ):
            run(tiny_robot(), tiny_config(), tmp_path, progress=False)
        assert sorted(p.name for p in tmp_path.iterdir()) == [".lock"]
        # The same through the CLI (no .hydra/, no litl.log written before the lock is taken).
        before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
        done = subprocess.run(
            [sys.executable, "-m", "litl", "+scale=smoke", f"hydra.run.dir={tmp_path}"],
            cwd=tmp_path,
            capture_output=True,
            text=True,
            timeout=300,
            env=child_environment(),
        )
        assert done.returncode == 2, done.stderr[-2000:]
        assert "in use by another litl run" in done.stderr
        assert {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()} == before
    finally:
        holder.send_signal(signal.SIGKILL)
        holder.wait()
    # The lock died with its process: no stale lock after a SIGKILL.
    with RunDirectoryLock(tmp_path):
        assert (tmp_path / ".lock").read_text().strip() == str(os.getpid())


def lines(path):
    return [json.loads(line) for line in path.read_text().splitlines()]


@pytest.mark.slow
@pytest.mark.gpu
def test_resume_skips_a_damaged_newest_checkpoint_and_ends_identical(tmp_path, capfd, deterministic):
    # Checkpoints hold the whole loop state whatever the observer: k-means compiles fastest.
    config = tiny_config(loop={"episodes": 2}, seeds=1, observer={"kind": "kmeans"})
    directory = tmp_path / "damaged"
    finished = run(tiny_robot(), config, directory, progress=False)
    reference = finished.metrics
    checkpoints = directory / "checkpoints"
    assert sorted(p.name for p in checkpoints.iterdir() if p.name.isdigit()) == ["1", "2"]

    # A truncated file in the newest checkpoint: resume from checkpoint 1, redo episode 2.
    damage(checkpoints / "2")
    again = run(tiny_robot(), config, directory, progress=False)
    resumed = again.metrics
    assert "checkpoint 2 (episodes done) could not be restored" in capfd.readouterr().err
    assert (checkpoints / "damaged-2").is_dir()  # kept aside, not deleted
    # Identical, bit for bit (a resume's claim): every field of every record but the clock's, and
    # the whole final state (controller, design, observer, optimizers, buffer, counters).
    untimed = lambda records: [{k: v for k, v in r.items() if k != "wall_s"} for r in records]
    np.testing.assert_equal(untimed(resumed), untimed(reference))
    for mine, theirs in zip(jax.tree.leaves(again.state), jax.tree.leaves(finished.state), strict=True):
        np.testing.assert_array_equal(mine, theirs)
    assert len(lines(directory / "metrics.jsonl")) == len(reference)

    # Lost metadata, this time on every checkpoint: a short message, no traceback.
    for step in ("1", "2"):
        for meta in (checkpoints / step).rglob("_METADATA"):
            meta.unlink()
    with pytest.raises(CheckpointError, match="no checkpoint in .* can be restored.*new run"):
        run(tiny_robot(), config, directory, progress=False)
    assert len(lines(directory / "metrics.jsonl")) == len(reference)  # nothing lost


def damage(checkpoint: pathlib.Path) -> None:
    biggest = max((p for p in checkpoint.rglob("*") if p.is_file()), key=lambda p: p.stat().st_size)
    biggest.write_bytes(biggest.read_bytes()[:10])


def test_a_checkpoint_damaged_twice_is_kept_aside_under_a_free_name(tmp_path):
    checkpoints = Checkpoints(tmp_path)
    state = {"w": np.random.default_rng(0).normal(size=20000)}  # incompressible: the data file is the biggest
    counters = {"episodes": np.asarray(0)}
    for episodes in (1, 2):
        checkpoints.save(episodes, {"w": state["w"] * episodes}, {"episodes": np.asarray(episodes)})
    for attempt in ("damaged-2", "damaged-2-2"):
        damage(tmp_path / "2")
        restored, restored_counters = checkpoints.restore(state, counters)
        assert int(restored_counters["episodes"]) == 1
        np.testing.assert_array_equal(restored["w"], state["w"])
        assert (tmp_path / attempt).is_dir()
        checkpoints.save(2, {"w": state["w"] * 2}, {"episodes": np.asarray(2)})
    checkpoints.close()


def test_a_restored_state_is_placed_as_the_fresh_one_and_reuses_its_program(tmp_path):
    """orbax alone restores arrays committed to a device, for which `jax.jit` compiles a second
    program (one more compilation per resume, and rounding of its own). Restored leaves are placed
    as the template's: uncommitted, committed to the same sharding, or host arrays."""
    device = jax.devices()[0]
    fresh = {
        "free": jnp.arange(6.0).reshape(2, 3),
        "placed": jax.device_put(jnp.ones(3, jnp.int32), device),
        "host": np.full(2, 0.5),
    }
    checkpoints = Checkpoints(tmp_path)
    checkpoints.save(1, jax.tree.map(lambda leaf: leaf * 2, fresh), {"episodes": np.asarray(1)})
    restored, _ = checkpoints.restore(fresh, {"episodes": np.asarray(0)})
    checkpoints.close()
    assert isinstance(restored["free"], jax.Array) and not restored["free"].committed
    assert restored["placed"].committed and restored["placed"].sharding == fresh["placed"].sharding
    assert isinstance(restored["host"], np.ndarray)
    chex.assert_trees_all_equal(restored, jax.tree.map(lambda leaf: leaf * 2, fresh))
    program = jax.jit(lambda tree: jax.tree.map(lambda leaf: leaf + 1, tree))
    program(fresh)
    program(restored)
    assert program._cache_size() == 1  # one program for both


def test_a_checkpoint_from_before_actions_were_recorded_restores_without_transitions(tmp_path):
    from flax import struct

    from litl.models import replay_buffer
    from litl.models.replay_buffer import ReplayBuffer

    @struct.dataclass
    class Holder:  # a state with a buffer, as `LoopState` has
        buffer: object
        weight: object

    fresh = Holder(buffer=ReplayBuffer.empty(4, (3, 3), 2, n_actions=2), weight=jnp.zeros(2))
    written = replay_buffer.add(fresh.buffer, jnp.ones((3, 3, 3, 2)), None, jnp.ones((3, 2)))
    old_leaves = ("fields", "velocities", "count", "cursor")  # the buffer before 2026-12-05
    old = Holder(buffer={k: v for k, v in vars(written).items() if k in old_leaves}, weight=jnp.ones(2))
    checkpoints = Checkpoints(tmp_path)
    checkpoints.save(1, old, {"episodes": np.asarray(1)})
    restored, counters = checkpoints.restore(fresh, {"episodes": np.asarray(0)})
    checkpoints.close()
    assert int(counters["episodes"]) == 1 and not (tmp_path / "damaged-1").exists()
    assert isinstance(restored.buffer, ReplayBuffer) and int(restored.buffer.count) == 3
    np.testing.assert_array_equal(restored.buffer.fields, written.fields)
    np.testing.assert_array_equal(restored.weight, np.ones(2))
    assert restored.buffer.actions.shape == (4, 2) and not np.any(restored.buffer.actions)
    assert not np.any(replay_buffer.chronological(restored.buffer)[1])
    np.testing.assert_array_equal(restored.buffer.point_velocities, written.velocities)


def test_a_checkpoint_from_before_the_task_point_was_recorded_keeps_its_transitions(tmp_path):
    from flax import struct

    from litl.models import replay_buffer
    from litl.models.replay_buffer import ReplayBuffer

    @struct.dataclass
    class Holder:
        buffer: object

    fresh = Holder(buffer=ReplayBuffer.empty(4, (3, 3), 2, n_actions=2))
    velocities = jnp.arange(6.0).reshape(3, 2)
    points = -velocities
    written = replay_buffer.add(fresh.buffer, jnp.ones((3, 3, 3, 2)), velocities, jnp.ones((3, 2)), points)
    np.testing.assert_array_equal(written.point_velocities[:3], points)
    old = Holder(buffer={k: v for k, v in vars(written).items() if k != "point_velocities"})
    checkpoints = Checkpoints(tmp_path)
    checkpoints.save(1, old, {"episodes": np.asarray(1)})
    restored, _ = checkpoints.restore(fresh, {"episodes": np.asarray(0)})
    checkpoints.close()
    np.testing.assert_array_equal(restored.buffer.actions, written.actions)
    np.testing.assert_array_equal(restored.buffer.follows, written.follows)
    np.testing.assert_array_equal(restored.buffer.point_velocities, written.velocities)
    # and a current checkpoint keeps its own
    current = Checkpoints(tmp_path / "current")
    current.save(1, Holder(buffer=written), {"episodes": np.asarray(1)})
    again, _ = current.restore(fresh, {"episodes": np.asarray(0)})
    current.close()
    np.testing.assert_array_equal(again.buffer.point_velocities, written.point_velocities)

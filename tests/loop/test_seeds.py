"""Seeds: one computation vmapped over seeds equals the seeds run one at a time; several devices."""

import functools
import json
import os
import pathlib
import subprocess
import sys

import jax
import numpy as np
import pytest

from litl.config import Config, SettingsError, seeds_at_once
from litl.loop.algorithm import make_algorithm, seed_slice, stack_seeds
from litl.loop.run import run
from tests.loop.tiny import tiny_config, tiny_robot
from tests.processes import child_environment

ROOT = pathlib.Path(__file__).resolve().parents[2]


SEEDS = (3, 4)


@pytest.fixture(scope="module")
def bootstrapped():
    """The tiny float64 run's algorithm, and seeds 3 and 4 after the bootstrap (a rollout and a
    learning phase), vmapped and jitted: the first step of both tests below, computed once."""
    with jax.enable_x64(True):
        algorithm = make_algorithm(tiny_robot(), tiny_config(sim={"steps": 40, "dtype": "float64"}).algorithm)
        states, stats = jax.jit(jax.vmap(algorithm.bootstrap))(
            stack_seeds([algorithm.init(s) for s in SEEDS])
        )
    return algorithm, states, stats


def episode_of(algorithm, batched):
    """bootstrap (a rollout and a learning phase) -> optimize -> optimize, jitted (and vmapped
    when `batched`); the jitted functions are built once, so running several seeds alone compiles
    once. (`algorithm.learn` is the bootstrap's learning phase with a soft update after it.)"""
    wrap = (lambda f: jax.jit(jax.vmap(f))) if batched else jax.jit
    bootstrap, optimize = wrap(algorithm.bootstrap), wrap(algorithm.optimize)

    def after_bootstrap(state, stats):
        state, first = optimize(state)
        state, second = optimize(state)
        return state, (first["task_loss"], second["task_loss"], stats["recon_loss_val"])

    def one_episode(state):
        return after_bootstrap(*bootstrap(state))

    one_episode.after_bootstrap = after_bootstrap
    return one_episode


@pytest.mark.slow
def test_vmapped_seeds_equal_sequential_runs(bootstrapped, x64):
    algorithm, states, stats = bootstrapped
    # The vmapped episode, from the fixture's vmapped bootstrap (the same jitted program).
    together, measured = episode_of(algorithm, True).after_bootstrap(states, stats)
    alone_episode = episode_of(algorithm, False)
    for index, seed in enumerate(SEEDS):
        alone, alone_measured = alone_episode(algorithm.init(seed))
        for batched, single in zip(measured, alone_measured, strict=True):
            np.testing.assert_allclose(batched[index], single, rtol=1e-6)
        for batched, single in zip(
            jax.tree.leaves(seed_slice(together, index)), jax.tree.leaves(alone), strict=True
        ):
            np.testing.assert_allclose(batched, single, rtol=1e-6, atol=1e-9)
    # Different seeds really are different runs.
    assert measured[0][0] != measured[0][1]


def test_learning_phases_run_one_seed_at_a_time_equal_the_vmapped_phases(bootstrapped, x64):
    """`loop.learning_seeds_at_once` groups the same computation: two seeds' learning phases one
    at a time or vmapped give the same observers, states and statistics (float64; in float32
    their rounding differs and early stopping can amplify it)."""
    algorithm, states, _ = bootstrapped
    expected = jax.jit(jax.vmap(algorithm.learn))(states)
    got = jax.jit(functools.partial(algorithm.learn_seeds, at_once=1))(states)
    for mine, theirs in zip(jax.tree.leaves(got), jax.tree.leaves(expected), strict=True):
        np.testing.assert_allclose(mine, theirs, rtol=1e-6, atol=1e-9)
    # The phases learned something, and each seed its own observer.
    learned = jax.tree.leaves(expected[0].observer)[0]
    assert not np.allclose(learned[0], learned[1])
    assert np.all(np.asarray(expected[1]["epochs_used"]) > 0)


def test_seeds_at_once_defaults_to_every_seed_and_refuses_bad_values():
    paper = Config.for_method("paper")
    assert seeds_at_once(paper.loop, 10) == 10
    assert seeds_at_once(paper.replace(loop={"learning_seeds_at_once": 4}).loop, 10) == 4
    assert seeds_at_once(paper.replace(loop={"learning_seeds_at_once": 4}).loop, 2) == 2
    for bad in (0, -1, "some", 1.5, True):
        with pytest.raises(SettingsError, match="loop.learning_seeds_at_once"):
            paper.replace(loop={"learning_seeds_at_once": bad})
    # Not among the settings a run records and resumes by.
    assert "learning_seeds_at_once" not in paper.run_settings()["loop"]


# Sharding concerns how seeds are placed, not what they run: k-means (no learning phase to compile)
# keeps the two float64 compilations short.
SHARDED = """
import json, sys, jax
from litl.loop.run import run, shard_seeds
from tests.loop.tiny import tiny_config, tiny_robot
SHARDED_CONFIG = tiny_config(loop={"episodes": 1}, sim={"steps": 40, "dtype": "float64"},
                             observer={"kind": "kmeans"})
assert jax.device_count() == 2
placed = shard_seeds({"x": jax.numpy.zeros((2, 3))})["x"]
result = run(tiny_robot(), SHARDED_CONFIG, sys.argv[1], progress=False)
print(json.dumps({"devices": len(placed.sharding.device_set),
                  "losses": [m["task_loss"] for m in result.metrics]}))
"""


def test_seeds_spread_over_two_devices_give_the_same_run(tmp_path, x64):
    env = child_environment(
        JAX_ENABLE_X64="1",
        XLA_FLAGS=f"{os.environ.get('XLA_FLAGS', '')} --xla_force_host_platform_device_count=2",
    )
    out = subprocess.run(
        [sys.executable, "-c", SHARDED, str(tmp_path / "two")],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, out.stderr[-3000:]
    sharded = json.loads(out.stdout.strip().splitlines()[-1])
    assert sharded["devices"] == 2
    local = run(
        tiny_robot(),
        tiny_config(loop={"episodes": 1}, sim={"steps": 40, "dtype": "float64"}, observer={"kind": "kmeans"}),
        tmp_path / "one",
        progress=False,
    )
    np.testing.assert_allclose(sharded["losses"], [m["task_loss"] for m in local.metrics], rtol=1e-6)

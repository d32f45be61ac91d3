"""The latent dynamics model measured in the loop's learning phases (`loop.dynamics`)."""

import json
import math

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import litl.observers
from litl.latent import in_loop
from litl.loop.algorithm import make_algorithm
from litl.loop.run import run
from litl.models import replay_buffer
from litl.models.replay_buffer import ReplayBuffer
from litl.observers import ObserverContext
from litl.observers.interface import LatentCodec
from litl.settings import SettingsError
from litl.settings.dynamics import DynamicsConfig, LinearSettings
from tests.loop.tiny import tiny_config, tiny_robot

GRID = (4, 3)
R, M = 3, 2


def linear_system_buffer(rollouts: int, length: int, capacity: int, seed: int = 0):
    """(buffer, codec, (A, B, c)): rollouts of z' = A z + B a + c seen through a linear decoder."""
    rng = np.random.default_rng(seed)
    A = 0.9 * np.linalg.qr(rng.normal(size=(R, R)))[0]
    B, c = rng.normal(size=(R, M)), rng.normal(size=R)
    decoder = rng.normal(size=(int(np.prod(GRID)) * 2, R))
    encoder = np.linalg.pinv(decoder)
    buffer = ReplayBuffer.empty(capacity, GRID, 2, jnp.float64, n_actions=M)
    for _ in range(rollouts):
        z = rng.normal(size=R)
        latents, actions = [], []
        for _ in range(length):
            a = rng.uniform(-1, 1, size=M)
            z = A @ z + B @ a + c
            latents.append(z), actions.append(a)
        fields = (np.stack(latents) @ decoder.T).reshape((length, *GRID, 2))
        buffer = replay_buffer.add(buffer, jnp.asarray(fields), None, jnp.asarray(np.stack(actions)))
    codec = LatentCodec(
        encode=lambda params, fields: fields.reshape(fields.shape[0], -1) @ jnp.asarray(encoder).T,
        decode=lambda params, z: (z @ jnp.asarray(decoder).T).reshape(z.shape[0], *GRID, 2),
    )
    return buffer, codec, (A, B, c)


# Plain least squares: the data determine the system exactly.
SETTINGS = DynamicsConfig(
    enabled=True, horizons=(1, 3), validation_fraction=0.25, linear=LinearSettings(ridge=0.0)
)


def test_a_linear_system_is_predicted_exactly_on_held_out_rollouts_and_the_baseline_is_not():
    with jax.enable_x64(True):
        buffer, codec, _ = linear_system_buffer(rollouts=4, length=10, capacity=40)
        stats = in_loop.measure(codec, None, buffer, jax.random.key(0), SETTINGS)
    assert set(stats) == set(in_loop.statistic_names(SETTINGS))
    assert int(stats["dynamics/rollouts_train"]) == 3 and int(stats["dynamics/rollouts_validation"]) == 1
    for h in (1, 3):
        # One held-out rollout of 10 snapshots: 10 - h starts with h steps ahead in it.
        assert int(stats[f"dynamics/starts/h={h}"]) == 10 - h
        assert float(stats[f"dynamics/latent/linear/h={h}"]) < 1e-6
        assert float(stats[f"dynamics/decoded/linear/h={h}"]) < 1e-6
        assert float(stats[f"dynamics/decoded/floor/h={h}"]) < 1e-9  # the codec is exact
        assert float(stats[f"dynamics/latent/constant/h={h}"]) > 0.1
        # The MLP learns something, from 27 transitions: better than standing still.
        assert float(stats[f"dynamics/latent/mlp/h={h}"]) < float(stats[f"dynamics/latent/constant/h={h}"])
    assert float(stats["dynamics/linear/train_rms"]) < 1e-6


def test_rollouts_are_held_out_whole_and_never_all_of_them():
    with jax.enable_x64(True):
        buffer, _, _ = linear_system_buffer(rollouts=5, length=6, capacity=30)
        _, links = replay_buffer.chronological(buffer)
        for seed in range(5):
            held, n, n_held = in_loop.held_out_rollouts(links, buffer.count, jax.random.key(seed), 0.4)
            held = np.asarray(held).reshape(5, 6)  # rollout by rollout
            assert int(n) == 5 and int(n_held) == 2
            assert set(held.all(axis=1) | ~held.any(axis=1)) == {True}  # whole rollouts
            assert held.all(axis=1).sum() == 2
        one, _, _ = linear_system_buffer(rollouts=1, length=6, capacity=30)
        _, links = replay_buffer.chronological(one)
        held, n, n_held = in_loop.held_out_rollouts(links, one.count, jax.random.key(0), 0.4)
        assert int(n) == 1 and int(n_held) == 1 and bool(held[:6].all()) and not bool(held[6:].any())


def test_one_rollout_has_nothing_to_fit_on_and_says_so_with_nan():
    with jax.enable_x64(True):
        buffer, codec, _ = linear_system_buffer(rollouts=1, length=10, capacity=20)
        stats = in_loop.measure(codec, None, buffer, jax.random.key(0), SETTINGS)
    assert int(stats["dynamics/rollouts_train"]) == 0
    assert math.isnan(float(stats["dynamics/latent/linear/h=1"]))
    assert float(stats["dynamics/latent/constant/h=1"]) > 0  # the baseline needs no fit


def test_measure_vmaps_over_seeds_as_each_seed_alone():
    with jax.enable_x64(True):
        pairs = [linear_system_buffer(rollouts=3, length=8, capacity=20, seed=s) for s in range(2)]
        codec = pairs[0][1]  # both seeds through the same (seed 0's) codec
        buffers = jax.tree.map(lambda *leaves: jnp.stack(leaves), *[b for b, _, _ in pairs])
        keys = jax.random.split(jax.random.key(1), 2)
        batched = jax.vmap(lambda b, k: in_loop.measure(codec, None, b, k, SETTINGS))(buffers, keys)
        for s in range(2):
            alone = in_loop.measure(codec, None, pairs[s][0], keys[s], SETTINGS)
            one = {name: value[s] for name, value in batched.items()}
            chex.assert_trees_all_close(one, alone, rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("kind", ["vae", "pca"])
def test_an_observers_latent_space_decodes_its_encoding_to_its_reconstruction(kind):
    robot = tiny_robot()
    config = tiny_config()
    scene = robot.scene(jnp.float32)
    observer = litl.observers.make(
        config.replace(observer={"kind": kind}).observer,
        robot,
        ObserverContext(scene.config, jnp.float32, config.loop.learning),
    )
    learner = observer.learner
    params = observer.init(jax.random.key(0), 0)
    fields = jax.random.normal(jax.random.key(1), (5, *learner.window.shape, robot.dim)) * 0.1
    if kind == "pca":  # a fitted projection, not the placeholder
        empty = ReplayBuffer.empty(12, learner.window.shape, robot.dim, jnp.float32)
        buffer = replay_buffer.add(empty, fields)
        params, _ = learner.phase(params, buffer, jax.random.key(2))
    latents = learner.latent.encode(params, fields)
    chex.assert_shape(latents, (5, observer.n_features))
    chex.assert_trees_all_close(
        learner.latent.decode(params, latents), learner.reconstruct(params, fields), rtol=1e-5, atol=1e-6
    )


def test_bad_dynamics_settings_are_refused_by_name_before_anything_runs():
    robot = tiny_robot()
    with pytest.raises(SettingsError, match=r"observer 'kmeans' has no latent space.*observer= one of"):
        kmeans = tiny_config(observer={"kind": "kmeans"}, loop={"dynamics": {"enabled": True}})
        make_algorithm(robot, kmeans.algorithm)
    with pytest.raises(SettingsError, match=r"\[20\] reach past the replay buffer's 12 snapshots"):
        make_algorithm(robot, tiny_config(loop={"dynamics": {"enabled": True}}).algorithm)
    with pytest.raises(SettingsError, match="loop.schedule=one_shot has none"):
        one_shot = tiny_config(loop={"schedule": "one_shot", "dynamics": {"enabled": True, "horizons": (1,)}})
        make_algorithm(robot, one_shot.algorithm)
    with pytest.raises(SettingsError, match=r"loop.dynamics.horizons=\(0,\): must be one or more positive"):
        DynamicsConfig(horizons=(0,))
    with pytest.raises(SettingsError, match=r"loop.dynamics.validation_fraction=1.0"):
        DynamicsConfig(validation_fraction=1.0)


def test_a_run_with_dynamics_records_it_at_every_phase_in_learning_jsonl_only(tmp_path):
    config = tiny_config(loop={"dynamics": {"enabled": True, "horizons": (1, 2)}})
    run(tiny_robot(), config, tmp_path, progress=False)
    phases = [json.loads(line) for line in (tmp_path / "learning.jsonl").read_text().splitlines()]
    assert [p["phase"] for p in phases] == [0, 0, 1, 1, 2, 2]  # 2 seeds, bootstrap + 2 episodes
    for record in phases:
        assert set(in_loop.statistic_names(config.loop.dynamics)) <= set(record)
    later = [p for p in phases if p["phase"] > 0]
    for record in later:  # 3 rollouts by then (4 snapshots each): one held out, two to fit on
        assert record["dynamics/rollouts_train"] >= 1
        assert np.isfinite(record["dynamics/latent/linear/h=1"])
        assert np.isfinite(record["dynamics/decoded/mlp/h=2"])
    metrics = (tmp_path / "metrics.jsonl").read_text().splitlines()
    assert not any(name.startswith("dynamics/") for name in json.loads(metrics[-1]))


def test_measuring_the_dynamics_leaves_the_run_as_it_is(tmp_path):
    plain, measured = tmp_path / "plain", tmp_path / "measured"
    run(tiny_robot(), tiny_config(), plain, progress=False)
    run(
        tiny_robot(),
        tiny_config(loop={"dynamics": {"enabled": True, "horizons": (1,)}}),
        measured,
        progress=False,
    )
    losses = [
        [json.loads(line)["task_loss"] for line in (path / "metrics.jsonl").read_text().splitlines()]
        for path in (plain, measured)
    ]
    # Another compiled program may round differently; the random streams are the same.
    np.testing.assert_allclose(losses[0], losses[1], rtol=1e-4, atol=1e-6)

"""`litl.envs`: a litl robot as a gymnax-style environment: shapes and spaces, jit and vmap over
keys, the return equal to minus the task loss of the same actions rolled out by the simulator,
gymnax's automatic reset, and bad input."""

import json

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import litl.envs
import litl.robots
from litl.sim import SimConfigError, make_rollout


@pytest.fixture(scope="module")
def biped():
    robot = litl.robots.get("biped", dx=1 / 32)
    env, params = litl.envs.make(robot, hold=8)
    return robot, env, params.replace(max_steps=6)


def test_reset_and_step_have_gymnax_shapes_and_spaces(biped):
    robot, env, params = biped
    obs, state = jax.jit(env.reset)(jax.random.key(0), params)
    chex.assert_shape(obs, env.observation_space(params).shape)
    assert obs.shape == (robot.dim + robot.n_actuators + 2,)
    action = env.action_space(params).sample(jax.random.key(1))
    assert bool(env.action_space(params).contains(action)) and env.num_actions == robot.n_actuators
    obs, state, reward, done, info = jax.jit(env.step)(jax.random.key(2), state, action, params)
    chex.assert_shape([obs, reward, done], [(obs.shape[0],), (), ()])
    assert int(state.time) == 1 and not bool(done) and set(info) >= {"nonfinite", "escaped", "loss"}


def test_environments_vmap_over_keys(biped):
    robot, env, params = biped
    keys = jax.random.split(jax.random.key(0), 3)
    _, started = jax.vmap(env.reset, in_axes=(0, None))(keys, params)
    actions = jnp.stack([jnp.full((robot.n_actuators,), a) for a in (-0.5, 0.0, 0.5)])
    obs, states, rewards, dones, _ = jax.jit(jax.vmap(env.step, in_axes=(0, 0, 0, None)))(
        keys, started, actions, params
    )
    chex.assert_shape([obs, rewards, dones], [(3, obs.shape[1]), (3,), (3,)])
    single = env.step(keys[2], jax.tree.map(lambda x: x[2], started), actions[2], params)[0]
    chex.assert_trees_all_close(obs[2], single, atol=1e-6)  # batched as one at a time
    strains = np.asarray(obs[:, robot.dim : robot.dim + robot.n_actuators])
    assert np.all(np.diff(strains[:, 0]) != 0)  # different activations, different strains


def test_the_return_is_minus_the_task_loss_of_the_same_actions(biped):
    """Rewards summed over an episode equal minus the task loss of the simulator's own rollout
    with the same actions held for `hold` steps each (a path that does not go through the env)."""
    robot, env, params = biped
    actions = jax.random.uniform(
        jax.random.key(3), (params.max_steps, robot.n_actuators), minval=-1, maxval=1
    )
    _, state = env.reset(jax.random.key(0), params)

    def one(state, action):
        _, state, reward, done, _ = env.step_env(jax.random.key(0), state, action, params)
        return state, (reward, done)

    _, (rewards, dones) = jax.lax.scan(one, state, actions)
    assert bool(dones[-1]) and not bool(jnp.any(dones[:-1]))
    scene = robot.scene()
    hold = params.hold

    def policy(sequence, sim_state, grid):
        return sequence[jnp.minimum(sim_state.step // hold, params.max_steps - 1)]

    rollout = make_rollout(scene.config, scene.body, policy, params.max_steps * hold)
    final, _ = rollout(actions, scene.design, scene.state)
    loss, _ = robot.task_loss()(scene.state, final)
    np.testing.assert_allclose(float(jnp.sum(rewards)), -float(loss), rtol=1e-4, atol=1e-7)


def test_a_done_environment_resets_itself(biped):
    robot, env, params = biped
    obs0, state = env.reset(jax.random.key(0), params)
    state = state.replace(time=jnp.asarray(params.max_steps - 1, jnp.int32))
    obs, state, _, done, _ = env.step(jax.random.key(1), state, jnp.ones(robot.n_actuators), params)
    assert bool(done) and int(state.time) == 0
    chex.assert_trees_all_close(obs, obs0)
    chex.assert_trees_all_close(state.sim.x, env.reset(jax.random.key(0), params)[1].sim.x)


def test_bad_actions_and_settings_are_refused(biped):
    robot, env, params = biped
    _, state = env.reset(jax.random.key(0), params)
    with pytest.raises(ValueError, match=rf"shape \({robot.n_actuators},\), got shape \(3,\)"):
        env.step(jax.random.key(0), state, jnp.zeros(3), params)
    nan = jnp.full((robot.n_actuators,), jnp.nan)
    _, after, reward, done, info = jax.jit(env.step_env)(jax.random.key(0), state, nan, params)
    assert bool(done) and bool(info["nonfinite_action"]) and np.isfinite(float(reward))
    for bad in ({"hold": 0}, {"observation": "pixels"}, {"period": -1.0}):
        with pytest.raises(SimConfigError, match=next(iter(bad))):
            litl.envs.make(robot, **bad)


def test_a_registered_robots_name_makes_the_same_environment_as_the_robot(biped):
    """``make("biped", dx=..., hold=...)`` (a name, as ``gymnax.make("CartPole-v1")`` takes one)
    is ``make(litl.robots.get("biped", dx=...), hold=...)``: the same spaces, the same start and the
    same first step from the same key and action."""
    robot, env, params = biped
    named, named_params = litl.envs.make("biped", dx=1 / 32, hold=8)
    named_params = named_params.replace(max_steps=params.max_steps)
    assert named.robot.name == robot.name and named.num_actions == env.num_actions
    assert named.observation_space(named_params) == env.observation_space(params)
    assert named.action_space(named_params) == env.action_space(params)
    chex.assert_trees_all_close(named_params.design, params.design, atol=0)
    key = jax.random.key(4)
    action = env.action_space(params).sample(jax.random.key(5))
    first = env.step(key, env.reset(key, params)[1], action, params)
    first_named = named.step(key, named.reset(key, named_params)[1], action, named_params)
    chex.assert_trees_all_close(first_named, first, atol=0)


def test_an_unknown_robot_name_or_a_dx_with_a_robot_is_refused(biped):
    from litl.robots.catalog import UnknownRobotError

    with pytest.raises(UnknownRobotError, match=r"unknown robot 'bipedd'; choose one of \[.*'biped'"):
        litl.envs.make("bipedd", hold=8)
    with pytest.raises(SimConfigError, match="only a robot's name takes dx"):
        litl.envs.make(biped[0], dx=1 / 32)


def test_a_3d_robot_is_an_environment_too():
    robot = litl.robots.get("quadruped", dx=1 / 16)
    env, params = litl.envs.make(robot, hold=4)
    obs, state = env.reset(jax.random.key(0), params)
    obs, state, reward, done, _ = jax.jit(env.step)(
        jax.random.key(1), state, jnp.zeros(robot.n_actuators), params
    )
    assert obs.shape == (3 + robot.n_actuators + 2,) and np.isfinite(float(reward))


def test_a_trained_runs_environment_observes_its_observer_and_gives_back_its_task_loss(tmp_path):
    """`litl.replay.environment`: the environment of a finished VAE run, observed by the seed's
    trained VAE (its latent and the clock). With one simulation step per action and the run's own controller
    acting on the latent, an episode's return is minus the task loss the run recorded for that
    seed (its final.json): the environment simulates what litl's loop simulated."""
    from litl.app import compose, run_experiment
    from litl.loop import load_final, make_algorithm
    from litl.replay import ReplayError

    run_dir = tmp_path / "run"
    overrides = ["+scale=smoke", "seeds=2", "sim.steps=100", "loop.episodes=1", "loop.iterations=2"]
    config = compose([*overrides, "output.progress=false"])
    run_experiment(config.replace(output=config.output.replace(pictures=False, animation=False)), run_dir)
    env, params = litl.replay.environment(run_dir, seed=1, hold=1)
    robot = env.robot
    algorithm = make_algorithm(robot, config.algorithm)
    assert env.observation_space(params).shape == (algorithm.observer.n_features + 2,)
    saved = jax.tree.map(lambda x: x[1], load_final(run_dir, robot, config))
    chex.assert_trees_all_close(params.design, robot.design_space.to_design(saved["design"]), atol=0)
    params = params.replace(max_steps=algorithm.steps)
    obs, state = env.reset(jax.random.key(0), params)
    chex.assert_shape(obs, (algorithm.observer.n_features + 2,))

    def one(carry, _):
        obs, state = carry
        features = obs[: algorithm.observer.n_features]
        time = state.sim.step.astype(obs.dtype) * robot.config.dt
        action = algorithm.controller.apply(saved["controller"], features, time=time)
        obs, state, reward, _, _ = env.step_env(jax.random.key(0), state, action, params)
        return (obs, state), reward

    _, rewards = jax.lax.scan(one, (obs, state), None, length=params.max_steps)
    recorded = json.loads((run_dir / "final.json").read_text())[1]["task_loss"]
    assert abs(recorded) > 1e-4  # it moved: the loss stands well above float32 rounding
    np.testing.assert_allclose(-float(jnp.sum(rewards)), recorded, rtol=1e-3)
    with pytest.raises(ReplayError, match="seed 5: the run has seeds"):
        litl.replay.environment(run_dir, seed=5)
    with pytest.raises(SimConfigError, match="observation='observer' needs an observer"):
        litl.envs.make(robot, observation="observer")

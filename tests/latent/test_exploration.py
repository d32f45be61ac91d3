"""Exploratory episodes for the latent model (`litl.latent.exploration`) and MPC warm-started by
the trained controller (`MPCSettings.warm_start`), in the environment and from the command line."""

import json

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import litl.envs
from litl.latent import control as cli
from litl.latent.exploration import Exploration, ExplorationError, Sequence, explore, join
from litl.latent.model import fit_sequence
from litl.latent.planning import Goal, MPCSettings, control, guided_plan, warm_start
from litl.loop.run import run
from litl.settings import SettingsError
from litl.settings.dynamics import DynamicsConfig
from tests.latent.test_planning import _obs_model, integrator
from tests.loop.tiny import tiny_config, tiny_robot


@pytest.fixture(scope="module")
def observed_biped():
    """A tiny biped observed by k-means (an observer whose features are no latent codec's)."""
    from litl.loop import make_algorithm

    robot = tiny_robot()
    config = tiny_config(observer={"kind": "kmeans"})
    algorithm = make_algorithm(robot, config.algorithm)
    params = algorithm.init(0).observer
    env, env_params = litl.envs.make(
        robot, 5, None, "observer", jnp.float32, observer=algorithm.observer, observer_params=params
    )
    return env, env_params


def test_exploratory_episodes_hold_random_actions_and_break_their_links(observed_biped):
    env, env_params = observed_biped
    settings = Exploration(episodes=3, hold=2)
    data = jax.jit(explore, static_argnums=(0, 3, 4))(env, env_params, jax.random.key(0), settings, 5)
    r, m = env.observer.n_features, env.num_actions
    chex.assert_shape([data.latents, data.actions, data.links], [(18, r), (18, m), (18,)])
    actions = np.asarray(data.actions).reshape(3, 6, m)
    assert np.all(actions[:, 0] == 0)  # each episode's first row follows nothing
    assert np.all(np.abs(actions) <= 1)
    np.testing.assert_array_equal(actions[:, 1], actions[:, 2])  # held for two control steps
    np.testing.assert_array_equal(actions[:, 3], actions[:, 4])
    assert np.all(actions[:, 2] != actions[:, 3])  # then drawn again
    assert not np.allclose(actions[0], actions[1])  # each episode draws its own
    links = np.asarray(data.links).reshape(3, 6)
    assert not links[:, 0].any() and links[:, 1:].all()  # a tiny biped neither escapes nor fails
    # the latents are the observer's features of each step: they move under the actions
    latents = np.asarray(data.latents).reshape(3, 6, r)
    assert np.all(np.isfinite(latents)) and np.abs(latents[:, -1] - latents[:, 0]).max() > 1e-4
    # the same key draws the same episodes
    again = explore(env, env_params, jax.random.key(0), settings, 5)
    chex.assert_trees_all_close(again, data, atol=1e-6)


def test_a_model_is_fitted_on_joined_sequences_without_linking_across_them():
    def sequence(offset, length):
        latents = jnp.arange(length, dtype=jnp.float32)[:, None] * 0.1 + offset
        ones = jnp.ones(length, bool)
        actions = jnp.full((length, 1), 0.1)
        return Sequence(latents, actions, latents, ones.at[0].set(False), ones)

    # z' = z + a, in two sequences whose end and start do not follow one another
    data = join(sequence(0.0, 6), sequence(5.0, 4))
    assert not bool(data.links[6])
    model, fit = fit_sequence(data, jax.random.key(0), DynamicsConfig(), 0.1, "linear")
    assert int(fit["transitions"]) == 5 + 3
    np.testing.assert_allclose(model.step(jnp.array([2.0]), jnp.array([0.1])), [2.1], atol=1e-3)


@pytest.mark.parametrize("settings", [{"episodes": 0}, {"hold": -1}, {"episodes": True}, {"hold": 1.5}])
def test_bad_exploration_settings_are_refused_by_name(settings):
    name = next(iter(settings))
    with pytest.raises(ExplorationError, match=f"exploration {name}=.*a positive whole number"):
        Exploration(**settings)


def test_the_warm_start_rolls_the_trained_controller_through_the_model_and_keeps_the_better_plan():
    model = integrator(r=2, m=2)
    guide = lambda z, t: jnp.tanh(jnp.array([t, -z[0]]))  # reads both the latent and the time
    guided = guided_plan(guide, jnp.array([0.2, 0.0]), 0.5, 3, model)
    # z' = z + a: the guide sees its own actions' effect and the clock advancing by DT
    a0 = jnp.tanh(jnp.array([0.5, -0.2]))
    a1 = jnp.tanh(jnp.array([0.5 + 0.1, -(0.2 + a0[0])]))
    chex.assert_trees_all_close(jnp.tanh(guided[:2]), jnp.stack([a0, a1]), atol=1e-5)
    previous = jnp.zeros((3, 2))
    cost = lambda plan: jnp.sum((jnp.tanh(plan) - 0.3) ** 2)
    chex.assert_trees_all_close(warm_start(previous, cost, MPCSettings(), guided), previous)
    chex.assert_trees_all_close(warm_start(previous, cost, MPCSettings(warm_start="trained"), guided), guided)
    better = MPCSettings(warm_start="better")
    chosen = warm_start(previous, cost, better, guided)
    assert float(cost(chosen)) == pytest.approx(min(float(cost(previous)), float(cost(guided))))


def test_mpc_warm_started_by_the_controller_acts_as_it_does_when_it_barely_plans():
    env, env_params = litl.envs.make("biped", hold=4, dx=1 / 32)
    model = _obs_model(env, env_params)
    settings = MPCSettings(horizon=3, iterations=1, learning_rate=1e-6, warm_start="trained")
    guide = lambda z, t: jnp.full(env.num_actions, 0.4, z.dtype)
    out = control(env, env_params, model, Goal("walk", 1.0), settings, jax.random.key(0), 3, guide=guide)
    np.testing.assert_allclose(np.asarray(out["actions"]), 0.4, atol=1e-4)
    with pytest.raises(ValueError, match="needs the trained controller"):
        control(env, env_params, model, Goal("walk", 1.0), settings, jax.random.key(0), 3)
    with pytest.raises(SettingsError, match="warm_start"):
        MPCSettings(warm_start="mlp")


@pytest.fixture(scope="module")
def kmeans_run(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("kmeans")
    run(tiny_robot(), tiny_config(observer={"kind": "kmeans"}, loop={"episodes": 1}), run_dir, progress=False)
    return run_dir


@pytest.mark.parametrize("planner", ["latent_mpc", "latent_lqr", "oracle_mpc"])
def test_a_kmeans_run_is_planned_with_a_model_of_exploratory_episodes(kmeans_run, tmp_path, planner):
    out = tmp_path / "explored.json"
    arguments = [str(kmeans_run), "--goal", "reach:0.4", "--planner", planner, "--out", str(out)]
    arguments += ["--data", "explored", "--explore-episodes", "3", "--explore-hold", "2"]
    if planner != "latent_lqr":
        arguments += ["--set", "horizon=2", "--set", "iterations=2", "--set", "warm_start=better"]
    if planner == "latent_mpc":  # the model trained on two-step rollouts
        arguments += ["--model", "rollout=2", "--model", "widths=8,8"]
    assert cli.main(arguments) == 0
    summary = json.loads(out.read_text())
    mlp = summary["model_settings"]
    assert (mlp["rollout"], mlp["widths"]) == ((2, [8, 8]) if planner == "latent_mpc" else (1, [64, 64]))
    assert summary["data"] == "explored" and summary["exploration"] == {"episodes": 3, "hold": 2}
    steps = summary["control_steps"]
    for entry in summary["seeds"]:
        assert entry["transitions"] == 3 * steps  # every step of every episode, none across them
        assert np.isfinite(entry["final"]) and entry["first_nonfinite_step"] is None
    if planner == "latent_mpc":  # 2 x (2 + 1) plus the warm start's 3 x 2
        assert summary["model_steps_per_control_step"] == 2 * (2 + 1 + 3)


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--data", "buffer", "--explore-episodes", "2"], "set --data explored or both"),
        (["--data", "explored", "--explore-episodes", "0"], "exploration episodes=0"),
        (["--data", "both", "--explore-hold", "0"], "exploration hold=0"),
        (["--set", "warm_start=mlp"], "warm_start"),
        (["--model", "depth=3"], "KEY one of"),
        (["--model", "rollout=0"], "rollout"),
        (["--model", "widths=wide"], "comma-separated ints"),
    ],
)
def test_bad_exploration_requests_are_refused_before_anything_is_written(
    kmeans_run, tmp_path, capsys, arguments, message
):
    out = tmp_path / "never.json"
    with pytest.raises(SystemExit) as stop:
        cli.main([str(kmeans_run), "--goal", "walk:1", *arguments, "--out", str(out)])
    assert stop.value.code == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_rest_needs_no_model_and_runs_on_any_observer(kmeans_run, tmp_path):
    out = tmp_path / "rest.json"
    assert cli.main([str(kmeans_run), "--goal", "reach:0.4", "--planner", "rest", "--out", str(out)]) == 0
    for entry in json.loads(out.read_text())["seeds"]:
        assert "readout_r2" not in entry  # no model was fitted: the buffer has no latent codec
        assert entry["final"] == pytest.approx(entry["positions"][-1], abs=1e-6)

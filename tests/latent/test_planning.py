"""Planning in the latent space (`litl.latent.planning`, `litl.latent.model`, `python -m
litl.latent.control`): the shooting objective's gradient, MPC and LQR on systems whose answer is
known, the environment loop in 2D and 3D, and a trained run steered from the command line."""

import json

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import litl.envs
from litl.latent import control as cli
from litl.latent.dynamics import LinearDynamics, MLPDynamics
from litl.latent.model import LatentModel, fit_readout
from litl.latent.planning import (
    Goal,
    GoalError,
    ILQRSettings,
    LQRSettings,
    MPCSettings,
    augmented_problem,
    control,
    ilqr_step,
    mpc_step,
    plan_cost,
    true_plan_cost,
)
from litl.loop.run import run
from litl.sim.rollout import centroid
from tests.loop.tiny import tiny_config, tiny_robot

DT = 0.1


def integrator(r: int = 2, m: int = 2, dtype=jnp.float32) -> LatentModel:
    """z' = z + a (velocity commanded directly), read out as v = z: x moves by DT z'."""
    eye = jnp.eye(r, m, dtype=dtype)
    dynamics = LinearDynamics(A=jnp.eye(r, dtype=dtype), B=eye, c=jnp.zeros(r, dtype))
    return LatentModel(dynamics, jnp.eye(r, 1, dtype=dtype), jnp.zeros(1, dtype), DT)


def random_mlp(key, r: int = 3, m: int = 2, dtype=jnp.float64) -> LatentModel:
    k1, k2, k3, k4 = jax.random.split(key, 4)
    layers = (
        (0.5 * jax.random.normal(k1, (r + m, 8), dtype), 0.1 * jax.random.normal(k2, (8,), dtype)),
        (0.5 * jax.random.normal(k3, (8, r), dtype), jnp.zeros(r, dtype)),
    )
    dynamics = MLPDynamics(layers, jnp.zeros(r + m, dtype), jnp.ones(r + m, dtype), jnp.ones(r, dtype))
    return LatentModel(dynamics, jax.random.normal(k4, (r, 2), dtype), jnp.zeros(2, dtype), DT)


@pytest.mark.parametrize("goal", [Goal("reach", 0.3), Goal("walk", -1.0)])
def test_the_shooting_objectives_gradient_matches_float64_central_differences(goal):
    with jax.enable_x64(True):
        model = random_mlp(jax.random.key(0))
        logits = 0.5 * jax.random.normal(jax.random.key(1), (5, 2), jnp.float64)
        z, x = jnp.array([0.1, -0.2, 0.3]), jnp.array(0.05)
        settings = MPCSettings(horizon=5, action_cost=0.01)
        cost = lambda u: plan_cost(u, z, x, model, goal, settings)[0]
        grad = jax.grad(cost)(logits)
        eps = 1e-6
        numeric = np.zeros(logits.shape)
        for i in np.ndindex(logits.shape):
            step = jnp.zeros_like(logits).at[i].set(eps)
            numeric[i] = (cost(logits + step) - cost(logits - step)) / (2 * eps)
        chex.assert_trees_all_close(grad, jnp.asarray(numeric), rtol=1e-6, atol=1e-9)


def test_mpc_brings_an_integrator_to_its_target_and_stops_it_there():
    model, goal = integrator(), Goal("reach", 0.5)
    settings = MPCSettings(horizon=15, iterations=200, learning_rate=0.1, stop=1.0, action_cost=0.0)
    cost = lambda u: plan_cost(u, jnp.zeros(2), 0.0, model, goal, settings)[0]
    plan, before, after = jax.jit(lambda u: mpc_step(u, cost, settings))(jnp.zeros((15, 2)))
    # The running cost cannot vanish: the first steps are spent getting there.
    assert after < 0.15 * before
    _, (positions, latents) = plan_cost(plan, jnp.zeros(2), 0.0, model, goal, settings)
    assert abs(float(positions[-1]) - 0.5) < 0.02
    assert abs(float(latents[-1][0])) < 0.05  # its speed at the end (it peaks near 1)


@pytest.mark.parametrize("model", [integrator(), random_mlp(jax.random.key(3), r=2, dtype=jnp.float32)])
def test_ilqr_lowers_the_shooting_cost_it_shares_with_mpc(model):
    goal, settings = Goal("reach", 0.5), ILQRSettings(horizon=15, iterations=10, action_cost=0.0)
    start = jnp.zeros((15, 2))
    plan, before, after = jax.jit(
        lambda u: ilqr_step(u, jnp.zeros(2), jnp.asarray(0.0), model, goal, settings)
    )(start)
    cost = lambda u: plan_cost(u, jnp.zeros(2), 0.0, model, goal, settings)[0]
    chex.assert_trees_all_close((before, after), (cost(start), cost(plan)), rtol=1e-5)
    assert float(after) < float(before)


def test_ilqr_brings_an_integrator_to_its_target_and_stops_it_there_and_walks_either_way():
    model, settings = integrator(), ILQRSettings(horizon=15, iterations=20, action_cost=0.0)
    plan, before, after = ilqr_step(
        jnp.zeros((15, 2)), jnp.zeros(2), jnp.asarray(0.0), model, Goal("reach", 0.5), settings
    )
    assert after < 0.15 * before
    _, (positions, latents) = plan_cost(plan, jnp.zeros(2), 0.0, model, Goal("reach", 0.5), settings)
    assert abs(float(positions[-1]) - 0.5) < 0.02
    assert abs(float(latents[-1][0])) < 0.05
    for direction in (1.0, -1.0):
        goal = Goal("walk", direction)
        plan, _, _ = ilqr_step(jnp.zeros((15, 2)), jnp.zeros(2), jnp.asarray(0.0), model, goal, settings)
        _, (positions, _) = plan_cost(plan, jnp.zeros(2), 0.0, model, goal, settings)
        assert direction * float(positions[-1]) > 0.5  # near full speed (1 per step of 0.1) that way


def test_the_augmented_lqr_problem_moves_the_position_as_the_shooting_cost_does():
    model, goal = integrator(3, 2), Goal("reach", 0.4)
    model = model.replace(
        dynamics=LinearDynamics(
            A=0.9 * jnp.eye(3), B=jnp.array([[1.0, 0.0], [0.0, 1.0], [0.5, 0.5]]), c=jnp.array([0.1, 0, 0])
        ),
        readout=jnp.array([[1.0], [0.5], [0.0]]),
        offset=jnp.array([0.02]),
    )
    problem = augmented_problem(model, goal, jnp.zeros(3), LQRSettings())
    z, x, a = jnp.array([0.2, -0.1, 0.3]), 0.07, jnp.array([0.4, -0.6])
    s_next = problem.A @ jnp.concatenate([z, jnp.array([x])]) + problem.B @ a + problem.c
    z_next = model.step(z, a)
    chex.assert_trees_all_close(s_next[:3], z_next, rtol=1e-6)
    chex.assert_trees_all_close(s_next[3], x + DT * model.velocity(z_next)[0], rtol=1e-6)
    with pytest.raises(GoalError, match="reach goals only"):
        augmented_problem(model, Goal("walk", 1.0), jnp.zeros(3), LQRSettings())


def test_the_velocity_readout_recovers_a_linear_map_and_reports_its_fit():
    rng = np.random.default_rng(0)
    z = rng.normal(size=(50, 4))
    W, b = rng.normal(size=(4, 2)), np.array([0.3, -0.1])
    mask = np.arange(50) < 40  # rows past it hold garbage
    v = np.where(mask[:, None], z @ W + b, 99.0)
    W_fit, b_fit, r2 = fit_readout(jnp.asarray(z), jnp.asarray(v), jnp.asarray(mask), ridge=0.0)
    chex.assert_trees_all_close((W_fit, b_fit), (jnp.asarray(W), jnp.asarray(b)), atol=1e-4)
    assert np.all(np.asarray(r2) > 0.9999)


@pytest.mark.parametrize(
    "text, message",
    [
        ("run:1", "choose one of"),
        ("walk:0.5", r"\+1 or -1"),
        ("reach", "KIND:VALUE"),
        ("reach:nan", "finite"),
    ],
)
def test_bad_goals_are_refused_by_name(text, message):
    with pytest.raises(GoalError, match=message):
        Goal.parse(text)


def test_a_reach_target_outside_the_domain_is_refused_with_its_bounds():
    with pytest.raises(GoalError, match=r"outside the domain .* \(0, 1\)"):
        Goal("reach", 1.5).check((0.0, 1.0))


def _obs_model(env, env_params) -> LatentModel:
    """A model whose latent is the particle observation (centroid velocity first): a real
    environment's observation as the latent of an exact velocity readout."""
    obs, _ = env.reset(jax.random.key(0), env_params)
    r, m, d = obs.shape[0], env.num_actions, env.robot.dim
    dynamics = LinearDynamics(A=jnp.eye(r), B=0.01 * jnp.ones((r, m)), c=jnp.zeros(r))
    return LatentModel(dynamics, jnp.eye(r, d), jnp.zeros(d), env_params.hold * env.robot.config.dt)


@pytest.mark.parametrize(
    "robot, dx, steps", [("biped", 1 / 32, 3), pytest.param("quadruped", 1 / 16, 2, marks=pytest.mark.slow)]
)
@pytest.mark.parametrize(
    "settings",
    [MPCSettings(horizon=3, iterations=2), ILQRSettings(horizon=3, iterations=2), LQRSettings(horizon=3)],
)
def test_a_planner_runs_an_episode_in_the_environment_in_2d_and_3d(robot, dx, steps, settings):
    env, env_params = litl.envs.make(robot, hold=4, dx=dx)
    model = _obs_model(env, env_params)
    out = jax.jit(control, static_argnums=(0, 3, 4, 6))(
        env, env_params, model, Goal("reach", 0.3), settings, jax.random.key(0), steps
    )
    chex.assert_shape(out["positions"], (steps + 1,))
    chex.assert_shape(out["actions"], (steps, env.num_actions))
    assert np.all(np.isfinite(np.asarray(out["positions"])))
    assert np.all(np.abs(np.asarray(out["actions"])) <= 1)
    assert not np.any(np.asarray(out["nonfinite"]))


def test_the_oracle_plans_through_the_simulator_and_improves_its_own_plan():
    env, env_params = litl.envs.make("biped", hold=10, dx=1 / 32)
    _, state = env.reset(jax.random.key(0), env_params)
    settings = MPCSettings(horizon=4, iterations=5, learning_rate=1.0, action_cost=0.0, stop=0.0)
    goal = Goal("reach", float(centroid(env.robot.own(state.sim))[0]) + 0.1)
    cost = lambda u: true_plan_cost(u, env, env_params, state, goal, settings, jax.random.key(0))
    plan, before, after = jax.jit(lambda u: mpc_step(u, cost, settings))(jnp.zeros((3, env.num_actions)))
    assert np.isfinite(float(before)) and float(after) < float(before)  # it moved toward the goal
    assert np.any(np.asarray(plan) != 0)


def test_planners_steer_the_arms_tip_not_its_centroid():
    env, env_params = litl.envs.make("arm", hold=10, dx=1 / 32)
    tip = np.asarray(env.robot.layout.groups["tip"])
    _, state = env.reset(jax.random.key(0), env_params)
    start = float(env.robot.task_point(state.sim)[0])
    settings = MPCSettings(horizon=3, iterations=5, learning_rate=1.0, action_cost=0.0, stop=0.0)
    goal = Goal("reach", start - 0.03)
    out = jax.jit(control, static_argnums=(0, 3, 4, 6, 7))(
        env, env_params, _obs_model(env, env_params), goal, settings, jax.random.key(0), 3, True
    )
    particles, positions = np.asarray(out["particles"]), np.asarray(out["positions"])
    # the episode records the tip's x, which the centroid's is not once the arm bends
    np.testing.assert_allclose(positions[1:], particles[:, tip, 0].mean(axis=1), rtol=1e-6)
    assert np.max(np.abs(positions[1:] - particles[:, :, 0].mean(axis=1))) > 1e-3
    assert positions[-1] < start - 0.005  # the oracle bent the tip toward the target


def test_a_nonfinite_prediction_is_not_acted_on_and_is_named():
    env, env_params = litl.envs.make("biped", hold=4, dx=1 / 32)
    model = _obs_model(env, env_params)
    model = model.replace(dynamics=model.dynamics.replace(c=jnp.full(model.latent_size, jnp.nan)))
    out = control(
        env, env_params, model, Goal("walk", 1.0), MPCSettings(horizon=2, iterations=1), jax.random.key(0), 2
    )
    assert np.all(np.asarray(out["nonfinite"]))
    assert np.all(np.asarray(out["actions"]) == 0)
    assert np.all(np.isfinite(np.asarray(out["positions"])))


@pytest.fixture(scope="module")
def trained_run(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("trained")
    run(tiny_robot(), tiny_config(loop={"episodes": 2}), run_dir, progress=False)
    return run_dir


@pytest.mark.parametrize(
    "planner", ["latent_mpc", "latent_ilqr", "latent_lqr", "trained", "rest", "oracle_mpc"]
)
def test_a_trained_run_is_steered_from_the_command_line(trained_run, tmp_path, planner, capsys):
    out = tmp_path / "out.json"
    arguments = [str(trained_run), "--goal", "reach:0.6", "--planner", planner, "--out", str(out)]
    if planner in ("latent_mpc", "latent_ilqr", "oracle_mpc"):
        arguments += ["--set", "horizon=3", "--set", "iterations=2"]
    if planner == "latent_mpc":
        arguments += ["--animate"]
    assert cli.main(arguments) == 0
    summary = json.loads(out.read_text())
    assert [s["seed"] for s in summary["seeds"]] == [0, 1]
    for entry in summary["seeds"]:
        assert len(entry["positions"]) == summary["control_steps"] + 1 == 40 // 10 + 1
        assert entry["error"] == pytest.approx(abs(entry["final"] - 0.6))
    if planner == "latent_mpc":
        assert out.with_suffix(".gif").stat().st_size > 0
    if planner in ("latent_mpc", "oracle_mpc"):
        assert summary["settings"]["horizon"] == 3
        assert summary["model_steps_per_control_step"] == 3 * 3
    if planner == "latent_ilqr":  # 3 steps x (1 rollout + 2 iterations x (1 + 6 line-search rollouts))
        assert summary["model_steps_per_control_step"] == 3 * (1 + 2 * 7)
    if planner == "oracle_mpc":  # 3 plans of 3 control steps of 10 simulation steps
        assert summary["sim_steps_per_control_step"] == 3 * 3 * 10
    assert "seed 0: final" in capsys.readouterr().out


def test_an_episode_runs_longer_than_the_run_and_says_how_fast_it_ends(trained_run, tmp_path):
    out = tmp_path / "long.json"
    arguments = ["--goal", "reach:0.6", "--planner", "rest", "--control-steps", "7", "--out", str(out)]
    assert cli.main([str(trained_run), *arguments]) == 0
    summary = json.loads(out.read_text())
    assert summary["control_steps"] == 7
    for entry in summary["seeds"]:
        assert len(entry["positions"]) == 8
        speed = (entry["positions"][-1] - entry["positions"][-2]) / summary["control_dt"]
        # the positions are written rounded to 1e-6
        assert entry["final_speed"] == pytest.approx(speed, abs=2e-6 / summary["control_dt"])


def test_the_trained_reference_ends_where_the_run_recorded_its_distance(trained_run, tmp_path):
    out = tmp_path / "trained.json"
    cli.main([str(trained_run), "--goal", "walk:1", "--planner", "trained", "--out", str(out)])
    recorded = {r["seed"]: r["task_loss"] for r in json.loads((trained_run / "final.json").read_text())}
    for entry in json.loads(out.read_text())["seeds"]:  # the biped's task loss is minus its travel
        assert entry["displacement"] == pytest.approx(-recorded[entry["seed"]], abs=1e-4)


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--goal", "reach:9"], "outside the domain"),
        (["--goal", "walk:1", "--planner", "ilqr"], "choose one of"),
        (["--goal", "walk:1", "--set", "depth=3"], "KEY one of"),
        (["--goal", "walk:1", "--seeds", "7"], "the run has seeds"),
        (["--goal", "walk:1", "--control-steps", "0"], "a positive number of control steps"),
        (
            ["--goal", "walk:1", "--planner", "trained", "--control-steps", "8"],
            "replays the run's own rollout",
        ),
    ],
)
def test_bad_requests_are_refused_before_anything_is_written(
    trained_run, tmp_path, capsys, arguments, message
):
    out = tmp_path / "never.json"
    with pytest.raises(SystemExit) as stop:
        cli.main([str(trained_run), *arguments, "--out", str(out)])
    assert stop.value.code == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_a_run_without_a_latent_space_is_refused_naming_its_observer(tmp_path, capsys):
    run(
        tiny_robot(), tiny_config(observer={"kind": "kmeans"}, loop={"episodes": 1}), tmp_path, progress=False
    )
    with pytest.raises(SystemExit):
        cli.main([str(tmp_path), "--goal", "walk:1"])
    assert "observer (kmeans) has no latent space" in capsys.readouterr().err
    # The trained reference plans nothing: it replays any run's own controller.
    out = tmp_path / "trained.json"
    assert cli.main([str(tmp_path), "--goal", "walk:1", "--planner", "trained", "--out", str(out)]) == 0
    entries = json.loads(out.read_text())["seeds"]
    assert entries and all(np.isfinite(entry["displacement"]) for entry in entries)

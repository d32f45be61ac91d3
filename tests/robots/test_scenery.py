"""Worlds with a second body (`world=sand`, `world=water`, `world=push_box`; `litl.worlds`): the robot's
particles first and the bed's after them, each with its material; the task and the observers read
the robot's particles only; the robot's time step holds for the bed."""

import dataclasses
import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.app import build_robot, compose
from litl.config import SettingsError
from litl.sim import SimConfigError, check_time_step, make_rollout, make_step, rasterize
from litl.sim.fields import grid_velocity, mass_weighted_velocity
from litl.sim.materials import Fluid, Sand
from litl.worlds import put


@pytest.fixture(scope="module")
def sandy():
    return build_robot(compose(["world=sand", "+scale=smoke"]))


def test_the_bed_follows_the_robot_in_the_scene_with_its_own_material(sandy):
    flat = build_robot(compose(["+scale=smoke"]))
    scene = sandy.scene()
    own, bed = flat.layout.n_particles, sandy.scenery[0].n_particles
    assert sandy.n_particles == own and scene.state.x.shape == (own + bed, 2)
    assert sandy.config.materials == (
        flat.config.own_material,
        Sand(30.0),
    )
    np.testing.assert_array_equal(np.asarray(scene.body.material), [0] * own + [1] * bed)
    np.testing.assert_array_equal(np.asarray(scene.body.observed), [True] * own + [False] * bed)
    # The robot stands on the bed: lifted by its depth; the bed lies on the floor, 1.5x as dense.
    lift = np.asarray(scene.state.x[:own]) - np.asarray(flat.layout.positions)
    np.testing.assert_allclose(lift, np.broadcast_to([0.0, 0.04], lift.shape), atol=1e-6)
    assert float(scene.state.x[own:, 1].max()) < float(scene.state.x[:own, 1].min())
    np.testing.assert_allclose(np.asarray(scene.design.density[own:]), 1.5 * flat.material.density)
    # Co-design moves the robot's Young's modulus only; the bed's is fixed.
    stiff = sandy.design_space.to_design(sandy.design_space.uniform(28.0))
    np.testing.assert_allclose(np.asarray(stiff.youngs_modulus[:own]), 28.0)
    np.testing.assert_array_equal(
        np.asarray(stiff.youngs_modulus[own:]), np.asarray(scene.design.youngs_modulus[own:])
    )
    # Its stiffness is matched to the robot's time step (the same dt, a CFL within the limit).
    assert sandy.config.dt == flat.config.dt
    check_time_step(sandy.config, scene.body, sandy.design_space.to_design(sandy.design_space.uniform(30.0)))


def test_the_task_reads_the_robots_particles_only(sandy):
    scene = sandy.scene()
    own = sandy.n_particles
    moved = scene.state.replace(x=scene.state.x.at[:own, 0].add(0.01).at[own:, 0].add(0.3))
    total, _ = sandy.task_loss()(scene.state, moved)
    robot_only, _ = sandy.task_loss()(sandy.own(scene.state), sandy.own(moved))
    assert float(total) == pytest.approx(float(robot_only))
    assert float(total) == pytest.approx(-0.01, rel=1e-4)


def test_observers_see_the_robots_part_of_the_grid_unless_told_otherwise(sandy):
    scene = sandy.scene()
    kicked = scene.state.replace(v=jnp.full_like(scene.state.v, 0.2))
    grid = rasterize(scene.config, scene.body, kicked, scene.design)
    seen, everything = np.asarray(grid_velocity(grid)), np.asarray(grid.velocity)
    sand_only = (np.asarray(grid.mass) > 0) & (np.asarray(grid.observed_mass) == 0)
    assert sand_only.sum() > 20
    assert np.all(seen[sand_only] == 0)
    assert (np.abs(everything[sand_only]).max(axis=-1) > 0.1).sum() > 20  # (the walls' nodes hold 0)
    robot = np.asarray(grid.observed_mass) > 0
    np.testing.assert_array_equal(seen[robot], everything[robot])
    weighted = np.asarray(mass_weighted_velocity(1.0)(grid))
    np.testing.assert_allclose(
        weighted[robot], everything[robot] * np.asarray(grid.observed_mass)[robot][:, None], rtol=1e-6
    )
    # A step scatters the observed mass too; world.sand.observe=scene shows everything.
    _, stepped = jax.jit(make_step(scene.config, scene.body))(
        scene.state, jnp.zeros(sandy.n_actuators), scene.design
    )
    assert stepped.observed_mass is not None
    whole = build_robot(compose(["world=sand", "world.sand.observe=scene", "+scale=smoke"]))
    assert whole.scene().body.observed is None


def test_water_is_a_fluid_as_dense_as_the_robot():
    wet = build_robot(compose(["world=water", "+scale=smoke"]))
    assert wet.config.materials[1] == Fluid()
    np.testing.assert_allclose(
        np.asarray(wet.scene().design.density[wet.n_particles :]), wet.material.density
    )


def test_open_loop_legs_move_a_biped_otherwise_on_sand_and_in_water_than_on_the_floor():
    """Open-loop legs on sand and in water: the bed gives under the feet (it is displaced) and
    the rollout stays finite; the same legs on the floor carry the biped another distance. (These
    arbitrary sinusoids are not a walk: on the floor the biped shuffles 0.8 cells backwards;
    a walk needs a trained controller, which the loop's tests train.)"""
    distances = {}
    for world in ("flat", "sand", "water"):
        robot = build_robot(compose([f"world={world}", "+scale=smoke"]))
        scene = robot.scene()
        step = jax.jit(make_step(scene.config, scene.body))
        state = scene.state
        for k in range(300):
            phase = 0.05 * k + jnp.arange(robot.n_actuators) * jnp.pi / 2
            state, _ = step(state, jnp.sin(phase), scene.design)
        assert np.all(np.isfinite(np.asarray(state.x)))
        own = robot.own(state)
        distances[world] = float(jnp.mean(own.x[:, 0]) - jnp.mean(robot.own(scene.state).x[:, 0]))
        if world != "flat":
            assert len(robot.scenery) == 1, world  # the bed is there
            bed = np.asarray(state.x[robot.n_particles :]) - np.asarray(scene.state.x[robot.n_particles :])
            assert np.abs(bed).max() > 0.2 * scene.config.dx, world  # the feet pushed the bed
    # Another distance by a quarter of a cell at least, a displacement the grid resolves (measured
    # 2026-12-05 at dx 1/32: floor -0.77 cells, sand -0.17, water +1.28), not float32 rounding.
    cell = scene.config.dx
    assert abs(distances["sand"] - distances["flat"]) > 0.25 * cell
    assert abs(distances["water"] - distances["flat"]) > 0.25 * cell


def test_bad_beds_are_refused_before_anything_runs():
    with pytest.raises(SimConfigError, match="world.sand.depth=0.9.*no room under the ceiling"):
        build_robot(compose(["world=sand", "world.sand.depth=0.9", "+scale=smoke"]))
    with pytest.raises(SimConfigError, match="thinner than one grid cell"):
        build_robot(compose(["world=sand", "world.sand.depth=0.01", "+scale=smoke"]))
    with pytest.raises(SettingsError, match="world.sand.density"):
        compose(["world=sand", "world.sand.density=-1"])
    robot = build_robot(compose(["+scale=smoke"]))
    world = compose(["world=sand", "world.sand.depth=0.1"]).world
    sandy = put(robot, world)
    assert put(sandy, world) is sandy  # applied once
    # A robot placed into its bed is refused.
    with pytest.raises(SimConfigError, match="start in cells the scenery"):
        dataclasses.replace(sandy, layout=sandy.layout.translated(np.array([0.0, -0.06])))


def test_the_environment_observes_the_robot_on_sand(sandy):
    import litl.envs

    env, params = litl.envs.make(sandy, hold=4)
    obs, state = env.reset(jax.random.key(0), params)
    assert obs.shape == env.observation_space(params).shape
    obs, state, reward, done, info = env.step(jax.random.key(1), state, jnp.zeros(sandy.n_actuators), params)
    assert np.all(np.isfinite(np.asarray(obs))) and not bool(info["nonfinite"])


def test_a_3d_robot_gets_a_bed_over_the_whole_floor():
    robot = build_robot(compose(["robot=quadruped", "world=sand", "world.sand.depth=0.125", "+scale=smoke"]))
    bed = robot.scenery[0].positions
    config = robot.config
    inner = [size - 2 * config.boundary.thickness * config.dx - config.dx for size in config.domain_size]
    assert np.ptp(bed[:, 0]) >= inner[0] and np.ptp(bed[:, 2]) >= inner[2]  # the floor between the walls
    assert bed[:, 1].max() < robot.layout.bounds()[0][1]


def test_the_bed_weighs_its_stated_density_whatever_its_depth():
    for depth in ("0.04", "0.05"):
        robot = build_robot(
            compose(["world=sand", f"world.sand.depth={depth}", "world.sand.density=2.5", "+scale=smoke"])
        )
        bed, config = robot.scenery[0], robot.config
        wall = config.boundary.thickness * config.dx
        area = (config.domain_size[0] - 2 * wall) * float(depth)
        assert bed.volume * bed.n_particles == pytest.approx(area, rel=1e-9)
        # What the simulator is given: the bed's particles' masses (density x volume) sum to the
        # stated density (2.5 times the robot's) times the layer's area, to float32 rounding.
        scene, (start, end) = robot.scene(), robot.bodies["sand"]
        assert end - start == bed.n_particles
        density = np.asarray(scene.design.density[start:end], np.float64)
        mass = np.sum(density * np.asarray(scene.body.volume[start:end], np.float64))
        assert mass == pytest.approx(2.5 * robot.material.density * area, rel=1e-5)


def test_the_push_box_task_is_the_boxs_distance_to_its_target():
    """world=push_box: an elastic box after the robot's particles, on the floor ahead of it; the
    task reads the box (the squared distance of its centroid to a target `push` ahead) and not
    the robot."""
    robot = build_robot(compose(["world=push_box", "+scale=smoke"]))
    scene = robot.scene()
    own = robot.n_particles
    (box,) = robot.scenery
    assert robot.bodies == {"box": (own, own + box.n_particles)}
    start = np.asarray(scene.state.x[own:]).mean(axis=0)
    assert start[0] > float(scene.state.x[:own, 0].max())  # ahead of the robot
    (target,) = robot.task.push_targets.values()
    np.testing.assert_allclose(target, start + [0.1, 0.0], atol=1e-6)
    loss = robot.task_loss()
    at_start, parts = loss(scene.state, scene.state)
    assert float(at_start) == pytest.approx(0.01, rel=1e-4) and set(parts) == {"push_box"}
    walked = scene.state.replace(x=scene.state.x.at[:own, 0].add(0.05))
    assert float(loss(scene.state, walked)[0]) == pytest.approx(0.01, rel=1e-4)  # the robot alone: no
    pushed = scene.state.replace(x=scene.state.x.at[own:, 0].add(0.06))
    assert float(loss(scene.state, pushed)[0]) == pytest.approx(0.04**2, rel=1e-3)
    assert robot.config.dt == build_robot(compose(["+scale=smoke"])).config.dt


def test_a_robot_thrown_at_the_box_pushes_it_towards_its_target():
    """Contact between two bodies through the grid: the robot slides into the box and the box
    moves on along x (the task loss falls), every particle finite; short of the target, the
    loss's gradient with respect to the robot's start velocity is that of pushing harder
    (negative). (At 1.0 it pushes the box past the target, and the gradient turns positive.)"""
    robot = build_robot(compose(["world=push_box", "world.push_box.gap=0", "+scale=smoke"]))
    scene = robot.scene()
    own = robot.n_particles
    rollout = make_rollout(scene.config, scene.body, lambda p, s, g: jnp.zeros((robot.n_actuators,)), 150)

    @jax.jit
    def loss(speed):
        state = scene.state.replace(v=scene.state.v.at[:own, 0].set(speed))
        final, _ = rollout(None, scene.design, state)
        return robot.task_loss()(scene.state, final)[0], final

    (before, (after, state)) = float(loss(0.0)[0]), loss(0.6)
    assert np.all(np.isfinite(np.asarray(state.x)))
    moved = float(jnp.mean(state.x[own:, 0]) - jnp.mean(scene.state.x[own:, 0]))
    assert moved > scene.config.dx and float(after) < before
    gradient = jax.jit(jax.grad(lambda s: loss(s)[0]))(0.6)
    assert np.isfinite(float(gradient)) and float(gradient) < 0


def test_bad_boxes_are_refused_naming_the_keys():
    with pytest.raises(SimConfigError, match="world.push_box.box_size=0.6.*fit between the robot's front"):
        build_robot(compose(["world=push_box", "world.push_box.box_size=0.6", "+scale=smoke"]))
    with pytest.raises(SimConfigError, match="world.push_box.box_size=0.04.*at least two cells"):
        build_robot(compose(["world=push_box", "world.push_box.box_size=0.04", "+scale=smoke"]))
    with pytest.raises(SimConfigError, match="world.push_box.push=0.5: the target lies beyond the wall"):
        build_robot(compose(["world=push_box", "world.push_box.push=0.5", "+scale=smoke"]))
    with pytest.raises(SettingsError, match="world.push_box.push"):
        compose(["world=push_box", "world.push_box.push=0"])


def test_the_push_box_world_says_it_brings_its_own_task_and_records_it(tmp_path, capsys):
    """Nothing is replaced silently: a task asked for beside world=push_box is refused, and a run
    in it says on stderr that the task is the world's and records it in run.json."""
    from litl.config import SettingsError
    from litl.loop.run import run
    from tests.loop.tiny import tiny_config, tiny_robot

    with pytest.raises(
        SettingsError, match="task=locomotion with world=push_box: that world brings its own task"
    ):
        build_robot(compose(["world=push_box", "task=locomotion", "+scale=smoke"]))
    # No observer to learn: what is checked is the task the run says and records (seconds, not a
    # VAE's compilation).
    config = tiny_config(
        seeds=1,
        observer={"kind": "none"},
        world={"kind": "push_box", "push_box": {"gap": 1.0}},
        loop={"episodes": 1, "iterations": 1},
    )
    run(tiny_robot(), config, tmp_path, progress=False)
    assert "world=push_box brings its own task, in place of the robot's" in capsys.readouterr().err
    (term,) = json.loads((tmp_path / "run.json").read_text())["task"]
    assert term["term"] == "Push" and term["body"] == "box"
    # The flat world records the robot's own task.
    flat = tmp_path / "flat"
    flat_config = tiny_config(seeds=1, observer={"kind": "none"}, loop={"episodes": 1, "iterations": 1})
    run(tiny_robot(), flat_config, flat, progress=False)
    assert json.loads((flat / "run.json").read_text())["task"][0]["term"] == "Locomotion"

"""Worlds (`world=`, `litl.worlds`): registered parts with their own settings; terrain ahead of the
robot as colliders, recorded in run.json, acting on the robot, and refused when it cannot be built."""

import dataclasses
import json

import jax.numpy as jnp
import numpy as np
import pytest

from litl.app import build_robot, compose
from litl.config import Config, SettingsError, WorldConfig
from litl.sim import SimConfigError, make_rollout
from litl.sim.boundary import apply_boundary
from litl.worlds import put
from tests.loop.tiny import tiny_config, tiny_robot


def test_the_flat_world_is_the_empty_box():
    robot = tiny_robot()
    assert put(robot, WorldConfig()) is robot
    assert "world" not in Config().run_settings()  # flat runs record what runs before worlds did


@pytest.mark.parametrize("kind", ["slope", "steps", "bumps"])
def test_each_world_starts_past_the_robot_and_holds_the_floor_walls_nodes(kind):
    robot = build_robot(compose([f"world={kind}", "+scale=smoke"]))
    (collider,) = robot.config.boundary.colliders
    ground = collider.shape
    front = robot.layout.bounds()[1][0]
    dx = robot.config.dx
    assert ground.xs[1] == pytest.approx(front + 2 * dx)  # world.gap cells past its front
    assert max(ground.heights) > ground.heights[0]  # it rises ahead
    # Behind the terrain's start the collider holds exactly the floor wall's nodes.
    config = robot.config
    velocity = [jnp.zeros(config.grid_shape), -jnp.ones(config.grid_shape)]
    flat = dataclasses.replace(config, boundary=dataclasses.replace(config.boundary, colliders=()))
    behind = slice(0, int(ground.xs[1] / dx))
    np.testing.assert_array_equal(
        apply_boundary(config, velocity)[1][behind], apply_boundary(flat, velocity)[1][behind]
    )
    assert put(robot, compose([f"world={kind}"]).world) is robot  # applied once


@pytest.mark.parametrize("kind", ["slope", "steps", "bumps"])
@pytest.mark.parametrize("resolution", ["demo", "smoke"])
def test_each_worlds_terrain_holds_nodes_above_the_floor_wall_at_its_defaults(kind, resolution):
    """The terrain acts: ahead of the robot, a falling grid velocity is stopped at nodes above the
    floor wall's layer, where the flat box leaves it falling (the bumps once lay inside the wall)."""
    robot = build_robot(compose([f"world={kind}", f"robot.resolution={resolution}"]))
    config = robot.config
    flat = dataclasses.replace(config, boundary=dataclasses.replace(config.boundary, colliders=()))
    velocity = [jnp.zeros(config.grid_shape), -jnp.ones(config.grid_shape)]
    held = np.asarray(apply_boundary(config, velocity)[1]) != np.asarray(apply_boundary(flat, velocity)[1])
    wall = config.boundary.thickness
    assert not held[:, :wall].any()  # the floor wall's own nodes were already held
    rows = np.flatnonzero(held.any(axis=0))
    columns = np.flatnonzero(held.any(axis=1))
    assert len(rows) >= 1 and len(columns) >= 3, (rows, columns)
    front = robot.layout.bounds()[1][0]
    assert columns.min() * config.dx > front  # where the terrain stands: ahead of the robot


def test_bumps_lower_than_a_grid_cell_are_refused():
    with pytest.raises(SimConfigError, match="below one grid cell"):
        build_robot(compose(["world=bumps", "world.bumps.amplitude=0.01", "robot.resolution=demo"]))


def test_a_world_is_recorded_and_the_same_command_builds_the_same_terrain():
    config = compose(["world=bumps", "world.bumps.seed=3", "world.bumps.amplitude=0.04", "+scale=smoke"])
    recorded = config.run_settings()["world"]
    assert recorded["kind"] == "bumps" and set(recorded) == {"kind", "module", "bumps"}  # its section only
    assert recorded["bumps"]["seed"] == 3 and recorded["bumps"]["amplitude"] == 0.04
    plain = build_robot(compose(["+scale=smoke"]))
    again = put(plain, config.world).config.boundary.colliders
    assert build_robot(config).config.boundary.colliders == again
    other = put(plain, config.world.replace(bumps={"seed": 4})).config.boundary.colliders
    assert other != again


def test_steps_stop_a_block_sliding_into_them():
    """A robot pushed along the floor toward the stairs ends up behind the first riser; on the
    flat floor it slides on past it."""
    robot = tiny_robot()
    world = WorldConfig().replace(kind="steps", steps={"step_height": 0.1, "contact": "slip", "gap": 3.0})
    stairs = put(robot, world)
    riser = stairs.config.boundary.colliders[0].shape.xs[1]

    def front_after(r):
        scene = r.scene()
        state = scene.state.replace(v=jnp.zeros_like(scene.state.v).at[:, 0].set(2.0))
        final, _ = make_rollout(scene.config, scene.body, lambda p, s, g: jnp.zeros((r.n_actuators,)), 150)(
            None, scene.design, state
        )
        return float(jnp.max(final.x[:, 0]))

    assert front_after(stairs) < riser + robot.config.dx < front_after(robot)


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("world.slope.angle=0", "world.slope.angle=0.0: must lie in \\(0, 45\\] degrees"),
        ("world.slope.angle=60", "world.slope.angle=60.0: must lie in \\(0, 45\\] degrees"),
        ("world.steps.friction=-1", "world.steps.friction=-1.0: must be a number >= 0"),
        ("world.sand.friction_angle=95", "world.sand.friction_angle=95.0: must lie in \\(0, 90\\) degrees"),
        ("world.water.depth=0", "world.water.depth=0.0: must be"),
        ("world.sand.observe=all", "world.sand.observe"),
        ("world.kind=ice", "world.kind='ice': unknown world; choose one of \\['flat', 'slope'"),
        ("world.ice.depth=1", "ice"),
    ],
)
def test_bad_worlds_are_refused_naming_the_key(override, message):
    with pytest.raises(SettingsError, match=message):
        compose([override])


def test_terrain_that_leaves_no_room_is_refused():
    with pytest.raises(SimConfigError, match="above the room under the ceiling"):
        build_robot(compose(["world=steps", "world.steps.step_height=0.3", "+scale=smoke"]))
    with pytest.raises(SimConfigError, match="leaves no room for terrain"):
        build_robot(compose(["world=slope", "world.slope.gap=100", "+scale=smoke"]))


def test_a_run_in_a_world_records_it_and_resumes_only_in_it(tmp_path):
    from litl.loop.run import RunDirectoryError, run

    config = tiny_config(seeds=1, world={"kind": "slope", "slope": {"angle": 15.0}}, loop={"episodes": 1})
    run(tiny_robot(), config, tmp_path, progress=False)
    assert json.loads((tmp_path / "run.json").read_text())["config"]["world"]["slope"]["angle"] == 15.0
    with pytest.raises(RunDirectoryError, match="world.slope.angle"):
        run(tiny_robot(), config.replace(world={"slope": {"angle": 20.0}}), tmp_path, progress=False)

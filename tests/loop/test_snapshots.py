"""What the loop stores: the observed grid field, the robot's velocity and the actions by each snapshot."""

import jax
import jax.numpy as jnp
import numpy as np

import litl.robots
from litl.loop.algorithm import make_algorithm
from litl.sim import make_rollout
from tests.loop.tiny import tiny_config, tiny_robot


def test_buffer_holds_the_configured_field_and_the_particles_mean_velocity():
    robot = tiny_robot()
    algorithm = make_algorithm(robot, tiny_config(observer={"vae": {"field": "mass_weighted"}}).algorithm)
    state = algorithm.init(0)
    after, _ = jax.jit(algorithm.bootstrap)(state)
    count = int(after.buffer.count)
    assert count == 4  # 40 steps, a snapshot every 10
    scene = robot.scene()
    rollout = make_rollout(
        scene.config,
        scene.body,
        algorithm.policy,
        40,
        snapshot_stride=10,
        observe=lambda s: jnp.mean(s.v, axis=0),
        field=algorithm.field,
    )
    _, trajectory = jax.jit(rollout)(
        (state.controller, state.observer), robot.design_space.to_design(state.design), scene.state
    )
    np.testing.assert_allclose(after.buffer.fields[:count], trajectory.snapshots, atol=1e-6)
    np.testing.assert_allclose(
        after.buffer.velocities[:count], trajectory.observations[9::10], rtol=1e-3, atol=5e-5
    )  # float32 differences of centroids
    # Beside snapshot k, the mean actuation of steps 10k ... 10k + 9, which led to it.
    assert after.buffer.actions.shape == (12, robot.n_actuators)
    np.testing.assert_allclose(
        after.buffer.actions[:count],
        trajectory.actuation.reshape(4, 10, -1).mean(axis=1),
        rtol=1e-5,
        atol=1e-6,
    )
    np.testing.assert_array_equal(after.buffer.follows[:count], [False, True, True, True])
    # Mass-weighted: the light boundary nodes read less than momentum / mass would.
    velocity = make_algorithm(robot, tiny_config(observer={"vae": {"field": "velocity"}}).algorithm)
    plain, _ = jax.jit(velocity.bootstrap)(velocity.init(0))
    assert np.abs(after.buffer.fields[:count]).sum() < np.abs(plain.buffer.fields[:count]).sum()


def test_beside_each_snapshot_the_velocity_of_the_point_the_task_steers():
    arm = litl.robots.get("arm", dx=1 / 32)
    assert arm.task.point_group == "tip"
    algorithm = make_algorithm(arm, tiny_config().algorithm)
    state = algorithm.init(0)
    after, _ = jax.jit(algorithm.bootstrap)(state)
    count = int(after.buffer.count)
    scene = arm.scene()
    tip = jnp.asarray(arm.layout.groups["tip"])
    rollout = make_rollout(
        scene.config,
        scene.body,
        algorithm.policy,
        40,
        snapshot_stride=10,
        observe=lambda s: jnp.stack([jnp.mean(s.v, axis=0), jnp.mean(s.v[tip], axis=0)]),
        field=algorithm.field,
    )
    _, trajectory = jax.jit(rollout)(
        (state.controller, state.observer), arm.design_space.to_design(state.design), scene.state
    )
    robot_velocity, tip_velocity = trajectory.observations[9::10, 0], trajectory.observations[9::10, 1]
    np.testing.assert_allclose(after.buffer.velocities[:count], robot_velocity, rtol=1e-3, atol=5e-5)
    np.testing.assert_allclose(after.buffer.point_velocities[:count], tip_velocity, rtol=1e-3, atol=5e-5)
    # the tip swings faster than the pinned arm's centroid moves
    assert np.abs(tip_velocity).sum() > 1.5 * np.abs(robot_velocity).sum()
    # a walker's task steers its centroid: the two are the same
    walker = make_algorithm(tiny_robot(), tiny_config().algorithm)
    walked, _ = jax.jit(walker.bootstrap)(walker.init(0))
    np.testing.assert_array_equal(walked.buffer.point_velocities, walked.buffer.velocities)

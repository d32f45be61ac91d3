"""The registered robots: each builds inside its domain and simulates 200 steps."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import litl.robots
from litl.models.open_loop import SinusoidParams, sinusoid_policy
from litl.sim import make_rollout, raise_if_unhealthy, validate

PAPER_ROBOTS = ["arm", "biped", "bunny", "curved_quadruped", "elephant", "hexapod", "quadruped", "rhino"]


def test_names_lists_the_papers_robots():
    assert litl.robots.names() == PAPER_ROBOTS


def test_unknown_robot_name_says_which_exist():
    with pytest.raises(KeyError, match="unknown robot 'bipd'; choose one of .*'biped'"):
        litl.robots.get("bipd")


@pytest.mark.compute_bound
@pytest.mark.parametrize("name", PAPER_ROBOTS)
def test_robot_builds_inside_the_domain_and_simulates_200_steps(name):
    robot = litl.robots.get(name)
    layout, config = robot.layout, robot.config
    assert robot.dim == (3 if name in ("quadruped", "curved_quadruped", "hexapod") else 2)
    low, high = layout.bounds()
    assert np.all(low > config.boundary.thickness * config.dx)
    assert np.all(high < (np.asarray(config.grid_shape) - config.boundary.thickness) * config.dx)
    assert robot.n_actuators >= 4 and robot.task is not None and robot.description
    scene = robot.scene()
    validate(scene.config, scene.body, scene.design, scene.state)
    params = SinusoidParams(
        weights=jnp.asarray(np.random.default_rng(0).normal(0, 0.5, (robot.n_actuators, 4)), jnp.float32),
        bias=jnp.zeros(robot.n_actuators),
    )
    rollout = jax.jit(make_rollout(config, scene.body, sinusoid_policy(20.0, config.dt), 200))
    final, trajectory = rollout(params, scene.design, scene.state)
    raise_if_unhealthy(trajectory.health, 200)
    assert np.all(np.isfinite(np.asarray(final.x))) and np.all(np.isfinite(np.asarray(final.F)))
    moved = np.abs(np.asarray(final.x) - np.asarray(scene.state.x)).max()
    assert 0 < moved < 0.2
    total, components = robot.task_loss()(scene.state, final)
    assert np.isfinite(float(total)) and set(components) == {t.name for t in robot.task.terms}


def test_resolution_changes_particles_but_keeps_shape_and_cfl():
    fine, coarse = litl.robots.get("biped"), litl.robots.get("biped", dx=1 / 64)
    assert coarse.layout.n_particles < fine.layout.n_particles / 3
    assert coarse.config.grid_shape == (64, 64) and coarse.config.dt == 2 * fine.config.dt
    assert coarse.steps * coarse.config.dt == pytest.approx(fine.steps * fine.config.dt)
    # Same body: the area of torso and legs (to within the lattice's edge error) and bounding box.
    area = 0.24 * 0.08 + 2 * 0.06 * 0.12
    for robot in (fine, coarse):
        assert robot.layout.volume.sum() == pytest.approx(area, rel=0.06)
    size = lambda robot: np.subtract(*robot.layout.bounds()[::-1])
    np.testing.assert_allclose(size(coarse), size(fine), atol=1 / 64)
    # Both rest just above the floor wall (3 cells thick at either resolution).
    for robot in (fine, coarse):
        assert robot.layout.bounds()[0][1] == pytest.approx(4 * robot.config.dx)


def test_a_dx_that_does_not_divide_the_domain_is_refused():
    with pytest.raises(ValueError, match="whole cells"):
        litl.robots.get("biped", dx=0.03)
    for dx in (-1 / 64, 0, 0.3, float("nan")):
        with pytest.raises(ValueError, match="not a usable grid spacing.*at most 1/16"):
            litl.robots.get("biped", dx=dx)


def test_biped_has_four_design_regions_for_co_design():
    robot = litl.robots.get("biped", dx=1 / 64)
    assert robot.n_regions == 4
    values = jnp.asarray([5.0, 10.0, 20.0, 40.0])
    projected = robot.design_space.project(values)
    np.testing.assert_allclose(projected, [15.0, 15.0, 20.0, 30.0])
    design = robot.design_space.to_design(projected)
    np.testing.assert_allclose(design.youngs_modulus, np.asarray(projected)[robot.layout.region])


def test_arm_cannot_reach_its_target_by_bending_statically():
    """Full constant actuation of either side leaves the tip far from the target all episode."""
    robot = litl.robots.get("arm")
    scene = robot.scene()
    assert bool(scene.body.pinned.any()) and robot.config.gravity == (0.0, 0.0)
    tip = jnp.asarray(robot.layout.groups["tip"])
    target = np.asarray(robot.task.targets["tip"])
    rest = np.asarray(scene.state.x[tip].mean(0))
    sides = jnp.asarray([1.0, -1.0] * (robot.n_actuators // 2))
    rollout = jax.jit(
        make_rollout(
            robot.config,
            scene.body,
            lambda sign, s, g: sign * sides,
            robot.steps,
            observe=lambda s: s.x[tip].mean(0),
        )
    )
    for sign in (1.0, -1.0):
        _, trajectory = rollout(sign, scene.design, scene.state)
        path = np.asarray(trajectory.observations)
        closest = np.linalg.norm(path - target, axis=1).min()
        assert closest > 0.5 * np.linalg.norm(target - rest)


@pytest.mark.compute_bound
@pytest.mark.parametrize("name", ["quadruped", "curved_quadruped"])
def test_3d_quadrupeds_carry_their_torsos_without_actuation(name):
    """The torso's middle spans the legs: with too soft a body (E = 20, the 2D robots' material)
    it sagged to the floor within 0.2 s of landing; the walkers' own material keeps it up."""
    robot = litl.robots.get(name)
    scene = robot.scene()
    rest = np.asarray(scene.state.x)
    middle = np.abs(rest[:, 0] - rest[:, 0].mean()) < 0.04
    top = rest[middle, 1].max()
    underside = np.flatnonzero(middle & (rest[:, 1] > top - 0.1) & (rest[:, 1] < top - 0.05))
    assert underside.size > 0
    floor = robot.config.boundary.thickness * robot.config.dx
    rollout = jax.jit(
        make_rollout(
            robot.config,
            scene.body,
            lambda params, state, grid: jnp.zeros(robot.n_actuators),
            robot.steps,
            observe=lambda state: jnp.mean(state.x[underside, 1]),
        )
    )
    _, trajectory = rollout(None, scene.design, scene.state)
    raise_if_unhealthy(trajectory.health, robot.steps)
    height = np.asarray(trajectory.observations)[robot.steps // 5 :] - floor
    assert height.min() > 0.02, f"the torso's middle came down to {height.min():.3f} above the floor"

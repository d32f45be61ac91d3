"""Task losses (values and gradients through a rollout) and the Robot's checks."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.robots import (
    Box,
    Layout,
    LayoutError,
    Locomotion,
    Material,
    Part,
    Reach,
    Robot,
    Task,
    make_task_loss,
    place,
    sample_parts,
)
from litl.sim import Boundary, SimConfig, SimConfigError, SimState, make_rollout

CONFIG = SimConfig(grid_shape=(32, 32), dx=1 / 32, dt=3e-3, gravity=(0.0, -3.8), boundary=Boundary.box(2))


def small_layout():
    return sample_parts(
        [
            Part(Box((0.0, 0.1), (0.25, 0.0625)), groups="torso"),
            Part(Box((0.0, 0.0), (0.0625, 0.1)), actuator=0, region=1, groups="back_foot"),
            Part(Box((0.1875, 0.0), (0.0625, 0.1)), actuator=1, region=1, groups="front_foot"),
        ],
        CONFIG.dx,
    )


def small_robot(task=None, config=CONFIG, material=Material()):
    return Robot(
        "small",
        place(small_layout(), config, x=0.2),
        config,
        material=material,
        task=task or Task(Locomotion()),
        steps=50,
    )


def moved(state, shift):
    return state.replace(x=state.x + jnp.asarray(shift, state.x.dtype))


def test_locomotion_reach_and_weighted_sum_values():
    robot = small_robot()
    start = robot.initial_state()
    end = moved(start, [0.1, 0.02])
    end = end.replace(v=jnp.full_like(end.v, 0.5))
    foot = np.asarray(robot.layout.positions[robot.layout.groups["front_foot"]]).mean(0)
    target = tuple(foot + [0.3, 0.0])
    task = Task((Locomotion(weight=2.0), Reach("front_foot", target, weight=4.0)))
    total, parts = make_task_loss(task, robot.layout)(start, end)
    assert float(parts["distance"]) == pytest.approx(0.1, rel=1e-5)
    assert float(parts["reach_front_foot"]) == pytest.approx(0.2**2 + 0.02**2, rel=1e-4)
    assert float(total) == pytest.approx(-2 * 0.1 + 4 * (0.2**2 + 0.02**2), rel=1e-4)
    speed, parts = make_task_loss(Task(Locomotion(measure="velocity")), robot.layout)(start, end)
    assert float(speed) == pytest.approx(-0.5) and set(parts) == {"velocity"}
    left, _ = make_task_loss(Task(Locomotion(direction=-1.0)), robot.layout)(start, end)
    assert float(left) == pytest.approx(0.1, rel=1e-5)
    assert Task((Reach("torso", (0.5, 0.5)),)).targets == {"torso": (0.5, 0.5)}


def test_task_loss_gradient_through_a_rollout_is_finite_and_nonzero(x64):
    robot = small_robot(Task((Locomotion(), Reach("front_foot", (0.6, 0.3)))))
    scene = robot.scene(jnp.float64)
    rollout = make_rollout(robot.config, scene.body, lambda w, s, g: jnp.tanh(w), 40)
    loss = robot.task_loss()

    def objective(w, youngs):
        final, _ = rollout(w, robot.design_space.to_design(youngs), scene.state)
        return loss(scene.state, final)[0]

    grads = jax.jit(jax.grad(objective, argnums=(0, 1)))(
        jnp.asarray([0.5, -0.5]), robot.design_space.initial(jnp.float64)
    )
    for g in grads:
        assert np.all(np.isfinite(g)) and np.abs(g).sum() > 0


@pytest.mark.parametrize(
    "task, message",
    [
        (Task(Reach("hand", (0.5, 0.5))), "unknown particle group 'hand'; this robot has"),
        (Task(Reach("torso", (0.5, 0.5, 0.5))), "finite 2D point"),
        (Task(Locomotion(axis=2)), "axis 2 does not exist in 2D"),
        (Task(Locomotion(measure="speed")), "'distance' or 'velocity'"),
    ],
)
def test_bad_tasks_fail_when_the_robot_is_built(task, message):
    with pytest.raises(LayoutError, match=message):
        small_robot(task)


def test_bad_task_definitions_fail_early():
    with pytest.raises(LayoutError, match="distinct names"):
        Task((Locomotion(), Locomotion(weight=2.0)))
    with pytest.raises(LayoutError, match="positive weight"):
        Task(Locomotion(weight=0.0))
    with pytest.raises(LayoutError, match="at least one term"):
        Task(())


def test_a_robot_that_does_not_fit_the_grid_says_so():
    with pytest.raises(SimConfigError, match="does not fit the grid: .*Scale the robot down"):
        Robot("big", place(small_layout(), CONFIG, x=0.9), CONFIG)
    with pytest.raises(SimConfigError, match="does not fit"):
        Robot("sunk", small_layout(), CONFIG)  # not placed: the feet are inside the floor wall


def test_a_time_step_too_large_for_the_stiffest_design_is_refused():
    coarse_dt = SimConfig(grid_shape=(32, 32), dx=1 / 32, dt=2e-2, gravity=(0.0, -3.8))
    with pytest.raises(SimConfigError, match="time step dt=0.02 is too large.*Use dt <="):
        small_robot(config=coarse_dt)
    # E_max decides: the same dt passes with a softer upper bound.
    soft = Material(youngs_modulus=1.0, youngs_modulus_bounds=(0.8, 1.0), actuator_strength=0.15)
    small_robot(config=coarse_dt, material=soft)


def test_bad_materials_and_dimension_mismatch_fail_clearly():
    with pytest.raises(SimConfigError, match="E_min <= youngs_modulus <= E_max"):
        Material(youngs_modulus=50.0)
    with pytest.raises(SimConfigError, match="poisson_ratio"):
        Material(poisson_ratio=0.5)
    for stretch in (1.0, 0.0, float("nan"), None):
        with pytest.raises(SimConfigError, match="max_stretch must be a number > 1"):
            Material(max_stretch=stretch)
    config3 = SimConfig(grid_shape=(32, 32, 32), dx=1 / 32, dt=1e-3, gravity=(0, -1, 0))
    with pytest.raises(SimConfigError, match="2D but its grid is 3D"):
        Robot("flat", small_layout(), config3)


def test_design_maps_regions_to_particles_and_scene_matches_layout():
    robot = small_robot()
    assert robot.n_regions == 2
    design = robot.design_space.to_design(jnp.asarray([17.0, 21.0]))
    expected = np.where(robot.layout.region == 0, 17.0, 21.0)
    np.testing.assert_allclose(design.youngs_modulus, expected)
    assert design.actuator_strength.shape == (2,)
    scene = robot.scene()
    assert isinstance(scene.state, SimState)
    np.testing.assert_allclose(scene.state.x, robot.layout.positions, rtol=1e-6)


def test_layout_rejects_inconsistent_arrays():
    good = small_layout()
    with pytest.raises(LayoutError, match="numbered 0 ... R-1"):
        Layout(good.positions, good.volume, good.actuator, good.fiber, good.region + 1, good.pinned)
    with pytest.raises(LayoutError, match=r"actuators \[1\] have no particles"):
        Layout(
            good.positions, good.volume, np.minimum(good.actuator, 0), good.fiber, good.region, good.pinned
        )
    with pytest.raises(LayoutError, match="volume must have shape"):
        Layout(good.positions, good.volume[:-1], good.actuator, good.fiber, good.region, good.pinned)

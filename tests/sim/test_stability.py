"""The simulator stays finite in the regime it accepts (issue: stable optimization).

The trained gait below blew up the biped when dt allowed CFL 0.81 and actuators could crush the
softest design: a foot particle was crushed into the sticky floor (det F ~ 0.1), inverted, was
ejected and rang until it left the grid, and the gradient became NaN.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import litl.robots
from litl.models.open_loop import SinusoidParams, sinusoid_policy
from litl.robots import walker2d
from litl.robots.robot import Material, Robot
from litl.sim import SimConfigError, check_actuation, check_time_step, make_rollout
from litl.sim.safety import MAX_ACTIVE_STRAIN, MAX_CFL

# Reached by Adam (lr 0.01) after 95 iterations from small random weights (float32).
TRAINED_WEIGHTS = [
    [0.19603531062602997, -0.4919760525226593, -0.18927504122257233, 0.48716074228286743],
    [-0.5875970125198364, 0.021475479006767273, 0.5912810564041138, -0.01120031252503395],
    [-0.2647717297077179, -0.17738912999629974, 0.2687017619609833, 0.18579815328121185],
    [0.6922667026519775, -0.21626016497612, -0.7044523358345032, 0.22061960399150848],
]
TRAINED_BIAS = [0.5260289907455444, -0.8027851581573486, 0.7163695096969604, 0.04422627389431]


def _det(F):
    return F[:, 0, 0] * F[:, 1, 1] - F[:, 0, 1] * F[:, 1, 0]


@pytest.mark.parametrize("youngs_modulus", ["default", "softest"])
def test_trained_biped_gait_stays_finite_with_finite_gradient(youngs_modulus):
    robot = litl.robots.get("biped", dx=1 / 64)
    scene = robot.scene()
    if youngs_modulus == "softest":
        space = robot.design_space
        design = space.to_design(space.uniform(space.bounds[0]))
    else:
        design = scene.design
    params = SinusoidParams(jnp.asarray(TRAINED_WEIGHTS, jnp.float32), jnp.asarray(TRAINED_BIAS, jnp.float32))
    policy = sinusoid_policy(omega=30.0, dt=robot.config.dt)
    rollout = make_rollout(
        robot.config, scene.body, policy, robot.steps, observe=lambda state: jnp.min(_det(state.F))
    )
    task_loss = robot.task_loss()

    def loss(p):
        final, trajectory = rollout(p, design, scene.state)
        return task_loss(scene.state, final)[0], trajectory

    (value, trajectory), grad = jax.jit(jax.value_and_grad(loss, has_aux=True))(params)
    assert int(trajectory.health.first_nonfinite_step) == -1
    assert int(trajectory.health.first_escape_step) == -1
    assert np.isfinite(float(value))
    assert all(np.all(np.isfinite(np.asarray(g))) for g in jax.tree.leaves(grad))
    assert float(jnp.min(trajectory.observations)) > 0.05  # no particle crushed or inverted
    # The gait moves the robot (a useful gradient, not a frozen body).
    assert float(value) < -0.02


def test_catalog_time_step_keeps_a_margin_below_the_accepted_cfl():
    for name in ("biped", "arm", "quadruped"):
        robot = litl.robots.get(name)
        space = robot.design_space
        stiffest = space.to_design(space.uniform(space.bounds[1]))
        assert check_time_step(robot.config, robot.body(), stiffest) <= 0.65 < MAX_CFL


def test_the_published_walker_is_accepted():
    scene = walker2d.build()
    assert check_time_step(scene.config, scene.body, scene.design) <= MAX_CFL
    assert check_actuation(scene.body, scene.design) == pytest.approx(4 / 30)


def test_time_step_that_blew_up_the_biped_is_refused():
    robot = litl.robots.get("biped", dx=1 / 64)
    import dataclasses

    config = dataclasses.replace(robot.config, dt=0.128 * robot.config.dx)  # CFL 0.80
    stiffest = robot.design_space.to_design(robot.design_space.uniform(30.0))
    with pytest.raises(SimConfigError, match="time step dt=.*too large"):
        check_time_step(config, robot.body(), stiffest)


def test_actuators_that_crush_the_softest_design_are_refused():
    robot = litl.robots.get("biped", dx=1 / 64)
    crushing = Material(youngs_modulus=20.0, youngs_modulus_bounds=(5.0, 30.0), actuator_strength=4.0)
    with pytest.raises(
        SimConfigError,
        match=r"actuators are too strong.*active strain of 0\.667.*"
        r"lambda \+ 2 mu >= 20",
    ):
        Robot("biped", robot.layout, robot.config, material=crushing, task=robot.task)
    assert check_actuation(robot.body(), robot.design_space.to_design()) <= MAX_ACTIVE_STRAIN

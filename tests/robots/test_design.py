"""The design space: φ's bounds, initial value and projection, its map to the simulator, and the
time step that follows the stiffest allowed material."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import litl.robots
from litl.robots import Material
from litl.robots.design import TARGET_CFL
from litl.sim import check_time_step
from litl.sim.safety import wave_speed


def test_the_design_space_holds_bounds_initial_value_projection_and_map():
    robot = litl.robots.get("biped", dx=1 / 32)
    space = robot.design_space
    assert space.bounds == (15.0, 30.0) and space.n_regions == 4
    np.testing.assert_array_equal(space.initial(), [20.0] * 4)
    np.testing.assert_array_equal(
        space.project(jnp.asarray([1.0, 16.0, 29.0, 99.0])), [15.0, 16.0, 29.0, 30.0]
    )
    # The map to per-particle parameters is differentiable in φ: d(sum E)/dφ_r = particles of r.
    grad = jax.grad(lambda phi: space.to_design(phi).youngs_modulus.sum())(space.initial())
    np.testing.assert_array_equal(grad, np.bincount(robot.layout.region, minlength=4))


@pytest.mark.parametrize(
    "material",
    [
        Material(),
        Material(actuator_strength=1.5),
        Material(youngs_modulus=40.0, youngs_modulus_bounds=(20.0, 80.0)),
        Material(
            youngs_modulus=3.0,
            youngs_modulus_bounds=(2.0, 4.0),
            density=0.5,
            actuator_strength=0.3,
            poisson_ratio=0.4,
        ),
    ],
)
def test_the_time_step_puts_the_stiffest_allowed_design_just_below_the_target_cfl(material):
    dx = 1 / 64
    dt = material.time_step(dx)
    robot = litl.robots.get("biped", dx=dx).with_material(material)
    space = robot.design_space
    stiffest = space.to_design(space.uniform(space.bounds[1]))
    cfl = check_time_step(robot.config, robot.body(), stiffest)
    assert robot.config.dt == dt and 0.9 * TARGET_CFL < cfl <= TARGET_CFL
    assert cfl == pytest.approx(wave_speed(robot.body(), stiffest) * dt / dx)
    assert abs(robot.steps * dt - 1.0) <= dt / 2  # the episode lasts 1 s


def test_the_catalog_materials_give_a_tenth_of_dx():
    """The rule reproduces the time step the robots were tuned at (and the reference runs)."""
    for name in ("biped", "arm"):
        robot = litl.robots.get(name, dx=1 / 64)
        assert robot.config.dt == 0.1 * (1 / 64) and robot.steps == 640


def test_a_stiffer_material_shortens_the_time_step_and_keeps_the_duration():
    biped = litl.robots.get("biped", dx=1 / 32)
    stiff = biped.with_material(Material(youngs_modulus=30.0, youngs_modulus_bounds=(15.0, 60.0)))
    assert stiff.config.dt < biped.config.dt
    assert abs(stiff.steps * stiff.config.dt - biped.steps * biped.config.dt) <= stiff.config.dt / 2
    np.testing.assert_array_equal(stiff.design_space.initial(), [30.0] * 4)

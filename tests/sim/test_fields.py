"""What an observer reads of the grid: velocity, or velocity weighted by node mass."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.sim import make_rollout, make_step, rasterize
from litl.sim.fields import full_cell_mass, grid_velocity, mass_weighted_velocity
from tests.sim.scenes import block, sine_params, sine_policy


def test_mass_weighted_field_is_the_velocity_inside_and_fades_at_the_boundary(x64):
    config, body, design, state = block(2, n_grid=24, lower=0.3, size=0.25, dtype=jnp.float64, gravity=0.0)
    state = state.replace(v=jnp.broadcast_to(jnp.asarray([0.5, -0.2]), state.v.shape))
    reference = full_cell_mass(config, body, design)
    assert reference == pytest.approx(1.0 * config.dx**2)  # density 1
    grid = rasterize(config, body, state, design)
    field = np.asarray(mass_weighted_velocity(reference)(grid))
    mass = np.asarray(grid.mass)
    full = mass > 0.99 * reference
    partial = (mass > 0) & (mass < 0.5 * reference)
    assert full.sum() >= 16 and partial.sum() >= 16
    # A uniform translation: full nodes read the velocity itself, light ones a fraction of it.
    np.testing.assert_allclose(field[full], np.broadcast_to([0.5, -0.2], field[full].shape), rtol=0.01)
    assert np.all(np.abs(field[partial]) < 0.5 * np.abs(np.asarray([0.5, -0.2])) + 1e-12)
    # The field sums to the body's momentum in units of the reference mass.
    momentum = np.sum(np.asarray(design.density * body.volume)[:, None] * np.asarray(state.v), 0)
    np.testing.assert_allclose(field.sum((0, 1)) * reference, momentum, rtol=1e-10)
    np.testing.assert_array_equal(grid_velocity(grid), grid.velocity)


def test_rollout_records_and_feeds_the_chosen_field(x64):
    config, body, design, state = block(2, n_grid=24, lower=0.3, size=0.25, dtype=jnp.float64)
    params = sine_params(body.n_actuators, jnp.float64)
    field = mass_weighted_velocity(full_cell_mass(config, body, design))

    def policy(p, s, grid_field):  # reads the field it is given
        return sine_policy(p, s, grid_field) * (1 + 0.5 * jnp.tanh(10 * jnp.sum(grid_field)))

    _, trajectory = jax.jit(make_rollout(config, body, policy, 10, snapshot_stride=5, field=field))(
        params, design, state
    )
    step = jax.jit(make_step(config, body))
    observed = field(rasterize(config, body, state, design))
    s = state
    for index in range(10):
        s, grid = step(s, policy(params, s, observed), design)
        observed = field(grid)
        if (index + 1) % 5 == 0:
            np.testing.assert_allclose(trajectory.snapshots[(index + 1) // 5 - 1], observed, atol=1e-12)
    np.testing.assert_allclose(trajectory.observations[-1], jnp.mean(s.x, 0), atol=1e-12)


def test_reference_mass_must_be_positive():
    with pytest.raises(ValueError, match="reference_mass must be positive"):
        mass_weighted_velocity(0.0)

"""Every bad setting a user can give fails early with a message that says what to change."""

import jax.numpy as jnp
import pytest

from litl.robots.primitives import sample_box
from litl.sim import (
    Boundary,
    SimConfig,
    SimConfigError,
    SimulationError,
    Wall,
    check_time_step,
    make_rollout,
    raise_if_unhealthy,
    simulate,
    validate,
)
from tests.sim.scenes import block

idle = lambda params, state, grid_velocity: jnp.zeros(2)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(grid_shape=(64,)), "2 or 3 entries"),
        (dict(grid_shape=(64, 0)), "integer >= 8"),
        (dict(grid_shape=(64, 64.0)), "integer >= 8"),
        (dict(dx=0.0), "dx must be a positive"),
        (dict(dx=-1.0), "dx must be a positive"),
        (dict(dt=0.0), "dt must be a positive"),
        (dict(dt=float("nan")), "dt must be a positive"),
        (dict(gravity=(0.0, -9.8, 0.0)), "2 entries"),
        (dict(constitutive_model="neo_hookean"), r"SimConfig\(constitutive_model=...\) is gone.*Elastic"),
        (dict(max_stretch=3.0), r"SimConfig\(max_stretch=...\) is gone.*materials=\(Elastic"),
        (dict(materials=()), "one or more litl.sim.materials models"),
        (dict(boundary=Boundary.box(3)), "needs 4 walls"),
        (dict(boundary=Boundary.box(2, thickness=40)), "leaves no room"),
        (dict(boundary=Boundary.box(2, pinned_boxes=[((0.5, 0.5), (0.1, 0.1))])), "lo <= hi"),
    ],
)
def test_bad_config(kwargs, message):
    base = dict(grid_shape=(64, 64), dx=1 / 64, dt=1e-4, gravity=(0.0, -9.8))
    with pytest.raises(SimConfigError, match=message):
        SimConfig(**{**base, **kwargs})


def test_bad_walls():
    with pytest.raises(SimConfigError, match="unknown wall kind"):
        Wall("bouncy")
    with pytest.raises(SimConfigError, match="friction must be"):
        Wall("friction", -0.1)
    with pytest.raises(SimConfigError, match="ignores friction"):
        Wall("sticky", 0.5)
    with pytest.raises(SimConfigError, match="thickness"):
        Boundary.box(2, thickness=0)


def test_the_old_name_of_the_simulators_error_still_catches_it():
    from litl.config import SettingsError
    from litl.errors import UserError
    from litl.sim import ConfigError

    assert ConfigError is SimConfigError and issubclass(SimConfigError, UserError)
    assert not issubclass(SimConfigError, SettingsError)


def test_time_step_too_large_for_stiffness():
    config, body, design, state = block(2, youngs=300.0)
    check_time_step(config, body, design)  # the scene's own dt is fine
    stiff = design.replace(youngs_modulus=design.youngs_modulus * 100)
    with pytest.raises(SimConfigError, match=r"dt=.* is too large.*Use dt <= "):
        check_time_step(config, body, stiff)
    with pytest.raises(SimConfigError, match="too large"):
        simulate(config, body, stiff, state, idle, None, 10)


def test_validate_rejects_inconsistent_inputs():
    config, body, design, state = block(2)
    validate(config, body, design, state)
    n = body.n_particles
    bad = [
        (dict(state=state.replace(x=state.x[:, :1])), "state.x must have shape"),
        (dict(state=state.replace(v=state.v[:-1])), "state.v must have shape"),
        (dict(body=body.replace(volume=body.volume[:-1])), "body.volume must have shape"),
        (dict(body=body.replace(actuator=body.actuator.at[0].set(7))), "actuator ids"),
        (dict(body=body.replace(fiber=body.fiber * 2)), "unit vector"),
        (dict(design=design.replace(actuator_strength=jnp.ones(5))), "one entry per actuator"),
        (dict(design=design.replace(youngs_modulus=-design.youngs_modulus)), "youngs_modulus"),
        (dict(design=design.replace(density=jnp.zeros(n))), "density"),
        (dict(design=design.replace(poisson_ratio=jnp.full(n, 0.5))), "poisson_ratio"),
        (dict(state=state.replace(x=state.x.at[0, 0].set(jnp.nan))), "NaN"),
        (dict(state=state.replace(x=state.x + 2.0)), "outside the grid"),
    ]
    for change, message in bad:
        args = {**dict(config=config, body=body, design=design, state=state), **change}
        with pytest.raises(SimConfigError, match=message):
            validate(**args)


def test_box_sampling_rejects_bad_sizes():
    with pytest.raises(ValueError, match="positive"):
        sample_box([0, 0], [0.1, -0.1], 0.01)
    with pytest.raises(ValueError, match="thinner than one grid cell"):
        sample_box([0, 0], [0.1, 0.001], 0.01)


def test_rollout_rejects_bad_lengths():
    config, body, design, state = block(2)
    with pytest.raises(ValueError, match="steps must be a positive integer"):
        make_rollout(config, body, idle, 0)
    with pytest.raises(ValueError, match="snapshot_stride"):
        make_rollout(config, body, idle, 10, snapshot_stride=11)


def test_particles_leaving_the_grid_are_reported():
    open_box = Boundary.box(2, floor="open", sides="open")
    config, body, design, state = block(2, n_grid=24, boundary=open_box, gravity=-50.0)
    with pytest.raises(SimulationError, match=r"particles left the grid at step \d+ of 400"):
        simulate(config, body, design, state, idle, None, 400)


def test_blow_up_is_reported_with_first_bad_step():
    config, body, design, state = block(2, n_grid=24)
    # Bypass the time-step check on purpose (as a jitted optimization loop would).
    config = SimConfig(config.grid_shape, config.dx, config.dt * 6, config.gravity)
    _, trajectory = make_rollout(config, body, idle, 300)(
        None, design.replace(youngs_modulus=design.youngs_modulus * 10), state
    )
    step = int(trajectory.health.first_nonfinite_step)
    assert 0 <= step < 300
    with pytest.raises(SimulationError, match=f"non-finite values .* at step {step}"):
        raise_if_unhealthy(trajectory.health)


def test_batched_health_names_the_failing_entry():
    from litl.sim import Health

    health = Health(first_nonfinite_step=jnp.array([-1, 12]), first_escape_step=jnp.array([-1, -1]))
    with pytest.raises(SimulationError, match=r"step 12 \(batch entry 1\)"):
        raise_if_unhealthy(health)
    raise_if_unhealthy(Health(jnp.array([-1, -1]), jnp.array([-1, -1])))

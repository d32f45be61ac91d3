"""Placed actuators (`Design.actuator_weights`): each particle takes a weighted share of every
actuator's drive, along that actuator's fiber; the weights are differentiable, so co-design can
move the muscles."""

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.sim import SimConfigError, make_rollout, make_step, simulate
from tests.sim.scenes import block


def one_hot(body, dtype):
    return (np.asarray(body.actuator)[:, None] == np.arange(body.n_actuators)).astype(dtype)


def test_one_hot_weights_are_the_bodys_own_actuators():
    """Weights equal to each particle's own actuator move the block as `Body.actuator` does; the
    step compiles a different program, so they agree to float32 rounding."""
    config, body, design, state = block(2, n_grid=24, gravity=-9.8)
    actuation = jnp.asarray([1.0, -0.5], state.x.dtype)
    own = make_step(config, body)(state, actuation, design)[0]
    placed = design.replace(actuator_weights=jnp.asarray(one_hot(body, np.float32)))
    weighted = make_step(config, body)(state, actuation, placed)[0]
    chex.assert_trees_all_close(
        (own.x, own.v, own.C), (weighted.x, weighted.v, weighted.C), rtol=1e-5, atol=1e-6
    )


def test_where_the_muscles_are_changes_the_motion_and_none_leaves_it_passive():
    """The same actuation from muscles in the block's upper half instead of its lower one moves
    it otherwise; weights of zero leave it as passive as no actuation does."""
    config, body, design, state = block(2, n_grid=24, gravity=0.0)
    actuation = jnp.asarray([1.0, 1.0], state.x.dtype)
    rollout = jax.jit(make_rollout(config, body, lambda params, sim, grid: actuation, 60))
    x = np.asarray(state.x)
    upper = (x[:, 1] >= np.median(x[:, 1])).astype(np.float32)
    weights_upper = np.stack(
        [upper * (x[:, 0] < np.median(x[:, 0])), upper * (x[:, 0] >= np.median(x[:, 0]))], 1
    )
    lower_final, _ = rollout(
        None, design.replace(actuator_weights=jnp.asarray(one_hot(body, np.float32))), state
    )
    upper_final, _ = rollout(None, design.replace(actuator_weights=jnp.asarray(weights_upper)), state)
    moved = float(jnp.abs(upper_final.x - lower_final.x).max())
    assert moved > 1e-3, moved
    passive = jax.jit(make_rollout(config, body, lambda params, sim, grid: 0.0 * actuation, 60))
    still, _ = passive(None, design, state)
    unplaced, _ = rollout(None, design.replace(actuator_weights=jnp.zeros((len(x), 2), jnp.float32)), state)
    chex.assert_trees_all_close(unplaced.x, still.x, rtol=1e-6, atol=1e-7)


def test_the_gradient_through_the_placement_matches_central_differences_in_float64():
    """d(final height of the block's centre) / d(placement logits), through a 40-step rollout,
    against central differences in float64 along three random directions."""
    with jax.enable_x64(True):
        config, body, design, state = block(2, n_grid=24, gravity=-9.8, dtype=jnp.float64)
        n, m = body.n_particles, body.n_actuators
        actuation = jnp.asarray([1.0, -1.0], jnp.float64)
        rollout = make_rollout(config, body, lambda params, sim, grid: actuation, 40)
        rng = np.random.default_rng(0)
        logits = jnp.asarray(rng.normal(size=(n, m + 1)))  # a passive channel last

        def height(logits):
            weights = jax.nn.softmax(logits, axis=-1)[:, :m]
            final, _ = rollout(None, design.replace(actuator_weights=weights), state)
            return jnp.mean(final.x[:, 1]) + 0.3 * jnp.mean(final.x[:, 0])

        grad = jax.jit(jax.grad(height))(logits)
        assert np.all(np.isfinite(np.asarray(grad))) and float(jnp.abs(grad).max()) > 0
        value = jax.jit(height)
        eps = 1e-5
        for _ in range(3):
            direction = jnp.asarray(rng.normal(size=logits.shape))
            numeric = (value(logits + eps * direction) - value(logits - eps * direction)) / (2 * eps)
            np.testing.assert_allclose(
                float(jnp.vdot(grad, direction)), float(numeric), rtol=1e-5, atol=1e-10
            )


@pytest.mark.parametrize(
    "weights, message",
    [
        (lambda n, m: np.zeros((n, m + 1)), r"shape \(n_particles, n_actuators\)"),
        (lambda n, m: -np.ones((n, m)) / m, "must be finite, >= 0"),
        (lambda n, m: np.ones((n, m)), "summing to at most 1"),
    ],
)
def test_bad_placements_are_refused_before_anything_runs(weights, message):
    config, body, design, state = block(2, n_grid=24)
    bad = design.replace(
        actuator_weights=jnp.asarray(weights(body.n_particles, body.n_actuators), jnp.float32)
    )
    with pytest.raises(SimConfigError, match=message):
        simulate(config, body, bad, state, lambda params, sim, grid: jnp.zeros(2), None, 5)

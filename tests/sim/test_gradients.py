"""Gradients through rollouts against float64 central differences, and their finiteness."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.sim import make_rollout, raise_if_unhealthy

from tests.sim.scenes import block, sine_params, sine_policy


def _directional_check(f, x, seed, eps=1e-6, rtol=1e-5):
    """Compare <grad f(x), u> with a central difference of f along a random direction u."""
    leaves, treedef = jax.tree.flatten(x)
    rng = np.random.default_rng(seed)
    u = jax.tree.unflatten(treedef, [jnp.asarray(rng.normal(size=np.shape(l))) for l in leaves])
    grad = jax.jit(jax.grad(f))(x)
    analytic = sum(jnp.vdot(g, d) for g, d in zip(jax.tree.leaves(grad), jax.tree.leaves(u)))
    shifted = lambda s: jax.tree.map(lambda a, d: a + s * eps * d, x, u)
    numeric = (f(shifted(1.0)) - f(shifted(-1.0))) / (2 * eps)
    assert np.isfinite(float(analytic))
    np.testing.assert_allclose(float(analytic), float(numeric), rtol=rtol, atol=1e-10)


def _scene(dim, material):
    config, body, design, state = block(dim, n_grid=16, lower=0.3, size=0.25, youngs=300.0,
                                        material=material, dtype=jnp.float64)
    rollout = jax.jit(make_rollout(config, body, sine_policy, 40))

    def loss(params, design, state):
        final, trajectory = rollout(params, design, state)
        # Mix position, velocity and deformation so every part of the state matters.
        return (jnp.mean(final.x[:, 0]) + 0.1 * jnp.mean(final.v ** 2)
                + jnp.mean(final.F[:, 0, 1]) + jnp.sum(trajectory.observations[:, 1]) / 40)

    return loss, sine_params(body.n_actuators, jnp.float64), design, state


CASES = [(2, "fixed_corotated"), (2, "neo_hookean"), (3, "fixed_corotated"), (3, "neo_hookean")]


@pytest.mark.parametrize("dim,material", CASES)
def test_gradient_wrt_policy_parameters(dim, material, x64):
    loss, params, design, state = _scene(dim, material)
    _directional_check(lambda p: loss(p, design, state), params, seed=0)


@pytest.mark.parametrize("dim,material", CASES)
def test_gradient_wrt_per_particle_youngs_modulus(dim, material, x64):
    loss, params, design, state = _scene(dim, material)
    # Relative perturbation of E per particle (E ~ 300), plus Poisson ratio and density.
    f = lambda log_e: loss(params, design.replace(youngs_modulus=design.youngs_modulus *
                                                  jnp.exp(log_e)), state)
    _directional_check(f, jnp.zeros_like(design.youngs_modulus), seed=1)
    f_rest = lambda d: loss(params, design.replace(poisson_ratio=design.poisson_ratio + 0.01 * d[0],
                                                   density=design.density * (1 + 0.01 * d[1])), state)
    _directional_check(f_rest, jnp.zeros((2,) + design.density.shape), seed=2)


@pytest.mark.parametrize("dim,material", CASES)
def test_gradient_wrt_initial_velocity(dim, material, x64):
    loss, params, design, state = _scene(dim, material)
    f = lambda v: loss(params, design, state.replace(v=v))
    _directional_check(f, state.v + 0.1, seed=3)


@pytest.mark.parametrize("dim", [2, 3])
def test_no_nan_gradient_at_rest(dim, x64):
    # F = I exactly, v = 0, no actuation: the SVD's derivative would be NaN here.
    config, body, design, state = block(dim, n_grid=16, lower=0.3, size=0.25, gravity=0.0,
                                        dtype=jnp.float64)
    rollout = make_rollout(config, body, lambda p, s, g: p, 3)
    loss = lambda p, e: jnp.sum(rollout(p, design.replace(youngs_modulus=e), state)[0].x ** 2)
    grads = jax.grad(loss, argnums=(0, 1))(jnp.zeros(2), design.youngs_modulus)
    assert all(np.all(np.isfinite(g)) for g in grads)


def test_no_nan_gradient_over_1000_steps():
    config, body, design, state = block(2, n_grid=24, lower=0.3, size=0.25, youngs=300.0)
    rollout = make_rollout(config, body, sine_policy, 1000)

    def loss(params, youngs):
        final, trajectory = rollout(params, design.replace(youngs_modulus=youngs), state)
        return -jnp.mean(final.x[:, 0]), trajectory.health

    (value, health), grads = jax.jit(jax.value_and_grad(loss, argnums=(0, 1), has_aux=True))(
        sine_params(body.n_actuators), design.youngs_modulus)
    raise_if_unhealthy(health)
    assert np.isfinite(float(value))
    assert all(np.all(np.isfinite(g)) for g in jax.tree.leaves(grads))
    assert float(jnp.abs(grads[1]).max()) > 0

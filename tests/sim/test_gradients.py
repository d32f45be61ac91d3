"""Gradients through rollouts against float64 central differences, and their finiteness."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.sim import make_rollout, raise_if_unhealthy
from tests.sim.scenes import block, sine_params, sine_policy

# Physics, gradients and determinism: worth running on a GPU (`pytest -m gpu`).
pytestmark = pytest.mark.gpu


def _directional_check(f, grad_f, x, direction, eps=1e-6, rtol=1e-5):
    """Compare <grad f(x), u> with a central difference of f along the direction u."""
    analytic = sum(
        jnp.vdot(g, d) for g, d in zip(jax.tree.leaves(grad_f(x)), jax.tree.leaves(direction), strict=True)
    )
    shifted = lambda s: jax.tree.map(lambda a, d: a + s * eps * d, x, direction)
    numeric = (f(shifted(1.0)) - f(shifted(-1.0))) / (2 * eps)
    assert np.isfinite(float(analytic)) and abs(float(numeric)) > 1e-8
    np.testing.assert_allclose(float(analytic), float(numeric), rtol=rtol, atol=1e-10)


CASES = [(2, "fixed_corotated"), (2, "neo_hookean"), (3, "fixed_corotated"), (3, "neo_hookean")]


@pytest.mark.parametrize("dim,model", CASES)
def test_gradients_match_central_differences(dim, model, x64):
    """d loss / d (policy parameters, per-particle E, Poisson ratio, density, initial velocity)."""
    config, body, design, state = block(
        dim, n_grid=16, lower=0.3, size=0.25, youngs=300.0, constitutive_model=model, dtype=jnp.float64
    )
    rollout = make_rollout(config, body, sine_policy, 40)
    n = body.n_particles

    def loss(x):
        # E, nu and density are perturbed relatively (E ~ 300), per particle.
        d = design.replace(
            youngs_modulus=design.youngs_modulus * jnp.exp(x["log_e"]),
            poisson_ratio=design.poisson_ratio + 0.01 * x["nu"],
            density=design.density * (1 + 0.01 * x["rho"]),
        )
        final, trajectory = rollout(x["policy"], d, state.replace(v=x["v"]))
        # Mix position, velocity and deformation so every part of the state matters.
        return (
            jnp.mean(final.x[:, 0])
            + 0.1 * jnp.mean(final.v**2)
            + jnp.mean(final.F[:, 0, 1])
            + jnp.sum(trajectory.observations[:, 1]) / 40
        )

    x = {
        "policy": sine_params(body.n_actuators, jnp.float64),
        "log_e": jnp.zeros(n),
        "nu": jnp.zeros(n),
        "rho": jnp.zeros(n),
        "v": state.v + 0.1,
    }
    f, grad_f = jax.jit(loss), jax.jit(jax.grad(loss))
    rng = np.random.default_rng(0)
    for name in x:
        direction = jax.tree.map(jnp.zeros_like, x)
        direction[name] = jax.tree.map(lambda a: jnp.asarray(rng.normal(size=a.shape)), x[name])
        _directional_check(f, grad_f, x, direction)


@pytest.mark.parametrize("dim", [2, 3])
def test_no_nan_gradient_at_rest(dim, x64):
    # F = I exactly, v = 0, no actuation: the SVD's derivative would be NaN here.
    config, body, design, state = block(dim, n_grid=16, lower=0.3, size=0.25, gravity=0.0, dtype=jnp.float64)
    rollout = make_rollout(config, body, lambda p, s, g: p, 3)
    loss = lambda p, e: jnp.sum(rollout(p, design.replace(youngs_modulus=e), state)[0].x ** 2)
    grads = jax.jit(jax.grad(loss, argnums=(0, 1)))(jnp.zeros(2), design.youngs_modulus)
    assert all(np.all(np.isfinite(g)) for g in grads)


def test_no_nan_gradient_over_1000_steps():
    config, body, design, state = block(2, n_grid=24, lower=0.3, size=0.25, youngs=300.0)
    rollout = make_rollout(config, body, sine_policy, 1000)

    def loss(params, youngs):
        final, trajectory = rollout(params, design.replace(youngs_modulus=youngs), state)
        return -jnp.mean(final.x[:, 0]), trajectory.health

    (value, health), grads = jax.jit(jax.value_and_grad(loss, argnums=(0, 1), has_aux=True))(
        sine_params(body.n_actuators), design.youngs_modulus
    )
    raise_if_unhealthy(health)
    assert np.isfinite(float(value))
    assert all(np.all(np.isfinite(g)) for g in jax.tree.leaves(grads))
    assert float(jnp.abs(grads[1]).max()) > 0

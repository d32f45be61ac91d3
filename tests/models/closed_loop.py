"""Shared check: a closed-loop rollout is differentiable w.r.t. controller and design."""

import jax
import jax.numpy as jnp
import numpy as np


def assert_finite_nonzero_gradients(rollout, params, design, state):
    """d(-mean x)/d(controller params, per-particle E) are finite and not all zero."""

    def loss(p, youngs):
        final, trajectory = rollout(p, design.replace(youngs_modulus=youngs), state)
        return -jnp.mean(final.x[:, 0]), trajectory.health

    (value, health), grads = jax.jit(jax.value_and_grad(loss, argnums=(0, 1), has_aux=True))(
        params, design.youngs_modulus
    )
    assert int(health.first_nonfinite_step) == -1 and np.isfinite(float(value))
    assert all(np.all(np.isfinite(g)) for g in jax.tree.leaves(grads))
    assert float(sum(jnp.abs(g).sum() for g in jax.tree.leaves(grads[0]))) > 0
    assert float(jnp.abs(grads[1]).sum()) > 0

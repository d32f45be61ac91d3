"""Buffering (`SimConfig.buffering`): the per-backend default, and that it changes speed only."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.sim import SimConfigError, make_rollout
from litl.sim.step import resolve_buffering
from tests.sim.scenes import block, sine_params, sine_policy

# Physics, gradients and determinism: worth running on a GPU (`pytest -m gpu`).
pytestmark = pytest.mark.gpu

SETTINGS = ("none", "fields", "fields_and_nodes")


def _tiny(dim):
    return block(dim, n_grid=16, lower=0.3, size=0.3)


@pytest.mark.parametrize("dim,cpu_choice", [(2, "fields"), (3, "fields_and_nodes")])
def test_auto_keeps_the_measured_cpu_choice_and_is_plain_elsewhere(dim, cpu_choice):
    config = _tiny(dim)[0]
    assert config.buffering == "auto"
    assert resolve_buffering(config, "cpu") == cpu_choice
    for backend in ("gpu", "cuda", "rocm", "tpu"):
        assert resolve_buffering(config, backend) == "none"
    for setting in SETTINGS:
        forced = dataclasses.replace(config, buffering=setting)
        assert resolve_buffering(forced, "cpu") == resolve_buffering(forced, "gpu") == setting
    if jax.default_backend() == "cpu":
        assert resolve_buffering(config) == cpu_choice


def test_every_setting_gives_the_same_values_and_gradients(deterministic, dim=2, settings=SETTINGS):
    config, body, design, state = _tiny(dim)
    params = sine_params(body.n_actuators)

    def value_and_grad(buffering):
        rollout = make_rollout(
            dataclasses.replace(config, buffering=buffering), body, sine_policy, 12, snapshot_stride=4
        )

        def loss(p, youngs):
            final, trajectory = rollout(p, design.replace(youngs_modulus=youngs), state)
            return jnp.mean(final.x[:, 0]) + 1e-3 * jnp.mean(trajectory.snapshots**2)

        return jax.jit(jax.value_and_grad(loss, argnums=(0, 1)))(params, design.youngs_modulus)

    auto = value_and_grad("auto")
    for setting in settings:
        value, grads = value_and_grad(setting)
        if setting == resolve_buffering(config):
            # The same program as "auto": bitwise equal.
            for a, b in zip(jax.tree.leaves((value, grads)), jax.tree.leaves(auto), strict=True):
                np.testing.assert_array_equal(a, b)
        np.testing.assert_allclose(value, auto[0], rtol=1e-6)
        for a, b in zip(jax.tree.leaves(grads), jax.tree.leaves(auto[1]), strict=True):
            scale = float(jnp.max(jnp.abs(b)))
            assert scale > 0
            np.testing.assert_allclose(a, b, rtol=1e-4, atol=1e-5 * scale)


def test_unknown_buffering_fails_with_the_choices():
    config = _tiny(2)[0]
    with pytest.raises(SimConfigError, match="unknown buffering 'nodes'.*fields_and_nodes"):
        dataclasses.replace(config, buffering="nodes")


def test_3d_node_buffering_gives_the_same_rollout_as_none():
    """In 3D "auto" on CPU also buffers the nodes; the rollout is the same as without buffering
    (forward only: a 3D forward+backward compiles in 15-20 s per setting on 2 cores, and the
    gradients of every setting are compared in 2D above)."""
    config, body, design, state = _tiny(3)
    params = sine_params(body.n_actuators)

    def forward(buffering):
        rollout = make_rollout(
            dataclasses.replace(config, buffering=buffering), body, sine_policy, 12, snapshot_stride=4
        )
        return jax.jit(rollout)(params, design, state)

    auto, none = forward("auto"), forward("none")
    for a, b in zip(jax.tree.leaves(auto), jax.tree.leaves(none), strict=True):
        # float32 sums in another order: rounding-level differences, relative to each field's size
        scale = float(np.max(np.abs(b))) if np.size(b) else 0.0
        np.testing.assert_allclose(a, b, rtol=1e-4, atol=1e-4 * scale)

"""The published DiffTaichi walker (tests/sim/data/walker2d.md) reproduced with litl's API."""

import json
import pathlib

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.robots import walker2d
from litl.sim import make_rollout, raise_if_unhealthy

# Physics, gradients and determinism: worth running on a GPU (`pytest -m gpu`).
pytestmark = [pytest.mark.gpu, pytest.mark.compute_bound]

# The scene's published numbers are a fixture of the repository (their provenance: data/README.md).
REFERENCE = pathlib.Path(__file__).resolve().parent / "data" / "walker2d.json"


@pytest.fixture(scope="module")
def reference():
    if not REFERENCE.exists():
        pytest.fail(f"reference values not found at {REFERENCE}")
    return json.loads(REFERENCE.read_text())


def _loss_and_grad(reference, dtype):
    scene = walker2d.build(dtype)
    params = walker2d.params(reference["W"], reference["b"], dtype)
    rollout = make_rollout(scene.config, scene.body, walker2d.policy(), walker2d.STEPS)

    def loss(p):
        final, trajectory = rollout(p, scene.design, scene.state)
        return walker2d.loss(final), trajectory

    (value, trajectory), grad = jax.jit(jax.value_and_grad(loss, has_aux=True))(params)
    raise_if_unhealthy(trajectory.health)
    return value, grad, trajectory


def test_walker_float64_loss_gradients_and_trajectory(reference, x64):
    expected = reference["float64"]
    value, grad, trajectory = _loss_and_grad(reference, jnp.float64)
    assert abs(float(value) - expected["loss"]) <= 1e-6 * abs(expected["loss"])
    np.testing.assert_allclose(grad.weights, expected["grad_W"], rtol=0, atol=1e-5)
    np.testing.assert_allclose(grad.bias, expected["grad_b"], rtol=0, atol=1e-5)
    assert np.all(np.isfinite(grad.weights)) and np.all(np.isfinite(grad.bias))
    for step, mean in expected["mean_position_after_steps"].items():
        if int(step) > 0:  # observations are recorded after each step
            np.testing.assert_allclose(trajectory.observations[int(step) - 1], mean, atol=1e-9)


def test_walker_float32_loss(reference):
    expected = reference["float32"]
    value, grad, _ = _loss_and_grad(reference, jnp.float32)
    assert value.dtype == jnp.float32
    assert abs(float(value) - expected["loss"]) <= 1e-4 * abs(expected["loss"])
    np.testing.assert_allclose(grad.weights, expected["grad_W"], rtol=0, atol=1e-3)

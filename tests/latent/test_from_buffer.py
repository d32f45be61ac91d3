"""The replay buffer's transitions, in its chronological order, feed the latent dynamics fit."""

import chex
import jax
import jax.numpy as jnp
import numpy as np

from litl.latent import LinearSettings, Transitions, fit_linear, prediction_error
from litl.latent.dynamics import LinearDynamics
from litl.models import replay_buffer
from litl.models.replay_buffer import ReplayBuffer

GRID = (4, 3)


def test_a_linear_system_seen_through_a_linear_encoder_is_recovered_from_a_wrapped_buffer():
    rng = np.random.default_rng(0)
    r, m = 3, 2
    A = 0.9 * np.linalg.qr(rng.normal(size=(r, r)))[0]
    B, c = rng.normal(size=(r, m)), rng.normal(size=r)
    decoder = rng.normal(size=(int(np.prod(GRID)) * 2, r))  # fields = decoder z, reshaped
    with jax.enable_x64(True):
        buffer = ReplayBuffer.empty(25, GRID, 2, jnp.float64, n_actions=m)
        for _ in range(4):  # 4 rollouts of 10 snapshots: the ring wraps, the oldest are lost
            z = rng.normal(size=r)
            latents, actions = [], []
            for _ in range(10):
                a = rng.uniform(-1, 1, size=m)
                z = A @ z + B @ a + c  # the action recorded with a snapshot led to it
                latents.append(z), actions.append(a)
            fields = (np.stack(latents) @ decoder.T).reshape((10, *GRID, 2))
            buffer = replay_buffer.add(buffer, jnp.asarray(fields), None, jnp.asarray(np.stack(actions)))
        order, links = replay_buffer.chronological(buffer)
        flat = np.asarray(buffer.fields)[np.asarray(order)].reshape(25, -1)
        encoded = jnp.asarray(flat @ np.linalg.pinv(decoder).T)
        data = Transitions.from_sequence(encoded, buffer.actions[order], links)
        # 25 kept snapshots of rollouts 2 (5 of them), 3 and 4: 4 + 9 + 9 transitions.
        assert int(data.mask.sum()) == 22
        fitted = fit_linear(data, LinearSettings(ridge=0.0))
        chex.assert_trees_all_close(fitted, LinearDynamics(A=A, B=B, c=c), atol=1e-9, rtol=0)
        error = prediction_error(fitted.step, encoded, buffer.actions[order], links, (1, 5))
        chex.assert_trees_all_close(error.model, jnp.zeros(2), atol=1e-9)
        np.testing.assert_array_equal(error.starts, [22, 10])  # five-step starts: 0 + 5 + 5

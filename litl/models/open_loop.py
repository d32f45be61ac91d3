"""Open-loop sinusoidal controller (the classic DiffTaichi/ChainQueen walker controller)."""

from __future__ import annotations

import math

import jax.numpy as jnp
from flax import struct


@struct.dataclass
class SinusoidParams:
    """Parameters of `sinusoid_policy`.

    Attributes:
      weights: (m, k) weight of each of k phase-shifted sinusoids for each of m actuators.
      bias: (m,) bias of each actuator.
    """

    weights: jnp.ndarray
    bias: jnp.ndarray


def sinusoid_policy(omega: float, dt: float):
    """Build a policy with actuation_i(s) = tanh(sum_j W_ij sin(omega s dt + 2 pi j / k) + b_i).

    Args:
      omega: angular frequency of the sinusoids.
      dt: simulation time step, so that ``s * dt`` is the time of step s.

    Returns:
      ``policy(params: SinusoidParams, state, grid_velocity) -> (m,) actuation``.
    """

    def policy(params: SinusoidParams, state, grid_velocity):
        del grid_velocity  # open loop
        k = params.weights.shape[-1]
        dtype = params.weights.dtype
        time = state.step.astype(dtype) * dt
        phases = omega * time + 2 * math.pi * jnp.arange(k, dtype=dtype) / k
        return jnp.tanh(params.weights @ jnp.sin(phases) + params.bias)

    return policy

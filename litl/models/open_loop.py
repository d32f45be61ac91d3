"""Open-loop sinusoidal controllers (the classic DiffTaichi/ChainQueen walker controller).

actuation_i(t) = tanh(sum_j W_ij sin(omega t + 2 pi j / k) + b_i): k phase-shifted sinusoids of
one frequency mixed per actuator. It ignores the robot's state; `SinusoidController` is the
baseline the paper's closed-loop controllers are compared with (`controller=sinusoid`).
"""

from __future__ import annotations

import math

import flax.linen as nn
import jax.numpy as jnp
from flax import struct


def sinusoid_actuation(weights, bias, omega: float, time):
    """(m,) actuation at simulated `time` from (m, k) `weights` and (m,) `bias`."""
    k = weights.shape[-1]
    phases = omega * time + 2 * math.pi * jnp.arange(k, dtype=weights.dtype) / k
    return jnp.tanh(weights @ jnp.sin(phases) + bias)


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
        time = state.step.astype(params.weights.dtype) * dt
        return sinusoid_actuation(params.weights, params.bias, omega, time)

    return policy


class SinusoidController(nn.Module):
    """The open-loop baseline with the MLP controller's interface: features are ignored.

    Attributes:
      n_actuators: m, number of outputs.
      omega: angular frequency (rad/s) of the sinusoids.
      phases: k, phase-shifted sinusoids per actuator.
      init_scale: standard deviation of the initial weights (biases start at zero).
    """

    n_actuators: int
    omega: float = 30.0
    phases: int = 4
    init_scale: float = 0.1

    def __post_init__(self):
        if self.n_actuators < 1 or self.phases < 1:
            raise ValueError("n_actuators and phases must be positive")
        if not (math.isfinite(self.omega) and self.omega > 0):
            raise ValueError(f"omega must be a positive angular frequency (rad/s), got {self.omega!r}")
        super().__post_init__()

    @nn.compact
    def __call__(self, features, task_inputs=None, time=None):
        """features: ignored (open loop), used for the dtype; time: () simulated time."""
        del task_inputs
        if time is None:
            raise ValueError("an open-loop controller needs the simulated time")
        dtype = features.dtype
        weights = self.param(
            "weights", nn.initializers.normal(self.init_scale), (self.n_actuators, self.phases), dtype
        )
        bias = self.param("bias", nn.initializers.zeros, (self.n_actuators,), dtype)
        return sinusoid_actuation(weights, bias, self.omega, jnp.asarray(time, dtype))

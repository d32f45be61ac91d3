"""The controller: an MLP from observer features (plus optional task and time inputs) to actuation."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import flax.linen as nn
import jax.numpy as jnp

ACTIVATIONS = {"relu": nn.relu, "tanh": jnp.tanh, "elu": nn.elu, "gelu": nn.gelu, "silu": nn.silu}


class MLPController(nn.Module):
    """features (+ task inputs) (+ sin/cos of a periodic clock) -> (n_actuators,) in [-1, 1].

    The simulator multiplies each output by its actuator's strength.

    Attributes:
      n_actuators: number of outputs.
      widths: hidden layer widths.
      activation: name in `ACTIVATIONS`.
      period: if set, the clock phase 2 pi t / period enters as (sin, cos).
      feature_scale: the features are multiplied by this on entry (an input gain).
    """

    n_actuators: int
    widths: Sequence[int] = (64, 64)
    activation: str = "tanh"
    period: float | None = None
    feature_scale: float = 1.0

    def __post_init__(self):
        if self.activation not in ACTIVATIONS:
            raise ValueError(f"unknown activation {self.activation!r}; choose from {sorted(ACTIVATIONS)}")
        if self.n_actuators < 1 or any(w < 1 for w in self.widths):
            raise ValueError("n_actuators and every width must be positive")
        if self.period is not None and not self.period > 0:
            raise ValueError(f"period must be positive, got {self.period!r}")
        if not self.feature_scale > 0:
            raise ValueError(f"feature_scale must be positive, got {self.feature_scale!r}")
        super().__post_init__()

    @nn.compact
    def __call__(self, features, task_inputs=None, time=None):
        """features: (f,); task_inputs: (t,) or None; time: () simulated time, used with `period`."""
        parts = [features * self.feature_scale]  # exact at 1.0
        if task_inputs is not None:
            parts.append(task_inputs)
        if self.period is not None:
            if time is None:
                raise ValueError("this controller has a period: pass the simulated time")
            phase = 2 * math.pi * jnp.asarray(time, features.dtype) / self.period
            parts.append(jnp.stack([jnp.sin(phase), jnp.cos(phase)]))
        h = jnp.concatenate(parts)
        act: Callable = ACTIVATIONS[self.activation]
        for width in self.widths:
            h = act(nn.Dense(width, param_dtype=features.dtype)(h))
        return jnp.tanh(nn.Dense(self.n_actuators, param_dtype=features.dtype)(h))

"""No observer (`none`): the controller runs open loop, on the clock or as sinusoids."""

from __future__ import annotations

import jax.numpy as jnp

from litl.observers.interface import Observer, ObserverContext


def no_observer(robot, settings, context: ObserverContext) -> Observer:
    """No features: the controller runs open loop (on the clock, or sinusoids)."""
    return Observer(
        n_features=0,
        init=lambda key, seed: jnp.zeros((), context.dtype),  # a placeholder
        features=lambda params, state, grid_velocity: jnp.zeros((0,), context.dtype),
    )

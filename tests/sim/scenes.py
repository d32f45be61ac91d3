"""Tiny scenes for tests: an elastic block in a small box, 2D or 3D."""

import jax.numpy as jnp
import numpy as np

from litl.robots.primitives import sample_box
from litl.sim import Body, Boundary, Design, Elastic, SimConfig, SimState


def block(
    dim=2,
    n_grid=24,
    lower=0.35,
    size=0.25,
    gravity=-9.8,
    youngs=300.0,
    constitutive_model="fixed_corotated",
    n_actuators=2,
    dtype=jnp.float32,
    velocity=None,
    boundary=None,
    dt=None,
):
    """A block whose lower half is split into `n_actuators` actuators along axis 0 (fibers up)."""
    dx = 1.0 / n_grid
    x = sample_box([lower] * dim, [size] * dim, dx, per_cell=2)
    n = len(x)
    actuator = np.full(n, -1, np.int32)
    if n_actuators:
        lower_half = x[:, 1] < lower + size / 2
        band = np.minimum(((x[:, 0] - lower) / size * n_actuators).astype(int), n_actuators - 1)
        actuator[lower_half] = band[lower_half]
    fiber = np.zeros((max(n_actuators, 0), dim))
    if n_actuators:
        fiber[:, 1] = 1.0
    density = 1.0
    # An active strain of 0.19, under `litl.sim.safety.MAX_ACTIVE_STRAIN`.
    strength = 0.25 * youngs
    design = Design.uniform(n, youngs, 0.3, density, [strength] * n_actuators, dtype)
    body = Body(
        volume=jnp.full((n,), (dx / 2) ** dim, dtype),
        actuator=jnp.asarray(actuator),
        fiber=jnp.asarray(fiber, dtype),
        pinned=jnp.zeros((n,), bool),
    )
    g = [0.0] * dim
    g[1] = gravity
    mu, lam = (float(p[0]) for p in design.lame())
    speed = np.sqrt((lam + 2 * mu + strength) / density)
    config = SimConfig(
        grid_shape=(n_grid,) * dim,
        dx=dx,
        dt=dt if dt is not None else 0.4 * dx / speed,
        gravity=tuple(g),
        materials=(Elastic(constitutive_model),),
        boundary=boundary if boundary is not None else Boundary.box(dim),
    )
    v = np.zeros_like(x) if velocity is None else np.broadcast_to(velocity, x.shape)
    state = SimState.at_rest(jnp.asarray(x, dtype), jnp.asarray(v, dtype))
    return config, body, design, state


def sine_policy(params, state, grid_velocity):
    """actuation_i = tanh(a_i sin(omega t) + b_i); params: dict(a=(m,), b=(m,), omega=())."""
    t = state.step.astype(params["a"].dtype)
    return jnp.tanh(params["a"] * jnp.sin(params["omega"] * t) + params["b"])


def sine_params(m, dtype=jnp.float32):
    return {
        "a": jnp.linspace(0.5, 1.0, m, dtype=dtype),
        "b": jnp.linspace(-0.2, 0.2, m, dtype=dtype),
        "omega": jnp.asarray(0.05, dtype),
    }

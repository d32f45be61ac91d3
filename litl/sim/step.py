"""One MLS-MPM step as a pure function: particle-to-grid, grid update, grid-to-particle."""

from __future__ import annotations

from typing import Callable

import jax.numpy as jnp

from litl.sim import linalg, transfer
from litl.sim.boundary import apply_boundary
from litl.sim.config import SimConfig
from litl.sim.materials import MODELS, actuation_stress
from litl.sim.state import Body, Design, Grid, SimState

StepFn = Callable[[SimState, jnp.ndarray, Design], tuple[SimState, Grid]]


def particle_activation(body: Body, actuation, design: Design):
    """Per-particle active stress magnitude (n,) and fiber direction (n, d).

    Args:
      body: the body layout.
      actuation: (m,) actuation of each actuator (typically in [-1, 1]).
      design: supplies `actuator_strength` (m,).
    """
    has_actuator = body.actuator >= 0
    index = jnp.where(has_actuator, body.actuator, 0)
    signal = (design.actuator_strength * actuation)[index]
    return jnp.where(has_actuator, signal, 0.0), body.fiber[index]


def make_step(config: SimConfig, body: Body) -> StepFn:
    """Build `step(state, actuation, design) -> (next_state, grid)` for a fixed config and body.

    `actuation` is (m,), one value per actuator; `grid` holds the post-boundary grid velocity and
    mass used to move the particles, i.e. what an observer sees.
    """
    stress_model = MODELS[config.material]
    gravity = jnp.asarray(config.gravity)
    dx, dt = config.dx, config.dt

    def step(state: SimState, actuation, design: Design):
        dtype = state.x.dtype
        mass = design.density * body.volume
        mu, lam = design.lame()
        F = linalg.matmul(linalg.identity_like(state.F) + dt * state.C, state.F)
        activation, fiber = particle_activation(body, actuation, design)
        tau = stress_model(F, mu, lam) + actuation_stress(F, activation, fiber)
        # MLS-MPM: the stress enters as an affine momentum term, -dt V 4/dx^2 tau (quadratic splines).
        affine = (-dt * 4.0 / dx**2) * body.volume[:, None, None] * tau + mass[:, None, None] * state.C
        st = transfer.stencil(state.x, dx, config.grid_shape)
        grid_mass, grid_momentum = transfer.particles_to_grid(
            st, mass, mass[:, None] * state.v, affine, dx, config.grid_shape
        )
        velocity = grid_momentum / (grid_mass[..., None] + config.mass_epsilon)
        velocity = velocity + dt * gravity.astype(dtype)
        velocity = apply_boundary(config, velocity)
        v, C = transfer.grid_to_particles(st, velocity, dx)
        pinned = body.pinned[:, None]
        v = jnp.where(pinned, 0.0, v)
        C = jnp.where(pinned[..., None], 0.0, C)
        next_state = SimState(x=state.x + dt * v, v=v, C=C, F=F, step=state.step + 1)
        return next_state, Grid(velocity=velocity, mass=grid_mass)

    return step


def rasterize(config: SimConfig, body: Body, state: SimState, design: Design) -> Grid:
    """Grid velocity and mass of a state by particle-to-grid without stress or gravity.

    This is the field an observer sees before the first step.
    """
    mass = design.density * body.volume
    st = transfer.stencil(state.x, config.dx, config.grid_shape)
    grid_mass, grid_momentum = transfer.particles_to_grid(
        st, mass, mass[:, None] * state.v, mass[:, None, None] * state.C, config.dx,
        config.grid_shape,
    )
    velocity = grid_momentum / (grid_mass[..., None] + config.mass_epsilon)
    return Grid(velocity=apply_boundary(config, velocity), mass=grid_mass)

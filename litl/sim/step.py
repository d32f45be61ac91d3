"""One MLS-MPM step as a pure function: particle-to-grid, grid update, grid-to-particle."""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp
from flax import struct

from litl.sim import linalg, materials, transfer
from litl.sim.boundary import apply_boundary
from litl.sim.config import SimConfig
from litl.sim.constitutive import actuation_stress
from litl.sim.state import Body, Design, Grid, SimState

StepFn = Callable[[SimState, jnp.ndarray, Design], tuple[SimState, Grid]]


def particle_activation(body: Body, actuation, design: Design):
    """Per-particle active stress magnitude (n,) and fiber direction (n, d) of a body whose
    particles each belong to one actuator (`Body.actuator`).

    Args:
      body: the body layout.
      actuation: (m,) actuation of each actuator (typically in [-1, 1]).
      design: supplies `actuator_strength` (m,).
    """
    # A one-hot product instead of indexing by actuator id: XLA:CPU fuses an index gather into
    # every consumer and re-evaluates it per element, while a dot is computed once.
    one_hot = (body.actuator[:, None] == jnp.arange(body.n_actuators)).astype(actuation.dtype)
    return one_hot @ (design.actuator_strength * actuation), one_hot @ body.fiber


def active_stress(F: linalg.Mat, body: Body, actuation, design: Design) -> linalg.Mat:
    """The actuators' Kirchhoff stress on every particle: `a (F f) ⊗ (F f)` along its actuator's
    fiber f, or, where the design places the actuators (`Design.actuator_weights` (n, m)), the sum
    over actuators k of `w_k a_k (F f_k) ⊗ (F f_k)`; the same value for one-hot weights."""
    if design.actuator_weights is None:
        activation, fiber = particle_activation(body, actuation, design)
        return actuation_stress(F, activation, linalg.split_vec(fiber))
    drive = design.actuator_weights * (design.actuator_strength * actuation)  # (n, m)
    dim = len(F)
    tau = None
    for k in range(body.n_actuators):
        direction = [body.fiber[k, j] for j in range(dim)]
        pulled = [sum(F[i][j] * direction[j] for j in range(dim)) for i in range(dim)]  # F f_k
        term = linalg.scale(linalg.outer(pulled, pulled), drive[:, k])
        tau = term if tau is None else linalg.add(tau, term)
    return tau if tau is not None else linalg.scale(F, jnp.zeros_like(F[0][0]))


def _grid_velocity(config: SimConfig, grid, particle_mass):
    """Grid mass and momentum / mass; `grid` is (*grid_shape, 1 + d) mass then momentum."""
    mass, *momentum = linalg.unstack(grid, -1)
    # The epsilon is relative to the mean particle mass, so that it means the same for bodies in
    # any units (the reference scene has unit masses, where this is DiffTaichi's 1e-10).
    inverse_mass = 1.0 / (mass + config.mass_epsilon * jnp.mean(particle_mass))
    return [p * inverse_mass for p in momentum], mass


def _grid_update(config: SimConfig, grid, particle_mass, time=0.0):
    """Momentum -> velocity, gravity, boundaries (moving colliders where they are at `time`)."""
    velocity, mass = _grid_velocity(config, grid, particle_mass)
    dtype = mass.dtype
    # Gravity only where there is material: particles never read empty nodes, but the observer
    # does, and an empty grid must read as zero velocity (not g * dt everywhere).
    occupied = mass > 0
    velocity = [
        v + jnp.where(occupied, jnp.asarray(config.dt * g, dtype), 0) if g else v
        for v, g in zip(velocity, config.gravity, strict=True)
    ]
    return apply_boundary(config, velocity, time), mass


@struct.dataclass
class Components:
    """A `SimState` held as per-component (n,) arrays: `x[a]`, `v[a]`, `C[i][j]`, `F[i][j]`.

    Rollouts carry this form from step to step, so no step ever packs or unpacks (n, d) arrays:
    on CPU, XLA fuses the producers of such a pack into one scalar loop, which made the backward
    pass 7x slower than the forward pass.
    """

    x: list
    v: list
    C: list
    F: list
    step: jnp.ndarray

    @classmethod
    def unpack(cls, state: SimState) -> Components:
        return cls(
            x=linalg.split_vec(state.x),
            v=linalg.split_vec(state.v),
            C=linalg.split_mat(state.C),
            F=linalg.split_mat(state.F),
            step=state.step,
        )

    def pack(self) -> SimState:
        return SimState(
            x=linalg.stack_vec(self.x),
            v=linalg.stack_vec(self.v),
            C=linalg.stack_mat(self.C),
            F=linalg.stack_mat(self.F),
            step=self.step,
        )


def resolve_buffering(config: SimConfig, backend: str | None = None) -> str:
    """The buffering a step uses (`SimConfig.buffering`): "none", "fields" or "fields_and_nodes".

    Args:
      config: its `buffering`, unless that is "auto".
      backend: the JAX platform the step will run on ("cpu", "gpu", "tpu"); None:
        `jax.default_backend()`, where `jax.jit` places computations unless told otherwise.
    """
    if config.buffering != "auto":
        return config.buffering
    if (backend or jax.default_backend()) == "cpu":
        # Measured on XLA:CPU: the fields pay off in 2D and 3D (walker forward+backward 1.1 s ->
        # 0.77 s). Buffering the grid and the node weights too (and, in reverse mode, their
        # cotangents) pays off in 3D (quadruped3d forward+backward 24 s -> 22.5 s for the
        # weights, 41 s -> 30 s for the grid) but costs more than it saves in 2D (walker 0.72 s
        # -> 0.78 s and 0.78 s -> 0.93 s).
        return "fields_and_nodes" if config.dim == 3 else "fields"
    # Elsewhere the default is the plain program: the recomputation a buffer prevents is XLA:CPU's
    # (its fusion re-evaluates cheap producers per read), while the conditional that makes the
    # buffer makes XLA:GPU copy its predicate to the host, a synchronization per value per step.
    # Not measured on a GPU: force a setting with `SimConfig.buffering` to compare.
    return "none"


def make_component_step(config: SimConfig, body: Body):
    """Like `make_step`, on `Components`: ``step(components, actuation, design, token=None)``.

    `token`, a () int32 >= 0 that is not batched under vmap (a scan counter), lets the step
    compute values read by many consumers into buffers (`linalg.materialize`), as
    `resolve_buffering(config)` says, decided once here for the default backend.
    """
    dx, dt, dim = config.dx, config.dt, config.dim
    buffering = resolve_buffering(config)
    buffer_fields = buffering != "none"
    buffer_nodes = buffering == "fields_and_nodes"
    moving = config.moving_colliders
    fixed = config.particle_to_grid == "fixed_point"

    def step(state: Components, actuation, design: Design, token=None):
        field_token = token if buffer_fields else None
        node_token = token if buffer_nodes else None
        mass = design.density * body.volume
        mu, lam = design.lame()
        F = linalg.matmul(linalg.add(linalg.identity(dim, mass), linalg.scale(state.C, dt)), state.F)
        # Each particle's return mapping and stress under its material (`SimConfig.materials`);
        # their shared scalars buffered wherever fields are (measured on XLA:CPU, 20k particles,
        # sand's forward+backward: 2D 15 ms -> 4 ms, 3D 3.1 s -> 29 ms).
        F, tau = materials.update(config.materials, body.material, F, mu, lam, field_token)
        tau = linalg.add(tau, active_stress(F, body, actuation, design))
        # MLS-MPM folds the stress into the affine momentum: -dt V 4/dx^2 tau (quadratic splines).
        stress_scale = (-dt * 4.0 / dx**2) * body.volume
        affine = linalg.add(linalg.scale(tau, stress_scale), linalg.scale(state.C, mass))
        if field_token is not None:
            # Every stencil node's momentum reads all of A, and in reverse mode every component of
            # the stress derivative reads all of A's cotangent: computed once into buffers here
            # instead of once per reader (measured: quadruped3d forward+backward 30 s -> 24 s).
            affine = linalg.materialize(affine, field_token)
        st = transfer.stencil(state.x, dx, config.grid_shape, node_token)
        momentum = [mass * v for v in state.v]
        extra = () if body.observed is None else (jnp.where(body.observed, mass, 0.0),)
        shape = config.grid_shape
        grid = transfer.particles_to_grid(st, mass, momentum, affine, dx, shape, node_token, extra, fixed)
        observed_mass = None
        if extra:
            grid, observed_mass = grid[..., : 1 + dim], grid[..., 1 + dim]
        if node_token is not None:
            # In reverse mode: the grid's cotangent is formed once before the scatter's transpose
            # gathers it, instead of the grid update's backward being recomputed per read.
            grid = linalg.materialize(grid, node_token)
        # The grid velocity is the step's end velocity: moving colliders stand where they are then.
        end_time = (state.step + 1).astype(mass.dtype) * config.dt if moving else 0.0
        velocity, grid_mass = _grid_update(config, grid, mass, end_time)
        velocity = linalg.stack(velocity, -1)
        if field_token is not None:
            velocity = linalg.materialize(velocity, field_token)
        v, C = transfer.grid_to_particles(st, velocity, dx, node_token, fixed)
        free = ~body.pinned
        v = [jnp.where(free, c, 0.0) for c in v]
        C = [[jnp.where(free, c, 0.0) for c in row] for row in C]
        x = [x + dt * c for x, c in zip(state.x, v, strict=True)]
        next_state = Components(x=x, v=v, C=C, F=F, step=state.step + 1)
        return next_state, Grid(velocity=velocity, mass=grid_mass, observed_mass=observed_mass)

    return step


def make_step(config: SimConfig, body: Body) -> StepFn:
    """Build `step(state, actuation, design) -> (next_state, grid)` for a fixed config and body.

    `actuation` is (m,), one value per actuator; `grid` holds the post-boundary grid velocity and
    mass used to move the particles, i.e. what an observer sees. Each particle's stress law is its
    material's (`config.materials`, `litl.sim.materials`; a law of one's own:
    ``Elastic(model=stress_fn)``).

    Each call unpacks and packs the (n, d) arrays. To differentiate many steps (a `lax.scan`),
    carry `Components` with `make_component_step` instead, giving it the scan's counter as its
    token: on XLA:CPU a scan of this step differentiates ~300x slower (the biped's 581 particles:
    81.7 ms against 0.27 ms per step, `benchmarks/env_step.py`; `litl.envs` carries components).
    """
    component_step = make_component_step(config, body)

    def step(state: SimState, actuation, design: Design):
        next_state, grid = component_step(Components.unpack(state), actuation, design)
        return next_state.pack(), grid

    return step


def rasterize(config: SimConfig, body: Body, state: SimState, design: Design) -> Grid:
    """Grid velocity and mass of a state by particle-to-grid without stress or gravity.

    This is the field an observer sees before the first step.
    """
    mass = design.density * body.volume
    st = transfer.stencil(linalg.split_vec(state.x), config.dx, config.grid_shape)
    extra = () if body.observed is None else (jnp.where(body.observed, mass, 0.0),)
    grid = transfer.particles_to_grid(
        st,
        mass,
        [mass * v for v in linalg.split_vec(state.v)],
        linalg.scale(linalg.split_mat(state.C), mass),
        config.dx,
        config.grid_shape,
        extra=extra,
        fixed_point=config.particle_to_grid == "fixed_point",
    )
    observed_mass = None
    if extra:
        grid, observed_mass = grid[..., : 1 + config.dim], grid[..., 1 + config.dim]
    velocity, grid_mass = _grid_velocity(config, grid, mass)
    moving = config.moving_colliders
    velocity = apply_boundary(config, velocity, state.step.astype(mass.dtype) * config.dt if moving else 0.0)
    return Grid(velocity=jnp.stack(velocity, axis=-1), mass=grid_mass, observed_mass=observed_mass)

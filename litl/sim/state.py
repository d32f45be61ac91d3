"""Pytrees of the simulator: the evolving state, the differentiable design, the fixed body layout.

Shapes use ``n`` for the number of particles, ``d`` for the dimension (2 or 3) and ``m`` for the
number of actuators.
"""

from __future__ import annotations

import jax.numpy as jnp
from flax import struct


@struct.dataclass
class SimState:
    """Per-particle state of an MLS-MPM simulation.

    Attributes:
      x: (n, d) positions.
      v: (n, d) velocities.
      C: (n, d, d) APIC/MLS affine velocity matrices.
      F: (n, d, d) deformation gradients.
      step: () int32 index of the next step to take.
    """

    x: jnp.ndarray
    v: jnp.ndarray
    C: jnp.ndarray
    F: jnp.ndarray
    step: jnp.ndarray

    @classmethod
    def at_rest(cls, positions, velocities=None) -> SimState:
        """A state with the given positions (n, d), zero affine field and F = I."""
        x = jnp.asarray(positions)
        n, d = x.shape
        v = jnp.zeros_like(x) if velocities is None else jnp.asarray(velocities, x.dtype)
        return cls(
            x=x,
            v=v,
            C=jnp.zeros((n, d, d), x.dtype),
            F=jnp.broadcast_to(jnp.eye(d, dtype=x.dtype), (n, d, d)),
            step=jnp.zeros((), jnp.int32),
        )


@struct.dataclass
class Design:
    """Differentiable material and actuator parameters (the co-design variables).

    Attributes:
      youngs_modulus: (n,) Young's modulus E per particle.
      poisson_ratio: (n,) Poisson ratio per particle, in (-1, 0.5).
      density: (n,) mass per unit of particle volume.
      actuator_strength: (m,) active stress per unit actuation for each actuator.
      actuator_weights: (n, m) how much of each actuator's drive each particle takes, rows
        summing to at most 1 (the rest passive): placed muscles, which co-design can move. Each
        actuator pulls along its own fiber, so a particle shared by two takes the sum of their
        active stresses, each weighted. None: `Body.actuator` says each particle's one actuator
        (the one-hot weights, computed so).
    """

    youngs_modulus: jnp.ndarray
    poisson_ratio: jnp.ndarray
    density: jnp.ndarray
    actuator_strength: jnp.ndarray
    actuator_weights: jnp.ndarray | None = None

    @classmethod
    def uniform(cls, n, youngs_modulus, poisson_ratio, density, actuator_strength, dtype=jnp.float32):
        """The same material on every particle; `actuator_strength` is one value per actuator."""
        full = lambda value: jnp.full((n,), value, dtype)
        return cls(
            youngs_modulus=full(youngs_modulus),
            poisson_ratio=full(poisson_ratio),
            density=full(density),
            actuator_strength=jnp.asarray(actuator_strength, dtype).reshape(-1),
        )

    @classmethod
    def from_lame(cls, mu, lam, density, actuator_strength) -> Design:
        """A design given by the Lamé parameters (arrays of shape (n,)) instead of E and nu."""
        mu, lam = jnp.asarray(mu), jnp.asarray(lam)
        return cls(
            youngs_modulus=mu * (3 * lam + 2 * mu) / (lam + mu),
            poisson_ratio=lam / (2 * (lam + mu)),
            density=jnp.asarray(density, mu.dtype),
            actuator_strength=jnp.asarray(actuator_strength, mu.dtype),
        )

    def lame(self):
        """Lamé parameters (mu, lambda), each (n,)."""
        E, nu = self.youngs_modulus, self.poisson_ratio
        mu = E / (2 * (1 + nu))
        lam = E * nu / ((1 + nu) * (1 - 2 * nu))
        return mu, lam


@struct.dataclass
class Body:
    """Fixed layout of a body: what each particle is, never differentiated.

    Attributes:
      volume: (n,) rest volume of each particle (mass = density * volume).
      actuator: (n,) int32 actuator id of each particle, -1 for passive particles.
      fiber: (m, d) unit fiber direction of each actuator.
      pinned: (n,) bool, particles held fixed in place.
      material: (n,) int32 index of each particle's material in `SimConfig.materials`, or None:
        every particle is of the first (the robot's own).
      observed: (n,) bool, the particles an observer sees (a robot among terrain bodies), or
        None: all. Given, each step also scatters these particles' mass to the grid
        (`Grid.observed_mass`), and the grid fields (`litl.sim.fields`) keep only the nodes it
        reaches.
    """

    volume: jnp.ndarray
    actuator: jnp.ndarray
    fiber: jnp.ndarray
    pinned: jnp.ndarray
    material: jnp.ndarray | None = None
    observed: jnp.ndarray | None = None

    @property
    def n_particles(self) -> int:
        return self.volume.shape[0]

    @property
    def n_actuators(self) -> int:
        return self.fiber.shape[0]


@struct.dataclass
class Grid:
    """Grid fields after the grid update of a step (post-boundary).

    Attributes:
      velocity: (*grid_shape, d) node velocities.
      mass: (*grid_shape,) node masses.
      observed_mass: (*grid_shape,) the mass of the observed particles (`Body.observed`) at each
        node, or None where every particle is observed.
    """

    velocity: jnp.ndarray
    mass: jnp.ndarray
    observed_mass: jnp.ndarray | None = None

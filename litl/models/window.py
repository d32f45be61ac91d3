"""A window of grid nodes that follows the robot: what a learned observer looks at.

The simulator's grid is mostly empty space: the 2D biped covers about 6% of its 64 x 64 grid at
dx 1/64. A window of fixed size centred on the robot's particle centroid holds the same motion in
a quarter of the nodes (a 32 x 32 window at dx 1/64), so the autoencoder is four times cheaper
and its loss is no longer dominated by empty grid. Convolutions are translation equivariant
(the paper's argument for them), so a field seen through a window that moves with the robot is
as good an input as the whole grid, and a better one to learn from: the same gait looks the same
wherever the robot has walked to.

    window = Window.around(grid_shape=(64, 64), dx=1 / 64, size=0.5)   # 32 x 32 nodes
    crop = window.crop(grid_velocity, centre)                          # (32, 32, 2)

The window's corner is the node nearest `centre - size / 2`, clamped so that the window stays
inside the grid (near a wall the robot is off-centre rather than the window padded). The crop is
a `lax.dynamic_slice`: jittable, vmappable and differentiable with respect to the field.
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp

# The encoder halves the field five times; windows are rounded up to a multiple of this.
NODE_MULTIPLE = 32


@dataclasses.dataclass(frozen=True)
class Window:
    """Nodes `shape` of a grid `grid_shape` (spacing `dx`) around a moving centre.

    Attributes:
      grid_shape: nodes per axis of the simulator grid.
      shape: nodes per axis of the window (equal to `grid_shape`: the whole grid, no cropping).
      dx: grid spacing.
    """

    grid_shape: tuple[int, ...]
    shape: tuple[int, ...]
    dx: float

    def __post_init__(self):
        object.__setattr__(self, "grid_shape", tuple(int(n) for n in self.grid_shape))
        object.__setattr__(self, "shape", tuple(int(n) for n in self.shape))
        if len(self.shape) != len(self.grid_shape) or any(
            not 0 < w <= n for w, n in zip(self.shape, self.grid_shape, strict=True)
        ):
            raise ValueError(
                f"window shape {self.shape} must have one size in [1, n] per grid axis of {self.grid_shape}"
            )
        if not self.dx > 0:
            raise ValueError(f"dx must be positive, got {self.dx!r}")

    @classmethod
    def around(cls, grid_shape, dx: float, size: float | None) -> Window:
        """A cube (square) of side `size` in domain units; None: the whole grid.

        The side in nodes is rounded up to a multiple of 32 (the encoder's five halvings) and
        capped at each axis of the grid.
        """
        grid_shape = tuple(int(n) for n in grid_shape)
        if size is None:
            return cls(grid_shape, grid_shape, dx)
        if (
            isinstance(size, bool)
            or not isinstance(size, (int, float))
            or not size > 0
            or not math.isfinite(size)
        ):
            raise ValueError(
                f"observer window must be a positive length in domain units (or "
                f"null for the whole grid), got {size!r}"
            )
        nodes = NODE_MULTIPLE * math.ceil(size / dx / NODE_MULTIPLE - 1e-9)
        return cls(grid_shape, tuple(min(nodes, n) for n in grid_shape), dx)

    @property
    def whole_grid(self) -> bool:
        return self.shape == self.grid_shape

    def corner(self, centre) -> jnp.ndarray:
        """(d,) int32 first node of the window around the (d,) position `centre`."""
        first = jnp.round(jnp.asarray(centre) / self.dx - jnp.asarray(self.shape) / 2)
        last = jnp.asarray(self.grid_shape) - jnp.asarray(self.shape)
        return jnp.clip(first, 0, last).astype(jnp.int32)

    def crop(self, field, centre):
        """(*grid_shape, c) field -> (*shape, c) nodes of the window around `centre`."""
        if self.whole_grid:
            return field
        # All int32: a Python 0 would be int64 under jax_enable_x64 (float64 runs).
        start = tuple(self.corner(centre)) + (jnp.zeros((), jnp.int32),)
        return jax.lax.dynamic_slice(field, start, self.shape + (field.shape[-1],))

"""Particle <-> grid transfers of MLS-MPM with quadratic B-splines, for any dimension.

Each particle touches the 3^d nodes starting at its `base` node. Rather than scattering 3^d single
values per particle, a particle's whole 3^d stencil is written as one window of a single `scatter`
(and read back as one window of a `gather`), which XLA executes much faster than 3^d times as many
scalar updates, and whose transpose (for reverse mode) is again one windowed gather/scatter.
"""

from __future__ import annotations

import itertools

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct


@struct.dataclass
class Stencil:
    """Where and how strongly each particle talks to the grid.

    Attributes:
      base: (n, d) int32 index of the first node of each particle's 3^d stencil (clamped inside).
      weights: (n, 3, ..., 3) B-spline weight of each stencil node (d axes of size 3).
      offset: (n, 3, ..., 3, d) node position minus particle position, in cells.
      inside: (n,) bool, whether the unclamped stencil lies inside the grid.
    """

    base: jnp.ndarray
    weights: jnp.ndarray
    offset: jnp.ndarray
    inside: jnp.ndarray


def _node_offsets(dim, dtype):
    """(3, ..., 3, d) integer offsets of the stencil nodes, as `dtype`."""
    grid = np.stack(np.meshgrid(*[np.arange(3)] * dim, indexing="ij"), -1)
    return jnp.asarray(grid, dtype)


def stencil(x, dx, grid_shape) -> Stencil:
    """Quadratic B-spline stencil of particles at positions x (n, d)."""
    dim = x.shape[-1]
    xi = x / dx
    base_float = jnp.floor(xi - 0.5)
    upper = jnp.asarray(grid_shape, x.dtype) - 3
    inside = jnp.all((base_float >= 0) & (base_float <= upper), axis=-1)
    # Clamping keeps every index valid (and every value finite) for particles that left the grid;
    # `inside` reports them so that the caller can raise.
    base_float = jnp.clip(base_float, 0, upper)
    fx = xi - base_float
    per_axis = jnp.stack(
        [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2], axis=-1
    )  # (n, d, 3)
    weights = per_axis[:, 0]
    for axis in range(1, dim):
        weights = weights[..., None] * per_axis[:, axis].reshape((-1,) + (1,) * axis + (3,))
    expand = (slice(None),) + (None,) * dim + (slice(None),)
    offset = _node_offsets(dim, x.dtype)[None] - fx[expand]
    return Stencil(base=base_float.astype(jnp.int32), weights=weights, offset=offset, inside=inside)


def _window_numbers(dim):
    window = tuple(range(1, dim + 2))
    axes = tuple(range(dim))
    return window, axes


def scatter_to_grid(st: Stencil, values, grid_shape):
    """Sum per-node particle values into the grid.

    Args:
      st: the particles' stencil.
      values: (n, 3, ..., 3, c) value each particle adds to each of its stencil nodes.
      grid_shape: nodes per axis.

    Returns:
      (*grid_shape, c) grid of summed values.
    """
    dim = st.base.shape[-1]
    window, axes = _window_numbers(dim)
    numbers = jax.lax.ScatterDimensionNumbers(
        update_window_dims=window, inserted_window_dims=(), scatter_dims_to_operand_dims=axes
    )
    grid = jnp.zeros(tuple(grid_shape) + values.shape[-1:], values.dtype)
    return jax.lax.scatter_add(
        grid, st.base, values, numbers, mode=jax.lax.GatherScatterMode.PROMISE_IN_BOUNDS
    )


def gather_from_grid(st: Stencil, grid):
    """Read each particle's 3^d stencil of a (*grid_shape, c) grid: (n, 3, ..., 3, c)."""
    dim = st.base.shape[-1]
    window, axes = _window_numbers(dim)
    numbers = jax.lax.GatherDimensionNumbers(
        offset_dims=window, collapsed_slice_dims=(), start_index_map=axes
    )
    return jax.lax.gather(
        grid,
        st.base,
        numbers,
        slice_sizes=(3,) * dim + grid.shape[-1:],
        mode=jax.lax.GatherScatterMode.PROMISE_IN_BOUNDS,
    )


def particles_to_grid(st: Stencil, mass, momentum, affine, dx, grid_shape):
    """MLS-MPM particle-to-grid transfer.

    Args:
      st: stencil of the particles.
      mass: (n,) particle masses.
      momentum: (n, d) particle momenta m v.
      affine: (n, d, d) affine momentum matrix (stress term + m C).
      dx: grid spacing.
      grid_shape: nodes per axis.

    Returns:
      grid_mass (*grid_shape,), grid_momentum (*grid_shape, d).
    """
    dim = momentum.shape[-1]
    lead = (slice(None),) + (None,) * dim
    # momentum_i += w (m v + affine (x_i - x_p)),   x_i - x_p = offset * dx
    affine_dpos = jnp.sum(affine[lead] * (st.offset * dx)[..., None, :], axis=-1)
    node_momentum = st.weights[..., None] * (momentum[lead] + affine_dpos)
    node_mass = st.weights * mass[lead]
    values = jnp.concatenate([node_mass[..., None], node_momentum], axis=-1)
    grid = scatter_to_grid(st, values, grid_shape)
    return grid[..., 0], grid[..., 1:]


def grid_to_particles(st: Stencil, grid_velocity, dx):
    """MLS-MPM grid-to-particle transfer.

    Args:
      st: stencil of the particles.
      grid_velocity: (*grid_shape, d) node velocities.
      dx: grid spacing.

    Returns:
      v (n, d) new particle velocities, C (n, d, d) new affine matrices.
    """
    dim = grid_velocity.shape[-1]
    node_velocity = gather_from_grid(st, grid_velocity)  # (n, 3, .., 3, d)
    weighted = st.weights[..., None] * node_velocity
    axes = tuple(range(1, dim + 1))
    v = jnp.sum(weighted, axis=axes)
    C = (4.0 / dx) * jnp.sum(weighted[..., :, None] * st.offset[..., None, :], axis=axes)
    return v, C

"""Particle <-> grid transfers of MLS-MPM with quadratic B-splines, for any dimension.

Each particle touches the 3^d nodes starting at its `base` node. Rather than scattering 3^d single
values per particle, a particle's whole stencil is written as one window of a single `scatter` (and
read back as one window of a `gather`): XLA runs that much faster than 3^d times as many scalar
updates, and its transpose for reverse mode is again one windowed gather/scatter. Per-particle
arithmetic uses per-component (n,) arrays (see `litl.sim.linalg`).
"""

from __future__ import annotations

import itertools
from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

from litl.sim import linalg


@struct.dataclass
class Stencil:
    """Where and how strongly each particle talks to the grid.

    Attributes:
      base: (n, d) int32 index of the first node of each particle's 3^d stencil, clamped inside.
      weights: d lists of 3 arrays (n,): the B-spline weight along axis a of node offset k.
      fx: d arrays (n,): particle position relative to `base`, in cells (in [0.5, 1.5) inside).
      inside: (n,) bool, whether the unclamped stencil lies inside the grid.
    """

    base: jnp.ndarray
    weights: list
    node_weights: list
    fx: list
    inside: jnp.ndarray

    @property
    def dim(self) -> int:
        return len(self.fx)

    def nodes(self):
        """(offset tuple, weight (n,)) for the 3^d stencil nodes in window (C) order."""
        return zip(itertools.product(range(3), repeat=self.dim), self.node_weights, strict=True)


def stencil(x, dx, grid_shape, token=None) -> Stencil:
    """Quadratic B-spline stencil of particles at positions x (d arrays (n,)).

    With a `token` (see `linalg.materialize`) the 3^d node weights are computed into buffers, and
    so are their cotangents in reverse mode, which every position component's cotangent reads.
    """
    bases, fx = [], []
    inside: Any = True  # a bool array after the first axis
    for xa, n in zip(x, grid_shape, strict=True):
        cells = xa / dx - 0.5
        base = jnp.floor(cells)
        inside = inside & (base >= 0) & (base <= n - 3)
        # Clamping keeps every index valid (and every value finite) for particles that left the
        # grid; `inside` reports them so that the caller can raise.
        base = jnp.clip(base, 0, n - 3)
        bases.append(base.astype(jnp.int32))
        fx.append(cells + 0.5 - base)
    weights = [[0.5 * (1.5 - f) ** 2, 0.75 - (f - 1.0) ** 2, 0.5 * (f - 0.5) ** 2] for f in fx]
    node_weights = []
    for offset in itertools.product(range(3), repeat=len(fx)):
        weight = weights[0][offset[0]]
        for axis in range(1, len(fx)):
            weight = weight * weights[axis][offset[axis]]
        node_weights.append(weight)
    if token is not None:
        node_weights = linalg.materialize(node_weights, token)
    return Stencil(
        base=jnp.stack(bases, -1), weights=weights, node_weights=node_weights, fx=fx, inside=inside
    )


def _window_numbers(dim):
    window_dims = tuple(range(1, dim + 2))
    return window_dims, tuple(range(dim))


def _raw_scatter(base, values, grid_shape):
    window, axes = _window_numbers(base.shape[-1])
    numbers = jax.lax.ScatterDimensionNumbers(
        update_window_dims=window, inserted_window_dims=(), scatter_dims_to_operand_dims=axes
    )
    grid = jnp.zeros(tuple(grid_shape) + values.shape[-1:], values.dtype)
    return jax.lax.scatter_add(grid, base, values, numbers, mode=jax.lax.GatherScatterMode.PROMISE_IN_BOUNDS)


# Fixed-point sums (`SimConfig.particle_to_grid="fixed_point"`): every value is scaled by a power
# of two so that the absolute sum of a channel's values stays below 2^FIXED_BITS, rounded to an
# integer, and split into a high part (value >> LOW_BITS) and a low part (its last LOW_BITS bits),
# each summed as int32. Integer addition is exact and associative, so the grid does not depend on
# the order in which a scatter's additions land (atomics on a GPU): deterministic by
# construction. Bounds: |sum of high parts| < 2^(FIXED_BITS - LOW_BITS) < 2^31 always; the low
# parts overflow only past 2^(31 - LOW_BITS) = 2^19 contributions to one node.
FIXED_BITS = 42
LOW_BITS = 12
# The scale exponent of a channel that holds a non-finite value (valid ones lie in [-87, 190]).
NON_FINITE = -10_000


def _power_of_two(exponent, dtype):
    """2^exponent exactly, as `dtype` (float32 or float64), built from its bits: XLA:CPU's
    `ldexp` is 5-10x slower than the multiply it stands for. `exponent` stays within a normal
    float's range (|exponent| < 127 here)."""
    if jnp.dtype(dtype) == jnp.float64:
        bits = (exponent.astype(jnp.int64) + 1023) << 52
        return jax.lax.bitcast_convert_type(bits, jnp.float64)
    bits = (exponent.astype(jnp.int32) + 127) << 23
    return jax.lax.bitcast_convert_type(bits, jnp.float32)


def _scaled(values, shift):
    """values * 2^shift, exactly: the power in two halves, each a normal float."""
    half = shift // 2
    return values * _power_of_two(half, values.dtype) * _power_of_two(shift - half, values.dtype)


def _fixed_point(values, reduce_axes):
    """(int32 high and low parts along the channel axis, doubled; the scale exponent per
    channel, or `NON_FINITE` where a channel holds a non-finite value), `reduce_axes` the axes one scale
    covers (all but a batch axis and the channels)."""
    total = jnp.sum(jnp.abs(values), axis=reduce_axes, keepdims=True)
    finite = jnp.isfinite(total)
    _, exponent = jnp.frexp(jnp.where(finite, total, 0.0))  # total < 2^exponent (0 for 0)
    shift = FIXED_BITS - exponent
    scaled = jnp.round(_scaled(jnp.where(finite, values, 0.0), shift))  # an integer < 2^FIXED_BITS
    high = jnp.floor(scaled * (1.0 / 2**LOW_BITS))
    low = scaled - high * 2**LOW_BITS  # in [0, 2^LOW_BITS), exact
    return jnp.concatenate([high, low], axis=-1).astype(jnp.int32), jnp.where(finite, shift, NON_FINITE)


def _from_fixed_point(sums, shift, dtype):
    """The grid's float values from its summed int32 parts (`_fixed_point`); NaN throughout a
    channel that held a non-finite value, as a float sum would spread it (and a rollout's health
    report it), never a finite grid made of it."""
    channels = sums.shape[-1] // 2
    high, low = sums[..., :channels].astype(dtype), sums[..., channels:].astype(dtype)
    finite = shift != NON_FINITE
    grid = _scaled(high * 2**LOW_BITS + low, -jnp.where(finite, shift, 0))
    return jnp.where(finite, grid, jnp.nan)


def _raw_gather(base, grid):
    window, axes = _window_numbers(base.shape[-1])
    numbers = jax.lax.GatherDimensionNumbers(
        offset_dims=window, collapsed_slice_dims=(), start_index_map=axes
    )
    return jax.lax.gather(
        grid,
        base,
        numbers,
        slice_sizes=(3,) * base.shape[-1] + grid.shape[-1:],
        mode=jax.lax.GatherScatterMode.PROMISE_IN_BOUNDS,
    )


def _fold_batch(axis_size, in_batched, base, other, grid_rows):
    """Batched windows -> one unbatched set over grids stacked along axis 0."""
    if not in_batched[0]:
        base = jnp.broadcast_to(base, (axis_size,) + base.shape)
    if not in_batched[1]:
        other = jnp.broadcast_to(other, (axis_size,) + other.shape)
    shift = (jnp.arange(axis_size, dtype=base.dtype) * grid_rows)[:, None]
    base = base.at[..., 0].add(shift)
    return base.reshape((-1,) + base.shape[2:]), other


def _window_transfers(grid_shape, fixed_point: bool = False):
    """Windowed scatter/gather for one grid shape, batched by stacking grids along axis 0.

    Under `vmap`, JAX's generic scatter batching adds the batch as an extra indexed axis, which
    XLA:CPU executes with layout copies of every update window; stacking the batch's grids into
    one taller grid keeps it a plain windowed scatter/gather. With `fixed_point` the scatter sums
    integers (`_fixed_point`, one scale per batch element), the gather is unchanged.
    """
    rows = grid_shape[0]

    def summed(base, values, shape, batched: bool):
        if not fixed_point:
            return _raw_scatter(base, values, shape)
        if batched:  # (B, n, 3, ..., 3, c): one scale per batch element and channel
            parts, shift = _fixed_point(values, tuple(range(1, values.ndim - 1)))
            parts = parts.reshape((-1,) + parts.shape[2:])
            sums = _raw_scatter(base, _pad_channels(parts), shape)[..., : parts.shape[-1]]
            sums = sums.reshape((values.shape[0],) + tuple(grid_shape) + sums.shape[-1:])
            return _from_fixed_point(
                sums, shift.reshape(shift.shape[:1] + (1,) * dim + shift.shape[-1:]), values.dtype
            )
        parts, shift = _fixed_point(values, tuple(range(values.ndim - 1)))
        sums = _raw_scatter(base, _pad_channels(parts), shape)[..., : parts.shape[-1]]
        return _from_fixed_point(sums, shift.reshape((1,) * dim + shift.shape[-1:]), values.dtype)

    dim = len(grid_shape)

    @jax.custom_batching.custom_vmap
    def scatter(base, values):
        return summed(base, values, grid_shape, batched=False)

    @scatter.def_vmap
    def _scatter_batched(axis_size, in_batched, base, values):
        base, values = _fold_batch(axis_size, in_batched, base, values, rows)
        tall = (axis_size * rows,) + tuple(grid_shape[1:])
        if fixed_point:
            return summed(base, values, tall, batched=True), True
        values = values.reshape((-1,) + values.shape[2:])
        out = _raw_scatter(base, values, tall)
        return out.reshape((axis_size,) + tuple(grid_shape) + out.shape[-1:]), True

    @jax.custom_batching.custom_vmap
    def gather(base, grid):
        return _raw_gather(base, grid)

    @gather.def_vmap
    def _gather_batched(axis_size, in_batched, base, grid):
        n = base.shape[-2]
        base, grid = _fold_batch(axis_size, in_batched, base, grid, rows)
        out = _raw_gather(base, grid.reshape((-1,) + grid.shape[2:]))
        return out.reshape((axis_size, n) + out.shape[1:]), True

    @jax.custom_vjp
    def scatter_diff(base, values):
        return scatter(base, values)

    scatter_diff.defvjp(
        lambda base, values: (scatter(base, values), base),
        lambda base, cotangent: (None, gather_diff(base, cotangent)),
    )

    @jax.custom_vjp
    def gather_diff(base, grid):
        return gather(base, grid)

    gather_diff.defvjp(
        lambda base, grid: (gather(base, grid), base),
        lambda base, cotangent: (None, scatter_diff(base, cotangent)),
    )
    return scatter_diff, gather_diff


def _pad_channels(a):
    """Pad the last axis to a power of two.

    XLA:CPU's windowed scatter runs ~3x slower with 3-channel windows than with 4 (4.5 ms vs 1.6 ms
    for 28k particles on 64^3). Used for the 3D velocity gather, whose transpose is such a scatter
    (quadruped3d forward+backward 22.5 s -> 20.2 s); padding 2D's 3-channel P2G scatter the same
    way measured no faster in the whole step, so it is left as is.
    """
    channels = a.shape[-1]
    padded = 1 << (channels - 1).bit_length()
    if padded == channels:
        return a
    return jnp.pad(a, [(0, 0)] * (a.ndim - 1) + [(0, padded - channels)])


def scatter_to_grid(st: Stencil, values, grid_shape, fixed_point: bool = False):
    """Sum per-node particle values into the grid.

    Args:
      st: the particles' stencil.
      values: (n, 3, ..., 3, c) value each particle adds to each of its 3^d stencil nodes.
      grid_shape: nodes per axis.
      fixed_point: sum them as integers (`SimConfig.particle_to_grid="fixed_point"`): the same
        grid for any order of the additions; its transpose (reverse mode) is the same gather.

    Returns:
      (*grid_shape, c) grid of summed values.
    """
    scatter, _ = _window_transfers(tuple(grid_shape), fixed_point)
    return scatter(st.base, values)


def gather_from_grid(st: Stencil, grid, fixed_point: bool = False):
    """Read each particle's stencil of a (*grid_shape, c) grid: (n, 3, ..., 3, c). The gather is
    the same either way; `fixed_point` makes its transpose (reverse mode's scatter) sum so."""
    channels = grid.shape[-1]
    grid = _pad_channels(grid)  # so that the transpose (a scatter) is fast, see `_pad_channels`
    _, gather = _window_transfers(tuple(grid.shape[:-1]), fixed_point)
    return gather(st.base, grid)[..., :channels]


def particles_to_grid(
    st: Stencil, mass, momentum, affine, dx, grid_shape, token=None, extra=(), fixed_point: bool = False
):
    """MLS-MPM particle-to-grid transfer: node i gets w_ip (m_p, m_p v_p + A_p (x_i - x_p)).

    Args:
      st: stencil of the particles.
      mass: (n,) particle masses.
      momentum: d arrays (n,), particle momenta m v.
      affine: d x d arrays (n,), affine momentum matrix A (stress term + m C).
      dx: grid spacing.
      grid_shape: nodes per axis.
      extra: more (n,) per-particle values to scatter with the same weights (e.g. the mass of
        the particles an observer sees), each one more channel after the momentum.
      fixed_point: sum in fixed point (`scatter_to_grid`).

    Returns:
      (*grid_shape, 1 + d + len(extra)) grid holding the mass, then the momentum components
      (then the extra values).
    """
    dim = st.dim
    # x_i - x_p = (offset - fx) dx, so A (x_i - x_p) = dx A offset - dx A fx: the second part is
    # the same for all nodes and folds into the momentum once per particle.
    affine_fx = linalg.matvec(affine, st.fx)
    shifted = [p - dx * a for p, a in zip(momentum, affine_fx, strict=True)]
    if token is not None:  # its cotangent is read by every position component's cotangent
        shifted = linalg.materialize(shifted, token)
    columns = [[dx * affine[c][k] for k in range(dim)] for c in range(dim)]
    values = []
    for offset, weight in st.nodes():
        values.append(weight * mass)
        for c in range(dim):
            node = shifted[c]
            for k in range(dim):
                if offset[k]:
                    node = node + offset[k] * columns[c][k]
            values.append(weight * node)
        values.extend(weight * value for value in extra)
    values = linalg.stack(values, -1).reshape((-1,) + (3,) * dim + (1 + dim + len(extra),))
    return scatter_to_grid(st, values, grid_shape, fixed_point)


def grid_to_particles(st: Stencil, grid_velocity, dx, token=None, fixed_point: bool = False):
    """MLS-MPM grid-to-particle transfer.

    Args:
      st: stencil of the particles.
      grid_velocity: (*grid_shape, d) node velocities.
      dx: grid spacing.
      fixed_point: reverse mode's scatter of the gather's cotangent sums in fixed point.

    Returns:
      v: d arrays (n,), new particle velocities; C: d x d arrays (n,), new affine matrices
      C = 4/dx sum_i w_ip v_i (offset_i - fx)^T.
    """
    dim = st.dim
    gathered = gather_from_grid(st, grid_velocity, fixed_point)
    window = linalg.unstack(gathered.reshape(-1, 3**dim * dim), -1)
    v = [0.0] * dim
    moment = [[0.0] * dim for _ in range(dim)]  # sum_i w v_i offset_i^T
    for node, (offset, weight) in enumerate(st.nodes()):
        for c in range(dim):
            wv = weight * window[node * dim + c]
            v[c] = v[c] + wv
            for k in range(dim):
                if offset[k]:
                    moment[c][k] = moment[c][k] + offset[k] * wv
    if token is not None:  # read by C and, in reverse mode, by every position cotangent
        v = linalg.materialize(v, token)
    C = [[(4.0 / dx) * (moment[c][k] - v[c] * st.fx[k]) for k in range(dim)] for c in range(dim)]
    return v, C

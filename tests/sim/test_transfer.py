"""Windowed scatter/gather: batching rules and derivatives agree with the plain definitions."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.sim import linalg, transfer

# Physics, gradients and determinism: worth running on a GPU (`pytest -m gpu`).
pytestmark = pytest.mark.gpu

SHAPE = (12, 10)


def _stencil(seed):
    x = np.random.default_rng(seed).uniform(0.15, 0.85, (30, 2))
    return transfer.stencil(linalg.split_vec(jnp.asarray(x)), 1 / 10, SHAPE)


def _values(seed, channels=3):
    return jnp.asarray(np.random.default_rng(seed).normal(size=(30, 3, 3, channels)))


def _dense_scatter(st, values):
    """The definition: each window entry added to its node, one by one."""
    grid = np.zeros(SHAPE + (values.shape[-1],))
    base = np.asarray(st.base)
    for p in range(base.shape[0]):
        for i in range(3):
            for j in range(3):
                grid[base[p, 0] + i, base[p, 1] + j] += np.asarray(values[p, i, j])
    return grid


@pytest.mark.parametrize("batched", ["values", "base", "both"])
def test_vmapped_scatter_and_gather_match_single_calls(batched, x64):
    stencils = [_stencil(s) for s in range(3)]
    values = [_values(10 + s) for s in range(3)]
    grids = [jnp.asarray(np.random.default_rng(20 + s).normal(size=SHAPE + (2,))) for s in range(3)]
    if batched == "values":
        stencils = [stencils[0]] * 3
    stacked = lambda items: jax.tree.map(lambda *a: jnp.stack(a), *items)
    base_axis = None if batched == "values" else 0
    value_axis = None if batched == "base" else 0
    if batched == "base":
        values, grids = [values[0]] * 3, [grids[0]] * 3
    scatter = jax.vmap(
        lambda b, v: transfer.scatter_to_grid(stencils[0].replace(base=b), v, SHAPE),
        in_axes=(base_axis, value_axis),
    )
    gather = jax.vmap(
        lambda b, g: transfer.gather_from_grid(stencils[0].replace(base=b), g),
        in_axes=(base_axis, value_axis),
    )
    bases = stacked([s.base for s in stencils]) if base_axis == 0 else stencils[0].base
    vs = stacked(values) if value_axis == 0 else values[0]
    gs = stacked(grids) if value_axis == 0 else grids[0]
    out_scatter, out_gather = jax.jit(scatter)(bases, vs), jax.jit(gather)(bases, gs)
    for k in range(3):
        np.testing.assert_allclose(out_scatter[k], _dense_scatter(stencils[k], values[k]), atol=1e-12)
        np.testing.assert_allclose(
            out_gather[k], transfer.gather_from_grid(stencils[k], grids[k]), atol=1e-12
        )


def test_scatter_and_gather_are_adjoint_under_vmap_and_grad(x64):
    stencils = [_stencil(s) for s in range(2)]
    bases = jnp.stack([s.base for s in stencils])
    values = jnp.stack([_values(s) for s in range(2)])
    weights = jnp.asarray(np.random.default_rng(5).normal(size=(2,) + SHAPE + (3,)))

    def loss(b, v, w):
        grid = transfer.scatter_to_grid(stencils[0].replace(base=b), v, SHAPE)
        back = transfer.gather_from_grid(stencils[0].replace(base=b), jnp.sin(grid) * w)
        return jnp.sum(back**2)

    per_entry = jax.jit(jax.vmap(jax.grad(loss, argnums=1)))(bases, values, weights)
    of_sum = jax.jit(jax.grad(lambda v: jnp.sum(jax.vmap(loss)(bases, v, weights))))(values)
    for k in range(2):
        single = jax.grad(loss, argnums=1)(bases[k], values[k], weights[k])
        np.testing.assert_allclose(per_entry[k], single, atol=1e-10)
        np.testing.assert_allclose(of_sum[k], single, atol=1e-10)
    nested = jax.vmap(jax.vmap(loss, in_axes=(None, 0, None)), in_axes=(0, None, 0))(bases, values, weights)
    for i in range(2):
        for j in range(2):
            np.testing.assert_allclose(nested[i, j], loss(bases[i], values[j], weights[i]), rtol=1e-12)


@pytest.mark.parametrize("dtype", [jnp.float32, jnp.float64])
def test_a_fixed_point_sum_is_the_definition_to_rounding_and_ignores_the_order(dtype, x64):
    """`fixed_point=True`: the grid agrees with the one-by-one sum to float32 rounding (its
    integers keep 42 bits below each channel's total), and reordering the particles, which
    reorders a scatter's additions, changes no bit of it (integer sums are associative)."""
    st = _stencil(3)
    values = _values(4, channels=4).astype(dtype) * jnp.asarray([1.0, 1e-3, 10.0, 0.0], dtype)
    exact = _dense_scatter(st, np.asarray(values, np.float64))
    fixed = jax.jit(lambda s, v: transfer.scatter_to_grid(s, v, SHAPE, fixed_point=True))
    grid = np.asarray(fixed(st, values), np.float64)
    np.testing.assert_allclose(grid, exact, rtol=2e-7, atol=1e-12 * np.abs(exact).max())
    assert not grid[..., 3].any()  # a channel of zeros stays zero
    order = np.random.default_rng(0).permutation(values.shape[0])
    shuffled = st.replace(base=st.base[order])
    np.testing.assert_array_equal(np.asarray(fixed(shuffled, values[order])), np.asarray(fixed(st, values)))
    # Under vmap each batch element has its own scale: the same grids as one at a time.
    stacked = jax.vmap(lambda v: transfer.scatter_to_grid(st, v, SHAPE, fixed_point=True))
    pair = jnp.stack([values, 1e3 * values])
    np.testing.assert_array_equal(np.asarray(stacked(pair)[0]), np.asarray(fixed(st, values)))
    np.testing.assert_array_equal(np.asarray(stacked(pair)[1]), np.asarray(fixed(st, 1e3 * values)))


def test_a_fixed_point_scatter_has_the_gather_as_its_transpose(x64):
    st = _stencil(5)
    values = _values(6)
    weights = jnp.asarray(np.random.default_rng(7).normal(size=SHAPE + (3,)))

    def loss(v, fixed_point):  # linear in the grid: its gradient is the transpose applied to weights
        grid = transfer.scatter_to_grid(st, v, SHAPE, fixed_point=fixed_point)
        return jnp.sum(grid * weights)

    transpose = transfer.gather_from_grid(st, weights)
    np.testing.assert_array_equal(np.asarray(jax.grad(loss)(values, True)), np.asarray(transpose))
    np.testing.assert_array_equal(np.asarray(jax.grad(loss)(values, False)), np.asarray(transpose))


def test_a_non_finite_value_is_not_summed_into_a_finite_fixed_point_grid():
    st = _stencil(8)
    values = _values(9).astype(jnp.float32).at[4, 1, 1, 2].set(jnp.nan)
    grid = np.asarray(transfer.scatter_to_grid(st, values, SHAPE, fixed_point=True))
    assert np.isnan(grid[..., 2]).all()  # the channel that held it
    np.testing.assert_allclose(
        grid[..., :2], _dense_scatter(st, np.asarray(values))[..., :2], rtol=2e-6, atol=1e-6
    )


def test_a_fixed_point_sum_of_huge_values_keeps_their_scale():
    """A channel whose total passes 2^42 scales down (a negative shift), not into NaN."""
    st = _stencil(10)
    values = _values(11).astype(jnp.float32) * 1e15
    grid = np.asarray(transfer.scatter_to_grid(st, values, SHAPE, fixed_point=True), np.float64)
    exact = _dense_scatter(st, np.asarray(values, np.float64))
    np.testing.assert_allclose(grid, exact, rtol=2e-6, atol=1e-12 * np.abs(exact).max())

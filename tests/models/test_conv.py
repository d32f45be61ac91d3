"""The autoencoder's matmul convolutions compute what XLA's convolutions compute."""

import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax import lax

from litl.models import conv, vae


def _numbers(d):
    spatial = "DHW"[-d:]
    return (f"N{spatial}C", f"{spatial}IO", f"N{spatial}C")


@pytest.mark.parametrize("spatial,kernel", [((9, 6), 3), ((8, 7), 2), ((5, 4, 6), 3), ((4, 4, 4), 4)])
def test_strided_and_transposed_convolutions_equal_lax(spatial, kernel, x64):
    d = len(spatial)
    keys = jax.random.split(jax.random.PRNGKey(0), 4)
    x = jax.random.normal(keys[0], (2, *spatial, 3), jnp.float64)
    w = jax.random.normal(keys[1], (kernel,) * d + (3, 5), jnp.float64)
    expected = lax.conv_general_dilated(x, w, (2,) * d, "SAME", dimension_numbers=_numbers(d))
    np.testing.assert_allclose(jax.jit(conv.strided_conv)(x, w), expected, rtol=1e-12, atol=1e-12)
    expected_t = lax.conv_transpose(x, w, (2,) * d, "SAME", dimension_numbers=_numbers(d))
    np.testing.assert_allclose(jax.jit(conv.strided_conv_transpose)(x, w), expected_t, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("transpose", [False, True])
def test_the_layer_has_flaxs_parameters_outputs_and_gradients(transpose, x64):
    x = jax.random.normal(jax.random.PRNGKey(1), (2, 6, 5, 4, 3), jnp.float64)
    reference = (nn.ConvTranspose if transpose else nn.Conv)(4, (3, 3, 3), (2, 2, 2), "SAME")
    params = reference.init(jax.random.PRNGKey(2), x)
    for implementation in ("xla", "matmul"):
        layer = conv.StridedConv(4, 3, implementation, transpose=transpose)
        mine = layer.init(jax.random.PRNGKey(2), x)
        assert jax.tree_util.tree_all(
            jax.tree_util.tree_map(lambda a, b: bool(jnp.array_equal(a, b)), mine, params)
        )

        def loss(p, model):
            return jnp.sum(jnp.sin(model.apply(p, x)))

        np.testing.assert_allclose(layer.apply(params, x), reference.apply(params, x), rtol=1e-12, atol=1e-12)
        gradient = jax.jit(jax.grad(loss), static_argnums=1)
        grads = gradient(params, layer), gradient(params, reference)
        for a, b in zip(*map(jax.tree_util.tree_leaves, grads), strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-12)


def test_auto_picks_matmul_on_the_cpu_and_unknown_names_are_refused():
    on_cpu = jax.default_backend() == "cpu"
    assert conv.resolve("auto", 3) == ("matmul" if on_cpu else "xla")
    assert conv.resolve("auto", 2) == ("matmul" if on_cpu else "xla")
    with pytest.raises(ValueError, match="choose one of"):
        conv.resolve("fft", 2)
    with pytest.raises(ValueError, match="unknown convolution"):
        vae.ConvAutoencoder(grid_shape=(32, 32), convolution="fft")

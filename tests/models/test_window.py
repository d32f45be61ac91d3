"""The observer's window: a fixed box of grid nodes that follows the robot."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.models.window import Window


def test_size_is_rounded_up_to_multiples_of_32_nodes_and_capped_by_the_grid():
    assert Window.around((64, 64), 1 / 64, 0.5).shape == (32, 32)
    assert Window.around((128, 128), 1 / 128, 0.5).shape == (64, 64)
    assert Window.around((128, 128), 1 / 128, 0.3).shape == (64, 64)  # 38.4 nodes -> 64
    assert Window.around((64, 32, 32), 1 / 32, 0.5).shape == (32, 32, 32)  # 16 -> 32
    assert Window.around((64, 64), 1 / 64, 2.0).whole_grid
    assert Window.around((64, 64), 1 / 64, None).whole_grid


@pytest.mark.parametrize("size", [0.0, -1.0, float("nan"), True, "0.5"])
def test_bad_size_says_what_to_set(size):
    with pytest.raises(ValueError, match="positive length in domain units"):
        Window.around((64, 64), 1 / 64, size)


def test_crop_is_centred_on_the_robot_and_stays_inside_the_grid():
    window = Window.around((64, 64), 1 / 64, 0.5)
    field = jnp.arange(64 * 64 * 2, dtype=jnp.float32).reshape(64, 64, 2)
    # Centre (0.5, 0.25): nodes 32 and 16, so the window starts at nodes 16 and 0.
    np.testing.assert_array_equal(window.crop(field, jnp.array([0.5, 0.25])), field[16:48, 0:32])
    # Near the walls the window is clamped rather than padded.
    np.testing.assert_array_equal(window.crop(field, jnp.array([0.98, 0.02])), field[32:64, 0:32])
    np.testing.assert_array_equal(window.corner(jnp.array([-1.0, 5.0])), [0, 32])


def test_crop_is_jittable_vmappable_and_passes_gradients_to_the_window_only():
    window = Window.around((64, 64), 1 / 64, 0.5)
    fields = jnp.ones((3, 64, 64, 2))
    centres = jnp.array([[0.2, 0.2], [0.5, 0.5], [0.8, 0.3]])
    crops = jax.jit(jax.vmap(window.crop))(fields, centres)
    assert crops.shape == (3, 32, 32, 2)
    grad = jax.grad(lambda f: jnp.sum(window.crop(f, centres[1])))(fields[0])
    assert float(grad.sum()) == 32 * 32 * 2
    assert float(grad[16:48, 16:48].sum()) == 32 * 32 * 2


def test_crop_works_in_float64():
    # Under jax_enable_x64 a Python int index is int64; the window's indices must agree in type.
    window = Window.around((64, 64), 1 / 64, 0.5)
    with jax.enable_x64(True):
        field = jnp.arange(64 * 64 * 2, dtype=jnp.float64).reshape(64, 64, 2)
        crop = jax.jit(window.crop)(field, jnp.array([0.5, 0.25], jnp.float64))
        np.testing.assert_array_equal(crop, field[16:48, 0:32])

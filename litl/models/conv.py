"""Stride-2 convolutions of the autoencoder, as XLA convolutions or as shifted matrix products.

Both implementations compute the same function from the same parameters (`flax.linen.Conv` and
`flax.linen.ConvTranspose` with "SAME" padding, stride 2, any kernel size), so a model trained with
one runs with the other. They differ only in speed:

* ``"xla"``: `lax.conv_general_dilated` / `lax.conv_transpose`, fast wherever the backend has a
  tuned convolution (GPU).
* ``"matmul"``: every kernel tap is a strided slice (or, transposed, a shift of the input into
  one of the 2^d output phases) and the taps are contracted in one matrix product. XLA's CPU
  backend has no fast 3D convolution; on the 3D VAE (batch 8, 32^3 window) this is ~30x faster for
  the gradient of a strided convolution and ~15x for a transposed one (`benchmarks/vae_conv.py`).
  In 2D it is ~1.5x faster for one model, and ~2.5x once seeds are vmapped (each seed's kernel
  makes XLA's CPU convolution a slow grouped one; matmul becomes a batched matrix product):
  `benchmarks/vae_conv.py --seeds 10`.
* ``"auto"``: ``"matmul"`` on the CPU, ``"xla"`` otherwise.
"""

from __future__ import annotations

import itertools

import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

IMPLEMENTATIONS = ("auto", "xla", "matmul")
STRIDE = 2


def resolve(implementation: str, dim: int) -> str:
    """The implementation `"auto"` stands for on this backend, for `dim`-dimensional fields."""
    if implementation not in IMPLEMENTATIONS:
        raise ValueError(
            f"unknown convolution implementation {implementation!r}; choose one of {list(IMPLEMENTATIONS)}"
        )
    if implementation == "auto":
        return "matmul" if jax.default_backend() == "cpu" else "xla"
    return implementation


def _same_padding(n: int, kernel: int) -> tuple[int, int]:
    """lax's "SAME" padding of one axis of length n for a stride-2 convolution."""
    total = max((-(-n // STRIDE) - 1) * STRIDE + kernel - n, 0)
    return total // 2, total - total // 2


def strided_conv(x, kernel):
    """Equals `lax.conv_general_dilated(x, kernel, (2,)*d, "SAME")` (channels last):
    x (B, *spatial, C_in), kernel (*(k,)*d, C_in, C_out) -> (B, *ceil(spatial/2), C_out)."""
    spatial = x.shape[1:-1]
    k = kernel.shape[0]
    padded = jnp.pad(x, [(0, 0)] + [_same_padding(n, k) for n in spatial] + [(0, 0)])
    out = [-(-n // STRIDE) for n in spatial]
    taps = []
    for offsets in itertools.product(range(k), repeat=len(spatial)):
        window = tuple(slice(t, t + STRIDE * (m - 1) + 1, STRIDE) for t, m in zip(offsets, out, strict=True))
        taps.append(padded[(slice(None),) + window])
    return jnp.concatenate(taps, axis=-1) @ kernel.reshape(-1, kernel.shape[-1])


def _shift(x, offsets):
    """y[m] = x[m + s] along each spatial axis (zero where m + s falls outside)."""
    config, window = [(0, 0, 0)], [slice(None)]
    for s, n in zip(offsets, x.shape[1:-1], strict=True):
        config.append((max(-s, 0), max(s, 0), 0))
        window.append(slice(max(s, 0), max(s, 0) + n))
    config.append((0, 0, 0))
    window.append(slice(None))
    return lax.pad(x, jnp.zeros((), x.dtype), config)[tuple(window)]


def strided_conv_transpose(x, kernel):
    """Equals `lax.conv_transpose(x, kernel, (2,)*d, "SAME")` (channels last, kernel not
    flipped): x (B, *spatial, C_in), kernel (*(k,)*d, C_in, C_out) -> (B, *2 spatial, C_out).

    Output node j = 2m + p of an axis (phase p) collects tap t from input node m + (p + t - a)/2
    where p + t - a is even (a: lax's leading padding of the dilated input), so each of the 2^d
    phases is one matrix product of shifted inputs; the phases are then interleaved."""
    d = x.ndim - 2
    k = kernel.shape[0]
    lead = k - 1 if k - 1 < STRIDE else int(np.ceil((k + STRIDE - 2) / 2))
    phases = []
    for phase in itertools.product(range(STRIDE), repeat=d):
        inputs, weights = [], []
        for taps in itertools.product(range(k), repeat=d):
            steps = [p + t - lead for p, t in zip(phase, taps, strict=True)]
            if all(s % STRIDE == 0 for s in steps):
                inputs.append(_shift(x, [s // STRIDE for s in steps]))
                weights.append(kernel[taps])
        phases.append(jnp.concatenate(inputs, -1) @ jnp.concatenate(weights, 0))
    batch, spatial, channels = x.shape[0], x.shape[1:-1], kernel.shape[-1]
    y = jnp.stack(phases, axis=-2).reshape((batch, *spatial) + (STRIDE,) * d + (channels,))
    order = [0] + [a for i in range(d) for a in (1 + i, 1 + d + i)] + [1 + 2 * d]
    return y.transpose(order).reshape((batch,) + tuple(STRIDE * n for n in spatial) + (channels,))


class StridedConv(nn.Module):
    """`nn.Conv(features, (kernel,)*d, strides=2, padding="SAME")`, same parameters, computed by
    `implementation` ("xla" or "matmul")."""

    features: int
    kernel: int
    implementation: str = "xla"
    transpose: bool = False

    @nn.compact
    def __call__(self, x):
        d = x.ndim - 2
        shape = (self.kernel,) * d + (x.shape[-1], self.features)
        kernel = self.param("kernel", nn.initializers.lecun_normal(), shape, jnp.float32)
        bias = self.param("bias", nn.initializers.zeros_init(), (self.features,), jnp.float32)
        dtype = jnp.result_type(x, kernel, bias)  # as flax's promote_dtype
        x, kernel, bias = x.astype(dtype), kernel.astype(dtype), bias.astype(dtype)
        if self.implementation == "matmul":
            y = (strided_conv_transpose if self.transpose else strided_conv)(x, kernel)
        else:
            numbers = lax.conv_dimension_numbers(x.shape, kernel.shape, _channels_last(d))
            strides = (STRIDE,) * d
            y = (
                lax.conv_transpose(x, kernel, strides, "SAME", dimension_numbers=numbers)
                if self.transpose
                else lax.conv_general_dilated(x, kernel, strides, "SAME", dimension_numbers=numbers)
            )
        return y + bias


def _channels_last(d: int):
    spatial = "DHW"[-d:]
    return (f"N{spatial}C", f"{spatial}IO", f"N{spatial}C")

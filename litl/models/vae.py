"""Convolutional (variational) autoencoder of grid velocity fields, 2D and 3D (paper Fig. 3).

Input: a grid velocity field (*grid_shape, d) with d = 2 or 3 channels.
  * Size: the field is zero-padded at the high end of every axis up to a multiple of 2^5, since the
    encoder halves it five times; zero is what an empty grid holds, so padding adds no signal. The
    decoder's output is cropped back.
  * Normalization: velocities are divided by `scale`, a non-trained observer parameter set from the
    training data (the RMS velocity of occupied nodes in the replay buffer) at every learning phase,
    so the encoder's input keeps unit size while the robot learns to move faster, and stays fixed
    within an episode.
Encoder: five stride-2 convolutions with an activation (ELU by default, ReLU as in the paper's
architecture), flattened to the mean and log-variance of r latents (the mean only for the plain
autoencoder). Decoder: a dense layer back to the coarsest grid, then five stride-2 transposed
convolutions, the activation between them and none at the end.

Why ELU: the velocity field is mostly empty grid, so predicting zero is a strong attractor, and
ReLU units that die there stay dead. Measured on 500 biped snapshots (dx 1/64, latent 8, trained on
one seed's buffer): validation `recon_explained` 0.62 with ELU vs 0.51 with ReLU after 200 Adam
steps (lr 3e-3), 0.73 vs 0.67 after 100 epochs (lr 3e-3 vs 1e-3), and 8 vs 5 active latents.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, Self

import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np
import optax
from flax import struct

from litl.models.conv import IMPLEMENTATIONS, StridedConv
from litl.models.conv import resolve as resolve_convolution
from litl.models.window import Window

LEVELS = 5
INITIAL_LOG_VARIANCE = -4.0
ACTIVATIONS = {"elu": nn.elu, "relu": nn.relu}


def padded_shape(grid_shape) -> tuple[int, ...]:
    """Grid shape rounded up per axis to a multiple of 2^5."""
    step = 2**LEVELS
    return tuple(-(-n // step) * step for n in grid_shape)


def pad_field(field, grid_shape):
    """(..., *grid_shape, d) -> (..., *padded_shape, d), zeros at the high ends."""
    target = padded_shape(grid_shape)
    lead = field.ndim - len(grid_shape) - 1
    pads = [(0, 0)] * lead + [(0, t - n) for n, t in zip(grid_shape, target, strict=True)] + [(0, 0)]
    return jnp.pad(field, pads)


class ConvAutoencoder(nn.Module):
    """Encoder/decoder of velocity fields; `variational=False` gives the plain autoencoder.

    Attributes:
      grid_shape: nodes per axis of the simulator grid (2 or 3 axes).
      latent_dim: r, the number of latent variables.
      channels: feature channels of the five encoder convolutions (mirrored by the decoder).
      variational: VAE (mean and log-variance) or plain AE (a point code).
      kernel: convolution kernel size along each axis.
      activation: ``"elu"`` or ``"relu"`` (the paper's), between the convolutions.
      convolution: how the convolutions are computed, "auto", "xla" or "matmul"
        (`litl.models.conv`); the same function either way, only the speed differs.
    """

    grid_shape: tuple[int, ...]
    latent_dim: int = 8
    channels: Sequence[int] = (8, 16, 32, 32, 64)
    variational: bool = True
    kernel: int = 3
    activation: str = "elu"
    convolution: str = "auto"

    def __post_init__(self):
        if self.activation not in ACTIVATIONS:
            raise ValueError(f"unknown activation {self.activation!r}; choose one of {sorted(ACTIVATIONS)}")
        if self.convolution not in IMPLEMENTATIONS:
            raise ValueError(
                f"unknown convolution {self.convolution!r}; choose one of {list(IMPLEMENTATIONS)}"
            )
        if len(self.grid_shape) not in (2, 3):
            raise ValueError(f"grid_shape must have 2 or 3 axes, got {self.grid_shape!r}")
        if len(self.channels) != LEVELS or any(c < 1 for c in self.channels):
            raise ValueError(f"channels must be {LEVELS} positive widths, got {self.channels!r}")
        if self.latent_dim < 1:
            raise ValueError(f"latent_dim must be positive, got {self.latent_dim!r}")
        super().__post_init__()

    @property
    def dim(self) -> int:
        return len(self.grid_shape)

    def setup(self):
        how = resolve_convolution(self.convolution, self.dim)
        self.encoder_convs = [StridedConv(c, self.kernel, how) for c in self.channels]
        self.to_mean = nn.Dense(self.latent_dim)
        # The posterior starts narrow (sigma ~ 0.1): with sigma ~ 1 the sampling noise swamps the
        # freshly initialized means and the decoder first learns to ignore the code.
        self.to_log_variance = (
            nn.Dense(self.latent_dim, bias_init=nn.initializers.constant(INITIAL_LOG_VARIANCE))
            if self.variational
            else None
        )
        coarse = tuple(n // 2**LEVELS for n in padded_shape(self.grid_shape))
        self.coarse_shape = coarse + (self.channels[-1],)
        self.from_latent = nn.Dense(int(np.prod(self.coarse_shape)))
        # A linear head from the encoder means to the field's mean over the grid (`momentum`).
        self.to_momentum = nn.Dense(self.dim)
        out_channels = list(self.channels[-2::-1]) + [self.dim]
        self.decoder_convs = [StridedConv(c, self.kernel, how, transpose=True) for c in out_channels]

    def encode(self, field):
        """(B, *grid_shape, d) normalized fields -> mean (B, r), log-variance (B, r) or None."""
        h = pad_field(field, self.grid_shape)
        act = ACTIVATIONS[self.activation]
        for conv in self.encoder_convs:
            h = act(conv(h))
        h = h.reshape(h.shape[0], -1)
        log_variance = self.to_log_variance(h) if self.variational else None
        return self.to_mean(h), log_variance

    def decode(self, z):
        """(B, r) latents -> (B, *grid_shape, d) normalized fields."""
        act = ACTIVATIONS[self.activation]
        h = act(self.from_latent(z)).reshape((z.shape[0],) + self.coarse_shape)
        for index, conv in enumerate(self.decoder_convs):
            h = conv(h)
            if index < LEVELS - 1:
                h = act(h)
        crop = (slice(None),) + tuple(slice(0, n) for n in self.grid_shape)
        return h[crop]

    def momentum(self, mean):
        """(B, r) encoder means -> (B, d) a linear estimate of the input field's mean over the
        grid (in the mass-weighted field: the robot's momentum per node); trained only with
        `loop.learning.momentum_weight` > 0."""
        return self.to_momentum(mean)

    def __call__(self, field, key=None):
        """Reconstruct; with a key, a VAE samples z = mean + sigma * noise (else z = mean)."""
        mean, log_variance = self.encode(field)
        if self.is_initializing():
            self.momentum(mean)  # creates the head's parameters
        z = mean
        if self.variational and key is not None:
            z = mean + jnp.exp(0.5 * log_variance) * jax.random.normal(key, mean.shape, mean.dtype)
        return self.decode(z), mean, log_variance


@struct.dataclass
class AutoencoderParams:
    """Observer parameters: network weights and the (non-trained) input scale.

    Attributes:
      network: flax parameters of `ConvAutoencoder`.
      scale: () velocity scale the fields are divided by.
    """

    network: Mapping[str, Any]
    scale: jnp.ndarray

    if TYPE_CHECKING:  # flax.struct adds `replace` at run time; declared for the type checker

        def replace(self, **changes: Any) -> Self: ...


# The initializer as one program, optimized as little as XLA can: it draws each layer's weights
# once (a truncated normal per tensor, thousands of lines of HLO) and computes nothing else, so its
# compilation is all of its cost. Op by op (flax's init outside jit) it compiled one program per
# layer and shape; at XLA's default level 3, one program took 8.5 s for the 3D VAE; at level 0,
# 1 s. The weights are those of level 3 to the last bit in 96% of them and within 1 ulp in the
# rest (docs/results/benchmarks.md, "Start-up: the initialization in one program").
INIT_COMPILER_OPTIONS = {"xla_backend_optimization_level": 0}


def init_autoencoder(model: ConvAutoencoder, key, dtype=jnp.float32) -> AutoencoderParams:
    """Θ for `model`: its network's initial weights (flax's initializers, drawn from `key`) and
    an input scale of 1 (`fit_scale` sets it from data).

    Called with a concrete key, one compiled program per model and dtype (`INIT_COMPILER_OPTIONS`);
    inside another trace (jit, vmap, eval_shape) it is traced in place, as XLA takes compiler
    options only at the top level."""
    if isinstance(key, jax.core.Tracer):
        return _init_autoencoder(model, key, jnp.dtype(dtype))
    return _init_autoencoder_compiled(model, key, jnp.dtype(dtype))


def _init_autoencoder(model: ConvAutoencoder, key, dtype) -> AutoencoderParams:
    field = jnp.zeros((1,) + tuple(model.grid_shape) + (model.dim,), dtype)
    return AutoencoderParams(network=model.init(key, field), scale=jnp.asarray(1.0, dtype))


_init_autoencoder_compiled = jax.jit(
    _init_autoencoder, static_argnums=(0, 2), compiler_options=INIT_COMPILER_OPTIONS
)


def fit_scale(params: AutoencoderParams, fields, floor=1e-6) -> AutoencoderParams:
    """Set the input scale to the RMS velocity over occupied nodes of `fields` (B, *grid, d).

    Fields with no motion (RMS at most `floor`, e.g. a robot without gravity that the untrained
    controller leaves at rest) say nothing about the velocity scale: the scale is kept as it
    was. Setting it to the floor instead would multiply every later input, and the controller's
    gradient through the features, by 1 / floor (seen: the arm under method=paper, gradient
    norms 1e8 to inf after such a bootstrap).
    """
    speed_sq = jnp.sum(fields**2, axis=-1)
    occupied = speed_sq > 0
    rms = jnp.sqrt(jnp.sum(speed_sq) / jnp.maximum(jnp.sum(occupied), 1))
    moving = rms > floor
    scale = jnp.where(moving, rms, params.scale).astype(params.scale.dtype)
    return params.replace(scale=scale)


def make_observer(model: ConvAutoencoder, window: Window | None = None):
    """`observe(params, state, grid_velocity) -> (r,)` encoder means, for use inside rollouts.

    With a `window` the encoder sees the window of the grid around the particles' centroid
    (`model.grid_shape` must be the window's shape); without one, the whole grid.
    """
    window = window or Window(model.grid_shape, model.grid_shape, 1.0)
    if tuple(window.shape) != tuple(model.grid_shape):
        raise ValueError(
            f"the model's grid_shape {tuple(model.grid_shape)} must be the window's shape {window.shape}"
        )

    def observe(params: AutoencoderParams, state, grid_velocity):
        field = grid_velocity
        if not window.whole_grid:
            field = window.crop(grid_velocity, jnp.mean(state.x, axis=0))
        mean, _ = model.apply(params.network, field[None] / params.scale, method="encode")
        return mean[0]

    return observe


def loss_terms(
    model: ConvAutoencoder, params: AutoencoderParams, fields, key=None, beta=1.0, momentum_weight=0.0
):
    """`losses` plus what held-out evaluation needs from the same forward pass.

    Returns the dict of `losses` and: signal, the mean squared normalized input (the error of
    predicting an empty field, for `explained_variance`); code, the (B, r) encoder means;
    distance, the mean over nodes of |reconstruction - field| in the field's own units (the
    paper's Fig. 5 unit, "average pixel distance").
    """
    x = fields / params.scale
    # flax types `apply` as returning Any or (Any, variables): the type checker cannot tell which.
    reconstruction, mean, log_variance = model.apply(params.network, x, key)  # type: ignore[misc]
    recon = jnp.mean((reconstruction - x) ** 2)
    fit = recon
    if momentum_weight:
        spatial = tuple(range(1, x.ndim - 1))
        estimate: jnp.ndarray = model.apply(params.network, mean, method="momentum")  # type: ignore[assignment]
        fit = fit + momentum_weight * jnp.mean((estimate - jnp.mean(x, axis=spatial)) ** 2)
    if model.variational:
        kl = 0.5 * jnp.mean(jnp.sum(jnp.exp(log_variance) + mean**2 - 1.0 - log_variance, axis=-1))
    else:
        kl = jnp.zeros((), recon.dtype)
    return {
        "recon": recon,
        "kl": kl,
        "total": fit + beta * kl / np.prod(x.shape[1:]),
        "signal": jnp.mean(x**2),
        "code": mean,
        "distance": jnp.mean(jnp.sqrt(jnp.sum((reconstruction - x) ** 2, axis=-1))) * params.scale,
    }


def losses(
    model: ConvAutoencoder, params: AutoencoderParams, fields, key=None, beta=1.0, momentum_weight=0.0
):
    """Mean per-pixel squared reconstruction error, KL to N(0, I) per sample, and their total.

    total = recon + beta * KL / (values per field): the negative ELBO of a unit-variance Gaussian
    decoder, divided by the number of values so that its size does not depend on the grid.

    Args:
      fields: (B, *grid_shape, d) raw velocity fields (normalized here by `params.scale`).
      key: sampling key for the VAE (None: use the means, e.g. for validation).
      beta: weight of the KL term.
      momentum_weight: w; adds w x the mean squared error of the linear head
        (`ConvAutoencoder.momentum`) against the field's mean over the grid (0: the paper's loss).
    """
    terms = loss_terms(model, params, fields, key, beta, momentum_weight)
    return {name: terms[name] for name in ("recon", "kl", "total")}


def explained_variance(recon, signal):
    """1 - recon / signal: the fraction of a field's energy that its reconstruction explains.

    `recon` and `signal` are mean squared reconstruction error and mean squared input over the
    same values (so a blank prediction scores 0, a perfect one 1). Velocity fields are compared
    with zero, what an empty grid holds, rather than with their mean.
    """
    return 1.0 - recon / signal


def active_units(code_mean, code_square_mean, threshold=0.01):
    """Latent units whose encoder mean varies across the data: Var(E[z_u]) > threshold.

    The measure of Burda et al. (2016); `code_mean` and `code_square_mean` (r,) are the mean and
    the mean square of the encoder means over the snapshots.
    """
    return jnp.sum(code_square_mean - code_mean**2 > threshold).astype(jnp.int32)


def per_pixel_reconstruction_loss(model, params: AutoencoderParams, fields):
    """Average per-pixel velocity distance |D(E(v)) - v| in the fields' own units (paper Fig. 5)."""
    x = fields / params.scale
    reconstruction, _, _ = model.apply(params.network, x)
    return jnp.mean(jnp.linalg.norm(reconstruction - x, axis=-1)) * params.scale


def make_train_step(
    model: ConvAutoencoder, optimizer: optax.GradientTransformation, beta=1.0, momentum_weight=0.0
):
    """`step(params, opt_state, fields, key) -> (params, opt_state, losses)`: one Adam step.

    Pure and jittable; vmappable over seeds. Only the network is trained; the scale is kept.
    """

    def step(params: AutoencoderParams, opt_state, fields, key):
        def objective(network):
            out = losses(model, params.replace(network=network), fields, key, beta, momentum_weight)
            return out["total"], out

        grads, out = jax.grad(objective, has_aux=True)(params.network)
        updates, opt_state = optimizer.update(grads, opt_state, params.network)
        return params.replace(network=optax.apply_updates(params.network, updates)), opt_state, out

    return step

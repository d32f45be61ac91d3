"""Convolutional VAE / AE of grid velocity fields."""

import chex
import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest

from litl.models import vae
from litl.models.controller import MLPController

# The tests' own evaluations as compiled programs: run eagerly, a VAE's forward pass compiles each
# of its ~200 operations on its own (5.1 s against 0.7 s for one program, on 2 CPU cores).
loss_terms = jax.jit(vae.loss_terms, static_argnums=0, static_argnames=("beta", "momentum_weight"))
losses = jax.jit(vae.losses, static_argnums=0)
per_pixel_reconstruction_loss = jax.jit(vae.per_pixel_reconstruction_loss, static_argnums=0)


def synthetic_fields(n, shape=(32, 32), seed=0):
    """Velocity fields of a disc: slightly random position, translation velocity and spin."""
    rng = np.random.default_rng(seed)
    grid = np.stack(np.meshgrid(*[np.arange(s) / s for s in shape], indexing="ij"), -1)
    fields = []
    for _ in range(n):
        centre = rng.uniform(0.45, 0.55, 2)
        velocity, spin = rng.normal(0, 1, 2), rng.normal(0, 2)
        r = grid - centre
        inside = (np.sum(r**2, -1) < 0.2**2)[..., None]
        field = velocity + spin * np.stack([-r[..., 1], r[..., 0]], -1)
        fields.append(inside * field)
    return jnp.asarray(np.stack(fields), jnp.float32)


def test_init_is_one_program_per_model_and_the_same_inside_a_trace():
    """`init_autoencoder` compiles one program per model and dtype (at XLA's level 0, whatever
    the caller's); traced inside the caller's jit or vmap it draws the same weights, to the
    float32 rounding of the two levels."""
    model = vae.ConvAutoencoder((16, 24), latent_dim=3, channels=(4, 4, 8, 8, 8))
    key = jax.random.key(3)
    compiled = vae._init_autoencoder_compiled
    params = vae.init_autoencoder(model, key)
    programs = compiled._cache_size()
    again = vae.init_autoencoder(vae.ConvAutoencoder((16, 24), latent_dim=3, channels=(4, 4, 8, 8, 8)), key)
    assert compiled._cache_size() == programs  # an equal model: the same program
    chex.assert_trees_all_equal(again, params)
    traced = jax.jit(vae.init_autoencoder, static_argnums=0)(model, key)
    chex.assert_trees_all_close(traced, params, rtol=1e-6, atol=0)
    batched = jax.jit(jax.vmap(lambda k: vae.init_autoencoder(model, k)))(jnp.stack([key, jax.random.key(4)]))
    chex.assert_trees_all_close(jax.tree.map(lambda leaf: leaf[0], batched), params, rtol=1e-6, atol=0)
    assert compiled._cache_size() == programs  # traced in place, not through the program
    assert float(params.scale) == 1.0 and params.scale.dtype == jnp.float32


@pytest.mark.parametrize("grid_shape", [(64, 48), (20, 20, 20)])
def test_shapes_2d_and_3d(grid_shape):
    model = vae.ConvAutoencoder(grid_shape, latent_dim=5, channels=(4, 4, 8, 8, 8))  # narrow: fast
    params = jax.jit(vae.init_autoencoder, static_argnums=0)(model, jax.random.key(0))
    fields = jnp.ones((3,) + grid_shape + (len(grid_shape),))
    reconstruction, mean, log_variance = jax.jit(model.apply)(params.network, fields, jax.random.key(1))
    assert reconstruction.shape == fields.shape
    assert mean.shape == log_variance.shape == (3, 5)
    assert jax.jit(vae.make_observer(model))(params, None, fields[0]).shape == (5,)
    assert vae.padded_shape(grid_shape) == tuple(-(-n // 32) * 32 for n in grid_shape)


def _train(model, fields, steps=500, seed=0):
    params = vae.fit_scale(vae.init_autoencoder(model, jax.random.key(seed)), fields)
    optimizer = optax.adam(3e-3)
    opt_state = optimizer.init(params.network)
    step = jax.jit(vae.make_train_step(model, optimizer, beta=1.0))
    key = jax.random.key(seed + 1)
    for _ in range(steps):
        key, batch_key, noise_key = jax.random.split(key, 3)
        batch = fields[jax.random.choice(batch_key, len(fields), (32,), replace=False)]
        params, opt_state, out = step(params, opt_state, batch, noise_key)
    return params, out


@pytest.mark.compute_bound
@pytest.mark.parametrize("variational", [True, False])
def test_training_beats_predicting_the_mean(variational):
    fields = synthetic_fields(256)
    model = vae.ConvAutoencoder((32, 32), latent_dim=6, variational=variational)
    # 300 steps: the held-out error is then well below 0.3 of the mean's (VAE and plain
    # autoencoder: 0.21 and 0.17 after 250 steps, 0.19 and 0.12 after 500; 100 steps cost
    # ~2 s on a CPU).
    params, out = _train(model, fields, steps=300)
    held_out = synthetic_fields(64, seed=1)
    val = losses(model, params, held_out)
    x = held_out / params.scale
    baseline = float(jnp.mean((x - jnp.mean(fields / params.scale, 0)) ** 2))
    assert float(val["recon"]) < 0.3 * baseline
    if variational:
        assert float(out["kl"]) > 0
    else:
        assert float(out["kl"]) == 0.0
    distance = per_pixel_reconstruction_loss(model, params, held_out)
    assert np.isfinite(float(distance)) and float(distance) > 0


def test_scale_follows_the_data():
    model = vae.ConvAutoencoder((32, 32), latent_dim=2)
    params = vae.init_autoencoder(model, jax.random.key(0))
    fields = synthetic_fields(8)
    slow, fast = vae.fit_scale(params, fields), vae.fit_scale(params, 10 * fields)
    np.testing.assert_allclose(fast.scale, 10 * slow.scale, rtol=1e-5)


def test_fields_without_motion_keep_the_scale():
    # A robot at rest (no gravity, an untrained controller that outputs zero) fills the buffer
    # with zero fields, or round-off: the scale must stay what it was, not drop to the floor
    # and multiply every later input by 1 / floor.
    model = vae.ConvAutoencoder((32, 32), latent_dim=2)
    params = vae.init_autoencoder(model, jax.random.key(0))
    fitted = vae.fit_scale(params, synthetic_fields(4))
    for still in (jnp.zeros((4, 32, 32, 2)), jnp.full((4, 32, 32, 2), 1e-9)):
        assert float(vae.fit_scale(params, still).scale) == 1.0
        np.testing.assert_allclose(vae.fit_scale(fitted, still).scale, fitted.scale)
    # Just above the floor it is motion again.
    slow = jnp.zeros((1, 32, 32, 2)).at[0, 3, 4, 0].set(2e-6)
    np.testing.assert_allclose(vae.fit_scale(params, slow).scale, 2e-6, rtol=1e-6)


def test_gradient_flows_from_actuation_to_grid_velocity():
    model = vae.ConvAutoencoder((32, 32), latent_dim=4)
    params = vae.init_autoencoder(model, jax.random.key(0))
    controller = MLPController(n_actuators=3, widths=(8,))
    control = controller.init(jax.random.key(1), jnp.zeros(4))
    observe = vae.make_observer(model)
    field = synthetic_fields(1)[0]
    actuation = lambda v: jnp.sum(controller.apply(control, observe(params, None, v)) ** 2)
    grad = jax.jit(jax.grad(actuation))(field)
    assert grad.shape == field.shape and float(jnp.abs(grad).sum()) > 0


def test_bad_settings():
    with pytest.raises(ValueError, match="2 or 3 axes"):
        vae.ConvAutoencoder((32,))
    with pytest.raises(ValueError, match="5 positive widths"):
        vae.ConvAutoencoder((32, 32), channels=(8, 8))
    with pytest.raises(ValueError, match="latent_dim"):
        vae.ConvAutoencoder((32, 32), latent_dim=0)
    with pytest.raises(ValueError, match="unknown activation 'tanh'"):
        vae.ConvAutoencoder((32, 32), activation="tanh")


def test_closed_loop_rollout_with_vae_observer_has_finite_gradients():
    from litl.sim import make_rollout
    from tests.models.closed_loop import assert_finite_nonzero_gradients
    from tests.sim.scenes import block

    config, body, design, state = block(2, n_grid=24, lower=0.3, size=0.25)
    model = vae.ConvAutoencoder(config.grid_shape, latent_dim=4)
    observer = vae.init_autoencoder(model, jax.random.key(0))
    observe = vae.make_observer(model)
    controller = MLPController(n_actuators=body.n_actuators, widths=(16,))
    params = controller.init(jax.random.key(1), jnp.zeros(4))
    policy = lambda p, s, grid_velocity: controller.apply(p, observe(observer, s, grid_velocity))
    rollout = make_rollout(config, body, policy, 40)
    assert_finite_nonzero_gradients(rollout, params, design, state)
    # Batched over two controllers (seeds) in one computation, as the loop runs them.
    two = jax.tree.map(lambda a: jnp.stack([a, -a]), params)
    batched = jax.jit(jax.vmap(lambda p: rollout(p, design, state)[0].x))(two)
    for i in range(2):
        single = jax.jit(lambda p: rollout(p, design, state)[0].x)(jax.tree.map(lambda a, i=i: a[i], two))
        np.testing.assert_allclose(batched[i], single, rtol=1e-4, atol=1e-5)


def test_momentum_term_is_the_linear_heads_error_on_the_field_mean():
    """total = recon + w * mean_c (head(mean) - mean over nodes of x)^2 + beta * KL / values; w = 0
    is the paper's loss."""
    model = vae.ConvAutoencoder((32, 32), latent_dim=3, channels=(4, 4, 8, 8, 8))
    params = vae.fit_scale(vae.init_autoencoder(model, jax.random.key(0)), synthetic_fields(4))
    fields = synthetic_fields(4, seed=2)
    plain = loss_terms(model, params, fields, beta=0.5)
    weighted = loss_terms(model, params, fields, beta=0.5, momentum_weight=3.0)
    x = fields / params.scale
    head = jax.jit(lambda network, code: model.apply(network, code, method="momentum"))(
        params.network, plain["code"]
    )
    expected = jnp.mean((head - jnp.mean(x, axis=(1, 2))) ** 2)
    np.testing.assert_allclose(weighted["total"] - plain["total"], 3.0 * expected, rtol=1e-5)
    np.testing.assert_allclose(plain["total"], plain["recon"] + 0.5 * plain["kl"] / (32 * 32 * 2), rtol=1e-6)
    assert float(expected) > 0


def _readout_r2(codes, targets, train, held_out):
    design = np.c_[codes, np.ones(len(codes))]
    weights = np.linalg.lstsq(design[train], targets[train], rcond=None)[0]
    residual = np.mean((design[held_out] @ weights - targets[held_out]) ** 2, axis=0)
    return 1 - residual / np.var(targets[held_out], axis=0)


@pytest.mark.compute_bound
def test_momentum_term_makes_the_codes_tell_the_fields_mean_linearly():
    """Discs that spin, swell and shear strongly and translate slowly: the mean velocity is a
    small part of the field's energy, and three latents cannot hold all five factors. Without the
    momentum term the codes keep the large factors; with it a linear readout of the codes gives
    the mean on held-out fields, and the one latent left still reconstructs about one large
    factor (a third of the energy)."""
    rng = np.random.default_rng(3)
    shape = (32, 32)
    grid = np.stack(np.meshgrid(*[np.arange(s) / s for s in shape], indexing="ij"), -1)
    fields, means = [], []
    for _ in range(320):
        r = grid - rng.uniform(0.45, 0.55, 2)
        inside = (np.sum(r**2, -1) < 0.2**2)[..., None]
        spin, swell, shear = rng.normal(0, 3, 3)
        field = inside * (
            0.2 * rng.normal(0, 1, 2)
            + spin * np.stack([-r[..., 1], r[..., 0]], -1)
            + swell * r
            + shear * np.stack([r[..., 1], r[..., 0]], -1)
        )
        fields.append(field)
        means.append(field.mean(axis=(0, 1)))
    fields, means = jnp.asarray(np.stack(fields), jnp.float32), np.stack(means)
    train, held_out = np.arange(256), np.arange(256, 320)
    model = vae.ConvAutoencoder(shape, latent_dim=3, channels=(8, 8, 16, 16, 16))
    scores = {}
    for weight in (0.0, 10.0):
        params = vae.fit_scale(vae.init_autoencoder(model, jax.random.key(0)), fields[train])
        optimizer = optax.adam(3e-3)
        opt_state = optimizer.init(params.network)
        step = jax.jit(vae.make_train_step(model, optimizer, beta=1.0, momentum_weight=weight))
        key = jax.random.key(1)
        for _ in range(300):
            key, batch_key, noise_key = jax.random.split(key, 3)
            batch = fields[train][jax.random.choice(batch_key, len(train), (32,), replace=False)]
            params, opt_state, _ = step(params, opt_state, batch, noise_key)
        terms = loss_terms(model, params, fields)
        codes = np.asarray(terms["code"], np.float64)
        held = loss_terms(model, params, fields[held_out])
        scores[weight] = (
            _readout_r2(codes, means, train, held_out),
            float(vae.explained_variance(held["recon"], held["signal"])),
        )
    r2, explained = scores[10.0]
    assert np.all(r2 > 0.9), scores
    assert np.all(scores[0.0][0] < 0.5), scores
    assert explained > 0.2, scores

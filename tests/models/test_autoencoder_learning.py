"""Learning phase of the observer copy and the target update."""

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.config import LearningConfig
from litl.loop.retraining import soft_update
from litl.models import replay_buffer, vae
from litl.models.replay_buffer import ReplayBuffer
from litl.observers import autoencoder_learning as learning

GRID = (32, 32)
CAPACITY = 40
MODEL = vae.ConvAutoencoder(GRID, latent_dim=4, channels=(4, 4, 8, 8, 8))
CONFIG = LearningConfig(
    patience_steps=None, max_steps=None, max_epochs=12, batch_size=5, patience=4, learning_rate=1e-2
)
EMPTY = np.zeros((0,) + GRID + (2,), np.float32)


def moving_discs(n, seed=0):
    """(n, 32, 32, 2) velocity fields of discs at random positions, translating and spinning."""
    rng = np.random.default_rng(seed)
    grid = np.stack(np.meshgrid(*[np.arange(s) / s for s in GRID], indexing="ij"), -1)
    fields = []
    for _ in range(n):
        r = grid - rng.uniform(0.35, 0.65, 2)
        inside = (np.sum(r**2, -1) < 0.2**2)[..., None]
        velocity, spin = rng.normal(0, 1, 2), rng.normal(0, 2)
        fields.append(inside * (velocity + spin * np.stack([-r[..., 1], r[..., 0]], -1)))
    return np.stack(fields).astype(np.float32)


def buffer_of(fields, capacity=CAPACITY, dtype=jnp.float32):
    return replay_buffer.add(ReplayBuffer.empty(capacity, GRID, 2, dtype), jnp.asarray(fields, dtype))


def assert_trees_equal(a, b):
    for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b), strict=True):
        np.testing.assert_array_equal(x, y)


def assert_stopping_rule(stats, config):
    """The phase ran to max_epochs or stopped exactly `patience` epochs after its best one."""
    epochs, best = int(stats.epochs_used), int(stats.best_epoch)
    assert 1 <= best <= epochs <= config.max_epochs
    assert epochs == config.max_epochs or epochs - best == config.patience


@pytest.fixture(scope="module")
def learn():
    return jax.jit(learning.make_learning_phase(MODEL, CONFIG))


@pytest.fixture(scope="module")
def two_params():
    """Initial observers of two seeds (one jitted init: eager init compiles op by op, slowly)."""
    init = jax.jit(vae.init_autoencoder, static_argnums=0)
    return init(MODEL, jax.random.key(0)), init(MODEL, jax.random.key(1))


@pytest.fixture(scope="module")
def params(two_params):
    return two_params[0]


def test_learning_lowers_validation_loss(learn, params):
    buffer = buffer_of(moving_discs(34))  # not a multiple of b: the last minibatch is partial
    best, stats = learn(params, buffer, jax.random.key(1))
    split = learning.random_split(buffer.count, CAPACITY, jax.random.split(jax.random.key(1))[0])
    validation = buffer.fields[np.asarray(split.validation)[np.asarray(split.validation_mask)]]
    assert len(validation) == 17
    # Before training, with the scale refitted the same way the phase does.
    initial = learning.fit_scale_masked(params, buffer.fields, replay_buffer.valid_mask(buffer))
    np.testing.assert_allclose(best.scale, initial.scale, rtol=1e-6)
    # The objective the phase trains: the VAE loss with the phase's KL and momentum weights
    # (the observer's defaults, `observer.vae.beta` and `.momentum_weight`).
    weights = dict(beta=1.0, momentum_weight=0.3)
    losses = jax.jit(vae.losses, static_argnums=0, static_argnames=tuple(weights))  # one program
    before = losses(MODEL, initial, validation, **weights)
    after = losses(MODEL, best, validation, **weights)
    # A few dozen Adam steps only get partway down from the initial loss (seen: 0.93-0.95 of it).
    assert float(after["total"]) < 0.97 * float(before["total"])
    # The stats describe the returned parameters.
    np.testing.assert_allclose(stats.val_loss, after["total"], rtol=1e-5)
    np.testing.assert_allclose(stats.recon_loss_val, after["recon"], rtol=1e-5)
    np.testing.assert_allclose(stats.kl, after["kl"], rtol=1e-5)
    assert np.isfinite(float(stats.recon_loss_train))
    assert_stopping_rule(stats, CONFIG)
    # Fig. 5's unit: the best epoch's mean error per node |D(E(v)) - v|, in the field's units.
    distance = jax.jit(vae.per_pixel_reconstruction_loss, static_argnums=0)(MODEL, best, validation)
    best_epoch = int(stats.best_epoch) - 1
    np.testing.assert_allclose(stats.val_distance_history[best_epoch], distance, rtol=1e-5)
    epochs = int(stats.epochs_used)
    assert np.all(np.isfinite(stats.val_distance_history[:epochs]))
    assert np.all(np.isnan(stats.val_distance_history[epochs:]))


def test_early_stopping_when_validation_cannot_improve(params):
    # With a zero learning rate every epoch has the same validation loss: epoch 1 stays the best
    # and epoch 1 + patience is the last.
    config = LearningConfig(
        patience_steps=None, max_steps=None, max_epochs=5, batch_size=8, patience=2, learning_rate=0.0
    )
    learn = jax.jit(learning.make_learning_phase(MODEL, config))
    best, stats = learn(params, buffer_of(moving_discs(12)), jax.random.key(2))
    assert int(stats.epochs_used) == 3 and int(stats.best_epoch) == 1
    assert_trees_equal(best.network, params.network)


@pytest.mark.parametrize("count", [0, 1, 2, 7, 30, CAPACITY])
def test_split_is_even_disjoint_and_covers_valid_entries(count):
    split = jax.jit(learning.random_split, static_argnums=1)(count, CAPACITY, jax.random.key(3))
    train = np.asarray(split.train)[np.asarray(split.train_mask)]
    validation = np.asarray(split.validation)[np.asarray(split.validation_mask)]
    assert len(train) == count - count // 2 and len(validation) == count // 2
    assert set(train).isdisjoint(validation)
    assert sorted(np.concatenate([train, validation]).tolist()) == list(range(count))


def test_split_is_random():
    draw = lambda seed: learning.random_split(20, CAPACITY, jax.random.key(seed)).train
    assert not np.array_equal(draw(0), draw(1))
    # Uniform: over 400 keys each of 20 valid slots is drawn for training with probability 1/2.
    # Its share has standard deviation sqrt(0.25 / 400) = 0.025; 0.5 +- 0.125 is 5 of them (all
    # 20 slots inside with probability 1 - 1e-5), while a split that favours some slots fails.
    keys = jax.random.split(jax.random.key(5), 400)
    split = jax.jit(jax.vmap(lambda key: learning.random_split(20, CAPACITY, key)))(keys)
    chosen = np.zeros(CAPACITY)
    for slots, mask in zip(np.asarray(split.train), np.asarray(split.train_mask), strict=True):
        chosen[slots[mask]] += 1
    np.testing.assert_allclose(chosen[:20] / len(keys), 0.5, atol=0.125)
    assert not chosen[20:].any()


def test_only_valid_entries_are_used(learn, params):
    fields = moving_discs(20)
    clean = buffer_of(fields)
    # Stale slots holding garbage, including values whose square overflows and NaN.
    garbage = clean.replace(fields=clean.fields.at[20:30].set(1e30).at[30:].set(jnp.nan))
    key = jax.random.key(4)
    expected_params, expected_stats = learn(params, clean, key)
    got_params, got_stats = learn(params, garbage, key)
    # Another input array, so another reduction order is allowed: equal to float32 rounding
    # (garbage that leaked in would be off by orders of magnitude, or NaN).
    chex.assert_trees_all_close(got_params, expected_params, rtol=1e-5, atol=1e-6)
    chex.assert_trees_all_close(got_stats, expected_stats, rtol=1e-5, atol=1e-6)


def test_masked_scale_fit_ignores_masked_entries(params):
    fields = moving_discs(6)
    garbage = jnp.asarray(fields).at[4:].set(1e30).at[5].set(jnp.nan)
    mask = jnp.arange(6) < 4
    masked = learning.fit_scale_masked(params, garbage, mask)
    np.testing.assert_allclose(masked.scale, vae.fit_scale(params, fields[:4]).scale, rtol=1e-6)


def test_same_key_same_result_and_other_key_differs(learn, params, deterministic):
    buffer = buffer_of(moving_discs(16))
    first = learn(params, buffer, jax.random.key(5))
    assert_trees_equal(first, learn(params, buffer, jax.random.key(5)))
    other, _ = learn(params, buffer, jax.random.key(6))
    kernel = lambda p: p.network["params"]["to_mean"]["kernel"]
    assert not np.array_equal(kernel(other), kernel(first[0]))


def test_too_few_entries_leave_params_unchanged(learn, params):
    for fields in (EMPTY, moving_discs(1)):
        best, stats = learn(params, buffer_of(fields), jax.random.key(7))
        assert_trees_equal(best, params)
        assert int(stats.epochs_used) == 0 and int(stats.best_epoch) == 0
        assert np.isnan(float(stats.val_loss))


def test_vmap_over_seeds_equals_separate_runs(two_params, x64):
    # The paper's loss (no momentum head): the keys below were chosen for its stopping epochs.
    config = LearningConfig(
        patience_steps=None,
        max_steps=None,
        max_epochs=4,
        batch_size=4,
        patience=1,
        learning_rate=1e-2,
    )
    learn = learning.make_learning_phase(MODEL, config, momentum_weight=0.0)
    as64 = lambda tree: jax.tree.map(lambda x: jnp.asarray(x, jnp.float64), tree)
    seeds = [as64(p) for p in two_params]
    keys = jax.random.split(jax.random.key(0), 2)
    buffers = [buffer_of(moving_discs(n, seed=n), capacity=16, dtype=jnp.float64) for n in (9, 16)]
    stack = lambda trees: jax.tree.map(lambda *leaves: jnp.stack(leaves), *trees)
    batched_params, batched_stats = jax.jit(jax.vmap(learn))(stack(seeds), stack(buffers), keys)
    single = jax.jit(learn)
    epochs = []
    for seed in range(2):
        expected_params, expected_stats = single(seeds[seed], buffers[seed], keys[seed])
        assert_stopping_rule(expected_stats, config)
        epochs.append(int(expected_stats.epochs_used))
        for a, b in zip(jax.tree.leaves(batched_params), jax.tree.leaves(expected_params), strict=True):
            np.testing.assert_allclose(a[seed], b, rtol=1e-9, atol=1e-12)
        for a, b in zip(jax.tree.leaves(batched_stats), jax.tree.leaves(expected_stats), strict=True):
            np.testing.assert_allclose(a[seed], b, rtol=1e-9, atol=1e-12)
    # The seeds stop after different numbers of epochs (keys chosen so), so the batched loop has
    # to hold a stopped seed still while the other trains on.
    assert epochs[0] != epochs[1], epochs


def test_soft_update(two_params):
    target = two_params[0].replace(scale=jnp.asarray(2.0))
    online = two_params[1].replace(scale=jnp.asarray(4.0))
    assert_trees_equal(soft_update(target, online, 1.0), online)
    assert_trees_equal(soft_update(target, online, 0.0), target)
    half = jax.jit(soft_update)(target, online, 0.5)
    assert float(half.scale) == 3.0
    for h, t, o in zip(*(jax.tree.leaves(p) for p in (half, target, online)), strict=True):
        np.testing.assert_allclose(h, (t + o) / 2, rtol=1e-6, atol=1e-7)
    with pytest.raises(ValueError, match=r"alpha must be in \[0, 1\]"):
        soft_update(target, online, 1.5)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"max_epochs": 0}, "^loop.learning.max_epochs=0: must be a positive integer"),
        ({"batch_size": 2.0}, "batch_size=2.0: must be a positive integer"),
        ({"patience": -1}, "patience=-1: must be a positive integer"),
        ({"learning_rate": -1e-3}, "learning_rate=-0.001: must be a number >= 0"),
        ({"learning_rate": float("nan")}, "learning_rate=nan: must be a number >= 0"),
        ({"learning_rate": "1"}, "learning_rate='1': must be a number >= 0"),
    ],
)
def test_bad_config(kwargs, message):
    with pytest.raises(ValueError, match=message):
        LearningConfig(**kwargs)


def test_bad_arguments(params):
    with pytest.raises(ValueError, match="must be a LearningConfig"):
        learning.make_learning_phase(MODEL, {"max_epochs": 3})
    learn = learning.make_learning_phase(MODEL, CONFIG)
    wrong = ReplayBuffer.empty(4, (16, 16), 2)
    with pytest.raises(ValueError, match=r"model expects \(32, 32, 2\)"):
        learn(params, wrong, jax.random.key(0))


def test_explained_variance_and_active_units_have_known_answers():
    x = jnp.asarray(moving_discs(6))
    recon = jnp.mean((0.5 * x - x) ** 2)  # reconstructions at half the size
    assert float(vae.explained_variance(recon, jnp.mean(x**2))) == pytest.approx(0.75)
    assert float(vae.explained_variance(jnp.mean(x**2), jnp.mean(x**2))) == 0.0  # blank output
    codes = jnp.stack([jnp.linspace(-1, 1, 11), jnp.full(11, 3.0), 0.05 * jnp.linspace(-1, 1, 11)], 1)
    assert int(vae.active_units(codes.mean(0), (codes**2).mean(0))) == 1


def test_an_epoch_costs_what_the_buffer_holds_not_its_capacity(params):
    evaluated = []

    class Counting(vae.ConvAutoencoder):
        def encode(self, field):
            jax.debug.callback(lambda n: evaluated.append(int(n)), field.shape[0])
            return super().encode(field)

    model = Counting(GRID, latent_dim=4, channels=(4, 4, 8, 8, 8))
    config = LearningConfig(
        patience_steps=None, max_steps=None, max_epochs=3, batch_size=5, patience=3, learning_rate=1e-2
    )
    learn = jax.jit(learning.make_learning_phase(model, config))
    fields = moving_discs(10)
    counts = {}
    for capacity in (10, 400):
        evaluated.clear()
        jax.block_until_ready(learn(params, buffer_of(fields, capacity), jax.random.key(0)))
        counts[capacity] = sum(evaluated)
    assert counts[400] == counts[10] > 0


def test_patience_and_budget_in_sgd_steps(learn, params):
    buffer = buffer_of(moving_discs(20))  # 10 training entries: 2 minibatches of 5
    config = LearningConfig(
        max_epochs=50, batch_size=5, patience=1, patience_steps=6, max_steps=14, learning_rate=1e-2
    )
    _, stats = jax.jit(learning.make_learning_phase(MODEL, config))(params, buffer, jax.random.key(0))
    epochs, best = int(stats.epochs_used), int(stats.best_epoch)
    assert int(stats.steps_per_epoch) == 2
    # Stops at the 14-step budget (7 epochs) or 3 epochs (6 steps) after its best one.
    assert epochs == 7 or epochs - best == 3
    assert epochs >= 3  # a patience of one epoch would have allowed stopping after epoch 2
    with pytest.raises(ValueError, match="patience_steps=0: must be a positive integer"):
        LearningConfig(patience_steps=0)


def test_velocity_readout_r2_has_known_answers():
    rng = np.random.default_rng(0)
    codes = jnp.asarray(rng.normal(size=(200, 3)))
    features = jnp.concatenate([codes, jnp.ones((200, 1))], axis=1)
    n = features.shape[0]
    exact = codes @ jnp.asarray([[1.0, 0.0], [2.0, 0.5], [0.0, -1.0]]) + 0.3
    noise = jnp.asarray(rng.normal(size=(200, 2)))
    for target, expected in ((exact, 1.0), (noise, 0.0)):
        readout = learning.fit_readout(features.T @ features / n, features.T @ target / n)
        means = {
            "residual": jnp.mean((features @ readout - target) ** 2, axis=0),
            "target": jnp.mean(target, axis=0),
            "target_square": jnp.mean(target**2, axis=0),
        }
        np.testing.assert_allclose(learning.readout_r2(means), expected, atol=0.05)
    # The target: the mean velocity over occupied nodes (empty nodes do not dilute it).
    field = np.zeros((1, 8, 8, 2), np.float32)
    field[0, 2:4, 2:4] = (1.0, -2.0)
    np.testing.assert_allclose(replay_buffer.occupied_mean(jnp.asarray(field)), [[1.0, -2.0]])


def test_learning_stats_velocity_r2_matches_an_independent_fit(params):
    """velocity_r2: fit on the training half, scored on the validation half, at the best params."""
    config = LearningConfig(max_epochs=3, batch_size=8, learning_rate=3e-3)
    fields = moving_discs(40)
    key = jax.random.key(1)
    best, stats = jax.jit(learning.make_learning_phase(MODEL, config))(params, buffer_of(fields, 40), key)
    split = learning.random_split(40, 40, jax.random.split(key)[0])
    x = fields / float(best.scale)
    encode = jax.jit(lambda network, x: MODEL.apply(network, x, method="encode")[0])
    codes = np.asarray(encode(best.network, jnp.asarray(x)), np.float64)
    occupied = np.any(x != 0, axis=-1)
    target = (x * occupied[..., None]).sum((1, 2)) / occupied.sum((1, 2))[:, None]
    design = np.c_[codes, np.ones(len(codes))]
    train, validation = np.asarray(split.train), np.asarray(split.validation)
    readout = np.linalg.lstsq(design[train], target[train], rcond=None)[0]
    residual = ((design[validation] @ readout - target[validation]) ** 2).mean(0)
    expected = 1 - residual / target[validation].var(0)
    np.testing.assert_allclose(stats.velocity_r2, expected, rtol=1e-3, atol=1e-3)


def test_the_progress_line_follows_the_epochs_of_a_running_phase(learn, params):
    """Epoch and validation loss come out of the jitted phase as it runs, to the callback it was
    built with (the progress display's); a phase built without one reports nothing and learns
    the same."""
    import io

    from litl.loop.progress import Progress

    heard = []
    log = io.StringIO()
    bar = Progress(3, 2, stream=log)

    def on_epoch(epoch, loss):
        heard.append((int(epoch), float(loss)))
        bar.on_epoch(epoch, loss)

    buffer = buffer_of(moving_discs(20))
    reporting = jax.jit(learning.make_learning_phase(MODEL, CONFIG, on_epoch=on_epoch))
    with bar.learning(0):
        _, stats = jax.block_until_ready(reporting(params, buffer, jax.random.key(2)))
    assert [epoch for epoch, _ in heard] == list(range(1, int(stats.epochs_used) + 1))
    history = np.asarray(stats.val_recon_history)[: len(heard)]
    assert np.all(np.isfinite([loss for _, loss in heard])) and np.all(np.isfinite(history))
    assert f"learning phase: epoch {int(stats.epochs_used)}, validation loss" in log.getvalue()
    _, quiet_stats = jax.block_until_ready(learn(params, buffer, jax.random.key(2)))
    assert len(heard) == int(stats.epochs_used)  # nothing more was reported
    assert int(quiet_stats.epochs_used) == int(stats.epochs_used)
    np.testing.assert_allclose(quiet_stats.val_recon_history, stats.val_recon_history, rtol=1e-6)

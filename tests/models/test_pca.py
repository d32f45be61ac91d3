"""The PCA observer (`litl.observers.pca`): its fit on the replay buffer, its features, its errors."""

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.config import SettingsError
from litl.loop import make_algorithm
from litl.models.replay_buffer import ReplayBuffer, add
from litl.observers import ObserverContext, make
from litl.observers.autoencoder_learning import random_split
from litl.observers.pca import PCAParams, PCASettings, fit, project, reconstruct
from tests.loop.tiny import tiny_config, tiny_robot

SHAPE, DIM = (8, 8), 2
SIZE = 8 * 8 * 2


def planted(n, seed=0, noise=1e-4, scales=(3.0, 1.0)):
    """(n, 8, 8, 2) fields mean + a·u + b·v (+ noise) and the orthonormal (SIZE, 2) basis [u, v];
    a and b are normal with standard deviations `scales`."""
    rng = np.random.default_rng(seed)
    basis, _ = np.linalg.qr(rng.normal(size=(SIZE, 2)))
    mean = rng.normal(size=SIZE)
    coefficients = rng.normal(size=(n, 2)) * np.asarray(scales)
    flat = mean + coefficients @ basis.T + noise * rng.normal(size=(n, SIZE))
    return flat.reshape(n, *SHAPE, DIM).astype(np.float32), basis


def buffer_of(fields, capacity=32):
    buffer = ReplayBuffer.empty(capacity, SHAPE, DIM, jnp.float32)
    return add(buffer, jnp.asarray(fields), jnp.zeros((len(fields), DIM), jnp.float32))


def placeholder(rank=2):
    return PCAParams(mean=jnp.zeros(SIZE), components=jnp.zeros((SIZE, rank)), std=jnp.ones(rank))


def test_the_fit_finds_a_planted_subspace_and_whitens_the_features():
    # Neither component has unit standard deviation already: whitening must divide both.
    fields, basis = planted(24, scales=(3.0, 0.25))
    key = jax.random.key(0)
    fitted, stats = jax.jit(fit, static_argnums=3)(placeholder(), buffer_of(fields), key, 2)
    components = np.asarray(fitted.components)
    # The span is the planted one (projectors agree), and the columns are orthonormal.
    np.testing.assert_allclose(components @ components.T, basis @ basis.T, atol=1e-3)
    np.testing.assert_allclose(components.T @ components, np.eye(2), atol=1e-5)
    assert int(stats["snapshots"]) == 12
    assert float(stats["recon_explained"]) > 0.999
    assert float(stats["recon_loss_val"]) < 1e-6
    # Features over the training snapshots (the fit's own half of the buffer) have unit standard
    # deviation (sample std over n). Exact but for float32 rounding in the SVD and the 1e-4 noise
    # (a variance 1e-8 beside 0.25**2): rel=1e-3, while an n - 1 in place of n is off by 4%.
    split = random_split(len(fields), 32, key)
    train = np.asarray(split.train)[np.asarray(split.train_mask)]
    flat = fields.reshape(len(fields), -1)[train]
    features = jax.vmap(lambda x: project(fitted, x))(jnp.asarray(flat))
    assert np.std(np.asarray(features), axis=0) == pytest.approx([1.0, 1.0], rel=1e-3)
    assert np.asarray(fitted.std) == pytest.approx([3.0, 0.25], rel=0.5)  # the scales, from 12 draws
    chex.assert_shape(reconstruct(fitted, jnp.asarray(fields)), fields.shape)


def test_stale_or_non_finite_slots_change_nothing():
    fields, _ = planted(10)
    clean = buffer_of(fields)
    garbage = clean.replace(fields=clean.fields.at[10:20].set(1e30).at[20:].set(jnp.nan))
    key = jax.random.key(3)
    expected = fit(placeholder(), clean, key, 2)
    got = fit(placeholder(), garbage, key, 2)
    chex.assert_trees_all_close(got, expected, rtol=1e-5, atol=1e-6)
    assert all(np.all(np.isfinite(np.asarray(leaf))) for leaf in jax.tree.leaves(got))


def test_a_refit_keeps_each_components_sign():
    fields, _ = planted(24)
    buffer, key = buffer_of(fields), jax.random.key(1)
    first, _ = fit(placeholder(), buffer, key, 2)
    flipped = first.replace(components=first.components * jnp.array([-1.0, 1.0]))
    again, _ = fit(flipped, buffer, key, 2)
    agreement = np.sum(np.asarray(again.components) * np.asarray(flipped.components), axis=0)
    assert np.all(agreement > 0.99)


def test_fewer_than_two_snapshots_leave_the_parameters_as_they_were():
    fields, _ = planted(2)
    params = placeholder()
    fitted, stats = fit(params, buffer_of(fields[:1]), jax.random.key(0), 2)
    chex.assert_trees_all_equal(fitted, params)
    assert int(stats["snapshots"]) <= 1


def test_bad_settings_are_clear_errors():
    with pytest.raises(SettingsError, match="observer.pca.components"):
        PCASettings(components=0)
    robot = tiny_robot()
    config = tiny_config(observer={"kind": "pca", "pca": {"components": 10**6}})
    with pytest.raises(SettingsError, match=r"observer.pca.components=1000000 exceeds the \d+ values"):
        make(config.observer, robot, ObserverContext(robot.config, jnp.float32, config.loop.learning))
    # It learns in phases only: the simultaneous ablation needs a single SGD step.
    with pytest.raises(SettingsError, match="learns in phases only.*loop.schedule=simultaneous"):
        make_algorithm(
            robot, tiny_config(observer={"kind": "pca"}, loop={"schedule": "simultaneous"}).algorithm
        )

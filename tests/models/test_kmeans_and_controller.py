"""k-means baseline observer and MLP controller (parts of the observers/controllers issue)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.models.controller import MLPController
from litl.models.kmeans import fit_kmeans, kmeans_features
from litl.sim import SimState


def test_kmeans_features_equal_hand_computed_centroids():
    # Two well separated blobs of 3 particles each.
    x = np.array([[0.1, 0.1], [0.2, 0.1], [0.1, 0.2], [0.8, 0.8], [0.9, 0.8], [0.8, 0.9]])
    v = np.array([[1.0, 0.0], [2.0, 0.0], [3.0, 0.0], [0.0, -1.0], [0.0, -2.0], [0.0, -3.0]])
    observer = fit_kmeans(jnp.asarray(x), k=2, seed=0)
    features = kmeans_features(observer, SimState.at_rest(jnp.asarray(x), jnp.asarray(v)))
    assert features.shape == (observer.n_features,) == (8,)
    positions, velocities = np.asarray(features[:4]).reshape(2, 2), np.asarray(features[4:]).reshape(2, 2)
    order = np.argsort(positions[:, 0])  # cluster numbering is arbitrary
    np.testing.assert_allclose(positions[order], [[0.4 / 3, 0.4 / 3], [2.5 / 3, 2.5 / 3]], atol=1e-6)
    np.testing.assert_allclose(velocities[order], [[2.0, 0.0], [0.0, -2.0]], atol=1e-6)


def _partition(observer):
    """The clusters as a set of particle sets: the same fit whatever the clusters' numbering."""
    return frozenset(frozenset(np.flatnonzero(row)) for row in np.asarray(observer.averaging) > 0)


def test_kmeans_is_seeded_and_checks_its_input():
    x = np.random.default_rng(0).uniform(size=(200, 3))
    a, b = fit_kmeans(x, 5, seed=3), fit_kmeans(x, 5, seed=3)
    np.testing.assert_array_equal(a.averaging, b.averaging)
    np.testing.assert_allclose(np.asarray(a.averaging).sum(1), 1.0, rtol=1e-6)
    # The seed is used: uniform points in a cube have many Lloyd fixed points (seeds 0-9 give ten
    # different partitions of these points), so another seed's k-means++ start ends in another
    # fit. Compared as partitions, so a mere renumbering of the same clusters would not count.
    other = fit_kmeans(x, 5, seed=4)
    assert _partition(other) != _partition(a)
    for fit in (a, other):  # each is a fit: every point in the cluster of its nearest centre
        nearest = np.argmin(((x[:, None] - np.asarray(fit.centers)[None]) ** 2).sum(-1), axis=1)
        np.testing.assert_array_equal(np.argmax(np.asarray(fit.averaging), axis=0), nearest)
    with pytest.raises(ValueError, match="k must be"):
        fit_kmeans(x, 0)
    with pytest.raises(ValueError, match="positions must have shape"):
        fit_kmeans(x[:, :1], 2)


def test_controller_outputs_bounded_actuation_and_uses_every_input():
    controller = MLPController(n_actuators=3, widths=(16, 16), period=0.5)
    features, task = jnp.ones(6), jnp.asarray([0.2, -0.4])
    params = controller.init(jax.random.key(0), features, task, 0.0)
    out = controller.apply(params, features, task, 0.1)
    assert out.shape == (3,) and bool(jnp.all(jnp.abs(out) <= 1.0))
    grads = jax.grad(lambda f, t, s: jnp.sum(controller.apply(params, f, t, s)), argnums=(0, 1, 2))(
        features, task, 0.1
    )
    assert all(float(jnp.abs(g).sum()) > 0 for g in grads)


def test_controller_rejects_bad_settings():
    with pytest.raises(ValueError, match="unknown activation"):
        MLPController(n_actuators=2, activation="sigmoidish")
    with pytest.raises(ValueError, match="period must be positive"):
        MLPController(n_actuators=2, period=0.0)
    controller = MLPController(n_actuators=2, period=1.0)
    with pytest.raises(ValueError, match="pass the simulated time"):
        controller.init(jax.random.key(0), jnp.ones(3))
    with pytest.raises(ValueError, match="feature_scale must be positive"):
        MLPController(n_actuators=2, feature_scale=0.0)


def test_feature_scale_is_an_input_gain_on_the_features_only():
    plain = MLPController(n_actuators=2, widths=(8,), period=0.5)
    scaled = MLPController(n_actuators=2, widths=(8,), period=0.5, feature_scale=0.25)
    features = jnp.asarray([0.3, -1.2, 2.0])
    params = plain.init(jax.random.key(0), features, time=0.0)
    np.testing.assert_allclose(
        scaled.apply(params, features, time=0.3), plain.apply(params, 0.25 * features, time=0.3), rtol=1e-6
    )
    assert not np.allclose(scaled.apply(params, features, time=0.3), plain.apply(params, features, time=0.3))


def test_closed_loop_rollout_with_kmeans_observer_has_finite_gradients():
    from litl.sim import make_rollout
    from tests.models.closed_loop import assert_finite_nonzero_gradients
    from tests.sim.scenes import block

    config, body, design, state = block(2, n_grid=24, lower=0.3, size=0.25)
    observer = fit_kmeans(state.x, k=4, seed=0)
    controller = MLPController(n_actuators=body.n_actuators, widths=(16,), period=0.05)
    params = controller.init(jax.random.key(1), jnp.zeros(observer.n_features), None, 0.0)

    def policy(p, s, grid_velocity):
        return controller.apply(p, kmeans_features(observer, s), None, s.step * config.dt)

    rollout = make_rollout(config, body, policy, 60)
    assert_finite_nonzero_gradients(rollout, params, design, state)


def test_sinusoid_controller_is_the_open_loop_policy_and_ignores_features():
    from litl.models.open_loop import SinusoidController, sinusoid_actuation

    controller = SinusoidController(3, omega=25.0, phases=4)
    params = controller.init(jax.random.key(0), jnp.zeros(5), time=jnp.zeros(()))
    weights, bias = params["params"]["weights"], params["params"]["bias"]
    assert weights.shape == (3, 4) and float(jnp.abs(bias).max()) == 0.0
    for t in (0.0, 0.13, 0.7):
        out = controller.apply(params, jnp.full(5, 7.0), time=jnp.asarray(t))
        np.testing.assert_allclose(out, controller.apply(params, jnp.zeros(5), time=jnp.asarray(t)))
        phases = 25.0 * t + 2 * np.pi * np.arange(4) / 4
        np.testing.assert_allclose(out, np.tanh(np.asarray(weights) @ np.sin(phases)), rtol=1e-5)
        np.testing.assert_allclose(out, sinusoid_actuation(weights, bias, 25.0, t), rtol=1e-6)
    with pytest.raises(ValueError, match="needs the simulated time"):
        controller.apply(params, jnp.zeros(5))
    with pytest.raises(ValueError, match="omega must be a positive"):
        SinusoidController(3, omega=0.0)


def test_reclustering_follows_the_material_and_keeps_each_cluster_in_its_place():
    """`refit_kmeans`: with every particle's material kept, a fitted clustering is its own refit;
    with the right half's material gone, every centre moves into the material that is left (the
    cluster left without any restarting there) and the relabelled share says how much material
    changed cluster; a small change keeps each cluster in its place (the controller's c-th
    input)."""
    from litl.models.kmeans import refit_kmeans

    x = np.stack([np.linspace(0.0, 1.0, 60), np.zeros(60)], axis=1)
    fitted = fit_kmeans(jnp.asarray(x, jnp.float32), 3, seed=0)
    same, relabelled = refit_kmeans(fitted, jnp.asarray(x, jnp.float32), jnp.ones(60))
    np.testing.assert_allclose(np.asarray(same.averaging), np.asarray(fitted.averaging), atol=1e-6)
    assert float(relabelled) == 0.0

    left = jnp.asarray(x[:, 0] < 0.5, jnp.float32)
    refitted, relabelled = refit_kmeans(fitted, jnp.asarray(x, jnp.float32), left)
    centers = np.asarray(refitted.centers)[:, 0]
    assert centers.max() < 0.5  # every cluster lies in the material left, none is left empty
    assert (np.asarray(refitted.averaging).sum(1) > 0.99).all()
    assert float(relabelled) > 0.2
    # A small change of material moves the centres a little and keeps their order.
    fading = jnp.asarray(np.where(x[:, 0] > 0.9, 0.5, 1.0), jnp.float32)
    nudged, _ = refit_kmeans(fitted, jnp.asarray(x, jnp.float32), fading)
    assert list(np.argsort(np.asarray(nudged.centers)[:, 0])) == list(
        np.argsort(np.asarray(fitted.centers)[:, 0])
    )
    np.testing.assert_allclose(np.asarray(nudged.centers), np.asarray(fitted.centers), atol=0.05)
    # A particle without material counts in no cluster's mean.
    np.testing.assert_allclose(np.asarray(refitted.averaging)[:, x[:, 0] >= 0.5], 0.0)
    np.testing.assert_allclose(np.asarray(refitted.averaging).sum(1), 1.0, rtol=1e-5)

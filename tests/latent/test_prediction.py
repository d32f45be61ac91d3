"""Multi-step prediction error: ~0 for the true model, the constant baseline's error where it moves."""

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.latent import prediction_error
from litl.latent.dynamics import LinearDynamics


def simulated_sequence(model, rollouts=3, length=30, seed=0):
    """Chronological latents, actions and links of `rollouts` rollouts of `length` each."""
    rng = np.random.default_rng(seed)
    latents, actions, links = [], [], []
    for _ in range(rollouts):
        z = rng.normal(size=model.A.shape[0])
        latents.append(z), actions.append(np.zeros(model.B.shape[1])), links.append(False)
        for _ in range(length - 1):
            a = rng.uniform(-1, 1, size=model.B.shape[1])
            z = np.asarray(model.step(jnp.asarray(z), jnp.asarray(a)))
            latents.append(z), actions.append(a), links.append(True)
    return jnp.asarray(np.stack(latents)), jnp.asarray(np.stack(actions)), jnp.asarray(links)


def test_the_true_model_predicts_every_horizon_and_the_constant_baseline_does_not():
    rng = np.random.default_rng(0)
    model = LinearDynamics(
        A=jnp.asarray(0.8 * np.linalg.qr(rng.normal(size=(3, 3)))[0]),
        B=jnp.asarray(rng.normal(size=(3, 2))),
        c=jnp.asarray(rng.normal(size=3)),
    )
    with jax.enable_x64(True):
        model = jax.tree.map(lambda x: jnp.asarray(x, jnp.float64), model)
        latents, actions, links = simulated_sequence(model)
        error = jax.jit(prediction_error, static_argnums=(0, 4))(
            model.step, latents, actions, links, (1, 5, 20)
        )
        chex.assert_trees_all_close(error.model, jnp.zeros(3), atol=1e-12)
        assert np.all(np.asarray(error.constant) > 0.3), error.constant
        # 3 rollouts of 30: 29 - h + 1 starts each with h linked steps ahead.
        np.testing.assert_array_equal(error.starts, [3 * 29, 3 * 25, 3 * 10])
        # A wrong model's error grows with the horizon.
        wrong = model.replace(A=model.A * 1.05)
        worse = prediction_error(wrong.step, latents, actions, links, (1, 5, 20))
        assert 0 < float(worse.model[0]) < float(worse.model[1]) < float(worse.model[2])
    assert set(error.as_dict()) == {
        f"{kind}/h={h}" for kind in ("model", "constant", "starts") for h in (1, 5, 20)
    }


def test_the_constant_baseline_matches_a_hand_computed_error_and_unlinked_steps_are_skipped():
    latents = jnp.asarray([[0.0], [1.0], [3.0], [10.0], [11.0]])
    actions = jnp.zeros((5, 1))
    links = jnp.asarray([False, True, True, False, True])  # two rollouts: [0, 1, 3] and [10, 11]
    error = prediction_error(lambda z, a: z, latents, actions, links, (1, 2, 3))
    # h = 1: pairs (0, 1), (1, 3), (10, 11): errors 1, 2, 1; h = 2: (0, 3) only; h = 3: none.
    np.testing.assert_allclose(error.constant[:2], [np.sqrt(6 / 3), 3.0], rtol=1e-6)
    np.testing.assert_array_equal(error.starts, [3, 1, 0])
    assert np.isnan(float(error.constant[2])) and np.isnan(float(error.model[2]))
    chex.assert_trees_all_close(error.model[:2], error.constant[:2])  # the identity model is the baseline


def test_bad_horizons_and_sequences_are_refused():
    latents, actions, links = jnp.zeros((6, 2)), jnp.zeros((6, 1)), jnp.ones(6, bool)
    identity = lambda z, a: z
    for horizons, message in [
        ((0,), "each must be a positive int"),
        ((-2,), "each must be a positive int"),
        ((1.5,), "each must be a positive int"),
        ((6,), r"6 must be below the sequence's length T=6 \(1 <= h <= 5\)"),
        ((), "at least one horizon"),
    ]:
        with pytest.raises(ValueError, match=message):
            prediction_error(identity, latents, actions, links, horizons)
    with pytest.raises(ValueError, match=r"actions must have shape \(T=6, m\)"):
        prediction_error(identity, latents, jnp.zeros((5, 1)), links, (1,))

"""Latent dynamics models: the linear fit recovers a known system, the MLP learns a nonlinear one."""

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.latent import LinearSettings, MLPSettings, Transitions, fit_linear, fit_mlp
from litl.latent.dynamics import LinearDynamics, MLPDynamics, random_split, rollout_mse, rollout_windows
from litl.settings import SettingsError


def random_linear_system(rng, r, m):
    A = 0.9 * rng.normal(size=(r, r)) / np.sqrt(r)
    return A, rng.normal(size=(r, m)), rng.normal(size=r)


@pytest.mark.parametrize(("r", "m"), [(4, 2), (3, 1), (6, 5)])
def test_the_linear_fit_recovers_a_known_system_from_noise_free_data(r, m):
    rng = np.random.default_rng(r * 10 + m)
    A, B, c = random_linear_system(rng, r, m)
    n = 60
    z, a = rng.normal(size=(n, r)), rng.uniform(-1, 1, size=(n, m))
    with jax.enable_x64(True):
        data = Transitions(
            jnp.asarray(z), jnp.asarray(a), jnp.asarray(z @ A.T + a @ B.T + c), jnp.ones(n, bool)
        )
        fitted = jax.jit(fit_linear, static_argnums=1)(data, LinearSettings(ridge=0.0))
        # float64 normal equations of a well-conditioned design: exact to ~1e-12.
        chex.assert_trees_all_close(fitted, LinearDynamics(A=A, B=B, c=c), atol=1e-10, rtol=0)
    # float32 with the default ridge (1e-6): close to float32 rounding amplified by the condition number.
    data32 = Transitions(
        *(jnp.asarray(x, jnp.float32) for x in (z, a, z @ A.T + a @ B.T + c)), jnp.ones(n, bool)
    )
    chex.assert_trees_all_close(fit_linear(data32), LinearDynamics(A=A, B=B, c=c), atol=2e-4, rtol=0)


def test_the_linear_fit_ignores_masked_rows_whatever_they_hold():
    rng = np.random.default_rng(1)
    A, B, c = random_linear_system(rng, 3, 2)
    z, a = rng.normal(size=(40, 3)), rng.uniform(-1, 1, size=(40, 2))
    following = z @ A.T + a @ B.T + c
    mask = np.arange(40) < 30
    following[~mask] = 1e30  # garbage in the padding
    with jax.enable_x64(True):
        fitted = fit_linear(
            Transitions(jnp.asarray(z), jnp.asarray(a), jnp.asarray(following), jnp.asarray(mask)),
            LinearSettings(ridge=0.0),
        )
        chex.assert_trees_all_close(fitted, LinearDynamics(A=A, B=B, c=c), atol=1e-10, rtol=0)


def test_the_ridge_shrinks_the_matrices():
    rng = np.random.default_rng(2)
    A, B, c = random_linear_system(rng, 3, 2)
    z, a = rng.normal(size=(50, 3)), rng.uniform(-1, 1, size=(50, 2))
    data = Transitions(jnp.asarray(z), jnp.asarray(a), jnp.asarray(z @ A.T + a @ B.T + c), jnp.ones(50, bool))
    loose, tight = fit_linear(data, LinearSettings(ridge=0.0)), fit_linear(data, LinearSettings(ridge=10.0))
    assert float(jnp.sum(tight.A**2) + jnp.sum(tight.B**2)) < 0.5 * float(
        jnp.sum(loose.A**2) + jnp.sum(loose.B**2)
    )


def nonlinear_toy(n, key):
    """A pendulum-like 2-latent system with a saturating input: z' = z + 0.2 (z1, -sin z0) + 0.3 tanh(a)."""
    z = jax.random.uniform(key, (n, 2), minval=-2, maxval=2)
    a = jax.random.uniform(jax.random.fold_in(key, 1), (n, 1), minval=-1, maxval=1)
    step = lambda z, a: (
        z + 0.2 * jnp.stack([z[1], -jnp.sin(z[0])]) + jnp.array([0.0, 0.3]) * jnp.tanh(2 * a[0])
    )
    return Transitions(z, a, jax.vmap(step)(z, a), jnp.ones(n, bool)), step


def test_the_mlp_beats_the_constant_baseline_and_the_linear_model_on_a_nonlinear_system():
    data, _ = nonlinear_toy(400, jax.random.key(0))
    settings = MLPSettings(widths=(32, 32), max_epochs=600, patience=100, learning_rate=1e-2)
    model, fit = jax.jit(fit_mlp, static_argnums=2)(jax.random.key(1), data, settings)
    test, _ = nonlinear_toy(200, jax.random.key(2))
    error = lambda step: float(
        jnp.mean((jax.vmap(step)(test.latents, test.actions) - test.next_latents) ** 2)
    )
    constant = error(lambda z, a: z)
    linear = error(fit_linear(data).step)
    mlp = error(model.step)
    assert mlp < 0.05 * constant, (mlp, constant)
    assert mlp < 0.5 * linear, (mlp, linear)
    assert int(fit.train_count) == 320 and int(fit.validation_count) == 80
    assert 0 < int(fit.best_epoch) <= int(fit.epochs) <= 600
    assert np.isfinite(float(fit.validation_loss)) and float(fit.validation_loss) < constant


def test_the_untrained_mlp_is_the_constant_baseline_and_early_stopping_keeps_the_best_epoch():
    data, _ = nonlinear_toy(40, jax.random.key(3))
    model, fit = fit_mlp(
        jax.random.key(4), data, MLPSettings(widths=(8,), max_epochs=1, patience=1, learning_rate=1e-12)
    )
    # One tiny step: the model is still (almost) the identity it starts as.
    chex.assert_trees_all_close(jax.vmap(model.step)(data.latents, data.actions), data.latents, atol=1e-6)
    # A learning rate that diverges: no epoch beats the start, so epoch 0's parameters are kept
    # and training stops after `patience` epochs.
    diverged, stats = fit_mlp(
        jax.random.key(4), data, MLPSettings(widths=(8,), max_epochs=50, patience=5, learning_rate=1e6)
    )
    assert (int(stats.best_epoch), int(stats.epochs)) == (0, 5)
    chex.assert_trees_all_close(jax.vmap(diverged.step)(data.latents, data.actions), data.latents, atol=0)


def test_mlp_fit_is_vmappable_over_seeds_and_equals_separate_fits():
    data, _ = nonlinear_toy(60, jax.random.key(5))
    settings = MLPSettings(widths=(8,), max_epochs=40, patience=5)
    keys = jax.random.split(jax.random.key(6), 2)
    both = jax.vmap(lambda key: fit_mlp(key, data, settings))(keys)
    for seed in range(2):
        single = fit_mlp(keys[seed], data, settings)
        chex.assert_trees_all_close(jax.tree.map(lambda x, i=seed: x[i], both), single, atol=1e-5, rtol=1e-5)


def test_the_split_holds_out_the_stated_share_of_real_rows_only():
    mask = jnp.arange(20) < 15
    train, validation = random_split(jax.random.key(0), mask, 0.2)
    assert int(validation.sum()) == 3 and int(train.sum()) == 12
    assert not np.any(np.asarray(train & validation)) and not np.any(np.asarray((train | validation) & ~mask))


def test_transitions_from_a_chronological_sequence():
    latents = jnp.arange(10.0).reshape(5, 2)
    actions = jnp.arange(5.0)[:, None] * 10
    links = jnp.asarray([False, True, False, True, True])
    data = Transitions.from_sequence(latents, actions, links)
    np.testing.assert_array_equal(data.latents, latents[:-1])
    np.testing.assert_array_equal(data.actions, actions[1:])
    np.testing.assert_array_equal(data.next_latents, latents[1:])
    np.testing.assert_array_equal(data.mask, [True, False, True, True])


def test_bad_data_and_settings_are_refused_by_name():
    z = jnp.zeros((5, 3))
    with pytest.raises(ValueError, match=r"actions must have shape \(N=5, m\)"):
        fit_linear(Transitions(z, jnp.zeros((4, 1)), z, jnp.ones(5, bool)))
    with pytest.raises(ValueError, match="latents and next_latents must both have shape"):
        fit_linear(Transitions(z, jnp.zeros((5, 1)), jnp.zeros((5, 2)), jnp.ones(5, bool)))
    with pytest.raises(ValueError, match=r"mask must have shape \(N=5,\)"):
        fit_linear(Transitions(z, jnp.zeros((5, 1)), z, jnp.ones(4, bool)))
    with pytest.raises(ValueError, match="holds 0 transitions.*at least 1"):
        fit_linear(Transitions(z, jnp.zeros((5, 1)), z, jnp.zeros(5, bool)))
    with pytest.raises(ValueError, match="holds 1 transitions.*at least 2"):
        fit_mlp(jax.random.key(0), Transitions(z, jnp.zeros((5, 1)), z, jnp.arange(5) == 0))
    with pytest.raises(
        ValueError, match=r"next_latents holds non-finite values in 1 transition\(s\) \(first at row 2\)"
    ):
        fit_linear(Transitions(z, jnp.zeros((5, 1)), z.at[2, 1].set(jnp.nan), jnp.ones(5, bool)))
    with pytest.raises(ValueError, match="actions holds non-finite"):
        fit_mlp(jax.random.key(0), Transitions(z, jnp.full((5, 1), jnp.inf), z, jnp.ones(5, bool)))
    # A non-finite value in a masked-out row is padding, not data.
    fit_linear(Transitions(z, jnp.zeros((5, 1)), z.at[4].set(jnp.nan), jnp.arange(5) < 4))
    with pytest.raises(ValueError, match=r"latents must have shape \(T, r\) with T >= 2"):
        Transitions.from_sequence(jnp.zeros((1, 2)), jnp.zeros((1, 1)), jnp.ones(1, bool))
    with pytest.raises(ValueError, match=r"links must have shape \(T=3,\)"):
        Transitions.from_sequence(jnp.zeros((3, 2)), jnp.zeros((3, 1)), jnp.ones(2, bool))
    with pytest.raises(SettingsError, match=r"loop.dynamics.linear.ridge=-1.0: must be a number >= 0"):
        LinearSettings(ridge=-1.0)
    with pytest.raises(SettingsError, match=r"loop.dynamics.mlp.validation_fraction=1.0: must be in \(0, 1"):
        MLPSettings(validation_fraction=1.0)
    with pytest.raises(SettingsError, match="loop.dynamics.mlp.widths"):
        MLPSettings(widths=(8, 0))
    with pytest.raises(SettingsError, match="loop.dynamics.mlp.max_epochs"):
        MLPSettings(max_epochs=0)


def chained(n_rollouts: int, steps: int, key):
    """Transitions of `n_rollouts` rollouts of `nonlinear_toy`'s system, `steps` each, laid out
    as `Transitions.from_sequence` lays out a buffer (no transition links one rollout to the next)."""
    _, step = nonlinear_toy(2, key)
    z0 = jax.random.uniform(key, (n_rollouts, 2), minval=-1.5, maxval=1.5)
    actions = jax.random.uniform(jax.random.fold_in(key, 1), (n_rollouts, steps, 1), minval=-1, maxval=1)

    def roll(z, acts):
        return jnp.concatenate([z[None], jax.lax.scan(lambda z, a: (step(z, a), step(z, a)), z, acts)[1]])

    latents = jax.vmap(roll)(z0, actions).reshape(-1, 2)
    actions = jnp.concatenate([jnp.zeros((n_rollouts, 1, 1)), actions], axis=1).reshape(-1, 1)
    links = jnp.ones((n_rollouts, steps + 1), bool).at[:, 0].set(False).reshape(-1)
    return Transitions.from_sequence(latents, actions, links), step


def test_multistep_windows_follow_one_rollout_and_one_side_of_the_split():
    data, _ = chained(2, 5, jax.random.key(7))  # rows 0-4 one rollout, row 5 the gap, rows 6-10
    windows = np.asarray(rollout_windows(data, data.mask, 3))
    np.testing.assert_array_equal(np.flatnonzero(windows), [0, 1, 2, 6, 7, 8])
    held = data.mask.at[1].set(False)  # a row on the other side of the split breaks its windows
    np.testing.assert_array_equal(np.flatnonzero(rollout_windows(data, held, 3)), [2, 6, 7, 8])
    # the split by blocks of K holds out whole blocks (but the one the count cuts)
    mask = jnp.ones(40, bool)
    _, validation = random_split(jax.random.key(0), mask, 0.25, block=4)
    blocks = np.asarray(validation).reshape(10, 4).sum(axis=1)
    assert int(validation.sum()) == 10 and np.sum(blocks == 4) == 2 and np.sum(blocks % 4 != 0) == 1


def test_the_multistep_loss_is_the_mean_of_the_rolled_errors():
    data, step = chained(1, 6, jax.random.key(8))
    model = MLPDynamics(
        layers=((jnp.zeros((3, 2)), jnp.zeros(2)),),
        input_mean=jnp.zeros(3),
        input_scale=jnp.ones(3),
        output_scale=jnp.ones(2),
    )  # the constant model z' = z: its k-step error is |z_{t+k} - z_t|²
    starts = rollout_windows(data, data.mask, 3)
    z = np.asarray(data.latents)
    z = np.concatenate([z, np.asarray(data.next_latents[-1:])])
    expected = np.mean([np.mean([np.mean((z[t + k] - z[t]) ** 2) for k in (1, 2, 3)]) for t in range(4)])
    assert float(rollout_mse(model, data, starts, 3)) == pytest.approx(expected, rel=1e-5)


def test_a_model_trained_on_three_steps_fits_its_rollouts_and_reports_that_loss():
    data, _ = chained(12, 20, jax.random.key(9))
    settings = MLPSettings(widths=(16,), max_epochs=300, patience=50, learning_rate=1e-2, rollout=3)
    model, fit = jax.jit(fit_mlp, static_argnums=2)(jax.random.key(10), data, settings)
    starts = rollout_windows(data, data.mask, 3)
    constant = rollout_mse(model.replace(layers=jax.tree.map(jnp.zeros_like, model.layers)), data, starts, 3)
    assert float(fit.validation_loss) < 0.1 * float(constant)
    # the reported losses are the three-step objective, on each side of the split
    assert 0 < float(fit.train_loss) < float(rollout_mse(model, data, starts, 3)) < float(fit.validation_loss)
    with pytest.raises(SettingsError, match="rollout"):
        MLPSettings(rollout=0)

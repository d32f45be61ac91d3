"""The strain limit (`SimConfig.max_stretch`, `litl.sim.stretch`): it clamps exactly the singular
values above the bound, leaves every other particle alone, and keeps derivatives right."""

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.sim import Elastic, SimConfigError, linalg, make_rollout
from litl.sim.stretch import largest_stretch, limit_stretch
from tests.sim.scenes import block, sine_params, sine_policy

CAP = 2.0
TRANSFORMS = pytest.mark.parametrize("transform", [jax.jit, lambda f: f], ids=["jit", "no_jit"])


def _deformations(dim, rng):
    """Random deformation gradients, many past the bound, plus the awkward ones: repeated singular
    values above and below it, the identity, a reflection."""
    special = [
        4.0 * np.eye(dim),
        np.eye(dim),
        np.diag([5.0] + [1.0] * (dim - 1)),
        np.diag([5.0, 5.0] + [0.5] * (dim - 2)),
        np.diag([-3.0] + [1.0] * (dim - 1)),
    ]
    return np.concatenate([np.stack(special), rng.normal(size=(400, dim, dim)) * 1.2 + np.eye(dim)])


def _clamp(F):
    return linalg.stack_mat(limit_stretch(linalg.split_mat(F), CAP))


@TRANSFORMS
@pytest.mark.parametrize("dim", [2, 3])
def test_singular_values_above_the_bound_are_clamped_as_by_the_svd(dim, transform, x64):
    F = _deformations(dim, np.random.default_rng(dim))
    got = np.asarray(transform(_clamp)(jnp.asarray(F)))
    chex.assert_shape(got, F.shape)
    U, s, Vt = np.linalg.svd(F)
    chex.assert_trees_all_close(got, U @ (np.minimum(s, CAP)[..., None] * Vt), rtol=1e-6, atol=1e-6)
    below = s[:, 0] <= CAP
    assert below.sum() > 10 and (~below).sum() > 10
    # The documented claim is "untouched, bit for bit": the clamp's branch is not taken there.
    np.testing.assert_array_equal(got[below], F[below])
    # Exactly repeated largest values split by up to ~5e-4 in 3D (`linalg.symmetric_eigenvalues`).
    stretch = transform(lambda f: largest_stretch(linalg.split_mat(f)))(jnp.asarray(F))
    chex.assert_trees_all_close(np.asarray(stretch), s[:, 0], rtol=1e-3)


@pytest.mark.parametrize("dim", [2, 3])
def test_the_clamp_is_accurate_in_float32(dim):
    F = _deformations(dim, np.random.default_rng(10 + dim))[5:].astype(np.float32)
    got = np.asarray(jax.jit(_clamp)(jnp.asarray(F)))
    U, s, Vt = np.linalg.svd(F.astype(np.float64))
    chex.assert_trees_all_close(got, U @ (np.minimum(s, CAP)[..., None] * Vt), rtol=1e-4, atol=1e-4)


@pytest.mark.compute_bound
@pytest.mark.parametrize("dim", [2, 3])
def test_the_clamps_derivative_matches_central_differences(dim, x64):
    rng = np.random.default_rng(20 + dim)
    F = jnp.asarray(_deformations(dim, rng)[:-1])  # no reflection: kinks at no point used here
    weights = jnp.asarray(rng.normal(size=F.shape))
    f = jax.jit(lambda x: jnp.sum(weights * jnp.sin(_clamp(x))))
    grad = jax.jit(jax.grad(f))(F)
    assert np.all(np.isfinite(np.asarray(grad)))  # repeated values and the identity included
    for seed in range(3):
        direction = jnp.asarray(np.random.default_rng(seed).normal(size=F.shape))
        eps = 1e-6
        numeric = (f(F + eps * direction) - f(F - eps * direction)) / (2 * eps)
        np.testing.assert_allclose(float(jnp.vdot(grad, direction)), float(numeric), rtol=1e-5)


def _stretching_block(dim, max_stretch):
    """A block whose top is thrown up while its bottom stays on the sticky floor: it is torn apart."""
    config, body, design, state = block(
        dim, n_grid=16, lower=0.2, size=0.25, gravity=0.0, youngs=30.0, dtype=jnp.float64
    )
    top = state.x[:, 1] > 0.2 + 0.125
    state = state.replace(v=state.v.at[:, 1].set(jnp.where(top, 3.0, 0.0)))
    return config.with_own_material(Elastic(max_stretch=max_stretch)), body, design, state


@pytest.mark.parametrize("dim", [2, 3])
def test_a_torn_block_keeps_no_particle_stretched_past_the_bound(dim, x64):
    stretches = {}
    for cap in (None, 1.2):
        config, body, design, state = _stretching_block(dim, cap)
        observe = lambda s: jnp.max(largest_stretch(linalg.split_mat(s.F)))
        rollout = make_rollout(config, body, lambda p, s, g: p, 40, observe=observe)
        final, trajectory = jax.jit(rollout)(jnp.zeros(body.n_actuators), design, state)
        assert int(trajectory.health.first_nonfinite_step) == -1
        stretches[cap] = float(jnp.max(trajectory.observations))
    assert stretches[None] > 1.25  # without the limit the block stretches past it (to 1.30)
    assert stretches[1.2] <= 1.2 * (1 + 1e-6)


@pytest.mark.parametrize("dim", [2, 3])
def test_rollout_gradients_through_the_clamp_match_central_differences(dim, x64):
    config, body, design, state = _stretching_block(dim, 1.2)
    rollout = make_rollout(config, body, sine_policy, 40)

    def loss(x):
        final, _ = rollout(
            x["policy"], design.replace(youngs_modulus=design.youngs_modulus * jnp.exp(x["log_e"])), state
        )
        return jnp.mean(final.x[:, 1]) + jnp.mean(final.F[:, 1, 1])

    x = {"policy": sine_params(body.n_actuators, jnp.float64), "log_e": jnp.zeros(body.n_particles)}
    f, grad_f = jax.jit(loss), jax.jit(jax.grad(loss))
    grad = grad_f(x)
    rng = np.random.default_rng(0)
    direction = jax.tree.map(lambda a: jnp.asarray(rng.normal(size=a.shape)), x)
    analytic = sum(
        jnp.vdot(g, d) for g, d in zip(jax.tree.leaves(grad), jax.tree.leaves(direction), strict=True)
    )
    eps = 1e-6
    shifted = lambda s: jax.tree.map(lambda a, d: a + s * eps * d, x, direction)
    numeric = (f(shifted(1.0)) - f(shifted(-1.0))) / (2 * eps)
    np.testing.assert_allclose(float(analytic), float(numeric), rtol=1e-5)


@pytest.mark.parametrize("bad", [1.0, 0.5, -2.0, float("nan"), float("inf"), True, "3"])
def test_a_bound_that_is_not_a_stretch_is_refused(bad):
    config = block(2, n_grid=16)[0]
    with pytest.raises(SimConfigError, match="max_stretch=.*must be a finite number > 1"):
        config.with_own_material(Elastic(max_stretch=bad))


def test_a_limit_never_reached_changes_states_and_gradients_only_by_rounding():
    """Float32, as the loop runs: the same rollout with no limit and with one it never reaches."""
    results = []
    for cap in (None, 1e6):
        config, body, design, state = block(2, n_grid=16, lower=0.3, size=0.25, youngs=30.0)
        rollout = make_rollout(config.with_own_material(Elastic(max_stretch=cap)), body, sine_policy, 60)

        def loss(p, rollout=rollout, design=design, state=state):
            final, _ = rollout(p, design, state)
            return jnp.mean(final.x[:, 0]) + jnp.mean(final.F[:, 1, 1]), final

        (value, final), grad = jax.jit(jax.value_and_grad(loss, has_aux=True))(sine_params(body.n_actuators))
        results.append((final.x, final.F, value, grad))
    # F is of order 1: atol 1e-6 is a few float32 ulps of it (its near-zero entries fail a relative
    # check alone); a limit that acted would move it by far more.
    chex.assert_trees_all_close(results[0], results[1], rtol=1e-5, atol=1e-6)

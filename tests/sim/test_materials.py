"""Materials with a return mapping (`litl.sim.materials`): each agrees with its definition written
with the SVD, keeps derivatives right (float64 central differences, repeated singular values
included), mixes per particle, and leaves today's scenes computing what they did."""

import dataclasses

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.sim import Body, SimConfigError, linalg, make_rollout, validate
from litl.sim.materials import Clay, Elastic, Fluid, Sand, update
from tests.sim.scenes import block, sine_params, sine_policy

MU, LAM = 2.0, 3.0
TRANSFORMS = pytest.mark.parametrize("transform", [jax.jit, lambda f: f], ids=["jit", "no_jit"])


def _deformations(dim, seed):
    """Random deformation gradients (det F > 0.2) and the awkward ones: the identity, uniform
    compression and expansion (every singular value repeated), two repeated values."""
    rng = np.random.default_rng(seed)
    F = rng.normal(size=(300, dim, dim)) * 0.3 + np.eye(dim)
    F = F[np.linalg.det(F) > 0.2]
    special = [
        np.eye(dim),
        0.9 * np.eye(dim),
        1.1 * np.eye(dim),
        np.diag([1.2] + [0.8] * (dim - 1)),
        np.diag([0.8] * (dim - 1) + [1.2]),
    ]
    return np.concatenate([np.stack(special), F])


def _hencky_reference(F, kind, parameter):
    """The return mapping and Hencky stress written with numpy's SVD (Klar et al. 2016)."""
    d = F.shape[-1]
    U, s, Vt = np.linalg.svd(F)
    eps = np.log(s)
    trace = eps.sum(-1, keepdims=True)
    deviator = eps - trace / d
    norm = np.linalg.norm(deviator, axis=-1, keepdims=True)
    direction = deviator / np.where(norm > 0, norm, 1.0)
    if kind == "sand":
        sin = np.sin(np.radians(parameter))
        alpha = np.sqrt(2 / 3) * 2 * sin / (3 - sin)
        dgamma = norm + (d * LAM + 2 * MU) / (2 * MU) * trace * alpha
        kept = np.where(trace > 0, 0.0, np.where(dgamma > 0, eps - dgamma * direction, eps))
    else:
        excess = np.maximum(norm - np.sqrt(2 / 3) * parameter / (2 * MU), 0.0)
        kept = eps - excess * direction
    F_kept = U @ (np.exp(kept)[..., None] * Vt)
    principal = 2 * MU * kept + LAM * kept.sum(-1, keepdims=True)
    return F_kept, U @ (principal[..., None] * np.swapaxes(U, -1, -2))


def _update(model, F, token=None):
    n = F.shape[0]
    mu, lam = jnp.full((n,), MU, F.dtype), jnp.full((n,), LAM, F.dtype)
    kept, tau = model.update(linalg.split_mat(F), mu, lam, token)
    return linalg.stack_mat(kept), linalg.stack_mat(tau)


PLASTIC = pytest.mark.parametrize(
    "kind, model, parameter", [("sand", Sand(30.0), 30.0), ("clay", Clay(1.0), 1.0)], ids=["sand", "clay"]
)


@TRANSFORMS
@PLASTIC
@pytest.mark.parametrize("dim", [2, 3])
def test_the_return_mapping_and_stress_agree_with_their_svd_definition(
    dim, kind, model, parameter, transform, x64
):
    F = _deformations(dim, dim)
    kept, tau = transform(lambda f: _update(model, f))(jnp.asarray(F))
    chex.assert_shape([kept, tau], F.shape)
    want_F, want_tau = _hencky_reference(F, kind, parameter)
    # The eigenvalues' regularization (`linalg.symmetric_eigenvalues`) moves exactly repeated
    # values by up to ~1e-6 in 2D and ~5e-4 relative in 3D.
    chex.assert_trees_all_close(np.asarray(kept), want_F, atol=2e-6 if dim == 2 else 1e-5)
    chex.assert_trees_all_close(np.asarray(tau), want_tau, atol=1e-5 if dim == 2 else 1e-4)
    # Both branches are exercised: some trial states are projected, some kept.
    moved = np.abs(want_F - F).max(axis=(1, 2)) > 1e-6
    assert 5 < moved.sum() < len(F) - 5


@PLASTIC
def test_the_return_mapping_is_accurate_in_float32(kind, model, parameter):
    F = _deformations(2, 7)
    kept, tau = jax.jit(lambda f: _update(model, f))(jnp.asarray(F, jnp.float32))
    want_F, want_tau = _hencky_reference(F, kind, parameter)
    chex.assert_trees_all_close(np.asarray(kept, np.float64), want_F, atol=1e-4)
    chex.assert_trees_all_close(np.asarray(tau, np.float64), want_tau, atol=1e-3)


@pytest.mark.parametrize("model", [Sand(30.0), Clay(1.0), Fluid()], ids=str)
@pytest.mark.parametrize("dim", [2, 3])
def test_derivatives_match_central_differences(model, dim, x64):
    # (The elastic material's strain limit has its own in tests/sim/test_stretch.py.)
    # The identity is left out: it is the apex of the sand's cone, where the mapping has no
    # derivative (a simulation's first step starts there with C = 0, so nothing flows through it).
    F = jnp.asarray(_deformations(dim, 20 + dim)[1:])
    weights = jnp.asarray(np.random.default_rng(3).normal(size=F.shape))

    # With a buffering token, as rollouts on XLA:CPU run it (`litl.sim.step`); a runtime value.
    token = jnp.int32(0)

    @jax.jit
    def f(x, token):
        kept, tau = _update(model, x, token)
        return jnp.sum(weights * jnp.sin(kept)) + 0.1 * jnp.sum(weights * jnp.sin(tau))

    grad = jax.jit(jax.grad(f))(F, token)
    assert np.all(np.isfinite(np.asarray(grad)))
    for seed in range(3):
        direction = jnp.asarray(np.random.default_rng(seed).normal(size=F.shape))
        eps = 1e-6
        numeric = (f(F + eps * direction, token) - f(F - eps * direction, token)) / (2 * eps)
        np.testing.assert_allclose(float(jnp.vdot(grad, direction)), float(numeric), rtol=1e-5)


def test_the_gradient_at_rest_is_finite(x64):
    """Every particle starts at F = I, where all singular values repeat."""
    for dim in (2, 3):
        F = jnp.broadcast_to(jnp.eye(dim), (4, dim, dim))
        for model in (Sand(30.0), Clay(0.3), Fluid()):
            grad = jax.grad(lambda x, m=model: jnp.sum(jnp.sin(_update(m, x)[1])))(F)
            assert np.all(np.isfinite(np.asarray(grad))), model


def test_a_fluid_keeps_its_volume_and_forgets_its_shear(x64):
    F = jnp.asarray(_deformations(2, 5))
    kept, tau = _update(Fluid(), F)
    J = np.linalg.det(np.asarray(F))
    chex.assert_trees_all_close(np.linalg.det(np.asarray(kept)), J, rtol=1e-12)
    chex.assert_trees_all_close(np.asarray(kept), np.sqrt(J)[:, None, None] * np.eye(2), rtol=1e-12)
    bulk = LAM + MU  # lambda + 2 mu / d in 2D
    chex.assert_trees_all_close(np.asarray(tau), (bulk * (J - 1) * J)[:, None, None] * np.eye(2), rtol=1e-12)


def test_sand_pulled_apart_keeps_no_stress_and_squeezed_evenly_stays_elastic(x64):
    expanded, compressed = 1.1 * jnp.eye(2)[None], 0.9 * jnp.eye(2)[None]
    kept, tau = _update(Sand(30.0), expanded)
    chex.assert_trees_all_close(np.asarray(kept), np.eye(2)[None], atol=1e-9)
    chex.assert_trees_all_close(np.asarray(tau), np.zeros((1, 2, 2)), atol=1e-9)
    kept, _ = _update(Sand(30.0), compressed)
    chex.assert_trees_all_close(np.asarray(kept), np.asarray(compressed), atol=1e-9)


def test_a_steeper_friction_angle_holds_more_shear(x64):
    """Under the same compression and shear, sand of a larger friction angle keeps more of it."""
    F = jnp.asarray([[[0.95, 0.25], [0.0, 0.95]]])
    shear = [float(_update(Sand(angle), F)[1][0, 0, 1]) for angle in (10.0, 25.0, 40.0)]
    assert shear[0] < shear[1] < shear[2]


def test_particles_take_their_own_material():
    F = _deformations(2, 9)
    n = len(F)
    ids = jnp.asarray(np.arange(n) % 3, jnp.int32)
    models = (Elastic(), Sand(30.0), Fluid())
    mu, lam = jnp.full((n,), MU), jnp.full((n,), LAM)
    kept, tau = update(models, ids, linalg.split_mat(jnp.asarray(F, jnp.float32)), mu, lam)
    kept, tau = linalg.stack_mat(kept), linalg.stack_mat(tau)
    for index, model in enumerate(models):
        mine = np.asarray(ids) == index
        alone_F, alone_tau = _update(model, jnp.asarray(F[mine], jnp.float32))
        np.testing.assert_array_equal(np.asarray(kept)[mine], np.asarray(alone_F))
        np.testing.assert_array_equal(np.asarray(tau)[mine], np.asarray(alone_tau))


def test_the_robots_own_material_is_the_first_and_changes_alone():
    """`SimConfig.materials` is the one way to give a body its material: the first is the
    robot's (`own_material`, `max_stretch`), and `with_own_material` swaps it, keeping the
    world's bodies after it."""
    config = block(2, n_grid=16)[0]
    assert config.materials == (Elastic("fixed_corotated"),) and config.max_stretch is None
    sandy = dataclasses.replace(config, materials=(Elastic(), Sand(30.0)))
    limited = sandy.with_own_material(Elastic("neo_hookean", 1.5))
    assert limited.materials == (Elastic("neo_hookean", 1.5), Sand(30.0))
    assert limited.max_stretch == 1.5 and limited.own_material.model == "neo_hookean"
    # A scene of sand alone (the column-collapse benchmark's) has no strain limit of its own.
    assert dataclasses.replace(config, materials=(Sand(30.0),)).max_stretch is None


@pytest.mark.parametrize("model", [Sand(30.0), Clay(30.0), Fluid()], ids=str)
def test_gradients_through_a_rollout_of_each_material_match_central_differences(model, x64):
    config, body, design, state = block(2, n_grid=16, lower=0.2, size=0.25, youngs=300.0, dtype=jnp.float64)
    config = dataclasses.replace(config, materials=(model,))
    params = sine_params(body.n_actuators, jnp.float64)
    rollout = make_rollout(config, body, sine_policy, 40)

    def loss(youngs):
        final, _ = rollout(params, dataclasses.replace(design, youngs_modulus=youngs), state)
        return jnp.mean(final.x[:, 0]) + jnp.mean(final.x[:, 1] ** 2)

    E = design.youngs_modulus
    grad = jax.jit(jax.grad(loss))(E)
    direction = jnp.ones_like(E)
    eps = 1e-3
    numeric = (loss(E + eps * direction) - loss(E - eps * direction)) / (2 * eps)
    assert abs(float(numeric)) > 1e-9
    np.testing.assert_allclose(float(jnp.vdot(grad, direction)), float(numeric), rtol=1e-4)


def test_bad_materials_are_refused_naming_the_key():
    with pytest.raises(SimConfigError, match=r"friction_angle=0.*\(0, 90\)"):
        Sand(0.0)
    with pytest.raises(SimConfigError, match=r"friction_angle=95"):
        Sand(95)
    with pytest.raises(SimConfigError, match=r"yield_stress=-1"):
        Clay(-1.0)
    with pytest.raises(SimConfigError, match=r"max_stretch=0.5"):
        Elastic(max_stretch=0.5)
    with pytest.raises(SimConfigError, match=r"Elastic.model='rubber': unknown.*stress function"):
        Elastic("rubber")
    config, body, design, state = block(2, n_grid=16)
    with pytest.raises(SimConfigError, match=r"SimConfig\(max_stretch=...\) is gone"):
        dataclasses.replace(config, max_stretch=2.0)
    with pytest.raises(SimConfigError, match="one or more litl.sim.materials models"):
        dataclasses.replace(config, materials=())
    with pytest.raises(SimConfigError, match="litl.sim.materials models"):
        dataclasses.replace(config, materials=("sand",))
    two = dataclasses.replace(config, materials=(Elastic(), Sand()))
    ids = jnp.full((body.n_particles,), 2, jnp.int32)
    with pytest.raises(SimConfigError, match=r"body.material ids must index SimConfig.materials \(2 given"):
        validate(two, dataclasses.replace(body, material=ids), design, state)
    validate(two, dataclasses.replace(body, material=ids - 1), design, state)


def test_a_body_without_material_ids_is_the_same_pytree_as_before():
    """`Body.material` defaults to None, an empty subtree: the leaves of every existing body (and
    so its checkpoints and jit cache keys) are unchanged."""
    _, body, _, _ = block(2, n_grid=16)
    assert body.material is None
    assert len(jax.tree_util.tree_leaves(body)) == 4
    assert isinstance(body, Body)

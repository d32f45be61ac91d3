"""Physical invariants of the MPM step in 2D and 3D."""

import dataclasses

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.sim import Boundary, SimConfig, Wall, linalg, make_rollout, make_step, raise_if_unhealthy, transfer
from litl.sim.boundary import apply_boundary
from litl.sim.safety import escape_margins
from tests.sim.scenes import block

# Physics, gradients and determinism: worth running on a GPU (`pytest -m gpu`).
pytestmark = pytest.mark.gpu

MODELS = ["fixed_corotated", "neo_hookean"]
idle = lambda params, state, grid_velocity: jnp.zeros(2, state.x.dtype)


def test_empty_grid_nodes_hold_zero_velocity_under_gravity():
    """The observer reads the grid: outside the body it must be still, not g * dt everywhere."""
    config, body, design, state = block(2, n_grid=32, lower=0.4, size=0.2, gravity=-9.8)
    rollout = jax.jit(make_rollout(config, body, idle, 10, snapshot_stride=5))
    _, trajectory = rollout(None, design, state)
    speed = np.linalg.norm(np.asarray(trajectory.snapshots[-1]), axis=-1)
    assert speed[:6].max() == 0 and speed[:, :6].max() == 0  # far from the block
    assert speed.max() > 0  # the falling block itself


@pytest.mark.parametrize("dim", [2, 3])
def test_free_fall_matches_half_g_t_squared(dim, x64):
    config, body, design, state = block(dim, n_grid=32, lower=0.5, size=0.2, gravity=-5.0, dtype=jnp.float64)
    steps = 60
    final, trajectory = jax.jit(make_rollout(config, body, idle, steps))(None, design, state)
    raise_if_unhealthy(trajectory.health)
    t = steps * config.dt
    drop = trajectory.observations[-1, 1] - jnp.mean(state.x[:, 1])
    # Symplectic Euler gives g dt^2 n(n+1)/2 (up to the grid's mass epsilon, 1e-10, in nodes of
    # tiny mass); g t^2/2 up to the O(dt) term g t dt / 2.
    np.testing.assert_allclose(drop, -5.0 * config.dt**2 * steps * (steps + 1) / 2, rtol=2e-5)
    np.testing.assert_allclose(drop, -5.0 * t**2 / 2, rtol=1.5 / steps)
    # Uniform acceleration does not deform the body.
    np.testing.assert_allclose(final.F, np.broadcast_to(np.eye(dim), final.F.shape), atol=1e-9)


def test_gravity_may_point_anywhere(x64):
    config, body, design, state = block(2, n_grid=32, lower=0.4, size=0.2, gravity=0.0, dtype=jnp.float64)
    config = SimConfig(config.grid_shape, config.dx, config.dt, gravity=(3.0, 0.0))
    final, _ = make_rollout(config, body, idle, 20)(None, design, state)
    np.testing.assert_allclose(jnp.mean(final.v, 0), [3.0 * 20 * config.dt, 0.0], atol=1e-12)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("model", MODELS)
def test_momentum_is_conserved_without_gravity(dim, model, x64):
    rng = np.random.default_rng(0)
    config, body, design, state = block(
        dim, n_grid=32, lower=0.4, size=0.2, gravity=0.0, constitutive_model=model, dtype=jnp.float64
    )
    state = state.replace(v=jnp.asarray(rng.normal(0, 0.3, state.x.shape)))
    mass = design.density * body.volume
    params = jnp.asarray([0.7, -0.9])  # constant actuation: internal forces only
    final, trajectory = make_rollout(config, body, lambda p, s, g: p, 100)(params, design, state)
    raise_if_unhealthy(trajectory.health)
    before = jnp.sum(mass[:, None] * state.v, 0)
    after = jnp.sum(mass[:, None] * final.v, 0)
    np.testing.assert_allclose(after, before, atol=1e-12 * float(jnp.sum(mass)))
    assert float(jnp.max(jnp.abs(final.x - state.x))) > 1e-3  # it did move and deform


@pytest.mark.parametrize("dim", [2, 3])
def test_particle_to_grid_conserves_mass_and_momentum(dim, x64):
    rng = np.random.default_rng(1)
    n = 200
    x = rng.uniform(0.3, 0.7, (n, dim))
    mass = rng.uniform(0.5, 2.0, n)
    momentum = rng.normal(size=(n, dim))
    affine = rng.normal(size=(n, dim, dim))
    st = transfer.stencil(linalg.split_vec(jnp.asarray(x)), 1 / 16, (16,) * dim)
    grid = transfer.particles_to_grid(
        st,
        jnp.asarray(mass),
        linalg.split_vec(jnp.asarray(momentum)),
        linalg.split_mat(jnp.asarray(affine)),
        1 / 16,
        (16,) * dim,
    )
    axes = tuple(range(dim))
    np.testing.assert_allclose(jnp.sum(grid[..., 0], axes), mass.sum(), rtol=1e-12)
    # The affine part sums to zero: quadratic B-splines reproduce linear functions exactly.
    np.testing.assert_allclose(jnp.sum(grid[..., 1:], axes), momentum.sum(0), atol=1e-10)


@pytest.mark.compute_bound
@pytest.mark.parametrize("dim,steps", [(2, 5000), (3, 5000)])
def test_elastic_block_stays_bounded(dim, steps):
    config, body, design, state = block(
        dim, n_grid=16 if dim == 3 else 24, lower=0.3, size=0.3, gravity=-9.8, youngs=200.0
    )
    params = jnp.asarray([0.5, -0.5])
    final, trajectory = jax.jit(make_rollout(config, body, lambda p, s, g: p, steps))(params, design, state)
    raise_if_unhealthy(trajectory.health)
    J = np.linalg.det(np.asarray(final.F))
    assert J.min() > 0.5 and J.max() < 1.5
    assert float(jnp.max(jnp.abs(final.v))) < 5.0
    heights = trajectory.observations[:, 1]
    assert float(heights.min()) > 3 * config.dx  # resting on the floor, not through it


def _hit_floor(wall, v):
    config = SimConfig(
        (16, 16),
        1 / 16,
        1e-3,
        (0.0, 0.0),
        boundary=Boundary(walls=(Wall("open"), Wall("open"), wall, Wall("open")), thickness=3),
    )
    velocity = [jnp.full((16, 16), v[0]), jnp.full((16, 16), v[1])]
    out = apply_boundary(config, velocity)
    return np.asarray(out[0][8, 1]), np.asarray(out[1][8, 1]), np.asarray(out[0][8, 8])


def test_floor_kinds():
    assert _hit_floor(Wall("sticky"), (2.0, -1.0))[:2] == (0.0, 0.0)
    assert _hit_floor(Wall("slip"), (2.0, -1.0))[:2] == (2.0, 0.0)
    assert _hit_floor(Wall("friction", 0.5), (2.0, -1.0))[:2] == (1.5, 0.0)
    assert _hit_floor(Wall("friction", 5.0), (2.0, -1.0))[:2] == (0.0, 0.0)  # static friction
    # Moving away from the floor is untouched, and nodes above the layer are never touched.
    assert _hit_floor(Wall("sticky"), (2.0, 1.0))[:2] == (2.0, 1.0)
    assert _hit_floor(Wall("sticky"), (2.0, -1.0))[2] == 2.0


def _deepest_in_wall(axis, sign, n_grid=32):
    """A soft block thrown at one wall with gravity pressing it there: the smallest distance, in
    cells, between any particle and the line where its stencil would leave the grid."""
    gravity = [0.0, 0.0]
    gravity[axis] = 30.0 * sign
    config, body, design, state = block(
        2, n_grid=n_grid, lower=0.4, size=0.2, gravity=0.0, youngs=20.0, n_actuators=0
    )
    config = dataclasses.replace(config, gravity=tuple(gravity))
    velocity = np.zeros(state.x.shape, np.float32)
    velocity[:, axis] = 4.0 * sign
    state = state.replace(v=jnp.asarray(velocity))
    steps = int(0.5 / config.dt)
    still = lambda params, state, grid_velocity: jnp.zeros(0, state.x.dtype)
    rollout = make_rollout(config, body, still, steps, observe=lambda s: s.x)
    _, trajectory = jax.jit(rollout)(None, design, state)
    return escape_margins(config, trajectory.observations)[f"{'xy'[axis]}_{'low' if sign < 0 else 'high'}"]


def test_every_wall_holds_a_body_pressed_into_it_with_the_same_margin():
    """A wall of thickness t is t nodes at both ends of an axis: a soft body pressed into the right
    wall or the ceiling stops as far from leaving the grid as at the left wall and the floor (with
    DiffTaichi's one node fewer at the high end it came within 0.46 cells of leaving)."""
    margins = [_deepest_in_wall(axis, sign) for axis in (0, 1) for sign in (-1, 1)]
    assert min(margins) > 1.0, margins
    np.testing.assert_allclose(margins, margins[0], atol=0.05)


def test_escape_margins_measure_each_face_in_cells():
    config = SimConfig(grid_shape=(32, 16), dx=1 / 32, dt=1e-3, gravity=(0.0, 0.0))
    cells = np.array([[[2.0, 1.5], [30.0, 13.0]], [[10.0, 7.0], [29.5, 14.25]]])
    margins = escape_margins(config, cells / 32)
    assert margins == pytest.approx({"x_low": 1.5, "x_high": 0.5, "y_low": 1.0, "y_high": 0.25})


def test_friction_wall_is_coulomb_in_3d():
    config = SimConfig(
        (16, 16, 16),
        1 / 16,
        1e-3,
        (0.0, 0.0, 0.0),
        boundary=Boundary.box(3, floor=Wall("friction", 0.25), sides="open"),
    )
    v = [jnp.full((16,) * 3, 3.0), jnp.full((16,) * 3, -2.0), jnp.full((16,) * 3, 4.0)]
    out = [np.asarray(c)[8, 0, 8] for c in apply_boundary(config, v)]
    # |v_t| = 5 drops by 0.25 * 2 = 0.5, keeping its direction.
    np.testing.assert_allclose(out, [3.0 * 0.9, 0.0, 4.0 * 0.9], rtol=1e-6)


def test_pinned_particles_and_pinned_grid_region_hold_still():
    config, body, design, state = block(2, n_grid=32, lower=0.4, size=0.2, gravity=-9.8)
    pinned = np.asarray(state.x[:, 0]) < 0.45
    body = body.replace(pinned=jnp.asarray(pinned))
    final, _ = make_rollout(config, body, idle, 200)(None, design, state)
    np.testing.assert_array_equal(final.x[pinned], state.x[pinned])
    assert float(jnp.mean(final.x[~pinned, 1] - state.x[~pinned, 1])) < -1e-3  # the rest sags
    region = SimConfig(
        config.grid_shape,
        config.dx,
        config.dt,
        config.gravity,
        boundary=Boundary.box(2, pinned_boxes=[((0.0, 0.0), (0.5, 1.0))]),
    )
    _, grid = make_step(region, body.replace(pinned=jnp.zeros_like(body.pinned)))(
        state.replace(v=jnp.ones_like(state.v)), jnp.zeros(2), design
    )
    assert float(jnp.abs(grid.velocity[:16]).max()) == 0.0  # nodes at x <= 0.5
    assert float(jnp.abs(grid.velocity[17:]).max()) > 0.0


def test_non_square_grid():
    config, body, design, state = block(2, n_grid=32, lower=0.3, size=0.15)
    wide = SimConfig((64, 32), config.dx, config.dt, config.gravity)
    final, trajectory = make_rollout(wide, body, idle, 100, snapshot_stride=50)(
        None, design, state.replace(x=state.x + jnp.asarray([1.0, 0.0]))
    )
    raise_if_unhealthy(trajectory.health)
    assert trajectory.snapshots.shape == (2, 64, 32, 2)
    assert float(final.x[:, 0].min()) > 1.0
    # The snapshot is the wide grid, x first: its moving nodes are the falling block's, under its
    # particles in x (the quadratic stencil reaches at most one node past them), none elsewhere.
    moving = np.argwhere(np.any(np.asarray(trajectory.snapshots[-1]) != 0, axis=-1))
    x = np.asarray(final.x[:, 0]) / config.dx
    assert np.floor(x.min()) - 1 <= moving[:, 0].min() and moving[:, 0].max() <= np.ceil(x.max()) + 1
    assert float(jnp.mean(trajectory.snapshots[-1][..., 1])) < 0  # falling


def test_polar_rotation_3d_is_a_rotation_with_finite_gradient_at_identity(x64):
    rng = np.random.default_rng(2)
    F = np.eye(3) + 0.3 * rng.normal(size=(50, 3, 3))
    F = F[np.linalg.det(F) > 0.1]
    R = linalg.stack_mat(linalg.polar_rotation(linalg.split_mat(jnp.asarray(F))))
    U, _, Vt = np.linalg.svd(F)
    np.testing.assert_allclose(R, U @ Vt, atol=1e-10)

    def energy(F):
        R = linalg.stack_mat(linalg.polar_rotation(linalg.split_mat(F)))
        return jnp.sum(jnp.sin(R) * jnp.arange(9.0).reshape(3, 3))

    for F0 in [jnp.eye(3)[None], jnp.asarray(F[:3])]:
        grad = jax.grad(energy)(F0)
        assert np.all(np.isfinite(grad))
        direction = jnp.asarray(rng.normal(size=F0.shape))
        eps = 1e-6
        numeric = (energy(F0 + eps * direction) - energy(F0 - eps * direction)) / (2 * eps)
        np.testing.assert_allclose(jnp.vdot(grad, direction), numeric, rtol=1e-6, atol=1e-8)


def test_a_stress_law_of_ones_own_is_a_material():
    """`Elastic(model=fn)`: the named model's function passed as one's own changes nothing; a law
    of one's own (here a stress-free one, which cannot hold the block up) changes the motion."""
    from litl.sim import Elastic
    from litl.sim.constitutive import fixed_corotated

    config, body, design, state = block(2, n_grid=24, lower=0.3, size=0.2, gravity=-9.8, youngs=200.0)
    actuation = jnp.zeros(2, state.x.dtype)
    named = make_step(config, body)(state, actuation, design)[0]
    own = config.with_own_material(Elastic(model=fixed_corotated))
    explicit = make_step(own, body)(state, actuation, design)[0]
    # Two compilations of one program: equal to float32 rounding (bit for bit on a CPU).
    chex.assert_trees_all_close((named.x, named.F), (explicit.x, explicit.F), rtol=1e-6, atol=1e-7)

    def stress_free(F, mu, lam):
        return [[jnp.zeros_like(mu) for _ in row] for row in F]

    def rollout(c):
        return jax.jit(make_rollout(c, body, lambda p, s, g: p, 300))(actuation, design, state)

    solid, _ = rollout(config)
    dust, _ = rollout(config.with_own_material(Elastic(model=stress_free)))
    # Without stress the block slumps onto the floor; the elastic one keeps its height.
    height = lambda final: float(jnp.max(final.x[:, 1]) - jnp.min(final.x[:, 1]))
    assert height(dust) < 0.8 * height(solid)

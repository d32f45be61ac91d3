"""Colliders (`litl.sim.colliders`): signed distances and normals of each shape, the contact
projection, the floor as a collider equal to the floor wall, gradients through a slope in float64,
a block sliding down a slope at g (sin θ - μ cos θ), and refusals of bad input."""

import math

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.robots.primitives import sample_box
from litl.sim import Body, Boundary, Design, SimConfig, SimConfigError, SimState, Wall, make_rollout
from litl.sim.boundary import apply_boundary
from litl.sim.colliders import (
    Ball,
    Box,
    Collider,
    HalfPlane,
    HeightField,
    Union,
    apply_colliders,
    check_clear,
)
from tests.sim.scenes import block

POINTS = np.array([[0.5, 0.5], [0.5, 0.05], [0.9, 0.3]])


def test_each_shape_gives_its_signed_distance_and_outward_normal():
    phi, normal = HalfPlane((0.0, 0.1), (0.0, 2.0)).distance(POINTS)
    np.testing.assert_allclose(phi, [0.4, -0.05, 0.2])
    np.testing.assert_allclose(normal, [[0, 1]] * 3)
    slope = HalfPlane((0.0, 0.0), (-1.0, 1.0))  # y = x, solid below
    np.testing.assert_allclose(slope.distance(np.array([[0.0, 1.0]]))[0], [math.sqrt(0.5)])
    phi, normal = Box((0.4, 0.0), (0.6, 0.1)).distance(POINTS)
    np.testing.assert_allclose(phi, [0.4, -0.05, math.hypot(0.3, 0.2)])
    np.testing.assert_allclose(normal[:2], [[0, 1], [0, 1]])  # inside: out through the top
    np.testing.assert_allclose(normal[2], np.array([0.3, 0.2]) / math.hypot(0.3, 0.2))
    phi, normal = Ball((0.5, 0.3), 0.1).distance(POINTS)
    np.testing.assert_allclose(phi, [0.1, 0.15, 0.3])
    np.testing.assert_allclose(normal[2], [1, 0])
    ground = HeightField((0.0, 0.5, 1.0), (0.1, 0.1, 0.6))  # flat, then a 45° ramp
    phi, normal = ground.distance(np.array([[0.25, 0.3], [0.75, 0.35], [0.75, 0.45]]))
    np.testing.assert_allclose(phi, [0.2, 0.0, 0.1 / math.sqrt(2)], atol=1e-12)
    np.testing.assert_allclose(normal[1], [-math.sqrt(0.5), math.sqrt(0.5)])
    both = Union((HalfPlane((0, 0.1), (0, 1)), Ball((0.9, 0.3), 0.05)))
    phi, _ = both.distance(POINTS)
    np.testing.assert_allclose(phi, [math.hypot(0.4, 0.2) - 0.05, -0.05, -0.05])  # the nearer: the ball
    phi3, normal3 = HeightField((0.0, 1.0), (0.2, 0.2), dim=3).distance(np.array([[0.5, 0.5, 0.9]]))
    np.testing.assert_allclose(phi3, [0.3])
    np.testing.assert_allclose(normal3, [[0, 1, 0]])


def _hit(contact, v, normal=(-1.0, 1.0)):
    """One node inside a 45° slope's solid, moving with `v`: its velocity after the contact."""
    collider = Collider(HalfPlane((0.5, 0.5), normal), contact, band=0)
    velocity = [jnp.full((8, 8), v[0]), jnp.full((8, 8), v[1])]
    out = apply_colliders([collider], (8, 8), 1 / 8, velocity)
    inside, outside = (5, 1), (1, 6)
    return [float(o[inside]) for o in out], [float(o[outside]) for o in out]


def test_the_contact_projects_only_velocity_into_the_solid():
    n = np.array([-1.0, 1.0]) / math.sqrt(2)
    v = np.array([1.0, -1.0])  # straight into the slope (v . n < 0)
    assert _hit(Wall("sticky"), v)[0] == [0.0, 0.0]
    np.testing.assert_allclose(_hit(Wall("slip"), v)[0], [0.0, 0.0], atol=1e-6)
    along = np.array([2.0, 1.0])  # into it and along it
    vn = along @ n
    tangential = along - vn * n
    np.testing.assert_allclose(_hit(Wall("slip"), along)[0], tangential, atol=1e-6)
    slowed = tangential * (1 - 0.5 * abs(vn) / np.linalg.norm(tangential))
    np.testing.assert_allclose(_hit(Wall("friction", 0.5), along)[0], slowed, atol=1e-6)
    np.testing.assert_allclose(_hit(Wall("friction", 50.0), along)[0], [0.0, 0.0], atol=1e-6)  # held
    away = np.array([-1.0, 1.0])
    np.testing.assert_allclose(_hit(Wall("sticky"), away)[0], away)  # leaving: untouched
    np.testing.assert_allclose(_hit(Wall("sticky"), along)[1], along)  # a node outside: untouched


@pytest.mark.parametrize("contact", [Wall("sticky"), Wall("slip"), Wall("friction", 0.4)])
def test_a_floor_collider_acts_as_the_floor_wall(contact):
    """The floor wall (3 nodes) and an open floor with a half plane one cell (its band) below the
    third node give the same rollout: a wall is a collider whose shape is the grid's outer layer."""

    def final(boundary):
        config, body, design, state = block(n_grid=24, lower=0.2, velocity=(0.5, -1.0), boundary=boundary)
        rollout = make_rollout(config, body, lambda p, s, g: jnp.zeros((2,)), 60)
        return rollout(None, design, state)[0]

    walls = final(Boundary.box(2, floor=contact, sides="slip"))
    floor = Collider(HalfPlane((0.0, 1 / 24), (0.0, 1.0)), contact)
    open_floor = Boundary(walls=(Wall("slip"), Wall("slip"), Wall("open"), Wall("slip")), colliders=(floor,))
    # Two programs that compute the same physics in another order: float32 rounding over 60 steps.
    # C (the velocity's gradient) is a difference of grid velocities over dx, so its rounding is
    # that of v times 1/dx: compared in v's units.
    in_v_units = lambda s: s.replace(C=s.C / 24)
    chex.assert_trees_all_close(in_v_units(walls), in_v_units(final(open_floor)), atol=1e-5, rtol=1e-5)


def test_gradients_through_a_friction_slope_match_central_differences(x64):
    slope = Collider(HalfPlane((0.0, 0.2), (-0.3, 1.0)), Wall("friction", 0.3))
    config, body, design, state = block(
        n_grid=16, lower=0.4, dtype=jnp.float64, boundary=Boundary.box(2, colliders=[slope])
    )
    rollout = make_rollout(config, body, lambda p, s, g: jnp.tanh(p), 40)

    def loss(action):
        final, _ = rollout(action, design, state)
        return jnp.mean(final.x[:, 0]) + jnp.mean(final.x[:, 1])

    loss = jax.jit(loss)
    action = jnp.array([0.3, -0.2])
    gradient = jax.jit(jax.grad(loss))(action)
    h = 1e-5
    numeric = [(loss(action.at[i].add(h)) - loss(action.at[i].add(-h))) / (2 * h) for i in range(2)]
    np.testing.assert_allclose(gradient, numeric, rtol=1e-5, atol=1e-9)


def _slide(theta_deg, mu, n_grid=32, seconds=0.25, youngs=2000.0, size=0.15):
    """A block's acceleration down a slope of `theta_deg` with Coulomb coefficient `mu`."""
    theta = math.radians(theta_deg)
    dx = 1.0 / n_grid
    x = sample_box([0.0, 0.0], [size, size], dx, per_cell=2)
    rotation = np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])
    normal = np.array([-math.sin(theta), math.cos(theta)])
    x = (x - [size / 2, 0.0]) @ rotation.T + np.array([0.55, 0.35]) + 0.6 * dx * normal
    contact = Wall("friction", mu) if mu else Wall("slip")
    plane = Collider(HalfPlane((0.55, 0.35), tuple(normal)), contact)
    n = len(x)
    design = Design.uniform(n, youngs, 0.3, 1.0, [], jnp.float32)
    body = Body(
        volume=jnp.full((n,), (dx / 2) ** 2),
        actuator=jnp.full((n,), -1, jnp.int32),
        fiber=jnp.zeros((0, 2)),
        pinned=jnp.zeros((n,), bool),
    )
    mu_, lam = (float(p[0]) for p in design.lame())
    dt = 0.4 * dx / math.sqrt(lam + 2 * mu_)
    config = SimConfig((n_grid, n_grid), dx, dt, (0.0, -9.8), boundary=Boundary.box(2, colliders=[plane]))
    steps = int(seconds / dt)
    rollout = jax.jit(make_rollout(config, body, lambda p, s, g: jnp.zeros((0,)), steps))
    _, trajectory = rollout(None, design, SimState.at_rest(jnp.asarray(x, jnp.float32)))
    down = np.asarray(trajectory.observations) @ -np.array([math.cos(theta), math.sin(theta)])
    t = np.arange(1, steps + 1) * dt
    window = t > 0.1 * seconds  # after the first contact settles
    fit = np.stack([np.ones(window.sum()), t[window], 0.5 * t[window] ** 2], axis=1)
    return float(np.linalg.lstsq(fit, down[window], rcond=None)[0][2])


@pytest.mark.parametrize(("theta", "mu"), [(30, 0.0), (30, 0.2), (30, 0.4), (20, 0.2)])
def test_a_block_slides_down_a_slope_at_g_sin_minus_mu_cos(theta, mu):
    expected = 9.8 * (math.sin(math.radians(theta)) - mu * math.cos(math.radians(theta)))
    assert _slide(theta, mu) == pytest.approx(expected, rel=0.05)


def test_a_block_sticks_where_tan_theta_is_below_mu():
    """30° with μ = 0.8: it stays (its fitted acceleration under 2% of the frictionless 4.9)."""
    assert abs(_slide(30, 0.8)) < 0.02 * 9.8 * math.sin(math.radians(30))


def test_bad_colliders_are_refused_naming_what_is_wrong():
    with pytest.raises(SimConfigError, match="non-zero normal"):
        HalfPlane((0.0, 0.0), (0.0, 0.0))
    with pytest.raises(SimConfigError, match="lower < upper"):
        Box((0.5, 0.5), (0.4, 0.6))
    with pytest.raises(SimConfigError, match="positive number"):
        Ball((0.5, 0.5), -1.0)
    with pytest.raises(SimConfigError, match="xs must increase"):
        HeightField((0.0, 0.0), (0.1, 0.2))
    with pytest.raises(SimConfigError, match="not open"):
        Collider(HalfPlane((0.0, 0.1), (0.0, 1.0)), Wall("open"))
    with pytest.raises(SimConfigError, match=">= 0"):
        Collider(HalfPlane((0.0, 0.1), (0.0, 1.0)), Wall("friction", -0.5))
    with pytest.raises(SimConfigError, match="band must be a number of cells >= 0"):
        Collider(HalfPlane((0.0, 0.1), (0.0, 1.0)), band=-1)
    with pytest.raises(SimConfigError, match="a 3D collider in a 2D grid"):
        SimConfig(
            (16, 16),
            1 / 16,
            1e-3,
            (0.0, -9.8),
            boundary=Boundary.box(2, colliders=[Collider(Ball((0.5,) * 3, 0.1))]),
        )
    with pytest.raises(SimConfigError, match="cuts through the robot 'x': 4 of its 4 particles"):
        check_clear([Collider(Box((0.0, 0.0), (1.0, 0.5)))], np.full((4, 2), 0.25), 1 / 16, "robot 'x'")


def test_a_scene_without_colliders_computes_what_it_did():
    config, *_ = block()
    velocity = [jnp.linspace(-1, 1, 24 * 24).reshape(24, 24)] * 2
    assert config.boundary.colliders == ()
    assert apply_colliders((), config.grid_shape, config.dx, velocity) == velocity
    inside_walls = (12, slice(4, 20))
    np.testing.assert_array_equal(
        apply_boundary(config, velocity)[0][inside_walls], velocity[0][inside_walls]
    )


# Moving colliders: a scripted translation at constant velocity, contact relative to it.


@pytest.mark.parametrize(
    "shape",
    [
        HalfPlane((0.1, 0.2), (-0.3, 1.0)),
        Box((0.2, 0.1), (0.5, 0.3)),
        Ball((0.4, 0.6), 0.15),
        HeightField((0.0, 0.3, 0.6, 1.0), (0.1, 0.2, 0.15, 0.3)),
        Union((Ball((0.4, 0.6), 0.15), Box((0.2, 0.1), (0.5, 0.3)))),
        Box((0.2, 0.1, 0.3), (0.5, 0.3, 0.6)),
        HeightField((0.0, 0.5, 1.0), (0.1, 0.3, 0.2), dim=3),
    ],
)
def test_a_shapes_distance_in_jax_is_its_distance_in_numpy(shape):
    """Moving colliders are evaluated in JAX at every step, static ones once in numpy: the two
    give one distance and normal (away from the kinks and faces where the nearest feature ties)."""
    points = np.random.default_rng(0).uniform(0.0, 1.0, (200, shape.dim))
    phi, normal = shape.distance(points)
    phi_jax, normal_jax = shape.distance(jnp.asarray(points, jnp.float32), jnp)
    chex.assert_trees_all_close((phi_jax, normal_jax), (phi, normal), atol=1e-5, rtol=1e-5)
    moving = Collider(shape, velocity=(0.5,) + (0.0,) * (shape.dim - 1))
    shifted = points + np.array(moving.velocity) * 0.2
    chex.assert_trees_all_close(moving.distance(shifted, 0.2), shape.distance(points), atol=1e-12)


def _passive_block(collider, seconds, lower, size, floor="sticky"):
    """(initial state, final state, config) of a resting passive block beside `collider`."""
    config, body, design, state = block(
        n_grid=32,
        lower=lower,
        size=size,
        youngs=1000.0,
        n_actuators=0,
        boundary=Boundary.box(2, floor=floor, colliders=[collider]),
    )
    steps = int(seconds / config.dt)
    rollout = jax.jit(make_rollout(config, body, lambda p, s, g: jnp.zeros((0,)), steps))
    final, _ = rollout(None, design, state)
    return state, final, config


def _carried(contact, seconds=0.3, speed=0.5):
    """The block's centroid displacement along x on a floor that moves along itself at `speed`."""
    floor = Collider(HalfPlane((0.0, 0.15), (0.0, 1.0)), contact, velocity=(speed, 0.0))
    state, final, _ = _passive_block(floor, seconds, lower=0.16, size=0.15)
    return float(jnp.mean(final.x[:, 0]) - jnp.mean(state.x[:, 0])), seconds


def test_a_sticky_conveyor_carries_a_block_and_a_slip_one_slides_under_it():
    """A floor moving along itself does not move in space: only the contact relative to its
    velocity tells it moves. Sticky, the block rides at the floor's speed; slip, it stays."""
    moved, seconds = _carried(Wall("sticky"))
    assert moved == pytest.approx(0.5 * seconds, rel=0.15)
    slipped, _ = _carried(Wall("slip"))
    assert abs(slipped) < 0.02 * 0.5 * seconds


def test_a_moving_paddle_pushes_a_block_ahead_of_it():
    """A slip paddle moving right at 0.4 reaches a block resting on the floor and pushes it: at
    the end the block is ahead of the paddle's face and has moved with it."""
    paddle = Collider(Box((0.05, 0.1), (0.15, 0.3)), Wall("slip"), velocity=(0.4, 0.0))
    state, final, config = _passive_block(paddle, 0.4, lower=0.2, size=0.12, floor="slip")
    face = 0.15 + 0.4 * int(0.4 / config.dt) * config.dt
    assert float(jnp.min(final.x[:, 0])) > face - config.dx  # not run through
    assert float(jnp.mean(final.x[:, 0]) - jnp.mean(state.x[:, 0])) > 0.5 * (face - 0.2)
    static = Collider(paddle.shape, Wall("slip"))
    assert Collider(paddle.shape, Wall("slip"), velocity=(0.0, 0.0)) == static  # zero: static


def test_gradients_through_a_moving_friction_collider_match_central_differences(x64):
    pusher = Collider(Ball((0.2, 0.3), 0.08), Wall("friction", 0.3), velocity=(0.6, -0.2))
    config, body, design, state = block(
        n_grid=16, lower=0.35, dtype=jnp.float64, boundary=Boundary.box(2, colliders=[pusher])
    )
    rollout = make_rollout(config, body, lambda p, s, g: jnp.tanh(p), 40)

    def loss(action):
        final, _ = rollout(action, design, state)
        return jnp.mean(final.x[:, 0]) + jnp.mean(final.x[:, 1] ** 2)

    loss = jax.jit(loss)
    action = jnp.array([0.3, -0.2])
    gradient = jax.jit(jax.grad(loss))(action)
    h = 1e-5
    numeric = [(loss(action.at[i].add(h)) - loss(action.at[i].add(-h))) / (2 * h) for i in range(2)]
    np.testing.assert_allclose(gradient, numeric, rtol=1e-5, atol=1e-9)


def test_bad_moving_colliders_are_refused_naming_what_is_wrong():
    floor = HalfPlane((0.0, 0.1), (0.0, 1.0))
    with pytest.raises(SimConfigError, match="a 2D collider needs a velocity of 2 numbers"):
        Collider(floor, velocity=(1.0, 0.0, 0.0))
    with pytest.raises(SimConfigError, match="Collider.velocity must be 2 or 3 finite numbers"):
        Collider(floor, velocity=(math.inf, 0.0))
    with pytest.raises(SimConfigError, match="travels 1.6 cells per step .*slow it down or lower dt"):
        SimConfig(
            (16, 16),
            1 / 16,
            1e-2,
            (0.0, -9.8),
            boundary=Boundary.box(2, colliders=[Collider(floor, velocity=(10.0, 0.0))]),
        )

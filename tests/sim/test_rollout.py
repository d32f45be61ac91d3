"""Rollout structure: snapshots, observations, remat, vmap and determinism."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.sim import make_rollout, make_step, rasterize
from litl.sim.step import Components
from tests.sim.scenes import block, sine_params, sine_policy

# Physics, gradients and determinism: worth running on a GPU (`pytest -m gpu`).
pytestmark = pytest.mark.gpu


@pytest.fixture(scope="module")
def scene():
    return block(2, n_grid=24, lower=0.3, size=0.25)


def test_snapshots_are_strided_grid_velocities(x64):
    config, body, design, state = block(2, n_grid=24, lower=0.3, size=0.25, dtype=jnp.float64)
    params = sine_params(body.n_actuators, jnp.float64)
    final, trajectory = jax.jit(make_rollout(config, body, sine_policy, 23, snapshot_stride=5))(
        params, design, state
    )
    assert trajectory.snapshots.shape == (4, 24, 24, 2)
    assert trajectory.observations.shape == (23, 2)
    # Replay with single steps: snapshot k is the grid velocity of step 5(k+1) - 1.
    step = jax.jit(make_step(config, body))
    grid_velocity = rasterize(config, body, state, design).velocity
    s = state
    for index in range(23):
        s, grid = step(s, sine_policy(params, s, grid_velocity), design)
        grid_velocity = grid.velocity
        if (index + 1) % 5 == 0:
            np.testing.assert_allclose(trajectory.snapshots[(index + 1) // 5 - 1], grid.velocity, atol=1e-12)
        np.testing.assert_allclose(trajectory.observations[index], jnp.mean(s.x, 0), atol=1e-12)
    np.testing.assert_allclose(final.x, s.x, atol=1e-12)
    assert int(final.step) == 23


def test_closed_loop_contract_step_k_sees_the_grid_after_step_k_minus_1(x64):
    """The policy at step 0 reads the rasterized initial grid; at step k, the post-boundary grid
    velocity that step k - 1 computed. Checked by a policy whose actuation is a readout of the
    grid it sees (actuators of zero strength, so the readout does not change the motion)."""
    config, body, design, state = block(2, n_grid=24, lower=0.3, size=0.25, dtype=jnp.float64)
    design = design.replace(actuator_strength=jnp.zeros_like(design.actuator_strength))
    state = state.replace(v=state.v + jnp.asarray([0.5, -0.2]))  # a field that is not zero
    weights = jnp.linspace(-1.0, 1.0, config.grid_shape[0] * config.grid_shape[1] * 2)

    def readout(grid_velocity):
        return jnp.full((body.n_actuators,), jnp.dot(weights, grid_velocity.reshape(-1)))

    steps = 6
    _, trajectory = make_rollout(config, body, lambda p, s, g: readout(g), steps)(None, design, state)
    step = make_step(config, body)
    seen = [rasterize(config, body, state, design).velocity]
    current = state
    for _ in range(steps - 1):
        current, grid = step(current, jnp.zeros(body.n_actuators), design)
        seen.append(grid.velocity)
    expected = jnp.stack([readout(g) for g in seen])
    assert float(jnp.max(jnp.abs(jnp.diff(expected[:, 0])))) > 1e-6  # the grids differ per step
    np.testing.assert_allclose(trajectory.actuation, expected, rtol=1e-12, atol=1e-14)


def test_remat_does_not_change_values_or_gradients(scene):
    config, body, design, state = scene
    params = sine_params(body.n_actuators)

    def loss(remat):
        rollout = make_rollout(config, body, sine_policy, 30, snapshot_stride=7, remat=remat)
        return lambda p: jnp.mean(rollout(p, design, state)[0].x[:, 0])

    v1, g1 = jax.jit(jax.value_and_grad(loss(True)))(params)
    v2, g2 = jax.jit(jax.value_and_grad(loss(False)))(params)
    np.testing.assert_allclose(v1, v2, rtol=1e-6)
    for a, b in zip(jax.tree.leaves(g1), jax.tree.leaves(g2), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-4, atol=1e-7)


def test_vmap_over_two_designs_equals_two_runs(scene):
    config, body, design, state = scene
    params = sine_params(body.n_actuators)
    rollout = make_rollout(config, body, sine_policy, 40, snapshot_stride=10)
    designs = jax.tree.map(lambda a: jnp.stack([a, a * 1.5]), design)
    batched_final, batched_traj = jax.jit(jax.vmap(rollout, in_axes=(None, 0, None)))(params, designs, state)
    for i in range(2):
        single = jax.tree.map(lambda a, i=i: a[i], designs)
        final, trajectory = jax.jit(rollout)(params, single, state)
        np.testing.assert_allclose(batched_final.x[i], final.x, rtol=1e-5, atol=1e-6)
        # Grid velocities are momentum / mass: at nodes the body barely reaches, a small mass
        # amplifies the rounding of a differently compiled (batched) program. On an H200 the
        # largest difference was 8.4e-4 of velocities up to ~1 (2026-11-27), on the CPU under 1e-4.
        np.testing.assert_allclose(batched_traj.snapshots[i], trajectory.snapshots, atol=2e-3)
    assert not np.allclose(batched_final.x[0], batched_final.x[1])


def test_same_inputs_give_identical_results_on_a_gpu(scene, deterministic):
    """One compiled program run twice gives the same bits: a claim about a GPU's scatter-adds
    (whose order XLA fixes only in litl's deterministic mode). XLA's CPU programs are
    deterministic by construction, so on a CPU the test could not fail and is skipped; it runs
    in the GPU check (`pytest -m gpu`, benchmarks/gpu_check.py)."""
    if jax.default_backend() == "cpu":
        pytest.skip("a CPU program cannot differ from itself: this means something only on a GPU")
    config, body, design, state = scene
    rollout = jax.jit(make_rollout(config, body, sine_policy, 40))
    a = rollout(sine_params(body.n_actuators), design, state)
    b = rollout(sine_params(body.n_actuators), design, state)
    for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b), strict=True):
        np.testing.assert_array_equal(x, y)


def test_component_form_round_trips(scene):
    _, _, _, state = scene
    state = state.replace(C=state.C + 0.5, F=state.F * 2.0)
    back = Components.unpack(state).pack()
    for x, y in zip(jax.tree.leaves(state), jax.tree.leaves(back), strict=True):
        np.testing.assert_array_equal(x, y)


def test_second_call_does_not_recompile(scene):
    config, body, design, state = scene
    rollout = jax.jit(make_rollout(config, body, sine_policy, 5))
    rollout(sine_params(body.n_actuators), design, state)
    before = rollout._cache_size()
    rollout(sine_params(body.n_actuators), design.replace(density=design.density * 2), state)
    assert rollout._cache_size() == before


@pytest.mark.parametrize("stride,every", [(None, 8), (4, 8), (5, 5), (None, 100)])
def test_segment_checkpointing_changes_nothing_but_memory(stride, every, x64):
    config, body, design, state = block(2, n_grid=24, lower=0.3, size=0.25, dtype=jnp.float64)
    params = sine_params(body.n_actuators, jnp.float64)

    def run(checkpoint_every):
        rollout = make_rollout(
            config, body, sine_policy, 37, snapshot_stride=stride, checkpoint_every=checkpoint_every
        )

        def loss(p):
            out = rollout(p, design, state)  # one rollout: tracing two doubles compilation
            return jnp.mean(out[0].x[:, 0]), out

        return jax.jit(jax.value_and_grad(loss, has_aux=True))(params)

    (v1, out1), g1 = run(None)
    (v2, out2), g2 = run(every)
    np.testing.assert_allclose(v1, v2, rtol=1e-12)
    for a, b in zip(jax.tree.leaves((out1, g1)), jax.tree.leaves((out2, g2)), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12)
    assert out2[1].observations.shape == (37, 2)
    assert out2[1].snapshots.shape[0] == (37 // stride if stride else 0)


def test_checkpoint_every_must_fit_the_stride(scene):
    config, body, design, state = scene
    with pytest.raises(ValueError, match="multiple of snapshot_stride"):
        make_rollout(config, body, sine_policy, 20, snapshot_stride=3, checkpoint_every=4)


def test_a_passive_body_rolls_out(stride=5):
    """A body without actuators (a falling block, a passive obstacle) simulates; its actuation
    record is (steps, 0)."""
    config, body, design, state = block(n_actuators=0)
    rollout = make_rollout(
        config, body, lambda params, state, grid: jnp.zeros((0,)), 12, snapshot_stride=stride
    )
    final, trajectory = jax.jit(rollout)(None, design, state)
    assert trajectory.actuation.shape == (12, 0)
    assert np.all(np.isfinite(final.x)) and float(jnp.mean(final.x[:, 1] - state.x[:, 1])) < 0


def test_a_rollout_with_a_fixed_point_particle_to_grid_is_the_scatters_to_rounding():
    """SimConfig(particle_to_grid="fixed_point"): a 60-step float32 rollout and its gradient
    agree with the float scatter's to float32 rounding; an unknown choice is refused naming both."""
    import dataclasses

    import chex

    from litl.sim import SimConfigError

    config, body, design, state = block(2, n_grid=16, lower=0.3, size=0.25, youngs=30.0)
    results = []
    for choice in ("scatter", "fixed_point"):
        rollout = make_rollout(dataclasses.replace(config, particle_to_grid=choice), body, sine_policy, 60)

        def loss(p, rollout=rollout):
            final, _ = rollout(p, design, state)
            return jnp.mean(final.x[:, 0]) + jnp.mean(final.F[:, 1, 1]), final

        (value, final), grad = jax.jit(jax.value_and_grad(loss, has_aux=True))(sine_params(body.n_actuators))
        results.append((value, final.x, grad))
    chex.assert_trees_all_close(results[0], results[1], rtol=2e-5, atol=2e-6)
    with pytest.raises(SimConfigError, match=r"unknown particle_to_grid 'atomic'.*scatter.*fixed_point"):
        dataclasses.replace(config, particle_to_grid="atomic")
    from litl import config as run_config
    from litl.sim import config as sim_config

    assert run_config.PARTICLE_TO_GRID == sim_config.PARTICLE_TO_GRID  # the run's key and the simulator's

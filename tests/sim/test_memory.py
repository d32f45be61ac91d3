"""Segment checkpointing chosen to fit a memory budget: the plan, and gradients unchanged by it."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.sim import make_rollout
from litl.sim.memory import (
    GIB,
    MemoryBudgetError,
    default_budget_bytes,
    plan_checkpointing,
    square_root_segment,
    stored_carries,
)
from tests.sim.scenes import block, sine_params, sine_policy


def test_plain_when_it_fits_segments_near_the_square_root_when_not():
    assert plan_checkpointing(4096, 1, 1000, 10, budget_bytes=10**8).checkpoint_every is None
    plan = plan_checkpointing(4096, 1, 1000, 10, budget_bytes=10**6)
    assert plan.checkpoint_every == 64 and plan.kept_carries == 128
    assert plan.backward_bytes == 128 * 1000 + 4096 * 10 <= 10**6 < plan.plain_bytes
    # With snapshots every 10 steps, K is a multiple of 10 near sqrt(1000) = 31.6.
    assert square_root_segment(1000, 10) in (30, 40)
    assert stored_carries(1000, 30) == 34 + 30 and stored_carries(1000, None) == 1000


def test_a_budget_too_small_even_for_segments_says_what_to_change():
    with pytest.raises(MemoryBudgetError, match=r"raise sim.memory_budget .*fewer steps"):
        plan_checkpointing(4096, 1, 1000, 10, budget_bytes=10**5)


class _Device:
    """A device reporting `stats` (or raising, as some CPU devices do) from `memory_stats()`."""

    def __init__(self, stats):
        self.stats = stats

    def memory_stats(self):
        if isinstance(self.stats, Exception):
            raise self.stats
        return self.stats


def test_the_default_budget_is_half_the_device_memory(monkeypatch):
    # A GPU's own memory (`bytes_limit`), whatever the machine's RAM: exactly half, in bytes.
    monkeypatch.setattr("os.sysconf", lambda name: {"SC_PAGE_SIZE": 4096, "SC_PHYS_PAGES": 2**20}[name])
    assert default_budget_bytes(_Device({"bytes_limit": 80 * GIB, "bytes_in_use": GIB})) == 40 * GIB
    # A device that reports no limit, or raises: half the machine's RAM (4 GiB of 4 KiB pages).
    for stats in (None, {}, {"bytes_limit": 0}, RuntimeError("no memory stats on this CPU")):
        assert default_budget_bytes(_Device(stats)) == 2 * GIB


@pytest.mark.parametrize("dim", [2, 3])
def test_a_tight_budget_picks_segments_and_the_gradient_is_unchanged(dim, x64):
    config, body, design, state = block(dim, n_grid=16, lower=0.3, size=0.25, youngs=300.0, dtype=jnp.float64)
    params = sine_params(body.n_actuators, jnp.float64)
    steps = 64

    def rollout(**memory):
        return make_rollout(config, body, sine_policy, steps, snapshot_stride=4, **memory)

    def gradient(**memory):
        run = rollout(**memory)
        loss = lambda p, e: jnp.mean(run(p, design.replace(youngs_modulus=e), state)[0].x)
        value, grads = jax.jit(jax.value_and_grad(loss, argnums=(0, 1)))(params, design.youngs_modulus)
        return run.plan(params, design, state), value, grads

    plain_plan, plain_value, plain_grads = gradient(checkpoint_every=None)
    assert plain_plan.checkpoint_every is None
    # Half the plain backward pass: segments of about sqrt(64) = 8 steps.
    budget = plain_plan.plain_bytes // 2
    plan, value, grads = gradient(memory_budget=budget)
    assert plan.checkpoint_every == 8 and plan.backward_bytes <= budget
    # A generous budget keeps the plain backward pass (the plan, from shapes alone).
    generous = rollout(memory_budget=10 * plain_plan.plain_bytes).plan(params, design, state)
    assert generous.checkpoint_every is None
    np.testing.assert_allclose(value, plain_value, rtol=1e-12)
    for a, b in zip(jax.tree.leaves(grads), jax.tree.leaves(plain_grads), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-14)


def test_bad_budgets_are_refused():
    config, body, design, state = block(2)
    for budget in (0, -1.0, True, "1GB"):
        with pytest.raises(ValueError, match="memory_budget must be a positive number"):
            make_rollout(config, body, sine_policy, 10, memory_budget=budget)


def test_the_grid_field_counts_only_when_the_policy_reads_it():
    config, body, design, state = block(2, n_grid=16)
    params = sine_params(body.n_actuators)
    reading = lambda p, s, g: sine_policy(p, s, g) + 0.0 * jnp.sum(g)

    def planned(policy):
        return (
            make_rollout(config, body, policy, 8, checkpoint_every=None)
            .plan(params, design, state)
            .carry_bytes
        )

    field_bytes = 16 * 16 * 2 * 4  # the 2D grid velocity, float32
    assert planned(reading) - planned(sine_policy) == field_bytes


def shapes(tree):
    return jax.tree.map(lambda leaf: jax.ShapeDtypeStruct(leaf.shape, leaf.dtype), tree)


@pytest.mark.parametrize(
    ("dim", "reads_field", "memory", "expected"),
    [
        # (checkpoint_every, carry bytes, per-step bytes, budget): the plans the rollout followed
        # when it was planned while traced; the field counts in the carry only when it is read.
        (2, False, {"checkpoint_every": None}, (None, 3084, 16, None)),
        (2, True, {"snapshot_stride": 4, "memory_budget": 200_000}, (8, 5132, 528, 200_000)),
        (2, False, {"snapshot_stride": 4, "checkpoint_every": 8}, (8, 3084, 528, None)),
        (2, True, {"memory_budget": 10**9}, (None, 5132, 16, 10**9)),
        (3, True, {"snapshot_stride": 5, "memory_budget": 700_000}, (5, 41484, 4167, 700_000)),
    ],
)
def test_the_plan_comes_from_shapes_alone_before_any_trace(dim, reads_field, memory, expected):
    config, body, design, state = block(dim, n_grid=16 if dim == 2 else 12)
    params = sine_params(body.n_actuators)
    policy = (lambda p, s, g: sine_policy(p, s, g) + 0.0 * jnp.sum(g)) if reads_field else sine_policy
    steps = 64 if dim == 2 else 30
    rollout = make_rollout(config, body, policy, steps, **memory)
    plan = rollout.plan(shapes(params), shapes(design), shapes(state))
    assert (plan.checkpoint_every, plan.carry_bytes, plan.per_step_bytes, plan.budget_bytes) == expected
    assert plan.steps == steps and rollout.plan(params, design, state) == plan


def test_a_budget_too_small_is_refused_by_the_plan_as_by_the_rollout():
    config, body, design, state = block(2, n_grid=16)
    params = sine_params(body.n_actuators)
    rollout = make_rollout(config, body, sine_policy, 64, memory_budget=1000)
    with pytest.raises(MemoryBudgetError):
        rollout.plan(shapes(params), shapes(design), shapes(state))
    with pytest.raises(MemoryBudgetError):
        jax.eval_shape(rollout, params, design, state)

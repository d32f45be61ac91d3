"""Rollouts: a `lax.scan` over steps with rematerialization, driven by a policy callback.

The policy sees the current state and the latest post-boundary grid field (the observer's input:
the grid velocity unless `make_rollout` is given another `field`, see `litl.sim.fields`) and
returns one actuation value per actuator:

    policy(policy_params, state, grid_velocity) -> (m,) actuation

`state.step` gives the step index for open-loop (time-dependent) policies.

`make_rollout` returns a `Rollout`: call it to run, and ask its `plan` what the backward pass will
keep (`litl.sim.memory.CheckpointPlan`), a pure function of the arguments' shapes that needs no
trace of the rollout.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

from litl.backend import warn_if_slow_gpu_scatter
from litl.sim.config import SimConfig
from litl.sim.fields import GridField
from litl.sim.fields import grid_velocity as velocity_field
from litl.sim.memory import CheckpointPlan, default_budget_bytes, plan_checkpointing
from litl.sim.state import Body, Design, SimState
from litl.sim.step import Components, make_component_step, rasterize

Policy = Callable[[Any, SimState, jnp.ndarray], jnp.ndarray]


@struct.dataclass
class Health:
    """Whether a rollout stayed valid; each field is the first step index that failed, or -1.

    Attributes:
      first_nonfinite_step: () int32, first step whose result had a NaN or infinity.
      first_escape_step: () int32, first step after which a particle's stencil left the grid.
    """

    first_nonfinite_step: jnp.ndarray
    first_escape_step: jnp.ndarray

    @classmethod
    def ok(cls) -> Health:
        return cls(jnp.array(-1, jnp.int32), jnp.array(-1, jnp.int32))

    def record(self, config: SimConfig, state: Components, step_index) -> Health:
        """Update with the state after step `step_index` (per-component form, see `Components`)."""
        # One reduction each: NaN and infinity survive the elementwise sum and the logical and.
        total = sum([*state.x, *state.v, *(f for row in state.F for f in row)])
        finite = jnp.all(jnp.isfinite(total))
        inside: Any = True  # a bool array after the first axis
        for x, n in zip(state.x, config.grid_shape, strict=True):
            # The next step's stencil starts at floor(x / dx - 0.5) and must lie in [0, n - 3].
            cells = x / config.dx - 0.5
            inside = inside & (cells >= 0) & (cells < n - 2)
        inside = jnp.all(inside)
        first = lambda seen, good: jnp.where((seen < 0) & ~good, step_index, seen)
        return Health(
            first_nonfinite_step=first(self.first_nonfinite_step, finite),
            first_escape_step=first(self.first_escape_step, inside),
        )


@struct.dataclass
class Trajectory:
    """What a rollout returns besides the final state.

    Attributes:
      snapshots: (n_snapshots, *grid_shape, d) grid velocity after steps stride, 2*stride, ...;
        (0, *grid_shape, d) without a stride.
      observations: pytree of `observe(state)` after every step, each leaf (steps, ...).
      actuation: (steps, m) the policy's output at every step.
      health: validity of the rollout (see `Health`).
    """

    snapshots: jnp.ndarray
    observations: Any
    actuation: jnp.ndarray
    health: Health


def centroid(state: SimState):
    """(d,) mean particle position: the default per-step observation."""
    return jnp.mean(state.x, axis=0)


def _counter(length):
    # Scanned over as xs: a per-step int that stays unbatched under vmap (see linalg.materialize).
    return jnp.arange(length, dtype=jnp.int32)


def _reads_field(policy: Policy, policy_params, state, field) -> bool:
    """Whether `policy`'s result depends on its grid field (from its jaxpr, traced on shapes
    alone: an unused input is never read)."""
    closed = jax.make_jaxpr(policy)(policy_params, state, field)
    used = {id(v) for eqn in closed.jaxpr.eqns for v in eqn.invars}
    used |= {id(v) for v in closed.jaxpr.outvars}
    field_inputs = closed.jaxpr.invars[len(closed.jaxpr.invars) - len(jax.tree.leaves(field)) :]
    return any(id(v) in used for v in field_inputs)


@dataclasses.dataclass(frozen=True)
class Rollout:
    """What `make_rollout` returns: call it to run; `plan` tells what its backward pass keeps.

    Attributes:
      run: ``run(policy_params, design, initial_state) -> (final_state, Trajectory)``, pure and
        jittable (calling the `Rollout` calls it).
      plan: ``plan(policy_params, design, initial_state) -> CheckpointPlan``, the segment length
        and bytes `run` keeps for its backward pass given the same arguments (one rollout's: under
        `jax.vmap`, pass one seed's). It reads only their shapes and dtypes (arrays or
        `jax.ShapeDtypeStruct`s), computes nothing and compiles nothing, so it can be asked before
        the rollout is ever traced. Raises `litl.sim.memory.MemoryBudgetError` as `run` would.
    """

    run: Callable[[Any, Design, SimState], tuple[SimState, Trajectory]]
    plan: Callable[[Any, Design, SimState], CheckpointPlan]

    def __call__(self, policy_params, design: Design, initial_state: SimState) -> tuple[SimState, Trajectory]:
        return self.run(policy_params, design, initial_state)


def make_rollout(
    config: SimConfig,
    body: Body,
    policy: Policy,
    steps: int,
    snapshot_stride: int | None = None,
    observe: Callable[[SimState], Any] = centroid,
    remat: bool = True,
    checkpoint_every: int | str | None = "auto",
    field: GridField = velocity_field,
    memory_budget: int | None = None,
) -> Rollout:
    """Build `rollout(policy_params, design, initial_state) -> (final_state, Trajectory)`.

    Pure and jittable; differentiate it with `jax.grad` through a loss of its outputs. With `remat`
    the backward pass keeps the particle state per step (plus the observations and snapshots), not
    every step's intermediates; `checkpoint_every=K` keeps one state per K steps plus K states, at
    the price of one more forward pass.

    Args:
      config: static simulator configuration.
      body: particle layout (volumes, actuator ids, fibers, pinned particles).
      policy: ``policy(params, state, grid_velocity) -> (m,) actuation``.
      steps: number of steps (> 0).
      snapshot_stride: record the grid field every this many steps (None: no snapshots).
      observe: per-step observation of the state, recorded after every step.
      remat: rematerialize each step in the backward pass (`jax.checkpoint`).
      checkpoint_every: "auto" (segments only where the memory budget needs them), K (always
        segments of K steps, a multiple of `snapshot_stride` when both are given), or None
        (never).
      field: ``field(grid) -> (*grid_shape, d)``, what the policy reads and the snapshots record
        of each step's `Grid` (`litl.sim.fields`; default: the node velocities).
      memory_budget: bytes one rollout's backward pass may keep (under `jax.vmap`, divide the
        budget by the batch); None: `litl.sim.memory.MEMORY_FRACTION` of the device's memory.
        Only read with `checkpoint_every="auto"`.

    Returns:
      A `Rollout`: the function above, and `plan`, the memory plan it follows.
    """
    _check_arguments(steps, snapshot_stride, checkpoint_every, memory_budget)
    warn_if_slow_gpu_scatter()
    step_fn = make_component_step(config, body)
    schedule = _Schedule(steps, snapshot_stride, checkpoint_every, memory_budget)

    def initial_carry(design: Design, initial_state: SimState):
        return (
            Components.unpack(initial_state),
            field(rasterize(config, body, initial_state, design)),
            Health.ok(),
        )

    step_of = _step_maker(config, step_fn, policy, observe, field)

    def plan(policy_params, design: Design, initial_state: SimState) -> CheckpointPlan:
        carry = jax.eval_shape(initial_carry, design, initial_state)
        outputs = jax.eval_shape(
            lambda p, d, c: step_of(p, d)(c, jnp.zeros((), jnp.int32)), policy_params, design, carry
        )[1]
        return schedule.plan(carry, outputs, _reads_field(policy, policy_params, initial_state, carry[1]))

    def rollout(policy_params, design: Design, initial_state: SimState):
        one_step = step_of(policy_params, design)
        every = plan(policy_params, design, initial_state).checkpoint_every
        one_step = jax.checkpoint(one_step) if remat else one_step
        return schedule.run(one_step, initial_carry(design, initial_state), every)

    return Rollout(run=rollout, plan=plan)


def _step_maker(config: SimConfig, step_fn, policy: Policy, observe, field: GridField):
    """`step_of(policy_params, design)`: one step of the scan, (carry, step index) -> (carry,
    (observation, actuation))."""

    def step_of(policy_params, design: Design):
        def one_step(carry, counter):
            components, grid_velocity, health = carry
            # Packing is free where a policy or observation does not read a field: XLA drops it.
            actuation = policy(policy_params, components.pack(), grid_velocity)
            index = components.step
            components, grid = step_fn(components, actuation, design, counter)
            health = health.record(config, components, index)
            return (components, field(grid), health), (observe(components.pack()), actuation)

        return one_step

    return step_of


def _check_arguments(steps, snapshot_stride, checkpoint_every, memory_budget) -> None:
    """`make_rollout`'s arguments, checked (`ValueError` names the one that is wrong)."""
    if not isinstance(steps, int) or steps <= 0:
        raise ValueError(f"steps must be a positive integer, got {steps!r}")
    if snapshot_stride is not None and (
        not isinstance(snapshot_stride, int) or not 0 < snapshot_stride <= steps
    ):
        raise ValueError(
            f"snapshot_stride must be an integer in [1, steps={steps}] or None, got {snapshot_stride!r}"
        )
    if (
        checkpoint_every != "auto"
        and checkpoint_every is not None
        and (
            isinstance(checkpoint_every, bool)
            or not isinstance(checkpoint_every, int)
            or checkpoint_every <= 0
            or checkpoint_every % (snapshot_stride or 1)
        )
    ):
        raise ValueError(
            f'checkpoint_every must be "auto", a positive integer multiple of snapshot_stride '
            f"({snapshot_stride}) or None, got {checkpoint_every!r}"
        )
    if memory_budget is not None and (
        isinstance(memory_budget, bool)
        or not isinstance(memory_budget, (int, float))
        or not memory_budget > 0
    ):
        raise ValueError(f"memory_budget must be a positive number of bytes or None, got {memory_budget!r}")


@dataclasses.dataclass(frozen=True)
class _Schedule:
    """How a rollout's steps are scanned: in units (a snapshot after each unit), units in
    segments (each rematerialized as a whole when there are segments), and the memory plan that
    sets the segments' length."""

    steps: int
    snapshot_stride: int | None
    checkpoint_every: int | str | None
    memory_budget: int | None

    def plan(self, carry, step_outputs, reads_field: bool) -> CheckpointPlan:
        """The segment length for this rollout's carry and per-step outputs (shapes only); the
        grid field is kept per step only when the policy reads it (else XLA drops it)."""
        nbytes = lambda tree: sum(
            math.prod(leaf.shape) * leaf.dtype.itemsize for leaf in jax.tree.leaves(tree)
        )
        stride = self.snapshot_stride
        carry_bytes = nbytes(carry) - (0 if reads_field else nbytes(carry[1]))
        per_step = nbytes(step_outputs) + (nbytes(carry[1]) // stride if stride else 0)
        if not isinstance(self.checkpoint_every, str):  # K or None: "auto" is the only string allowed
            return CheckpointPlan(self.checkpoint_every, self.steps, carry_bytes, per_step)
        budget = default_budget_bytes() if self.memory_budget is None else int(self.memory_budget)
        return plan_checkpointing(self.steps, stride or 1, carry_bytes, per_step, budget)

    def run(self, one_step, carry, every: int | None):
        """Scan `one_step` over the steps from `carry`: (final state, `Trajectory`)."""
        steps, stride = self.steps, self.snapshot_stride
        unit = stride or min(every or steps, steps)
        n_units, rest_steps = divmod(steps, unit)
        units_per_segment = min((every or steps) // unit, n_units)
        n_segments, rest_units = divmod(n_units, units_per_segment)

        def run_unit(carry, start):
            carry, observed = jax.lax.scan(one_step, carry, start + _counter(unit))
            return carry, (observed, carry[1] if stride else None)

        def run_segment(carry, start):
            return jax.lax.scan(run_unit, carry, start + unit * _counter(units_per_segment))

        if every:
            run_segment = jax.checkpoint(run_segment)

        segment_steps = unit * units_per_segment
        carry, (observed, snapshots) = jax.lax.scan(run_segment, carry, segment_steps * _counter(n_segments))
        # Merge the leading `per` axes (an explicit size: -1 is ambiguous for a passive body's
        # (..., 0) actuation record).
        flatten = lambda a, per: a.reshape((math.prod(a.shape[:per]),) + a.shape[per:])
        observations = [jax.tree.map(lambda o: flatten(o, 3), observed)]
        snapshots = [flatten(snapshots, 2)] if stride else []
        done = n_segments * segment_steps
        if rest_units:
            carry, (observed, tail) = jax.lax.scan(run_unit, carry, done + unit * _counter(rest_units))
            observations.append(jax.tree.map(lambda o: flatten(o, 2), observed))
            snapshots += [tail] if stride else []
            done += rest_units * unit
        if rest_steps:
            carry, observed = jax.lax.scan(one_step, carry, done + _counter(rest_steps))
            observations.append(observed)
        final_components, last_grid_velocity, health = carry
        concatenate = lambda *parts: jnp.concatenate(parts) if len(parts) > 1 else parts[0]
        if not snapshots:
            snapshots = [jnp.zeros((0,) + last_grid_velocity.shape, last_grid_velocity.dtype)]
        observations, actuation = jax.tree.map(concatenate, *observations)
        return final_components.pack(), Trajectory(
            snapshots=concatenate(*snapshots),
            observations=observations,
            actuation=actuation,
            health=health,
        )

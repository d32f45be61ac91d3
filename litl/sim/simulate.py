"""The checked, non-jitted entry point: validate inputs, run a rollout, raise on blow-ups."""

from __future__ import annotations

import jax

from litl.sim.config import SimConfig
from litl.sim.rollout import Policy, centroid, make_rollout
from litl.sim.safety import check_actuation, check_time_step, raise_if_unhealthy, validate
from litl.sim.state import Body, Design, SimState


def simulate(
    config: SimConfig,
    body: Body,
    design: Design,
    state: SimState,
    policy: Policy,
    policy_params,
    steps: int,
    snapshot_stride: int | None = None,
    observe=centroid,
):
    """Run `steps` steps from `state` and return ``(final_state, trajectory)``.

    Checks shapes, material values, particle placement, the time step and the actuators' strength
    before running, and raises `litl.sim.safety.SimulationError` if the rollout produced NaNs or
    lost particles. Compiles on every call: for repeated runs (optimization), jit
    `make_rollout(...)` once and call `raise_if_unhealthy(trajectory.health)` on its results.
    """
    validate(config, body, design, state)
    check_time_step(config, body, design)
    check_actuation(body, design)
    rollout = jax.jit(make_rollout(config, body, policy, steps, snapshot_stride, observe))
    final_state, trajectory = rollout(policy_params, design, state)
    raise_if_unhealthy(trajectory.health, steps)
    return final_state, trajectory

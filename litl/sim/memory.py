"""How much memory a rollout's backward pass keeps, and segment checkpointing chosen to fit.

With each step rematerialized (`make_rollout(remat=True)`), reverse mode keeps the scan's carry
(the particle state and the grid field the policy reads) once per step, plus what the rollout
returns per step (observations, actuation, snapshots). Segments of K steps (`checkpoint_every=K`)
keep a carry per segment and, while a segment is differentiated, one per step of it: about
steps / K + K carries, least at K ≈ √steps, for one more forward pass.

`plan_checkpointing` picks: no segments when the plain backward pass fits the budget, else
K near √steps (a multiple of the snapshot stride), else a `MemoryBudgetError` saying what
would fit.
"""

from __future__ import annotations

import dataclasses
import math
import os

from litl.sim.config import SimConfigError

# The default budget: this fraction of the device's memory (a GPU's, or the machine's RAM on
# the CPU); the rest is for the learning phase, the replay buffer and XLA's scratch space.
MEMORY_FRACTION = 0.5
GIB = 2**30


class MemoryBudgetError(SimConfigError):
    """Even segment checkpointing cannot fit the rollout's backward pass in the budget."""


def device_memory_bytes(device=None) -> int:
    """Memory of `device` (default: JAX's first): a GPU's own (`bytes_limit`), else the RAM."""
    import jax

    device = device or jax.devices()[0]
    stats = None
    try:
        stats = device.memory_stats()
    except Exception:  # CPU devices may not report, or raise, depending on the jaxlib
        stats = None
    if stats and stats.get("bytes_limit"):
        return int(stats["bytes_limit"])
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def default_budget_bytes(device=None) -> int:
    """`MEMORY_FRACTION` of the device's memory."""
    return int(MEMORY_FRACTION * device_memory_bytes(device))


@dataclasses.dataclass(frozen=True)
class CheckpointPlan:
    """What a rollout keeps for its backward pass.

    Attributes:
      checkpoint_every: K, the segment length; None: no segments.
      steps: the rollout's steps.
      carry_bytes: one step's carry (particle state, grid field, health).
      per_step_bytes: what the rollout returns per step (observations, actuation, snapshots
        amortized over their stride).
      budget_bytes: the budget it was planned for (None: not planned, K given).
    """

    checkpoint_every: int | None
    steps: int
    carry_bytes: int
    per_step_bytes: int
    budget_bytes: int | None = None

    @property
    def kept_carries(self) -> int:
        return stored_carries(self.steps, self.checkpoint_every)

    @property
    def backward_bytes(self) -> int:
        """Bytes kept for the backward pass (per rollout; a vmap multiplies it)."""
        return self.kept_carries * self.carry_bytes + self.steps * self.per_step_bytes

    @property
    def plain_bytes(self) -> int:
        """The same without segments."""
        return self.steps * (self.carry_bytes + self.per_step_bytes)


def stored_carries(steps: int, checkpoint_every: int | None) -> int:
    """Carries kept: `steps` without segments, ceil(steps / K) + K with."""
    if not checkpoint_every:
        return steps
    return -(-steps // checkpoint_every) + min(checkpoint_every, steps)


def square_root_segment(steps: int, unit: int) -> int:
    """A multiple of `unit` near √steps that keeps the fewest carries (at least `unit`)."""
    candidates = {
        max(unit, unit * round(math.sqrt(steps) / unit)),
        max(unit, unit * math.floor(math.sqrt(steps) / unit)),
        unit * math.ceil(math.sqrt(steps) / unit),
    }
    return min(sorted(candidates), key=lambda k: stored_carries(steps, k))


def plan_checkpointing(
    steps: int, unit: int, carry_bytes: int, per_step_bytes: int, budget_bytes: int
) -> CheckpointPlan:
    """No segments if the plain backward pass fits `budget_bytes`, else K ≈ √steps.

    Args:
      steps: rollout length.
      unit: K must be a multiple of this (the snapshot stride, or 1).
      carry_bytes, per_step_bytes: see `CheckpointPlan`.
      budget_bytes: the memory the backward pass of one rollout may keep.

    Raises:
      MemoryBudgetError: even K ≈ √steps keeps more than the budget.
    """
    plain = CheckpointPlan(None, steps, carry_bytes, per_step_bytes, budget_bytes)
    if plain.backward_bytes <= budget_bytes:
        return plain
    segmented = dataclasses.replace(plain, checkpoint_every=square_root_segment(steps, unit))
    if segmented.backward_bytes > budget_bytes:
        raise MemoryBudgetError(
            f"the backward pass of a {steps}-step rollout keeps {plain.plain_bytes / GIB:.3g} "
            f"GiB, and {segmented.backward_bytes / GIB:.3g} GiB with segments of "
            f"{segmented.checkpoint_every} steps, over the budget of {budget_bytes / GIB:.3g} "
            f"GiB per rollout (sim.memory_budget, divided among vmapped seeds): raise "
            f"sim.memory_budget (GiB), or run fewer steps, particles or seeds per device"
        )
    return segmented

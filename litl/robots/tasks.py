"""Tasks as pure loss functions of a rollout.

A `Task` is a weighted sum of terms; `make_task_loss(task, layout)` closes over the static particle
groups and returns

    loss(initial_state, final_state) -> (total, components)

where `components` maps each term's name to its raw value (a distance travelled, a squared distance
to a target) and ``total = sum(sign * weight * raw)`` is minimized. Pure and jittable; differentiate
it through `litl.sim.make_rollout`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import TYPE_CHECKING, Literal

import jax.numpy as jnp
import numpy as np

from litl.robots.layout import Layout, LayoutError


@dataclasses.dataclass(frozen=True)
class Locomotion:
    """Move the body's centroid along `axis` (default +x).

    `measure="distance"` rewards the centroid's displacement from the start; `"velocity"` the mean
    particle velocity along the axis at the end. `direction=-1` runs the other way.
    """

    axis: int = 0
    measure: Literal["distance", "velocity"] = "distance"
    direction: float = 1.0
    weight: float = 1.0

    @property
    def name(self) -> str:
        return self.measure

    def validate(self, layout: Layout):
        if self.measure not in ("distance", "velocity"):
            raise LayoutError(f"Locomotion measure must be 'distance' or 'velocity', got {self.measure!r}")
        if not 0 <= self.axis < layout.dim:
            raise LayoutError(f"Locomotion axis {self.axis} does not exist in {layout.dim}D")

    def raw(self, layout, initial_state, final_state):
        if self.measure == "velocity":
            return self.direction * jnp.mean(final_state.v[:, self.axis])
        moved = jnp.mean(final_state.x[:, self.axis]) - jnp.mean(initial_state.x[:, self.axis])
        return self.direction * moved

    sign = -1.0  # more is better


@dataclasses.dataclass(frozen=True)
class Reach:
    """Bring the centroid of particle group `group` to `target` (squared distance at the end)."""

    group: str
    target: tuple[float, ...]
    weight: float = 1.0

    def __post_init__(self):
        object.__setattr__(self, "target", tuple(float(t) for t in self.target))

    @property
    def name(self) -> str:
        return f"reach_{self.group}"

    def validate(self, layout: Layout):
        layout.group_mask(self.group)
        if len(self.target) != layout.dim or not np.all(np.isfinite(self.target)):
            raise LayoutError(f"reach target {self.target} must be a finite {layout.dim}D point")

    def raw(self, layout, initial_state, final_state):
        indices = jnp.asarray(layout.groups[self.group])
        centroid = jnp.mean(final_state.x[indices], axis=0)
        return jnp.sum((centroid - jnp.asarray(self.target, centroid.dtype)) ** 2)

    sign = 1.0  # less is better


Term = Locomotion | Reach


@dataclasses.dataclass(frozen=True)
class Task:
    """A weighted sum of terms, e.g. walk right while a trunk reaches a point."""

    terms: tuple[Term, ...]

    if TYPE_CHECKING:  # for the type checker: the constructor takes one term or several

        def __init__(self, terms: Term | Sequence[Term]) -> None: ...

    def __post_init__(self):
        terms = (self.terms,) if isinstance(self.terms, (Locomotion, Reach)) else tuple(self.terms)
        if not terms:
            raise LayoutError("a task needs at least one term")
        names = [term.name for term in terms]
        if len(set(names)) != len(names):
            raise LayoutError(f"task terms must have distinct names, got {names}")
        for term in terms:
            if not (np.isfinite(term.weight) and term.weight > 0):
                raise LayoutError(f"term {term.name!r} needs a positive weight, got {term.weight}")
        object.__setattr__(self, "terms", terms)

    @property
    def targets(self) -> dict[str, tuple[float, ...]]:
        """Target point of every reach term, by group name."""
        return {term.group: term.target for term in self.terms if isinstance(term, Reach)}


def make_task_loss(task: Task, layout: Layout):
    """`loss(initial_state, final_state) -> (total, {term name: raw value})`, pure and jittable."""
    for term in task.terms:
        term.validate(layout)

    def loss(initial_state, final_state):
        components = {term.name: term.raw(layout, initial_state, final_state) for term in task.terms}
        total = sum(term.sign * term.weight * components[term.name] for term in task.terms)
        return total, components

    return loss

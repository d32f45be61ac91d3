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


def _as_point(term) -> None:
    """Store a term's `target` as a tuple of floats (a frozen dataclass's __post_init__)."""
    object.__setattr__(term, "target", tuple(float(t) for t in term.target))


def _check_point(kind: str, target: tuple[float, ...], dim: int) -> None:
    if len(target) != dim or not np.all(np.isfinite(target)):
        raise LayoutError(f"{kind} target {target} must be a finite {dim}D point")


def _squared_distance(points, target: tuple[float, ...]):
    """Squared distance of the centroid of `points` (k, d) to `target`."""
    centroid = jnp.mean(points, axis=0)
    return jnp.sum((centroid - jnp.asarray(target, centroid.dtype)) ** 2)


@dataclasses.dataclass(frozen=True)
class Reach:
    """Bring the centroid of particle group `group` to `target` (squared distance at the end)."""

    group: str
    target: tuple[float, ...]
    weight: float = 1.0

    def __post_init__(self):
        _as_point(self)

    @property
    def name(self) -> str:
        return f"reach_{self.group}"

    def validate(self, layout: Layout):
        layout.group_mask(self.group)
        _check_point("reach", self.target, layout.dim)

    def raw(self, layout, initial_state, final_state):
        return _squared_distance(final_state.x[jnp.asarray(layout.groups[self.group])], self.target)

    sign = 1.0  # less is better


@dataclasses.dataclass(frozen=True)
class Push:
    """Bring the centroid of the scenery body `body` (`Robot.scenery`: the push_box world's box)
    to `target` (squared distance at the end)."""

    body: str
    target: tuple[float, ...]
    weight: float = 1.0

    def __post_init__(self):
        _as_point(self)

    @property
    def name(self) -> str:
        return f"push_{self.body}"

    def validate(self, layout: Layout):
        _check_point("push", self.target, layout.dim)

    def raw(self, span: tuple[int, int], initial_state, final_state):
        start, stop = span
        return _squared_distance(final_state.x[start:stop], self.target)

    sign = 1.0  # less is better


@dataclasses.dataclass(frozen=True)
class Position:
    """Bring the body's centroid (or particle group `group`'s) along `axis` to the coordinate
    `target` (squared distance at the end): walk to a point, or move an arm's tip to one, along
    one axis, whatever the other coordinates."""

    target: float
    axis: int = 0
    weight: float = 1.0
    group: str | None = None

    @property
    def name(self) -> str:
        return "position"

    def validate(self, layout: Layout):
        if not 0 <= self.axis < layout.dim:
            raise LayoutError(f"Position axis {self.axis} does not exist in {layout.dim}D")
        if not np.isfinite(self.target):
            raise LayoutError(f"Position target {self.target} must be a finite coordinate")
        if self.group is not None:
            layout.group_mask(self.group)

    def raw(self, layout, initial_state, final_state):
        x = final_state.x[:, self.axis]
        if self.group is not None:
            x = x[jnp.asarray(layout.groups[self.group])]
        return (jnp.mean(x) - self.target) ** 2

    sign = 1.0  # less is better


Term = Locomotion | Reach | Push | Position


@dataclasses.dataclass(frozen=True)
class Task:
    """A weighted sum of terms, e.g. walk right while a trunk reaches a point."""

    terms: tuple[Term, ...]

    if TYPE_CHECKING:  # for the type checker: the constructor takes one term or several

        def __init__(self, terms: Term | Sequence[Term]) -> None: ...

    def __post_init__(self):
        terms = (
            (self.terms,)
            if isinstance(self.terms, (Locomotion, Reach, Push, Position))
            else tuple(self.terms)
        )
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

    @property
    def point_group(self) -> str | None:
        """The particle group whose centroid the task steers: the one group every term reaches
        or positions (the arm's ``tip``); None where the task moves the whole body (walkers, and
        a task whose terms steer different groups or none). Latent planners steer this point
        (`Robot.task_point`)."""
        groups = {term.group if isinstance(term, (Reach, Position)) else None for term in self.terms}
        return groups.pop() if len(groups) == 1 else None

    @property
    def push_targets(self) -> dict[str, tuple[float, ...]]:
        """Target point of every push term, by body name."""
        return {term.body: term.target for term in self.terms if isinstance(term, Push)}


def make_task_loss(task: Task, layout: Layout, own=None, bodies: dict[str, tuple[int, int]] | None = None):
    """`loss(initial_state, final_state) -> (total, {term name: raw value})`, pure and jittable.

    Args:
      own: ``own(state)``, the robot's part of a scene's state (`Robot.own`), which every term
        but `Push` reads; None: the states are the robot's alone.
      bodies: each scenery body's particles in a scene's state, ``{name: (start, stop)}``
        (`Robot.bodies`), which `Push` terms read.
    """
    own = own or (lambda state: state)
    bodies = bodies or {}
    for term in task.terms:
        term.validate(layout)
        if isinstance(term, Push) and term.body not in bodies:
            raise LayoutError(
                f"task term {term.name!r} moves the body {term.body!r}, which is not in the scene "
                f"(its other bodies: {sorted(bodies) or 'none'}); push_box worlds have a 'box'"
            )

    def loss(initial_state, final_state):
        robot_initial, robot_final = own(initial_state), own(final_state)
        components = {
            term.name: term.raw(bodies[term.body], initial_state, final_state)
            if isinstance(term, Push)
            else term.raw(layout, robot_initial, robot_final)
            for term in task.terms
        }
        total = sum(term.sign * term.weight * components[term.name] for term in task.terms)
        return total, components

    return loss

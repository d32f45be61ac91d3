"""`Robot`: a layout placed in a simulation domain, with its material, design space and task.

A robot is data. It yields the simulator's pytrees (`body`, `initial_state`, `scene`) and its
`design_space` (`litl.robots.design`): the co-design variables φ (one Young's modulus per design
region), their bounds and their map to the simulator's per-particle `Design`.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax.numpy as jnp
import numpy as np

from litl.robots.design import DesignSpace, Material
from litl.robots.layout import Layout, LayoutError
from litl.robots.scenery import Scenery, check_apart
from litl.robots.tasks import Reach, Task, make_task_loss
from litl.sim import (
    Body,
    Design,
    SimConfig,
    SimConfigError,
    SimState,
    check_actuation,
    check_time_step,
)
from litl.sim.colliders import check_clear


@dataclasses.dataclass(frozen=True)
class Scene:
    """Everything needed to simulate a body: static config, layout, design, initial state."""

    config: SimConfig
    body: Body
    design: Design
    state: SimState


@dataclasses.dataclass(frozen=True, eq=False)
class Robot:
    """A robot ready to simulate.

    Attributes:
      name: registry name or a user's label.
      layout: particles and labels, already placed in the domain (see `place`).
      config: simulator settings (grid, dx, dt, gravity, walls, material model).
      material: material values and the bounds of the design variables (`Material`).
      task: the default task.
      steps: the rollout length in simulation steps (1 s of simulated time for the catalog's
        robots); `sim.steps` overrides it. (An episode is one of Algorithm 1's K rounds.)
      description: one paragraph for users: shape, size, actuators, task.
      scenery: passive bodies sharing the scene (`litl.robots.scenery.Scenery`: a sand bed, a
        pool), their particles after the robot's; `config.materials` holds the robot's elastic
        material first and theirs after it (`litl.worlds` builds both).
      observe_scenery: whether observers see the whole scene's grid field; False (the default):
        only the nodes the robot's particles reach (`litl.sim.Body.observed`).
      design: the design space co-design works in (`litl.designs`: ``design=actuators``), or
        None: the robot's own, one Young's modulus per region (`DesignSpace`).
    """

    name: str
    layout: Layout
    config: SimConfig
    material: Material = Material()
    task: Task | None = None
    steps: int = 1000
    description: str = ""
    scenery: tuple[Scenery, ...] = ()
    observe_scenery: bool = False
    design: Any = None

    def __post_init__(self):
        if self.layout.dim != self.config.dim:
            raise SimConfigError(
                f"robot {self.name!r} is {self.layout.dim}D but its grid is {self.config.dim}D"
            )
        if not isinstance(self.steps, int) or self.steps <= 0:
            raise SimConfigError(f"steps must be a positive integer, got {self.steps!r}")
        check_fits(self.layout, self.config, self.name)
        assert self.config.boundary is not None  # SimConfig sets the default box
        check_clear(
            self.config.boundary.colliders, self.layout.positions, self.config.dx, f"robot {self.name!r}"
        )
        if self.scenery:
            materials = self.config.materials
            for body in self.scenery:
                if body.material not in materials:
                    raise SimConfigError(
                        f"robot {self.name!r}: its scenery {body.name!r} is of {body.material}, which its "
                        f"config's materials {materials} lack; build the scene with litl.worlds.put"
                    )
            check_apart(self.layout.positions, self.scenery, self.config.dx, f"robot {self.name!r}")
        if self.task is not None:
            make_task_loss(self.task, self.layout, bodies=self.bodies)  # validates groups and targets
        # The stiffest design allowed must still be stable at this dt, and the softest must hold
        # its actuators without being crushed (co-design drifts to either bound).
        space = self.design_space
        low, high = space.bounds
        check_time_step(self.config, self.body(), space.to_design(space.uniform(high)))
        check_actuation(self.body(), space.to_design(space.uniform(low)))

    # ---- sizes
    @property
    def dim(self) -> int:
        return self.layout.dim

    @property
    def n_actuators(self) -> int:
        return self.layout.n_actuators

    @property
    def n_regions(self) -> int:
        return self.layout.n_regions

    # ---- simulator pytrees
    def body(self, dtype=jnp.float32) -> Body:
        layout = self.layout
        if not self.scenery:
            return Body(
                volume=jnp.asarray(layout.volume, dtype),
                actuator=jnp.asarray(layout.actuator),
                fiber=jnp.asarray(layout.fiber, dtype),
                pinned=jnp.asarray(layout.pinned),
            )
        # The robot's particles first, each passive body's after them.
        counts = [body.n_particles for body in self.scenery]
        materials = self.config.materials
        own = layout.n_particles
        return Body(
            volume=jnp.asarray(
                np.concatenate([layout.volume] + [np.full(b.n_particles, b.volume) for b in self.scenery]),
                dtype,
            ),
            actuator=jnp.asarray(np.concatenate([layout.actuator, np.full(sum(counts), -1, np.int32)])),
            fiber=jnp.asarray(layout.fiber, dtype),
            pinned=jnp.asarray(np.concatenate([layout.pinned, np.zeros(sum(counts), bool)])),
            material=jnp.asarray(
                np.concatenate(
                    [np.zeros(own, np.int32)]
                    + [
                        np.full(k, materials.index(b.material), np.int32)
                        for k, b in zip(counts, self.scenery, strict=True)
                    ]
                )
            ),
            observed=None
            if self.observe_scenery
            else jnp.asarray(np.concatenate([np.ones(own, bool), np.zeros(sum(counts), bool)])),
        )

    @property
    def n_particles(self) -> int:
        """The robot's own particles (the scene's first ones; the scenery's follow)."""
        return self.layout.n_particles

    @property
    def bodies(self) -> dict[str, tuple[int, int]]:
        """Each scenery body's particles in the scene's state: ``{name: (start, stop)}``."""
        spans, start = {}, self.layout.n_particles
        for body in self.scenery:
            spans[body.name] = (start, start + body.n_particles)
            start += body.n_particles
        return spans

    def own(self, state: SimState) -> SimState:
        """The robot's part of a scene's state (`state` itself when there is no scenery)."""
        if not self.scenery:
            return state
        n = self.layout.n_particles
        return dataclasses.replace(
            state,
            x=state.x[..., :n, :],
            v=state.v[..., :n, :],
            C=state.C[..., :n, :, :],
            F=state.F[..., :n, :, :],
        )

    def task_point(self, state: SimState):
        """(d,) the point the task steers in a scene's state: the centroid of its group
        (`Task.point_group`, the arm's tip) or of the robot's own particles."""
        return self._task_point_mean(self.own(state).x)

    def task_point_velocity(self, state: SimState):
        """(d,) the mean velocity of the particles whose centroid is `task_point`."""
        return self._task_point_mean(self.own(state).v)

    def _task_point_mean(self, values):
        group = None if self.task is None else self.task.point_group
        if group is not None:
            values = values[..., jnp.asarray(self.layout.groups[group]), :]
        return jnp.mean(values, axis=-2)

    def shifted(self, offset: float) -> Robot:
        """This robot moved by `offset` along x (domain units) from where its definition placed
        it, its reach targets with it (a walker started mid-domain, so that walking −x has room).
        A `SimConfigError` where it would leave the walls, with the offsets that fit. Scenery
        (a world's bodies) is placed around the robot afterwards (`litl.worlds.put`), so a robot
        that already has some is refused."""
        if not np.isfinite(offset):
            raise SimConfigError(f"robot {self.name!r}: a shift must be a finite length, got {offset!r}")
        if self.scenery:
            raise SimConfigError(
                f"robot {self.name!r} already stands in a world (its scenery "
                f"{[b.name for b in self.scenery]}); shift it before litl.worlds.put"
            )
        assert self.config.boundary is not None  # SimConfig sets the default box
        margin = (self.config.boundary.thickness + 0.5) * self.config.dx
        low, high = self.layout.bounds()
        least, most = margin - low[0], (self.config.grid_shape[0] * self.config.dx - margin) - high[0]
        if not least <= offset <= most:
            raise SimConfigError(
                f"robot {self.name!r}: a shift of {offset:g} along x takes it through a wall; "
                f"shifts from {least:.4f} to {most:.4f} keep it inside (dx = {self.config.dx:g})"
            )
        move = np.zeros(self.dim)
        move[0] = offset
        task = self.task
        if task is not None:
            task = Task(tuple(_shifted_term(term, move) for term in task.terms))
        return dataclasses.replace(self, layout=self.layout.translated(move), task=task)

    @property
    def design_space(self) -> DesignSpace:
        """The co-design variables φ: bounds, initial value, projection, map to `Design`: the
        robot's own (one Young's modulus per region), or its `design` space built around it (so
        that a robot given another material or world afterwards keeps its design space)."""
        own = DesignSpace(
            region=self.layout.region,
            n_regions=self.n_regions,
            n_actuators=self.n_actuators,
            material=self.material,
            scenery=self.scenery,
        )
        return own if self.design is None else self.design.around(own)

    def with_material(self, material: Material) -> Robot:
        """This robot with another `Material`; dt follows the stiffest allowed design
        (`Material.time_step`), the strain limit follows the material's `max_stretch` where that
        changed (a robot with a `SimConfig` of its own keeps its limit otherwise), and a rollout
        keeps its duration in seconds."""
        duration = self.steps * self.config.dt
        dt = material.time_step(self.config.dx)
        limit = self.config.max_stretch
        if material.max_stretch != self.material.max_stretch:
            limit = material.stretch_limit
        config = dataclasses.replace(self.config, dt=dt).with_own_material(
            dataclasses.replace(self.config.own_material, max_stretch=limit)
        )
        return dataclasses.replace(
            self, material=material, config=config, steps=max(int(round(duration / dt)), 1)
        )

    def initial_state(self, dtype=jnp.float32) -> SimState:
        """The scene at rest: the robot's particles, then the scenery's."""
        positions = [self.layout.positions] + [body.positions for body in self.scenery]
        return SimState.at_rest(jnp.asarray(np.concatenate(positions), dtype))

    def scene(self, dtype=jnp.float32) -> Scene:
        return Scene(
            self.config, self.body(dtype), self.design_space.to_design(dtype=dtype), self.initial_state(dtype)
        )

    def task_loss(self, task: Task | None = None):
        """`loss(initial_state, final_state) -> (total, components)` for `task` (default: own)."""
        task = task or self.task
        if task is None:
            raise SimConfigError(f"robot {self.name!r} has no default task; pass one")
        if not self.scenery:
            return make_task_loss(task, self.layout)
        return make_task_loss(task, self.layout, own=self.own, bodies=self.bodies)


def _shifted_term(term, move):
    """A task term of a robot moved by `move`: reach targets move with it; the other terms are
    displacements, velocities or coordinates the user chose (`Position`), and stay."""
    if isinstance(term, Reach):
        return dataclasses.replace(term, target=tuple(np.asarray(term.target) + move))
    return term


def check_fits(layout: Layout, config: SimConfig, name: str = "robot") -> None:
    """Raise `SimConfigError` unless every particle lies inside the walls with a cell of margin."""
    assert config.boundary is not None  # SimConfig sets the default box
    thickness = config.boundary.thickness
    lower = np.full(config.dim, (thickness + 0.5) * config.dx)
    upper = (np.asarray(config.grid_shape) - thickness - 0.5) * config.dx
    low, high = layout.bounds()
    if np.all(low >= lower) and np.all(high <= upper):
        return
    raise SimConfigError(
        f"{name} does not fit the grid: its particles span {np.round(low, 4).tolist()} to "
        f"{np.round(high, 4).tolist()}, but must stay within {np.round(lower, 4).tolist()} to "
        f"{np.round(upper, 4).tolist()} (inside walls of {thickness} cells, dx = {config.dx:g}). "
        f"Scale the robot down, move it, or enlarge grid_shape."
    )


def place(layout: Layout, config: SimConfig, x: float | None = None, lift: float = 0.5, lower=None) -> Layout:
    """Move a layout into the domain.

    By default its bounding box is centred across the domain in every axis but "up" (axis 1); it
    rests `lift` cells above the floor wall; `x` sets the left edge instead of centring along
    axis 0. `lower` (d,) sets the bounding box's lower corner explicitly and overrides the rest.
    """
    low, high = layout.bounds()
    if lower is None:
        domain = np.asarray(config.domain_size)
        lower = (domain - (high - low)) / 2
        assert config.boundary is not None  # SimConfig sets the default box
        lower[1] = (config.boundary.thickness + 0.5 + lift) * config.dx
        if x is not None:
            lower[0] = x
    lower = np.asarray(lower, np.float64)
    if lower.shape != (layout.dim,):
        raise LayoutError(f"placement corner must have {layout.dim} entries, got {lower.tolist()}")
    return layout.translated(lower - low)

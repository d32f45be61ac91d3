"""`Robot`: a layout placed in a simulation domain, with its materials, design bounds and task.

A robot is data. It yields the simulator's pytrees (`body`, `design`, `initial_state`, `scene`) and
maps the co-design variables (one Young's modulus per design region) to a per-particle `Design`.
"""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp
import numpy as np

from litl.robots.layout import Layout, LayoutError
from litl.robots.tasks import Task, make_task_loss
from litl.sim import (
    Body, ConfigError, Design, SimConfig, SimState, check_actuation, check_time_step,
)


@dataclasses.dataclass(frozen=True)
class Scene:
    """Everything needed to simulate a body: static config, layout, design, initial state."""

    config: SimConfig
    body: Body
    design: Design
    state: SimState


@dataclasses.dataclass(frozen=True)
class Material:
    """Material of a robot and the bounds of its design variables.

    Attributes:
      youngs_modulus: initial Young's modulus E of every region.
      youngs_modulus_bounds: (E_min, E_max): co-design projects each region's E into this range.
      poisson_ratio: Poisson ratio nu, in (-1, 0.5).
      density: mass per unit volume.
      actuator_strength: active stress per unit actuation, the same for every actuator.
    """

    youngs_modulus: float = 20.0
    youngs_modulus_bounds: tuple[float, float] = (15.0, 30.0)
    poisson_ratio: float = 0.25
    density: float = 1.0
    actuator_strength: float = 3.0

    def __post_init__(self):
        low, high = self.youngs_modulus_bounds
        if not (0 < low <= self.youngs_modulus <= high < np.inf):
            raise ConfigError(
                f"need 0 < E_min <= youngs_modulus <= E_max, got E = {self.youngs_modulus}, "
                f"bounds {self.youngs_modulus_bounds}")
        if not -1 < self.poisson_ratio < 0.5:
            raise ConfigError(f"poisson_ratio must lie in (-1, 0.5), got {self.poisson_ratio}")
        if not (self.density > 0 and np.isfinite(self.actuator_strength)):
            raise ConfigError(f"density must be > 0 and actuator_strength finite, got "
                              f"{self.density}, {self.actuator_strength}")


@dataclasses.dataclass(frozen=True, eq=False)
class Robot:
    """A robot ready to simulate.

    Attributes:
      name: registry name or a user's label.
      layout: particles and labels, already placed in the domain (see `place`).
      config: simulator settings (grid, dx, dt, gravity, walls, material model).
      material: materials and design bounds.
      task: the default task.
      steps: default episode length in simulation steps.
      description: one paragraph for users: shape, size, actuators, task.
    """

    name: str
    layout: Layout
    config: SimConfig
    material: Material = Material()
    task: Task | None = None
    steps: int = 1000
    description: str = ""

    def __post_init__(self):
        if self.layout.dim != self.config.dim:
            raise ConfigError(f"robot {self.name!r} is {self.layout.dim}D but its grid is {self.config.dim}D")
        if not isinstance(self.steps, int) or self.steps <= 0:
            raise ConfigError(f"steps must be a positive integer, got {self.steps!r}")
        check_fits(self.layout, self.config, self.name)
        if self.task is not None:
            make_task_loss(self.task, self.layout)  # validates groups and targets
        # The stiffest design allowed must still be stable at this dt, and the softest must hold
        # its actuators without being crushed (co-design drifts to either bound).
        low, high = self.material.youngs_modulus_bounds
        check_time_step(self.config, self.body(), self.design(jnp.full((self.n_regions,), high)))
        check_actuation(self.body(), self.design(jnp.full((self.n_regions,), low)))

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
        return Body(
            volume=jnp.asarray(layout.volume, dtype),
            actuator=jnp.asarray(layout.actuator),
            fiber=jnp.asarray(layout.fiber, dtype),
            pinned=jnp.asarray(layout.pinned),
        )

    def region_youngs_modulus(self, dtype=jnp.float32) -> jnp.ndarray:
        """(R,) the initial design variables: Young's modulus of each region."""
        return jnp.full((self.n_regions,), self.material.youngs_modulus, dtype)

    def project(self, region_youngs_modulus):
        """Clip design variables (R,) into the material's bounds (the paper's projection step)."""
        low, high = self.material.youngs_modulus_bounds
        return jnp.clip(region_youngs_modulus, low, high)

    def design(self, region_youngs_modulus=None, dtype=None) -> Design:
        """Per-particle `Design` from one Young's modulus per region (R,); jittable, differentiable."""
        if region_youngs_modulus is None:
            region_youngs_modulus = self.region_youngs_modulus(dtype or jnp.float32)
        region_youngs_modulus = jnp.asarray(region_youngs_modulus, dtype)
        dtype = region_youngs_modulus.dtype
        n, m = self.layout.n_particles, self.n_actuators
        material = self.material
        return Design(
            youngs_modulus=region_youngs_modulus[jnp.asarray(self.layout.region)],
            poisson_ratio=jnp.full((n,), material.poisson_ratio, dtype),
            density=jnp.full((n,), material.density, dtype),
            actuator_strength=jnp.full((m,), material.actuator_strength, dtype),
        )

    def initial_state(self, dtype=jnp.float32) -> SimState:
        return SimState.at_rest(jnp.asarray(self.layout.positions, dtype))

    def scene(self, dtype=jnp.float32) -> Scene:
        return Scene(self.config, self.body(dtype), self.design(dtype=dtype), self.initial_state(dtype))

    def task_loss(self, task: Task | None = None):
        """`loss(initial_state, final_state) -> (total, components)` for `task` (default: own)."""
        task = task or self.task
        if task is None:
            raise ConfigError(f"robot {self.name!r} has no default task; pass one")
        return make_task_loss(task, self.layout)


def check_fits(layout: Layout, config: SimConfig, name: str = "robot") -> None:
    """Raise `ConfigError` unless every particle lies inside the walls with a cell of margin."""
    thickness = config.boundary.thickness
    lower = np.full(config.dim, (thickness + 0.5) * config.dx)
    upper = (np.asarray(config.grid_shape) - thickness - 0.5) * config.dx
    low, high = layout.bounds()
    if np.all(low >= lower) and np.all(high <= upper):
        return
    raise ConfigError(
        f"{name} does not fit the grid: its particles span {np.round(low, 4).tolist()} to "
        f"{np.round(high, 4).tolist()}, but must stay within {np.round(lower, 4).tolist()} to "
        f"{np.round(upper, 4).tolist()} (inside walls of {thickness} cells, dx = {config.dx:g}). "
        f"Scale the robot down, move it, or enlarge grid_shape.")


def place(layout: Layout, config: SimConfig, x: float | None = None, lift: float = 0.5,
          lower=None) -> Layout:
    """Move a layout into the domain.

    By default its bounding box is centred across the domain in every axis but "up" (axis 1); it
    rests `lift` cells above the floor wall; `x` sets the left edge instead of centring along
    axis 0. `lower` (d,) sets the bounding box's lower corner explicitly and overrides the rest.
    """
    low, high = layout.bounds()
    if lower is None:
        domain = np.asarray(config.domain_size)
        lower = (domain - (high - low)) / 2
        lower[1] = (config.boundary.thickness + 0.5 + lift) * config.dx
        if x is not None:
            lower[0] = x
    lower = np.asarray(lower, np.float64)
    if lower.shape != (layout.dim,):
        raise LayoutError(f"placement corner must have {layout.dim} entries, got {lower.tolist()}")
    return layout.translated(lower - low)

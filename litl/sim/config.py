"""Static simulator configuration: grid, time step, gravity, materials, boundaries.

Everything here is a frozen, hashable dataclass. It is closed over by the factories in
`litl.sim.step` and `litl.sim.rollout`, so changing it recompiles; differentiable quantities live in
`litl.sim.state.Design` instead.

Conventions:
  * The domain is the box [0, grid_shape[a] * dx] along each axis a; grid node i of axis a sits at
    i * dx.
  * Axis 1 is "up": the face at the low end of axis 1 is the floor. Gravity is any vector.
  * A wall of thickness t acts on the t outermost nodes at each end of an axis: index i < t at
    the low end, i >= n - t at the high end. (ChainQueen / DiffTaichi's `diffmpm` use i > n - t
    at the high end, one node fewer: a body pressed against a high wall then comes within
    half a cell of leaving the grid, measured in docs/results/2026-11-26-paper-scale-stability.md.
    The published walker never reaches its high walls, so its numbers do not depend on this.)
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable, Iterable, Sequence
from typing import Any, Literal

from litl.sim.errors import SimConfigError as SimConfigError
from litl.sim.errors import is_stretch_bound as is_stretch_bound
from litl.sim.materials import Elastic

WallKind = Literal["sticky", "slip", "friction", "open"]
Buffering = Literal["auto", "none", "fields", "fields_and_nodes"]
ParticleToGrid = Literal["scatter", "fixed_point"]

WALL_KINDS = ("sticky", "slip", "friction", "open")
BUFFERINGS = ("auto", "none", "fields", "fields_and_nodes")
PARTICLE_TO_GRID = ("scatter", "fixed_point")


# The name before issue 39 (it read like the settings' error): kept, `litl.sim` exported it.
ConfigError = SimConfigError


@dataclasses.dataclass(frozen=True)
class Wall:
    """How one face of the domain treats grid velocity pointing into it.

    Attributes:
      kind: ``"sticky"`` zeroes the whole velocity; ``"slip"`` removes the normal component;
        ``"friction"`` removes the normal component and reduces the tangential speed by
        ``friction * |normal speed|`` (Coulomb), stopping it if it would reverse; ``"open"`` does
        nothing (particles may then leave the grid, which is detected and reported).
      friction: Coulomb coefficient, used by ``"friction"`` only; must be >= 0.
    """

    kind: WallKind = "sticky"
    friction: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in WALL_KINDS:
            raise SimConfigError(f"unknown wall kind {self.kind!r}; choose one of {WALL_KINDS}")
        if not (self.friction >= 0.0 and math.isfinite(self.friction)):
            raise SimConfigError(f"wall friction must be a finite number >= 0, got {self.friction!r}")
        if self.kind != "friction" and self.friction != 0.0:
            raise SimConfigError(
                f"a {self.kind!r} wall ignores friction={self.friction}; use Wall('friction', "
                f"{self.friction}) for a Coulomb wall"
            )


@dataclasses.dataclass(frozen=True)
class Boundary:
    """Grid boundary conditions.

    Attributes:
      walls: one `Wall` per face, ordered (axis 0 low, axis 0 high, axis 1 low, axis 1 high, ...);
        axis 1 low is the floor.
      thickness: wall thickness in grid cells (>= 1).
      pinned_boxes: boxes ``((lo_0, lo_1, ...), (hi_0, hi_1, ...))`` in domain coordinates whose grid
        nodes have their velocity set to zero every step (e.g. the fixed base of an arm).
      colliders: solid shapes inside the box, each with its own contact
        (`litl.sim.colliders.Collider`: a half plane at any angle, a box, a ball, a height
        field, a union), applied after the walls, in order.
    """

    walls: tuple[Wall, ...]
    thickness: int = 3
    pinned_boxes: tuple[tuple[tuple[float, ...], tuple[float, ...]], ...] = ()
    colliders: tuple[Any, ...] = ()

    @classmethod
    def box(
        cls,
        dim: int,
        floor: Wall | WallKind = "sticky",
        sides: Wall | WallKind = "sticky",
        thickness: int = 3,
        pinned_boxes: Iterable[Corners] = (),
        colliders: Iterable[Any] = (),
    ) -> Boundary:
        """A closed box: `floor` on the low face of axis 1, `sides` on every other face, and
        `colliders` inside it."""
        floor = floor if isinstance(floor, Wall) else Wall(floor)
        sides = sides if isinstance(sides, Wall) else Wall(sides)
        walls = [sides] * (2 * dim)
        walls[2] = floor
        return cls(
            walls=tuple(walls),
            thickness=thickness,
            pinned_boxes=_as_boxes(pinned_boxes),
            colliders=tuple(colliders),
        )

    def __post_init__(self) -> None:
        object.__setattr__(self, "walls", tuple(self.walls))
        object.__setattr__(self, "pinned_boxes", _as_boxes(self.pinned_boxes))
        object.__setattr__(self, "colliders", tuple(self.colliders))
        if not all(hasattr(c, "shape") and hasattr(c, "contact") for c in self.colliders):
            raise SimConfigError("Boundary.colliders must be litl.sim.colliders.Collider objects")
        if not all(isinstance(w, Wall) for w in self.walls):
            raise SimConfigError("Boundary.walls must be Wall objects, e.g. Wall('sticky')")
        if not isinstance(self.thickness, int) or self.thickness < 1:
            raise SimConfigError(f"wall thickness must be an integer >= 1 cell, got {self.thickness!r}")


# A pinned box as given: (lower corner, upper corner) in domain coordinates.
Corners = tuple[Sequence[float], Sequence[float]]


def _as_boxes(boxes: Iterable[Corners]) -> tuple[tuple[tuple[float, ...], tuple[float, ...]], ...]:
    return tuple((tuple(float(v) for v in lo), tuple(float(v) for v in hi)) for lo, hi in boxes)


@dataclasses.dataclass(frozen=True)
class SimConfig:
    """Static configuration of an MLS-MPM simulation (a robot brings its own; a run's `sim.*`
    settings, the rollouts' length and float type, are `litl.config.RolloutConfig`).

    Attributes:
      grid_shape: number of grid nodes per axis, e.g. ``(128, 128)`` or ``(128, 64)`` in 2D,
        ``(64, 64, 64)`` in 3D. Its length is the dimension.
      dx: grid spacing (domain units).
      dt: time step.
      gravity: acceleration vector, one entry per axis (zero allowed).
      boundary: walls and pinned regions; default: sticky box of thickness 3.
      mass_epsilon: added to the grid mass before dividing momentum by it, in units of the mean
        particle mass (1e-10 as in DiffTaichi, whose particles have unit mass).
      materials: the scene's materials, each a stress law with its return mapping
        (`litl.sim.materials`: `Elastic`, `Sand`, `Clay`, `Fluid`): the one way to give a body its
        material. Each particle's `Body.material` indexes this tuple (None: every particle is of
        the first). The first is the robot's own (`own_material`), for the catalog's robots an
        `Elastic`: its stress law, fixed-corotated or neo-Hookean or a function of one's own, and
        its strain limit (`max_stretch`); a world's bodies (sand, water) join it. Default: ``(Elastic(),)``,
        purely elastic fixed-corotated (ChainQueen / DiffTaichi, the published walker's scene,
        the 3D walkers); the catalog's 2D robots limit their stretch
        (`litl.robots.design.MAX_STRETCH`, `Material.max_stretch`).
      particle_to_grid: how particle-to-grid sums each node's contributions: ``"scatter"`` (the
        default), one float scatter-add, whose float32 sum depends on the order the additions
        land in (on a GPU, atomics: another rounding each run unless XLA is asked for
        deterministic ops); ``"fixed_point"``, each channel scaled by a power of two, rounded to
        integers (42 bits below its total) and summed as int32 pairs: exact and associative, the
        same grid in any order, deterministic by construction (`litl.sim.transfer`); it agrees
        with the float sum to float32 rounding. Reverse mode's scatters (the gathers'
        transposes) follow the same setting.
      buffering: which values a rolled-out step computes into buffers before their many readers
        read them (`litl.sim.linalg.materialize`); it changes speed only, results agree to
        rounding. ``"none"``; ``"fields"``: the particles' affine momentum and the grid velocity;
        ``"fields_and_nodes"``: also the stencil's node weights, the scattered grid and the
        particle-side values of both transfers. ``"auto"``
        (`litl.sim.step.resolve_buffering`): on XLA:CPU what was measured fastest there,
        ``"fields_and_nodes"`` in 3D and ``"fields"`` in 2D; on any other backend ``"none"``, the
        plain program (the reasons are in `litl.sim.step`; GPU speeds of the three settings are
        not measured yet).
    """

    grid_shape: tuple[int, ...]
    dx: float
    dt: float
    gravity: tuple[float, ...]
    boundary: Boundary | None = None
    mass_epsilon: float = 1e-10
    buffering: Buffering = "auto"
    materials: tuple[Any, ...] = (Elastic(),)
    particle_to_grid: ParticleToGrid = "scatter"

    def __post_init__(self) -> None:
        object.__setattr__(self, "grid_shape", tuple(self.grid_shape))
        object.__setattr__(self, "gravity", tuple(float(g) for g in self.gravity))
        dim = len(self.grid_shape)
        if dim not in (2, 3):
            raise SimConfigError(
                f"grid_shape must have 2 or 3 entries (the dimension), got {self.grid_shape!r}"
            )
        for n in self.grid_shape:
            if not isinstance(n, int) or n < 8:
                raise SimConfigError(
                    f"every grid_shape entry must be an integer >= 8 nodes, got {self.grid_shape!r}"
                )
        for name in ("dx", "dt"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise SimConfigError(f"{name} must be a positive finite number, got {value!r}")
        if len(self.gravity) != dim or not all(math.isfinite(g) for g in self.gravity):
            raise SimConfigError(
                f"gravity must be a finite vector with {dim} entries (one per axis), got {self.gravity!r}"
            )
        object.__setattr__(self, "materials", tuple(self.materials))
        if not self.materials or not all(callable(getattr(m, "update", None)) for m in self.materials):
            raise SimConfigError(
                "SimConfig.materials must hold one or more litl.sim.materials models (Elastic, "
                "Sand, Clay, Fluid), the robot's own first, e.g. (Elastic(max_stretch=3.0),); "
                f"got {self.materials!r}"
            )
        if self.buffering not in BUFFERINGS:
            raise SimConfigError(f"unknown buffering {self.buffering!r}; choose one of {BUFFERINGS}")
        if self.particle_to_grid not in PARTICLE_TO_GRID:
            raise SimConfigError(
                f"unknown particle_to_grid {self.particle_to_grid!r}; choose one of {PARTICLE_TO_GRID}"
            )
        boundary = Boundary.box(dim) if self.boundary is None else self.boundary
        object.__setattr__(self, "boundary", boundary)
        if len(boundary.walls) != 2 * dim:
            raise SimConfigError(
                f"a {dim}D boundary needs {2 * dim} walls (low and high face of each axis), "
                f"got {len(boundary.walls)}"
            )
        if 2 * boundary.thickness + 3 > min(self.grid_shape):
            raise SimConfigError(
                f"wall thickness {boundary.thickness} leaves no room in grid {self.grid_shape}"
            )
        for collider in boundary.colliders:
            if collider.dim != dim:
                raise SimConfigError(f"a {collider.dim}D collider in a {dim}D grid: {collider}")
            if collider.velocity is not None:
                cells = math.hypot(*collider.velocity) * self.dt / self.dx
                if cells > 0.5:
                    raise SimConfigError(
                        f"a collider moving at {collider.velocity} travels {cells:.3g} cells per step "
                        f"(dt {self.dt:g}, dx {self.dx:g}); at most half a cell, or its contact skips "
                        "nodes: slow it down or lower dt"
                    )
        for lo, hi in boundary.pinned_boxes:
            if len(lo) != dim or len(hi) != dim or any(a > b for a, b in zip(lo, hi, strict=True)):
                raise SimConfigError(f"pinned box {(lo, hi)} must be two {dim}D corners with lo <= hi")

    @property
    def dim(self) -> int:
        return len(self.grid_shape)

    @property
    def domain_size(self) -> tuple[float, ...]:
        return tuple(n * self.dx for n in self.grid_shape)

    @property
    def own_material(self) -> Any:
        """The robot's own material, `materials[0]` (an `Elastic` for every catalog robot)."""
        return self.materials[0]

    @property
    def max_stretch(self) -> float | None:
        """The robot's own strain limit (`Elastic.max_stretch` of `materials[0]`; None: none)."""
        return getattr(self.own_material, "max_stretch", None)

    def with_own_material(self, material: Any) -> SimConfig:
        """This config with `material` as the robot's own (`materials[0]`), the others kept."""
        return dataclasses.replace(self, materials=(material, *self.materials[1:]))

    @property
    def moving_colliders(self) -> bool:
        """Whether a collider moves (`Collider.velocity`): the step then reads the time."""
        assert self.boundary is not None  # set in __post_init__
        return any(c.moving for c in self.boundary.colliders)


# Keys that SimConfig had before its materials were the one way to give a body its material.
MOVED_TO_MATERIAL = frozenset({"constitutive_model", "max_stretch"})


def _refusing_moved_keys(init: Callable[..., None]) -> Callable[..., None]:
    """SimConfig's __init__, refusing the keys that became the robot's `Elastic` with a message
    that says where they went."""

    @functools.wraps(init)
    def checked(self: SimConfig, *args: Any, **kwargs: Any) -> None:
        moved = sorted(MOVED_TO_MATERIAL & kwargs.keys())
        if moved:
            raise SimConfigError(
                f"SimConfig({moved[0]}=...) is gone: a body's material is given one way, as "
                "SimConfig(materials=(Elastic(model=..., max_stretch=...),)) "
                "(litl.sim.materials.Elastic; config.with_own_material(...) changes it)"
            )
        init(self, *args, **kwargs)

    return checked


SimConfig.__init__ = _refusing_moved_keys(SimConfig.__init__)  # type: ignore[method-assign]

"""`Layout`: a body as data, the particles of a robot and what each of them is.

A layout is plain numpy (built once, outside jit). Builders (`litl.robots.shapes`,
`litl.robots.image`) produce one; `litl.robots.robot.Robot` places it in a simulation domain.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from numpy.typing import ArrayLike

from litl.errors import UserError


class LayoutError(UserError, ValueError):
    """A robot description is invalid; the message says what and how to fix it."""


@dataclasses.dataclass(frozen=True, eq=False)
class Layout:
    """Particles of a body and their labels (``n`` particles, ``d`` = 2 or 3, ``m`` actuators).

    Attributes:
      positions: (n, d) rest positions.
      volume: (n,) rest volume of each particle (mass = density * volume).
      actuator: (n,) int32 actuator id, -1 for passive particles.
      fiber: (m, d) unit direction of each actuator's active stress.
      region: (n,) int32 design region (0 ... R-1): the granularity at which materials are designed.
      pinned: (n,) bool, particles held fixed.
      groups: named particle groups, each an array of particle indices (e.g. ``"tip"``).
    """

    positions: np.ndarray
    volume: np.ndarray
    actuator: np.ndarray
    fiber: np.ndarray
    region: np.ndarray
    pinned: np.ndarray
    groups: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        positions = np.asarray(self.positions, np.float64)
        if positions.ndim != 2 or positions.shape[1] not in (2, 3):
            raise LayoutError(f"positions must be (n, 2) or (n, 3), got shape {positions.shape}")
        n, d = positions.shape
        if n == 0:
            raise LayoutError("the robot has no particles")
        fields: dict[str, tuple[np.ndarray, tuple[int, ...]]] = {
            "volume": (np.asarray(self.volume, np.float64), (n,)),
            "actuator": (np.asarray(self.actuator, np.int32), (n,)),
            "region": (np.asarray(self.region, np.int32), (n,)),
            "pinned": (np.asarray(self.pinned, bool), (n,)),
        }
        for name, (value, shape) in fields.items():
            if value.shape != shape:
                raise LayoutError(f"{name} must have shape {shape}, got {value.shape}")
            object.__setattr__(self, name, value)
        fiber = np.asarray(self.fiber, np.float64).reshape(-1, d)
        m = len(fiber)
        object.__setattr__(self, "positions", positions)
        object.__setattr__(self, "fiber", fiber)
        if not np.all(np.isfinite(positions)) or not np.all(self.volume > 0):
            raise LayoutError("positions must be finite and volumes positive")
        if self.actuator.min() < -1 or self.actuator.max() >= m:
            raise LayoutError(f"actuator ids must be -1 or in [0, {m}) for {m} fiber directions")
        used = np.unique(self.actuator[self.actuator >= 0])
        if len(used) != m:
            raise LayoutError(f"actuators {sorted(set(range(m)) - set(used.tolist()))} have no particles")
        if m and not np.allclose(np.linalg.norm(fiber, axis=1), 1.0):
            raise LayoutError("fiber directions must be unit vectors")
        regions = np.unique(self.region)
        if regions[0] < 0 or len(regions) != regions[-1] + 1:
            raise LayoutError(
                f"design regions must be numbered 0 ... R-1 with particles in each; got {regions.tolist()}"
            )
        groups = {}
        for name, indices in dict(self.groups).items():
            indices = np.unique(np.asarray(indices, np.int64))
            if not isinstance(name, str) or not name:
                raise LayoutError(f"group names must be non-empty strings, got {name!r}")
            if indices.size == 0:
                raise LayoutError(f"group {name!r} holds no particle; a group needs at least one")
            if indices[0] < 0 or indices[-1] >= n:
                raise LayoutError(
                    f"group {name!r} holds particle indices outside [0, {n}): "
                    f"{indices[(indices < 0) | (indices >= n)][:5].tolist()}"
                )
            groups[name] = indices
        object.__setattr__(self, "groups", groups)

    @property
    def n_particles(self) -> int:
        return len(self.positions)

    @property
    def dim(self) -> int:
        return int(self.positions.shape[1])

    @property
    def n_actuators(self) -> int:
        return len(self.fiber)

    @property
    def n_regions(self) -> int:
        return int(self.region.max()) + 1

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper corner (d,) of the particles' bounding box."""
        return self.positions.min(axis=0), self.positions.max(axis=0)

    def translated(self, offset: ArrayLike) -> Layout:
        """The same layout moved by `offset` (d,)."""
        return dataclasses.replace(self, positions=self.positions + np.asarray(offset, np.float64))

    def group_mask(self, name: str) -> np.ndarray:
        """(n,) bool mask of a named group; clear error for an unknown name."""
        if name not in self.groups:
            raise LayoutError(f"unknown particle group {name!r}; this robot has {sorted(self.groups)}")
        mask = np.zeros(self.n_particles, bool)
        mask[self.groups[name]] = True
        return mask

    def extruded(self, depth: float, spacing: float) -> Layout:
        """A 3D layout: this 2D layout repeated in layers of `spacing` over [0, depth] along axis 2.

        Fiber directions get a zero third component; groups, regions and pins carry over.
        """
        if self.dim != 2:
            raise LayoutError("only a 2D layout can be extruded")
        if not (depth > 0 and spacing > 0):
            raise LayoutError(f"extrusion depth and spacing must be positive, got {depth}, {spacing}")
        layers = max(int(round(depth / spacing)), 1)
        z = (np.arange(layers) + 0.5) * depth / layers
        n = self.n_particles
        positions = np.concatenate([np.column_stack([self.positions, np.full(n, zi)]) for zi in z])
        tile = lambda a: np.tile(a, layers)
        return Layout(
            positions=positions,
            volume=tile(self.volume) * depth / layers,
            actuator=tile(self.actuator),
            fiber=np.column_stack([self.fiber, np.zeros(self.n_actuators)]),
            region=tile(self.region),
            pinned=tile(self.pinned),
            groups={k: np.concatenate([v + i * n for i in range(layers)]) for k, v in self.groups.items()},
        )

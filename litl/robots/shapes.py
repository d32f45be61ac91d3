"""Geometric primitives and labelled parts, sampled into a particle `Layout`.

A robot drawn from shapes is a list of `Part`s: a shape (box, ellipse, polygon, extrusion, voxels)
plus labels (actuator id and fiber, design region, named groups, pinned). `sample_parts` fills the
union of the shapes with particles on one regular lattice of spacing ``dx / per_cell`` (aligned with
the simulator grid, so overlapping parts share particles instead of doubling them) and merges the
labels of every part that covers a particle. Two parts that give the same particle different
actuator ids or different regions are a mistake and raise `LayoutError`.

Shapes are dimension-generic where it makes sense: `Box` and `Ellipse` work in 2D and 3D,
`Polygon` is 2D, `Extrusion` turns a 2D shape into 3D along axis 2 (depth; axis 1 is up).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Protocol

import numpy as np

from litl.robots.layout import Layout, LayoutError


class Shape(Protocol):
    dim: int

    def contains(self, points: np.ndarray) -> np.ndarray:
        """(k,) bool: which of the (k, dim) points lie inside."""

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper corner of the bounding box, each (dim,)."""


def _vector(value, name, dim=None) -> np.ndarray:
    array = np.asarray(value, np.float64).reshape(-1)
    if not np.all(np.isfinite(array)) or (dim is not None and array.size != dim):
        want = f"{dim} finite numbers" if dim else "finite numbers"
        raise LayoutError(f"{name} must be {want}, got {value!r}")
    return array


@dataclasses.dataclass(frozen=True)
class Box:
    """Axis-aligned rectangle (2D) or box (3D) with lower corner `lower` and edge lengths `size`."""

    lower: tuple[float, ...]
    size: tuple[float, ...]

    def __post_init__(self):
        lower = _vector(self.lower, "Box lower corner")
        size = _vector(self.size, "Box size", lower.size)
        if lower.size not in (2, 3) or np.any(size <= 0):
            raise LayoutError(f"a Box needs a 2D/3D corner and positive sizes, got {self.lower}, {self.size}")
        object.__setattr__(self, "lower", tuple(lower))
        object.__setattr__(self, "size", tuple(size))

    @property
    def dim(self) -> int:
        return len(self.lower)

    def contains(self, points):
        lower, upper = self.bounds()
        return np.all((points >= lower) & (points <= upper), axis=-1)

    def bounds(self):
        lower = np.asarray(self.lower)
        return lower, lower + np.asarray(self.size)


@dataclasses.dataclass(frozen=True)
class Ellipse:
    """Ellipse (2D) or ellipsoid (3D) with semi-axes `radii` along the coordinate axes.

    A single radius gives a circle / sphere.
    """

    center: tuple[float, ...]
    radii: tuple[float, ...] | float

    def __post_init__(self):
        center = _vector(self.center, "Ellipse center")
        radii = _vector(self.radii, "Ellipse radii")
        radii = np.broadcast_to(radii, center.shape) if radii.size == 1 else radii
        if center.size not in (2, 3) or radii.shape != center.shape or np.any(radii <= 0):
            raise LayoutError(
                f"an Ellipse needs a 2D/3D center and one positive radius (or one per axis), "
                f"got center {self.center}, radii {self.radii}"
            )
        object.__setattr__(self, "center", tuple(center))
        object.__setattr__(self, "radii", tuple(radii))

    @property
    def dim(self) -> int:
        return len(self.center)

    def contains(self, points):
        scaled = (points - np.asarray(self.center)) / np.asarray(self.radii)
        return np.sum(scaled**2, axis=-1) <= 1.0

    def bounds(self):
        center, radii = np.asarray(self.center), np.asarray(self.radii)
        return center - radii, center + radii


def Circle(center, radius) -> Ellipse:  # noqa: N802 (reads like a shape class)
    """A circle (2D) or sphere (3D)."""
    return Ellipse(center, radius)


@dataclasses.dataclass(frozen=True)
class Polygon:
    """Simple 2D polygon given by its vertices in order (either orientation); even-odd fill."""

    vertices: tuple[tuple[float, float], ...]

    def __post_init__(self):
        vertices = np.asarray(self.vertices, np.float64)
        if vertices.ndim != 2 or vertices.shape[1] != 2 or len(vertices) < 3:
            raise LayoutError(f"a Polygon needs at least 3 (x, y) vertices, got {self.vertices!r}")
        if not np.all(np.isfinite(vertices)):
            raise LayoutError("Polygon vertices must be finite")
        x, y = vertices.T
        if abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))) < 1e-12:
            raise LayoutError("Polygon has zero area (are all its vertices on one line?)")
        object.__setattr__(self, "vertices", tuple(map(tuple, vertices)))

    dim = 2

    def contains(self, points):
        vertices = np.asarray(self.vertices)
        x, y = points[:, 0:1], points[:, 1:2]
        x0, y0 = vertices[:, 0], vertices[:, 1]
        x1, y1 = np.roll(x0, -1), np.roll(y0, -1)
        # Even-odd rule: count edges that a ray towards +x crosses.
        straddles = (y0 > y) != (y1 > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            crossing_x = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
        return np.sum(straddles & (x < crossing_x), axis=1) % 2 == 1

    def bounds(self):
        vertices = np.asarray(self.vertices)
        return vertices.min(axis=0), vertices.max(axis=0)


@dataclasses.dataclass(frozen=True)
class Extrusion:
    """A 2D shape (in the x-y side view) extruded along axis 2 over ``[z_min, z_max]``."""

    profile: Box | Ellipse | Polygon
    z_min: float
    z_max: float

    def __post_init__(self):
        if getattr(self.profile, "dim", None) != 2:
            raise LayoutError("Extrusion needs a 2D profile shape (Box, Ellipse or Polygon in 2D)")
        if not (np.isfinite(self.z_min) and np.isfinite(self.z_max) and self.z_max > self.z_min):
            raise LayoutError(f"Extrusion needs z_min < z_max, got {self.z_min}, {self.z_max}")

    dim = 3

    def contains(self, points):
        inside = self.profile.contains(points[:, :2])
        return inside & (points[:, 2] >= self.z_min) & (points[:, 2] <= self.z_max)

    def bounds(self):
        lower, upper = self.profile.bounds()
        return np.append(lower, self.z_min), np.append(upper, self.z_max)


@dataclasses.dataclass(frozen=True, eq=False)
class Voxels:
    """Occupied cells of a boolean voxel (3D) or pixel (2D) array, each of edge `voxel_size`.

    Array index (i, j[, k]) is the cell ``lower + (i, j[, k]) * voxel_size``: axis 0 is x, axis 1
    is up.
    """

    occupied: np.ndarray
    voxel_size: float
    lower: tuple[float, ...] | None = None

    def __post_init__(self):
        occupied = np.asarray(self.occupied)
        if occupied.ndim not in (2, 3) or occupied.dtype != bool:
            raise LayoutError(
                f"Voxels need a 2D or 3D bool array, got {occupied.dtype} of shape {occupied.shape}"
            )
        if not occupied.any():
            raise LayoutError("the voxel array has no occupied cell")
        if not (np.isfinite(self.voxel_size) and self.voxel_size > 0):
            raise LayoutError(f"voxel_size must be positive, got {self.voxel_size!r}")
        lower = (
            np.zeros(occupied.ndim)
            if self.lower is None
            else _vector(self.lower, "Voxels lower corner", occupied.ndim)
        )
        object.__setattr__(self, "occupied", occupied)
        object.__setattr__(self, "lower", tuple(lower))

    @property
    def dim(self) -> int:
        return self.occupied.ndim

    def cell_index(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Integer cell index (k, dim) of each point and whether it is inside the array."""
        index = np.floor((points - np.asarray(self.lower)) / self.voxel_size).astype(np.int64)
        inside = np.all((index >= 0) & (index < np.asarray(self.occupied.shape)), axis=-1)
        return np.where(inside[:, None], index, 0), inside

    def contains(self, points):
        index, inside = self.cell_index(points)
        return inside & self.occupied[tuple(index.T)]

    def bounds(self):
        lower = np.asarray(self.lower)
        return lower, lower + np.asarray(self.occupied.shape) * self.voxel_size


@dataclasses.dataclass(frozen=True)
class Part:
    """A shape with the labels its particles get.

    Attributes:
      shape: any shape above.
      actuator: actuator id (0, 1, ...) of its particles, or None for passive material.
      fiber: direction of that actuator's active stress (normalized here); default: axis 1 ("up").
      region: design region (co-design granularity, e.g. one Young's modulus per region); None
        leaves the region to other parts (default region 0).
      groups: names of particle groups it belongs to (used by task losses, e.g. ``"tip"``).
      pinned: its particles are held fixed (e.g. the base of an arm).
    """

    shape: Box | Ellipse | Polygon | Extrusion | Voxels
    actuator: int | None = None
    fiber: tuple[float, ...] | None = None
    region: int | None = None
    groups: tuple[str, ...] = ()
    pinned: bool = False

    def __post_init__(self):
        groups = (self.groups,) if isinstance(self.groups, str) else tuple(self.groups)
        object.__setattr__(self, "groups", groups)
        object.__setattr__(
            self, "fiber", check_labels(self.actuator, self.fiber, self.region, self.shape.dim)
        )


def check_labels(actuator, fiber, region, dim: int):
    """Validate a part's (or a legend colour's) labels; return the unit fiber (or None)."""
    for name, value in (("actuator", actuator), ("region", region)):
        if value is not None and (
            isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0
        ):
            raise LayoutError(f"{name} id must be an integer >= 0 or None, got {value!r}")
    if fiber is None:
        return None
    if actuator is None:
        raise LayoutError("a fiber direction was given for a passive part (no actuator); set an actuator")
    fiber = _vector(fiber, "fiber direction", dim)
    if np.linalg.norm(fiber) == 0:
        raise LayoutError("fiber direction must not be the zero vector")
    return tuple(fiber / np.linalg.norm(fiber))


def lattice(lower, upper, spacing) -> np.ndarray:
    """(k, d) points ``(i + 1/2) * spacing`` of the global lattice inside the box [lower, upper]."""
    start = np.floor(np.asarray(lower) / spacing).astype(np.int64)
    stop = np.ceil(np.asarray(upper) / spacing).astype(np.int64)
    axes = [(np.arange(a, b) + 0.5) * spacing for a, b in zip(start, stop, strict=True)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(axes))


def sample_parts(parts: Sequence[Part], dx: float, per_cell: int = 2) -> Layout:
    """Fill the union of the parts' shapes with particles and merge their labels.

    Args:
      parts: the robot's parts, all of the same dimension.
      dx: simulator grid spacing; particles sit on a lattice of spacing ``dx / per_cell``.
      per_cell: particles per grid cell along each axis (2 is the usual MPM choice).

    Returns:
      A `Layout` with one particle per covered lattice point, each of volume ``spacing ** d``.
    """
    parts = list(parts)
    if not parts:
        raise LayoutError("a robot needs at least one part")
    dims = {part.shape.dim for part in parts}
    if len(dims) != 1:
        raise LayoutError(f"all parts must have the same dimension, got {sorted(dims)}")
    if not (dx > 0 and isinstance(per_cell, (int, np.integer)) and per_cell >= 1):
        raise LayoutError(f"need dx > 0 and an integer per_cell >= 1, got dx={dx!r}, per_cell={per_cell!r}")
    spacing = dx / per_cell
    lowers, uppers = zip(*(part.shape.bounds() for part in parts), strict=True)
    points = lattice(np.min(lowers, axis=0), np.max(uppers, axis=0), spacing)
    labels = LabelMerger(len(points))
    for index, part in enumerate(parts):
        inside = part.shape.contains(points)
        if not inside.any():
            raise LayoutError(
                f"part {index} ({type(part.shape).__name__}) covers no particle at spacing "
                f"{spacing:g}: make it larger than dx / per_cell or refine dx"
            )
        labels.add(
            f"part {index}", inside, part.actuator, part.fiber, part.region, part.groups, part.pinned, points
        )
    return labels.layout(points, spacing ** points.shape[1])


class LabelMerger:
    """Accumulates the labels that several sources (parts, colours) give to candidate particles."""

    def __init__(self, n: int):
        self.occupied = np.zeros(n, bool)
        self.actuator = np.full(n, -1, np.int32)
        self.region = np.full(n, -1, np.int32)
        self.pinned = np.zeros(n, bool)
        self.groups: dict[str, np.ndarray] = {}
        self.fibers: dict[int, tuple[float, ...]] = {}
        # Which source labelled each particle, as an index into `sources` (for error messages).
        self.sources: list = []
        self.actuator_source = np.full(n, -1)
        self.region_source = np.full(n, -1)

    def add(self, source, mask, actuator, fiber, region, groups, pinned, points):
        """Label the particles in `mask` (bool (n,)); `source` names the part/colour in errors."""
        self.occupied |= mask
        self.sources.append(source)
        for name, value, labels, origin in (
            ("actuator", actuator, self.actuator, self.actuator_source),
            ("region", region, self.region, self.region_source),
        ):
            if value is None:
                continue
            clash = mask & (labels >= 0) & (labels != value)
            if clash.any():
                at = int(np.argmax(clash))
                raise LayoutError(
                    f"conflicting labels: {source} and {self.sources[origin[at]]} both cover the particle "
                    f"at {np.round(points[at], 6).tolist()} but give it {name} {value} and "
                    f"{labels[at]}; make the parts disjoint or give them the same {name}"
                )
            labels[mask] = value
            origin[mask] = len(self.sources) - 1
        if actuator is not None:
            known = self.fibers.get(int(actuator))
            if fiber is not None and known is not None and not np.allclose(known, fiber):
                raise LayoutError(f"actuator {actuator} is given two fiber directions, {known} and {fiber}")
            if fiber is not None or known is None:
                self.fibers[int(actuator)] = fiber
        self.pinned |= mask & bool(pinned)
        for group in groups:
            self.groups[group] = self.groups.get(group, np.zeros_like(mask)) | mask

    def layout(self, points, volume) -> Layout:
        keep = self.occupied
        actuator = self.actuator[keep]
        ids = sorted(self.fibers)
        if ids and ids != list(range(len(ids))):
            missing = sorted(set(range(max(ids) + 1)) - set(ids))
            raise LayoutError(f"actuator ids must be 0, 1, ..., m-1 without gaps; missing {missing}")
        dim = points.shape[1]
        up = np.eye(dim)[1]
        fiber = np.asarray(
            [self.fibers[i] if self.fibers[i] is not None else up for i in ids], np.float64
        ).reshape(len(ids), dim)
        region = np.where(self.region[keep] >= 0, self.region[keep], 0).astype(np.int32)
        return Layout(
            positions=points[keep],
            volume=np.full(int(keep.sum()), volume),
            actuator=actuator,
            fiber=fiber,
            region=region,
            pinned=self.pinned[keep],
            groups={name: np.flatnonzero(mask[keep]) for name, mask in self.groups.items()},
        )

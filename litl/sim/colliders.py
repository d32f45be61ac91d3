"""Colliders: solid shapes given by signed distance functions, each with its own contact.

A `Collider` is a shape (a signed distance: negative inside the solid, with the outward normal)
and a contact (`litl.sim.config.Wall`: sticky, slip or Coulomb friction). After the grid update,
every grid node in contact with a collider (its signed distance at most `Collider.band` cells:
inside the solid or within that band of its surface) whose velocity points into it (v · n < 0)
is projected as MPM codes do (Stomakhin et al. 2013, Sec. 8; Hu et al. 2018):
sticky nodes stop, slip nodes lose the normal component, friction nodes lose it and have their
tangential speed reduced by μ |v · n|, never reversed. The band is a cell by default: with
only the nodes inside the solid in contact (band 0), the particles resting on it read nodes
that no contact holds, and a block on a 30° slope with μ = 0.8 (tan θ < μ) slid at 0.79 m/s²
instead of sticking; with a band of one cell it stays (tests/sim/test_colliders.py).

A static collider's distance and normal at the grid nodes are computed once, in numpy (float64),
when the step is built, so it costs the same as a wall. A moving one (`Collider.velocity`: a
scripted translation at constant velocity from where its shape is given, at time 0) is evaluated
by the same distance functions in JAX at every step, at the step's end time, and its contact acts
on the grid velocity relative to its own: a sticky one carries what touches it, a slip or friction
one pushes without dragging (a paddle, a piston, a moving platform, a conveyor: a floor moving
along itself). Colliders live in `Boundary.colliders` and act after the box's walls
(`litl.sim.boundary`); the walls themselves stay the box's axis-aligned layers, so scenes without
colliders compute exactly what they did.

Shapes (2D and 3D; axis 1 is up):

* `HalfPlane(point, normal)`: the solid behind a plane (a floor, a slope at any angle);
* `Box(lower, upper)`: a solid box;
* `Ball(center, radius)`: a disc (2D) or a sphere (3D);
* `HeightField(xs, heights)`: the ground below a piecewise-linear profile y = h(x) along axis 0
  (in 3D the same profile for every z);
* `Union(shapes)`: all of them (the nearest one's normal).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import jax.numpy as jnp
import numpy as np

from litl.sim.config import SimConfigError, Wall


def _vector(values: Sequence[float], name: str) -> tuple[float, ...]:
    vector = tuple(float(v) for v in values)
    if len(vector) not in (2, 3) or not all(math.isfinite(v) for v in vector):
        raise SimConfigError(f"{name} must be 2 or 3 finite numbers, got {values!r}")
    return vector


@dataclasses.dataclass(frozen=True)
class HalfPlane:
    """The solid behind the plane through `point` with outward `normal` (any length > 0):
    ``HalfPlane((0, 0.1), (0, 1))`` is a floor at y = 0.1, ``(-sin θ, cos θ)`` a slope of θ."""

    point: tuple[float, ...]
    normal: tuple[float, ...]

    def __post_init__(self) -> None:
        point, normal = _vector(self.point, "HalfPlane.point"), _vector(self.normal, "HalfPlane.normal")
        length = math.sqrt(sum(n * n for n in normal))
        if len(point) != len(normal) or length == 0:
            raise SimConfigError(
                f"HalfPlane needs a point and a non-zero normal of one dimension, got {self}"
            )
        object.__setattr__(self, "point", point)
        object.__setattr__(self, "normal", tuple(n / length for n in normal))

    @property
    def dim(self) -> int:
        return len(self.point)

    def distance(self, x, xp=np):
        normal = xp.asarray(self.normal, x.dtype)
        phi = (x - xp.asarray(self.point, x.dtype)) @ normal
        return phi, xp.broadcast_to(normal, x.shape)


@dataclasses.dataclass(frozen=True)
class Box:
    """A solid axis-aligned box from corner `lower` to corner `upper`."""

    lower: tuple[float, ...]
    upper: tuple[float, ...]

    def __post_init__(self) -> None:
        lower, upper = _vector(self.lower, "Box.lower"), _vector(self.upper, "Box.upper")
        if len(lower) != len(upper) or any(a >= b for a, b in zip(lower, upper, strict=True)):
            raise SimConfigError(
                f"Box needs corners of one dimension with lower < upper, got {lower}, {upper}"
            )
        object.__setattr__(self, "lower", lower)
        object.__setattr__(self, "upper", upper)

    @property
    def dim(self) -> int:
        return len(self.lower)

    def distance(self, x, xp=np):
        lower, upper = xp.asarray(self.lower, x.dtype), xp.asarray(self.upper, x.dtype)
        centre, half = (lower + upper) / 2, (upper - lower) / 2
        offset = x - centre
        q = xp.abs(offset) - half
        outside = xp.maximum(q, 0.0)
        squared = xp.sum(outside * outside, axis=-1)
        out_length = xp.sqrt(squared)
        phi = out_length + xp.minimum(q.max(axis=-1), 0.0)
        sign = xp.where(offset >= 0, 1.0, -1.0)
        # Outside: towards the nearest point; inside: out through the nearest face.
        nearest_face = xp.eye(x.shape[-1], dtype=x.dtype)[xp.argmax(q, axis=-1)]
        safe = xp.where(out_length > 0, out_length, 1.0)[..., None]
        normal = xp.where((out_length > 0)[..., None], sign * outside / safe, sign * nearest_face)
        return phi, normal


@dataclasses.dataclass(frozen=True)
class Ball:
    """A solid disc (2D) or sphere (3D)."""

    center: tuple[float, ...]
    radius: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _vector(self.center, "Ball.center"))
        if not (math.isfinite(self.radius) and self.radius > 0):
            raise SimConfigError(f"Ball.radius must be a positive number, got {self.radius!r}")

    @property
    def dim(self) -> int:
        return len(self.center)

    def distance(self, x, xp=np):
        offset = x - xp.asarray(self.center, x.dtype)
        length = xp.sqrt(xp.sum(offset * offset, axis=-1))
        up = xp.asarray([float(axis == 1) for axis in range(x.shape[-1])], x.dtype)
        normal = xp.where((length > 0)[..., None], offset / xp.where(length > 0, length, 1.0)[..., None], up)
        return length - self.radius, normal


@dataclasses.dataclass(frozen=True)
class HeightField:
    """The ground below the profile y = h(x): heights at increasing `xs` along axis 0, linear
    in between and flat beyond the ends; `dim` 3 extrudes it along axis 2. Its distance is the
    vertical one times the slope's cosine (exact on each segment away from its kinks)."""

    xs: tuple[float, ...]
    heights: tuple[float, ...]
    dim: int = 2

    def __post_init__(self) -> None:
        xs, heights = tuple(float(v) for v in self.xs), tuple(float(v) for v in self.heights)
        if len(xs) < 2 or len(xs) != len(heights) or not all(map(math.isfinite, xs + heights)):
            raise SimConfigError(
                f"HeightField needs at least two finite (x, height) points, got xs={self.xs!r}, "
                f"heights={self.heights!r}"
            )
        if any(b <= a for a, b in zip(xs, xs[1:], strict=False)):
            raise SimConfigError(f"HeightField.xs must increase, got {xs}")
        if self.dim not in (2, 3):
            raise SimConfigError(f"HeightField.dim must be 2 or 3, got {self.dim!r}")
        object.__setattr__(self, "xs", xs)
        object.__setattr__(self, "heights", heights)

    def distance(self, x, xp=np):
        xs, heights = xp.asarray(self.xs, x.dtype), xp.asarray(self.heights, x.dtype)
        along = x[..., 0]
        height = xp.interp(along, xs, heights)
        segment = xp.clip(xp.searchsorted(xs, along) - 1, 0, len(self.xs) - 2)
        slope = (heights[segment + 1] - heights[segment]) / (xs[segment + 1] - xs[segment])
        slope = xp.where((along < xs[0]) | (along > xs[-1]), 0.0, slope)
        cosine = 1.0 / xp.sqrt(1.0 + slope**2)
        zero = xp.zeros_like(cosine)
        normal = xp.stack([-slope * cosine, cosine] + [zero] * (x.shape[-1] - 2), axis=-1)
        return (x[..., 1] - height) * cosine, normal


@dataclasses.dataclass(frozen=True)
class Union:
    """All of `shapes`; at a point, the distance and normal of the nearest."""

    shapes: tuple

    def __post_init__(self) -> None:
        object.__setattr__(self, "shapes", tuple(self.shapes))
        if not self.shapes or len({s.dim for s in self.shapes}) != 1:
            raise SimConfigError(f"Union needs one or more shapes of one dimension, got {self.shapes!r}")

    @property
    def dim(self) -> int:
        return self.shapes[0].dim

    def distance(self, x, xp=np):
        results = [shape.distance(x, xp) for shape in self.shapes]
        phis = xp.stack([phi for phi, _ in results])
        normals = xp.stack([xp.broadcast_to(normal, x.shape) for _, normal in results])
        nearest = xp.argmin(phis, axis=0)
        phi = xp.take_along_axis(phis, nearest[None], axis=0)[0]
        normal = xp.take_along_axis(normals, nearest[None, ..., None], axis=0)[0]
        return phi, normal


Shape = HalfPlane | Box | Ball | HeightField | Union


@dataclasses.dataclass(frozen=True)
class Collider:
    """A solid `shape`, how grid velocity pointing into it is treated (`contact`: a `Wall`
    that is sticky, slip or friction with its Coulomb coefficient; not open), the `band`
    (cells, >= 0) beyond its surface within which grid nodes are in contact, and its `velocity`
    (None: static; d numbers: it translates at that constant velocity, its shape given at time 0,
    and its contact acts on the grid velocity relative to its own)."""

    shape: Shape
    contact: Wall = Wall("sticky")
    band: float = 1.0
    velocity: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        if not hasattr(self.shape, "distance"):
            raise SimConfigError(
                f"a collider's shape must be one of litl.sim.colliders' shapes, got {self.shape!r}"
            )
        contact = self.contact if isinstance(self.contact, Wall) else Wall(self.contact)
        if contact.kind == "open":
            raise SimConfigError("a collider's contact must be sticky, slip or friction, not open")
        if not (isinstance(self.band, (int, float)) and math.isfinite(self.band) and self.band >= 0):
            raise SimConfigError(f"a collider's band must be a number of cells >= 0, got {self.band!r}")
        object.__setattr__(self, "contact", contact)
        if self.velocity is not None:
            velocity = _vector(self.velocity, "Collider.velocity")
            if len(velocity) != self.shape.dim:
                raise SimConfigError(
                    f"a {self.shape.dim}D collider needs a velocity of {self.shape.dim} numbers, got "
                    f"{self.velocity!r}"
                )
            # A zero velocity is a static collider: it takes the static (precomputed) path.
            object.__setattr__(self, "velocity", velocity if any(velocity) else None)

    @property
    def dim(self) -> int:
        return self.shape.dim

    @property
    def moving(self) -> bool:
        return self.velocity is not None

    def distance(self, x, time=0.0, xp=np):
        """(signed distance, outward normal) at positions `x` (..., d) at `time` (seconds from
        the start; a static collider's are the same at every time)."""
        if self.velocity is None:
            return self.shape.distance(x, xp)
        return self.shape.distance(x - xp.asarray(self.velocity, x.dtype) * time, xp)


def node_positions(grid_shape: Sequence[int], dx: float) -> np.ndarray:
    """(*grid_shape, d) the grid nodes' positions (node i of axis a at i * dx), float64."""
    axes = np.meshgrid(*[np.arange(n) * dx for n in grid_shape], indexing="ij")
    return np.stack(axes, axis=-1)


def apply_colliders(colliders: Sequence[Collider], grid_shape, dx: float, velocity: list, time=0.0) -> list:
    """The grid velocity components with every collider's contact applied, in order; moving
    colliders where they are at `time` (seconds, a scalar that may be traced)."""
    if not colliders:
        return velocity
    nodes = node_positions(grid_shape, dx)
    velocity = list(velocity)
    dtype = velocity[0].dtype
    for collider in colliders:
        if collider.velocity is not None:
            phi, normal = collider.distance(jnp.asarray(nodes, dtype), jnp.asarray(time, dtype), jnp)
            inside = phi <= collider.band * dx
            own = [jnp.asarray(u, dtype) for u in collider.velocity]
            # The contact acts on the velocity relative to the collider's.
            velocity = [v - u for v, u in zip(velocity, own, strict=True)]
        else:
            phi, normal = collider.shape.distance(nodes)
            inside = jnp.asarray(phi <= collider.band * dx)
            own = None
        n = [jnp.asarray(normal[..., a], dtype) for a in range(len(velocity))]
        velocity = apply_contact(velocity, n, inside, collider.contact)
        velocity = _add_own(velocity, own)
    return velocity


def _along(value, component):
    """value * component, where a Python 0 or ±1 component (an axis-aligned wall's normal) costs
    no arithmetic and changes no bit."""
    if isinstance(component, (int, float)) and component in (0, 1, -1):
        return 0.0 if component == 0 else (value if component == 1 else -value)
    return value * component


def apply_contact(velocity: list, normal: Sequence, touching, contact: Wall) -> list:
    """The one contact law of walls and colliders (the module docstring): at the nodes
    `touching` the surface whose velocity points into it (v · n < 0), sticky nodes stop, slip
    nodes lose the normal component, friction nodes lose it and have their tangential speed
    reduced by μ |v · n|, never reversed.

    Args:
      velocity: d arrays (*grid_shape,), the grid velocity components.
      normal: d outward normals of the solid: arrays (*grid_shape,), or Python numbers for a
        plane (an axis-aligned wall: 0 and ±1).
      touching: (*grid_shape,) bool, the nodes in contact (a wall's layer, a collider's band).
      contact: its kind (sticky, slip, friction) and Coulomb coefficient.
    """
    normal_speed = sum(_along(v, na) for v, na in zip(velocity, normal, strict=True))
    hit = touching & (normal_speed < 0)
    if contact.kind == "sticky":
        return [jnp.where(hit, 0.0, v) for v in velocity]
    tangential = [v - _along(normal_speed, na) for v, na in zip(velocity, normal, strict=True)]
    if contact.kind == "friction":
        squared = sum(t * t for t in tangential)
        positive = squared > 0
        speed = jnp.where(positive, jnp.sqrt(jnp.where(positive, squared, 1.0)), 0.0)
        reduced = jnp.maximum(speed - contact.friction * jnp.abs(normal_speed), 0.0)
        factor = jnp.where(positive, reduced / jnp.where(positive, speed, 1.0), 0.0)
        tangential = [t * factor for t in tangential]
    return [jnp.where(hit, t, v) for t, v in zip(tangential, velocity, strict=True)]


def _add_own(velocity: list, own: list | None) -> list:
    """Back from a moving collider's frame (`own`: its velocity; None: a static one)."""
    return velocity if own is None else [v + u for v, u in zip(velocity, own, strict=True)]


def check_clear(colliders: Sequence[Collider], positions: np.ndarray, dx: float, name: str = "robot") -> None:
    """Raise `SimConfigError` if any particle starts inside a collider or within half a cell of
    its surface (it would be pushed out on the first step)."""
    positions = np.asarray(positions, np.float64)
    for index, collider in enumerate(colliders):
        phi, _ = collider.shape.distance(positions)
        inside = int(np.sum(phi < 0.5 * dx))
        if inside:
            raise SimConfigError(
                f"collider {index} ({type(collider.shape).__name__}) cuts through the {name}: "
                f"{inside} of its {len(positions)} particles start inside it or within half a cell "
                f"of its surface (deepest {float(-phi.min()):.4g} inside); move the {name} or the collider"
            )

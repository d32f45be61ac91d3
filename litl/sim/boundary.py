"""Grid boundary conditions: walls (sticky, slip, Coulomb friction), colliders and pinned regions."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from litl.sim.colliders import apply_colliders, apply_contact
from litl.sim.config import SimConfig


def _face_masks(config: SimConfig):
    """For each face, a (*grid_shape,) numpy bool mask of the nodes inside its wall layer."""
    assert config.boundary is not None  # SimConfig sets the default box
    t = config.boundary.thickness
    masks = []
    for axis, n in enumerate(config.grid_shape):
        index = np.arange(n).reshape([-1 if a == axis else 1 for a in range(config.dim)])
        masks.append(np.broadcast_to(index < t, config.grid_shape))
        masks.append(np.broadcast_to(index >= n - t, config.grid_shape))
    return masks


def pinned_node_mask(config: SimConfig) -> np.ndarray:
    """(*grid_shape,) bool mask of the nodes inside any of the boundary's pinned boxes."""
    mask = np.zeros(config.grid_shape, bool)
    coords = np.meshgrid(*[np.arange(n) * config.dx for n in config.grid_shape], indexing="ij")
    assert config.boundary is not None  # SimConfig sets the default box
    for lo, hi in config.boundary.pinned_boxes:
        inside = np.ones(config.grid_shape, bool)
        for c, a, b in zip(coords, lo, hi, strict=True):
            inside &= (c >= a) & (c <= b)
        mask |= inside
    return mask


def apply_boundary(config: SimConfig, velocity, time=0.0):
    """Enforce walls, colliders and pinned regions on grid velocity components.

    Faces are applied in order (axis 0 low, axis 0 high, axis 1 low, ...). On a face's layer, a wall
    acts only on velocities moving into it, by the contact law colliders use
    (`litl.sim.colliders.apply_contact`). Then the colliders
    (`litl.sim.colliders`), then the pinned boxes.

    Args:
      config: supplies grid shape and boundary.
      velocity: d arrays (*grid_shape,), the grid velocity components.
      time: () seconds since the rollout's start, where moving colliders are.

    Returns:
      d arrays (*grid_shape,), the constrained velocity components.
    """
    boundary = config.boundary
    assert boundary is not None  # SimConfig sets the default box
    velocity = list(velocity)
    for face, (wall, layer) in enumerate(zip(boundary.walls, _face_masks(config), strict=True)):
        if wall.kind == "open":
            continue
        axis, high = divmod(face, 2)
        # The wall's outward normal points into the domain: +e_axis on the low face.
        normal = [0 if a != axis else (-1 if high else 1) for a in range(config.dim)]
        velocity = apply_contact(velocity, normal, jnp.asarray(layer), wall)
    velocity = apply_colliders(boundary.colliders, config.grid_shape, config.dx, velocity, time)
    if boundary.pinned_boxes:
        pinned = jnp.asarray(pinned_node_mask(config))
        velocity = [jnp.where(pinned, 0.0, v) for v in velocity]
    return velocity

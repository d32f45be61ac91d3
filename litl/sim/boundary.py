"""Grid boundary conditions: walls (sticky, slip, Coulomb friction) and pinned grid regions."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from litl.sim.config import Boundary, SimConfig


def _face_masks(config: SimConfig):
    """For each face, a (*grid_shape,) numpy bool mask of the nodes inside its wall layer."""
    t = config.boundary.thickness
    masks = []
    for axis, n in enumerate(config.grid_shape):
        index = np.arange(n).reshape([-1 if a == axis else 1 for a in range(config.dim)])
        masks.append(np.broadcast_to(index < t, config.grid_shape))
        masks.append(np.broadcast_to(index > n - t, config.grid_shape))
    return masks


def pinned_node_mask(config: SimConfig) -> np.ndarray:
    """(*grid_shape,) bool mask of the nodes inside any of the boundary's pinned boxes."""
    mask = np.zeros(config.grid_shape, bool)
    coords = np.meshgrid(*[np.arange(n) * config.dx for n in config.grid_shape], indexing="ij")
    for lo, hi in config.boundary.pinned_boxes:
        inside = np.ones(config.grid_shape, bool)
        for c, a, b in zip(coords, lo, hi):
            inside &= (c >= a) & (c <= b)
        mask |= inside
    return mask


def _safe_norm(v):
    sq = jnp.sum(v * v, axis=-1)
    positive = sq > 0
    return jnp.where(positive, jnp.sqrt(jnp.where(positive, sq, 1.0)), 0.0)


def apply_boundary(config: SimConfig, velocity):
    """Enforce walls and pinned regions on a (*grid_shape, d) grid velocity field.

    Faces are applied in order (axis 0 low, axis 0 high, axis 1 low, ...). On a face's layer, a wall
    acts only on velocities moving into it (outward normal component > 0).
    """
    boundary: Boundary = config.boundary
    for face, (wall, layer) in enumerate(zip(boundary.walls, _face_masks(config))):
        if wall.kind == "open":
            continue
        axis, high = divmod(face, 2)
        normal_speed = velocity[..., axis]
        into_wall = (normal_speed > 0) if high else (normal_speed < 0)
        hit = (jnp.asarray(layer) & into_wall)[..., None]
        if wall.kind == "sticky":
            new = jnp.zeros_like(velocity)
        else:
            tangential = velocity.at[..., axis].set(0.0)
            if wall.kind == "friction":
                speed = _safe_norm(tangential)
                # Coulomb: the tangential speed drops by mu * |normal speed|, never below zero.
                reduced = jnp.maximum(speed - wall.friction * jnp.abs(normal_speed), 0.0)
                scale = jnp.where(speed > 0, reduced / jnp.where(speed > 0, speed, 1.0), 0.0)
                tangential = tangential * scale[..., None]
            new = tangential
        velocity = jnp.where(hit, new, velocity)
    if boundary.pinned_boxes:
        pinned = jnp.asarray(pinned_node_mask(config))[..., None]
        velocity = jnp.where(pinned, 0.0, velocity)
    return velocity

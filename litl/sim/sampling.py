"""Particle sampling of geometric primitives: a box filled on a regular lattice."""

from __future__ import annotations

import numpy as np


def sample_box(lower, size, dx, per_cell=2) -> np.ndarray:
    """Particles on a regular lattice filling an axis-aligned box (2D rectangle or 3D box).

    Along each axis of length L the box gets ``int(L / dx) * per_cell`` particles at the centres of
    equal sub-intervals, so spacing is close to ``dx / per_cell`` and the box is filled exactly (the
    sampling of DiffTaichi's and ChainQueen's scenes). The first axis varies slowest.

    Args:
      lower: (d,) lower corner.
      size: (d,) edge lengths, each > 0.
      dx: grid spacing.
      per_cell: particles per grid cell along each axis.

    Returns:
      (count, d) float64 positions.
    """
    lower = np.asarray(lower, np.float64)
    size = np.asarray(size, np.float64)
    if lower.shape != size.shape or lower.ndim != 1 or lower.size not in (2, 3):
        raise ValueError(f"box corner {lower.tolist()} and size {size.tolist()} must be 2D or 3D vectors")
    if not np.all(np.isfinite(size)) or np.any(size <= 0):
        raise ValueError(f"box size must be positive, got {size.tolist()}")
    if not (dx > 0 and per_cell >= 1):
        raise ValueError(f"need dx > 0 and per_cell >= 1, got dx={dx}, per_cell={per_cell}")
    counts = [int(length / dx) * per_cell for length in size]
    if min(counts) == 0:
        raise ValueError(
            f"box of size {size.tolist()} is thinner than one grid cell (dx={dx}); make it larger"
        )
    axes = [lo + (np.arange(n) + 0.5) * length / n for lo, length, n in zip(lower, size, counts, strict=True)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, lower.size)

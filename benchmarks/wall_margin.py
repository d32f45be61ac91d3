"""How close does a body pressed into each wall come to leaving the grid?

    python benchmarks/wall_margin.py                 # litl's walls, grids of 32, 64 and 128 cells
    python benchmarks/wall_margin.py --diffmpm-walls # DiffTaichi's: one node fewer at high ends

A soft block (E = 20, the biped's range) is thrown at each of the four walls of a 2D box at 4
units/s with gravity 30 pressing it there, for 0.5 s (`tests/sim/test_physics.py`, which checks
the same margins on 32 cells). Printed per grid and wall: the smallest distance, in cells, between
any particle and the line where its stencil would leave the grid (`Health.first_escape_step`).
"""

from __future__ import annotations

import argparse
import pathlib
import sys

import numpy as np

import litl  # noqa: F401  (before JAX starts: XLA's determinism flag, litl.backend)


def diffmpm_face_masks(config):
    """DiffTaichi's `diffmpm` wall layers: i < t at the low end, i > n - t at the high end."""
    t = config.boundary.thickness
    masks = []
    for axis, n in enumerate(config.grid_shape):
        index = np.arange(n).reshape([-1 if a == axis else 1 for a in range(config.dim)])
        masks.append(np.broadcast_to(index < t, config.grid_shape))
        masks.append(np.broadcast_to(index > n - t, config.grid_shape))
    return masks


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--grids", nargs="+", type=int, default=[32, 64, 128])
    parser.add_argument("--diffmpm-walls", action="store_true")
    args = parser.parse_args()
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))
    from litl.sim import boundary
    from tests.sim.test_physics import _deepest_in_wall

    if args.diffmpm_walls:
        boundary._face_masks = diffmpm_face_masks
    walls = {"left": (0, -1), "right": (0, 1), "floor": (1, -1), "ceiling": (1, 1)}
    print(f"walls: {'diffmpm' if args.diffmpm_walls else 'litl'}; margin to leaving the grid, cells")
    print("| grid | " + " | ".join(walls) + " |")
    print("|---:|" + "---:|" * len(walls))
    for n in args.grids:
        margins = [_deepest_in_wall(axis, sign, n_grid=n) for axis, sign in walls.values()]
        print(f"| {n} | " + " | ".join(f"{m:.3f}" for m in margins) + " |")


if __name__ == "__main__":
    main()

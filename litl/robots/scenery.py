"""Scenery: passive bodies that share a robot's scene (a sand bed, a pool of water, a box to push).

A robot's own particles come first in its scene, the scenery's after them, each body with its
material (`litl.sim.materials`) and fixed values of E, ν and density (co-design changes the
robot's only). The robot's task reads its own particles, and so do its observers
(`litl.sim.Body.observed`): the grid field an observer sees is the field at the nodes the robot's
particles reach, unless the world says to show the whole scene.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from litl.sim import SimConfigError


@dataclasses.dataclass(frozen=True, eq=False)
class Scenery:
    """One passive body of the scene.

    Attributes:
      name: what it is, for messages and pictures ("sand", "water", "box").
      positions: (k, d) its particles' initial positions.
      volume: each particle's rest volume.
      material: its `litl.sim.materials` model (`Sand`, `Fluid`, `Clay`, `Elastic`).
      youngs_modulus, poisson_ratio, density: its fixed material values.
    """

    name: str
    positions: np.ndarray
    volume: float
    material: object
    youngs_modulus: float
    poisson_ratio: float
    density: float

    def __post_init__(self) -> None:
        positions = np.asarray(self.positions, np.float64)
        object.__setattr__(self, "positions", positions)
        if positions.ndim != 2 or positions.shape[1] not in (2, 3) or len(positions) == 0:
            raise SimConfigError(
                f"scenery {self.name!r}: positions must be a non-empty (k, 2) or (k, 3) array, "
                f"got shape {positions.shape}"
            )
        for key in ("volume", "youngs_modulus", "density"):
            value = getattr(self, key)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise SimConfigError(
                    f"scenery {self.name!r}: {key} must be a finite number > 0, got {value!r}"
                )
        if not -1 < self.poisson_ratio < 0.5:
            raise SimConfigError(
                f"scenery {self.name!r}: poisson_ratio must lie in (-1, 0.5), got {self.poisson_ratio!r}"
            )
        if not callable(getattr(self.material, "update", None)):
            raise SimConfigError(
                f"scenery {self.name!r}: material must be a litl.sim.materials model, got {self.material!r}"
            )

    @property
    def n_particles(self) -> int:
        return len(self.positions)

    @property
    def lame(self) -> tuple[float, float]:
        E, nu = self.youngs_modulus, self.poisson_ratio
        return E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))

    def wave_speed(self) -> float:
        """Its P-wave speed sqrt((lambda + 2 mu) / density), which the time step must cover."""
        mu, lam = self.lame
        return math.sqrt((lam + 2 * mu) / self.density)


def check_apart(positions: np.ndarray, scenery: tuple[Scenery, ...], dx: float, name: str) -> None:
    """Raise `SimConfigError` if a robot's particles share a grid cell with the scenery's (a
    body that starts inside another)."""
    if not scenery:
        return
    taken = {tuple(c) for body in scenery for c in np.floor(body.positions / dx).astype(int)}
    cells = np.floor(np.asarray(positions) / dx).astype(int)
    inside = [i for i, c in enumerate(cells) if tuple(c) in taken]
    if inside:
        first = np.asarray(positions)[inside[0]]
        raise SimConfigError(
            f"{name}: {len(inside)} of its particles start in cells the scenery "
            f"({', '.join(body.name for body in scenery)}) fills, e.g. one at {np.round(first, 4).tolist()}; "
            f"place the robot above it"
        )

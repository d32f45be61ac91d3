"""The design space: what co-design optimizes, its bounds, and how it reaches the simulator.

Three things are called "design" in litl, each with one name:

* φ, the *design variables*: a (R,) vector, one Young's modulus per design region of the robot
  (`LoopState.design`, the ``design`` column of `metrics.jsonl`); Adam updates it.
* `DesignSpace`: everything about φ (its regions, bounds, initial value, projection, and the map
  to the simulator); `Robot.design_space` gives a robot's.
* `litl.sim.Design`: the simulator's per-particle parameters (E, ν, density per particle,
  strength per actuator) that `DesignSpace.to_design(φ)` produces, differentiably.

A robot's `Material` holds the values: the initial Young's modulus and its bounds, and the fixed
Poisson ratio, density and actuator strength.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import jax.numpy as jnp
import numpy as np
from jax.typing import ArrayLike, DTypeLike

from litl.sim import Design, SimConfigError
from litl.sim.config import is_stretch_bound

# Target CFL number of the stiffest allowed material: below the accepted 0.75
# (`litl.sim.safety.MAX_CFL`; at 0.81 trained gaits blew up). dt / dx is rounded down to two
# significant digits, which gives the catalog's robots dt = dx / 10.
TARGET_CFL = 0.63

# The largest principal stretch a `Material` keeps before yielding by default (`SimConfig.max_stretch`,
# `litl.sim.stretch`): the catalog's 2D robots' (its 3D walkers set inf). Set from the biped at
# dx 1/128: see `Material.max_stretch`.
MAX_STRETCH = 3.0


@dataclasses.dataclass(frozen=True)
class Material:
    """Material of a robot and the bounds of its design variables.

    Attributes:
      youngs_modulus: initial Young's modulus E of every region.
      youngs_modulus_bounds: (E_min, E_max): co-design projects each region's E into this range.
      poisson_ratio: Poisson ratio nu, in (-1, 0.5).
      density: mass per unit volume.
      actuator_strength: active stress per unit actuation, the same for every actuator.
      max_stretch: the principal stretch past which the material yields (strain limiting,
        `SimConfig.max_stretch`); math.inf: never (purely elastic). The default, `MAX_STRETCH`,
        bounds the stress of particles torn from a leg at dx 1/128, whose stiffening the time
        step does not cover (docs/results/2026-11-26-paper-scale-stability.md).
    """

    youngs_modulus: float = 20.0
    youngs_modulus_bounds: tuple[float, float] = (15.0, 30.0)
    poisson_ratio: float = 0.25
    density: float = 1.0
    actuator_strength: float = 3.0
    max_stretch: float = MAX_STRETCH

    def __post_init__(self) -> None:
        object.__setattr__(self, "youngs_modulus_bounds", tuple(self.youngs_modulus_bounds))
        if len(self.youngs_modulus_bounds) != 2:
            raise SimConfigError(
                f"youngs_modulus_bounds must be (E_min, E_max), got {self.youngs_modulus_bounds}"
            )
        low, high = self.youngs_modulus_bounds
        if not (0 < low <= self.youngs_modulus <= high < np.inf):
            raise SimConfigError(
                f"need 0 < E_min <= youngs_modulus <= E_max, got E = {self.youngs_modulus}, "
                f"bounds {self.youngs_modulus_bounds}"
            )
        if not -1 < self.poisson_ratio < 0.5:
            raise SimConfigError(f"poisson_ratio must lie in (-1, 0.5), got {self.poisson_ratio}")
        if not (self.density > 0 and np.isfinite(self.actuator_strength)):
            raise SimConfigError(
                f"density must be > 0 and actuator_strength finite, got "
                f"{self.density}, {self.actuator_strength}"
            )
        never = isinstance(self.max_stretch, float) and self.max_stretch == math.inf
        if not (never or is_stretch_bound(self.max_stretch)):
            raise SimConfigError(
                f"max_stretch must be a number > 1 (the stretch at which the material yields, e.g. "
                f"{MAX_STRETCH}) or inf (never), got {self.max_stretch!r}"
            )

    @property
    def stretch_limit(self) -> float | None:
        """`max_stretch` as `SimConfig.max_stretch` takes it: None for no limit."""
        return None if math.isinf(self.max_stretch) else float(self.max_stretch)

    def max_wave_speed(self) -> float:
        """The fastest elastic wave at E_max, actuators counted as extra stiffness (as
        `litl.sim.safety.wave_speed`): sqrt((lambda + 2 mu + |strength|) / density)."""
        youngs, nu = self.youngs_modulus_bounds[1], self.poisson_ratio
        mu = youngs / (2 * (1 + nu))
        lam = youngs * nu / ((1 + nu) * (1 - 2 * nu))
        return math.sqrt((lam + 2 * mu + abs(self.actuator_strength)) / self.density)

    def time_step(self, dx: float) -> float:
        """The time step for grid spacing dx: `TARGET_CFL` for the stiffest allowed design, with
        dt / dx rounded down to two significant digits."""
        ratio = TARGET_CFL / self.max_wave_speed()
        scale: float = 10 ** (1 - math.floor(math.log10(ratio)))
        return math.floor(ratio * scale) / scale * dx


@dataclasses.dataclass(frozen=True, eq=False)
class DesignSpace:
    """The co-designed parameters φ of a robot: one Young's modulus per design region.

    Attributes:
      region: (n_particles,) int design region of each particle.
      n_regions: R, the length of φ.
      n_actuators: actuators of the robot (one strength each in the `Design`).
      material: initial value and bounds of φ, and the fixed material parameters.
      scenery: the scene's passive bodies (`litl.robots.scenery.Scenery`), whose particles follow
        the robot's in the `Design` with their own fixed values.
    """

    region: np.ndarray
    n_regions: int
    n_actuators: int
    material: Material
    scenery: tuple[Any, ...] = ()

    @property
    def bounds(self) -> tuple[float, float]:
        """(E_min, E_max) of every entry of φ."""
        return self.material.youngs_modulus_bounds

    def initial(self, dtype: DTypeLike = jnp.float32) -> jnp.ndarray:
        """(R,) φ0: the material's Young's modulus in every region."""
        return self.uniform(self.material.youngs_modulus, dtype)

    def uniform(self, youngs_modulus: float, dtype: DTypeLike = jnp.float32) -> jnp.ndarray:
        """(R,) the same Young's modulus in every region (e.g. a bound: the stiffest design)."""
        return jnp.full((self.n_regions,), youngs_modulus, dtype)

    def project(self, design_variables: ArrayLike) -> jnp.ndarray:
        """Clip φ (R,) into the bounds (the paper's projection step)."""
        low, high = self.bounds
        return jnp.clip(design_variables, low, high)

    def modulus(self, design_variables: ArrayLike) -> jnp.ndarray:
        """(R,) the Young's modulus per region that φ gives: φ itself."""
        return jnp.asarray(design_variables)

    def summary(self, design_variables: ArrayLike) -> dict[str, jnp.ndarray]:
        """Per-iteration figures of φ beyond its modulus: none."""
        return {}

    def step_sizes(self, design_learning_rate: float) -> dict[str, float]:
        """Parts of φ whose Adam step is not `design_learning_rate`: none."""
        return {}

    def penalty(self, design_variables: ArrayLike) -> dict[str, jnp.ndarray]:
        """The loss's design terms (a constraint's cost): none."""
        return {}

    def to_design(self, design_variables: ArrayLike | None = None, dtype: DTypeLike | None = None) -> Design:
        """The simulator's per-particle `Design` for φ (R,) (None: φ0); jittable and
        differentiable in φ."""
        if design_variables is None:
            design_variables = self.initial(dtype or jnp.float32)
        design_variables = jnp.asarray(design_variables, dtype)
        dtype = design_variables.dtype
        n, material = len(self.region), self.material
        design = Design(
            youngs_modulus=design_variables[jnp.asarray(self.region)],
            poisson_ratio=jnp.full((n,), material.poisson_ratio, dtype),
            density=jnp.full((n,), material.density, dtype),
            actuator_strength=jnp.full((self.n_actuators,), material.actuator_strength, dtype),
        )
        if not self.scenery:
            return design

        def fixed(key: str) -> jnp.ndarray:
            return jnp.concatenate(
                [getattr(design, key)]
                + [jnp.full((body.n_particles,), getattr(body, key), dtype) for body in self.scenery]
            )

        return Design(
            youngs_modulus=fixed("youngs_modulus"),
            poisson_ratio=fixed("poisson_ratio"),
            density=fixed("density"),
            actuator_strength=design.actuator_strength,
        )

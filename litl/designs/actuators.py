"""``design=actuators``: where the muscles are, co-designed by gradients.

Each particle of the robot holds logits over the robot's actuators and one passive channel; its
weights are their softmax, the passive one dropped (`litl.sim.Design.actuator_weights`): every
actuator pulls along its own fiber on each particle in proportion to that particle's weight. The
logits start at `sharpness` on the particle's own channel (its actuator, or passive) and 0
elsewhere, so the initial body is the robot's own with its muscles slightly blurred (a weight of
e^s / (e^s + m) on its own channel: 0.93 at s = 4 with 4 actuators). The softmax has a derivative
everywhere, so a channel a particle has left can come back.

φ is a dict: ``placement`` (n, m + 1) logits, and ``youngs_modulus`` (R,) when `modulus` co-designs
the stiffness too (else each region keeps the material's). Both step with the loop's design Adam
(`loop.design_learning_rate`); the modulus stays in its bounds, the logits are free.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from jax.typing import DTypeLike

from litl.robots.design import DesignSpace
from litl.robots.layout import Layout
from litl.robots.robot import Robot
from litl.settings import Settings, SettingsError, number
from litl.sim import Design


@dataclass(frozen=True)
class ActuatorsSettings(Settings):
    """``design.actuators``: actuator placement.

    Attributes:
      sharpness: the initial logit of each particle's own channel (the others 0), > 0: how crisp
        the robot's own muscles start.
      modulus: also co-design the Young's modulus per region (as ``design=modulus``).
    """

    sharpness: float = 4.0
    modulus: bool = False

    def check(self) -> None:
        if not (number(self.sharpness) and self.sharpness > 0):
            self._invalid("sharpness", "must be a number > 0 (the initial logit of a particle's own channel)")


@dataclasses.dataclass(frozen=True, eq=False)
class PlacementSpace:
    """The design space of ``design=actuators`` around a robot's own (`base`)."""

    base: DesignSpace
    actuator: np.ndarray  # (n_robot,) each particle's own actuator, -1 passive
    sharpness: float
    modulus_codesigned: bool

    def around(self, base: DesignSpace) -> PlacementSpace:
        """This space around the robot's own `base` (`Robot.design_space`)."""
        return dataclasses.replace(self, base=base)

    # ---- what the loop and the pictures read, as of `DesignSpace`
    @property
    def bounds(self) -> tuple[float, float]:
        return self.base.bounds

    @property
    def region(self) -> np.ndarray:
        return self.base.region

    @property
    def n_regions(self) -> int:
        return self.base.n_regions

    @property
    def n_actuators(self) -> int:
        return self.base.n_actuators

    def initial(self, dtype: DTypeLike = jnp.float32) -> dict[str, jnp.ndarray]:
        return self.uniform(self.base.material.youngs_modulus, dtype)

    def uniform(self, youngs_modulus: float, dtype: DTypeLike = jnp.float32) -> dict[str, jnp.ndarray]:
        """φ with the robot's own placement and `youngs_modulus` in every region (if co-designed)."""
        m = self.n_actuators
        own = np.where(self.actuator >= 0, self.actuator, m)
        logits = self.sharpness * np.eye(m + 1)[own]
        phi = {"placement": jnp.asarray(logits, dtype)}
        if self.modulus_codesigned:
            phi["youngs_modulus"] = self.base.uniform(youngs_modulus, dtype)
        return phi

    def project(self, phi: dict[str, Any]) -> dict[str, Any]:
        if "youngs_modulus" not in phi:
            return phi
        return {**phi, "youngs_modulus": self.base.project(phi["youngs_modulus"])}

    def modulus(self, phi: dict[str, Any]) -> jnp.ndarray:
        """(R,) the Young's modulus per region that φ gives."""
        if "youngs_modulus" in phi:
            return phi["youngs_modulus"]
        return self.base.initial(phi["placement"].dtype)

    def weights(self, phi: dict[str, Any]) -> jnp.ndarray:
        """(n_robot, m) each particle's share of every actuator."""
        return jax.nn.softmax(phi["placement"], axis=-1)[:, : self.n_actuators]

    def summary(self, phi: dict[str, Any]) -> dict[str, jnp.ndarray]:
        """Per-iteration figures of the placement: `actuated` (the mean weight on any actuator:
        the share of the body that is muscle) and `moved` (the fraction of particles whose
        strongest channel is no longer their own)."""
        m = self.n_actuators
        own = jnp.asarray(np.where(self.actuator >= 0, self.actuator, m))
        strongest = jnp.argmax(phi["placement"], axis=-1)
        return {
            "placement/actuated": jnp.mean(jnp.sum(self.weights(phi), axis=-1)),
            "placement/moved": jnp.mean((strongest != own).astype(phi["placement"].dtype)),
        }

    def placed_layout(self, phi: dict[str, Any], layout: Layout) -> Layout:
        """`layout` (the robot's own) with each particle's strongest channel as its actuator
        (passive where that is the passive channel): the co-designed body as a drawing shows it
        (`litl.robots.image.write_png`)."""
        strongest = np.asarray(phi["placement"]).argmax(-1)
        actuator = np.where(strongest < self.n_actuators, strongest, -1).astype(np.int32)
        return dataclasses.replace(layout, actuator=actuator)

    def to_design(self, phi: dict[str, Any] | None = None, dtype: DTypeLike | None = None) -> Design:
        if phi is None:
            phi = self.initial(dtype or jnp.float32)
        phi = jax.tree.map(lambda x: jnp.asarray(x, dtype), phi)
        design = self.base.to_design(self.modulus(phi))
        weights = self.weights(phi)
        scenery = design.youngs_modulus.shape[0] - weights.shape[0]
        if scenery:  # the scene's passive bodies hold no actuator
            weights = jnp.concatenate([weights, jnp.zeros((scenery, weights.shape[1]), weights.dtype)])
        return dataclasses.replace(design, actuator_weights=weights)


def actuators(robot: Robot, settings: ActuatorsSettings, context: object = None) -> PlacementSpace:
    """The actuator-placement design space of `robot`."""
    if robot.n_actuators < 1:
        raise SettingsError(
            f"design=actuators places the robot's actuators, and robot {robot.name!r} has none; "
            f"choose a robot with actuators or design=modulus",
            "design.kind",
        )
    base = robot.design_space
    return PlacementSpace(
        base=base,
        actuator=np.asarray(robot.layout.actuator),
        sharpness=float(settings.sharpness),
        modulus_codesigned=bool(settings.modulus),
    )

"""The body's design spaces: where the muscles are (``design=actuators``), where the material is
(``design=geometry``), and both with the modulus (``design=all``), co-designed by gradients.

φ is a dict of the parts the space co-designs:

* ``placement`` (n, m + 1): each particle's logits over the robot's actuators and one passive
  channel. Its weights are their softmax, the passive one dropped (`litl.sim.Design.
  actuator_weights`): every actuator pulls along its own fiber on each particle in proportion to
  that particle's weight. The logits start at `sharpness` on the particle's own channel (its
  actuator, or passive) and 0 elsewhere, so the first body is the robot's own with its muscles
  slightly blurred (weight e^s / (e^s + m) on its own channel: 0.93 at s = 4 with 4 actuators).
* ``occupancy`` (n,) in [0, 1], starting at 1: how much material each particle is. As topology
  optimization does (SIMP, Bendsøe and Sigmund), it is filtered over the particles within
  `filter_radius` cells (a cone filter), projected towards 0 or 1 by a smoothed Heaviside of
  sharpness `projection` (Wang et al. 2011), and scales the particle's mass by
  ``rho_min + (1 - rho_min) rho``, its stiffness by ``rho_min + (1 - rho_min) rho^p`` and its
  actuation by ``rho^p`` (`penalty` p). A volume above `volume_fraction` costs
  ``volume_weight (volume - volume_fraction)^2`` in the loss, and the grayness (the mean of
  ``4 rho (1 - rho)``) ``grayness_weight`` times itself.
* ``youngs_modulus`` (R,): as ``design=modulus``, where the space co-designs it too.

Every map has a derivative everywhere, so material or a muscle that a particle has lost can come
back: the loop's Adam follows the gradient's sign, however small it has become. All parts step
with the loop's design Adam, at `loop.design_learning_rate` or at their own `learning_rate`
(in their units); modulus and occupancy are kept in their bounds, the logits are free.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
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
      learning_rate: the logits' own Adam step size, > 0; None: the loop's
        (`loop.design_learning_rate`, which the modulus takes).
    """

    sharpness: float = 4.0
    modulus: bool = False
    learning_rate: float | None = None

    def check(self) -> None:
        if not (number(self.sharpness) and self.sharpness > 0):
            self._invalid("sharpness", "must be a number > 0 (the initial logit of a particle's own channel)")
        if self.learning_rate is not None and not (number(self.learning_rate) and self.learning_rate > 0):
            self._invalid("learning_rate", "must be a number > 0, or null (the loop's design_learning_rate)")


@dataclass(frozen=True)
class GeometrySettings(Settings):
    """``design.geometry``: where the material is.

    Attributes:
      filter_radius: the cone filter's radius in grid cells, >= 1 (a particle's occupancy is the
        weighted mean of its neighbours' within it).
      projection: the smoothed Heaviside's first sharpness beta, > 0 (larger: crisper, 0/1 designs).
      projection_growth: the factor beta is multiplied by after every design step, >= 1 (1: constant),
        up to `projection_max`: a continuation that makes the design crisper as the run goes on.
      projection_max: the largest beta, >= `projection`.
      penalty: the SIMP exponent p >= 1 of stiffness and actuation.
      rho_min: the mass and stiffness left where there is no material, in (0, 1).
      volume_fraction: the largest share of the robot's particles the material may fill without
        cost, in (0, 1] (1: no constraint).
      volume_weight: the cost of each unit of volume above it, squared, >= 0.
      grayness_weight: the cost of the design's grayness (the mean of 4 rho (1 - rho): 0 for a
        crisp 0/1 design, 1 for all halves), >= 0 (0: none).
      modulus: also co-design the Young's modulus per region.
      learning_rate: the occupancy's own Adam step size, > 0 (the occupancy lies in [0, 1]);
        None: the loop's (`loop.design_learning_rate`, which the modulus takes).
    """

    filter_radius: float = 1.5
    projection: float = 2.0
    projection_growth: float = 1.0
    projection_max: float = 64.0
    penalty: float = 3.0
    rho_min: float = 0.01
    volume_fraction: float = 1.0
    volume_weight: float = 1.0
    grayness_weight: float = 0.0
    modulus: bool = False
    learning_rate: float | None = None

    def check(self) -> None:
        if not (number(self.filter_radius) and self.filter_radius >= 1):
            self._invalid(
                "filter_radius", "must be at least 1 grid cell (the filter reaches no neighbour below it)"
            )
        if not (number(self.projection) and self.projection > 0):
            self._invalid("projection", "must be a number > 0 (the projection's sharpness)")
        if not (number(self.projection_growth) and self.projection_growth >= 1):
            self._invalid("projection_growth", "must be a number >= 1 (1: a constant sharpness)")
        if not (number(self.projection_max) and self.projection_max >= self.projection):
            self._invalid("projection_max", f"must be a number >= projection ({self.projection})")
        if not (number(self.penalty) and self.penalty >= 1):
            self._invalid("penalty", "must be a number >= 1 (SIMP's exponent)")
        if not (number(self.rho_min) and 0 < self.rho_min < 1):
            self._invalid("rho_min", "must lie in (0, 1)")
        if not (number(self.volume_fraction) and 0 < self.volume_fraction <= 1):
            self._invalid("volume_fraction", "must lie in (0, 1]")
        for key in ("volume_weight", "grayness_weight"):
            if not (number(getattr(self, key)) and getattr(self, key) >= 0):
                self._invalid(key, "must be a number >= 0")
        if self.learning_rate is not None and not (number(self.learning_rate) and self.learning_rate > 0):
            self._invalid("learning_rate", "must be a number > 0, or null (the loop's design_learning_rate)")


@dataclass(frozen=True)
class AllSettings(Settings):
    """``design.all``: actuators, geometry and the modulus together (``design.all.actuators.*``,
    ``design.all.geometry.*``; the modulus is always co-designed)."""

    actuators: ActuatorsSettings = field(default_factory=ActuatorsSettings)
    geometry: GeometrySettings = field(default_factory=GeometrySettings)


@dataclasses.dataclass(frozen=True, eq=False)
class Filter:
    """A cone filter over the particles: `neighbours` (n, K) indices, `weights` (n, K) summing to 1
    per row (padding: the particle itself with weight 0)."""

    neighbours: np.ndarray
    weights: np.ndarray

    @classmethod
    def of(cls, positions: np.ndarray, radius: float) -> Filter:
        from scipy.spatial import cKDTree

        tree = cKDTree(positions)
        found = tree.query_ball_point(positions, radius)
        width = max(len(f) for f in found)
        neighbours = np.tile(np.arange(len(positions))[:, None], (1, width))
        weights = np.zeros((len(positions), width))
        for i, near in enumerate(found):
            near = np.asarray(near)
            cone = np.maximum(radius - np.linalg.norm(positions[near] - positions[i], axis=1), 0.0)
            neighbours[i, : len(near)] = near
            weights[i, : len(near)] = cone / cone.sum()
        return cls(neighbours, weights)

    def __call__(self, values: jnp.ndarray) -> jnp.ndarray:
        return jnp.sum(values[self.neighbours] * jnp.asarray(self.weights, values.dtype), axis=-1)


@dataclasses.dataclass(frozen=True, eq=False)
class BodySpace:
    """A body design space around the robot's own (`base`): placement, geometry (its settings and
    its `filter`, or None) and the modulus, each co-designed or not."""

    base: DesignSpace
    actuator: np.ndarray  # (n_robot,) each particle's own actuator, -1 passive
    placement: ActuatorsSettings | None
    geometry: GeometrySettings | None
    modulus_codesigned: bool
    filter: Filter | None = None

    def around(self, base: DesignSpace) -> BodySpace:
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
        """φ with the robot's own body and `youngs_modulus` in every region (if co-designed)."""
        phi: dict[str, jnp.ndarray] = {}
        if self.placement is not None:
            m = self.n_actuators
            own = np.where(self.actuator >= 0, self.actuator, m)
            phi["placement"] = jnp.asarray(self.placement.sharpness * np.eye(m + 1)[own], dtype)
        if self.geometry is not None:
            phi["occupancy"] = jnp.ones((len(self.actuator),), dtype)
            if self.geometry.projection_growth > 1:
                # The projection's sharpness, where it grows: carried in φ so that it grows step by
                # step (and resumes with the run), never moved by the gradient (`density` stops it).
                phi["projection"] = jnp.asarray(self.geometry.projection, dtype)
        if self.modulus_codesigned:
            phi["youngs_modulus"] = self.base.uniform(youngs_modulus, dtype)
        return phi

    def project(self, phi: dict[str, Any]) -> dict[str, Any]:
        projected = dict(phi)
        if "youngs_modulus" in phi:
            projected["youngs_modulus"] = self.base.project(phi["youngs_modulus"])
        if "occupancy" in phi:
            projected["occupancy"] = jnp.clip(phi["occupancy"], 0.0, 1.0)
        if "projection" in phi and self.geometry is not None:
            grown = phi["projection"] * self.geometry.projection_growth
            projected["projection"] = jnp.minimum(grown, self.geometry.projection_max)
        return projected

    def modulus(self, phi: dict[str, Any]) -> jnp.ndarray:
        """(R,) the Young's modulus per region that φ gives."""
        if "youngs_modulus" in phi:
            return phi["youngs_modulus"]
        return self.base.initial(next(iter(phi.values())).dtype)

    def weights(self, phi: dict[str, Any]) -> jnp.ndarray:
        """(n_robot, m) each particle's share of every actuator (before geometry)."""
        if "placement" in phi:
            return jax.nn.softmax(phi["placement"], axis=-1)[:, : self.n_actuators]
        own = self.actuator[:, None] == np.arange(self.n_actuators)
        return jnp.asarray(own, next(iter(phi.values())).dtype)

    def density(self, phi: dict[str, Any]) -> jnp.ndarray:
        """(n_robot,) each particle's material after the filter and the projection, in [0, 1]."""
        assert self.geometry is not None and self.filter is not None
        beta = jax.lax.stop_gradient(phi["projection"]) if "projection" in phi else self.geometry.projection
        eta = 0.5
        filtered = self.filter(phi["occupancy"])
        top = jnp.tanh(beta * eta) + jnp.tanh(beta * (filtered - eta))
        return jnp.clip(top / (jnp.tanh(beta * eta) + jnp.tanh(beta * (1.0 - eta))), 0.0, 1.0)

    def summary(self, phi: dict[str, Any]) -> dict[str, jnp.ndarray]:
        """Per-iteration figures: of the placement, `placement/actuated` (the mean weight on any
        actuator: how much of the body is muscle) and `placement/moved` (the fraction of particles
        whose strongest channel is no longer their own); of the geometry, `geometry/volume` (the
        mean material) and `geometry/grayness` (the mean of 4 rho (1 - rho): 0 for a crisp design)."""
        figures = {}
        if "placement" in phi:
            m = self.n_actuators
            own = jnp.asarray(np.where(self.actuator >= 0, self.actuator, m))
            strongest = jnp.argmax(phi["placement"], axis=-1)
            figures["placement/actuated"] = jnp.mean(jnp.sum(self.weights(phi), axis=-1))
            figures["placement/moved"] = jnp.mean((strongest != own).astype(phi["placement"].dtype))
        if "occupancy" in phi:
            rho = self.density(phi)
            figures["geometry/volume"] = jnp.mean(rho)
            figures["geometry/grayness"] = jnp.mean(4.0 * rho * (1.0 - rho))
            if "projection" in phi:
                figures["geometry/projection"] = phi["projection"]
        return figures

    def step_sizes(self, design_learning_rate: float) -> dict[str, float]:
        """{part: its Adam step over the loop's} for the parts with a step size of their own."""
        own = {}
        if self.placement is not None and self.placement.learning_rate is not None:
            own["placement"] = self.placement.learning_rate / design_learning_rate
        if self.geometry is not None and self.geometry.learning_rate is not None:
            own["occupancy"] = self.geometry.learning_rate / design_learning_rate
        return own

    def penalty(self, phi: dict[str, Any]) -> dict[str, jnp.ndarray]:
        """The loss's design terms: the volume above `volume_fraction`, weighted and squared, and
        the grayness, weighted (each where its weight is not 0)."""
        if "occupancy" not in phi or self.geometry is None:
            return {}
        rho, terms = self.density(phi), {}
        if self.geometry.volume_weight:
            over = jnp.maximum(jnp.mean(rho) - self.geometry.volume_fraction, 0.0)
            terms["design/volume"] = self.geometry.volume_weight * over**2
        if self.geometry.grayness_weight:
            terms["design/grayness"] = self.geometry.grayness_weight * jnp.mean(4.0 * rho * (1.0 - rho))
        return terms

    def placed_layout(self, phi: dict[str, Any], layout: Layout) -> Layout:
        """`layout` (the robot's own) as φ shapes it: each particle's strongest channel as its
        actuator (passive where that is the passive channel), and only the particles whose
        material (`density`) is at least a half: the co-designed body, as a drawing keeps it
        (`litl.robots.image.write_png`).

        Raises:
          LayoutError: the body left an actuator, a design region or a named group with no
            particle (a robot needs each).
        """
        actuator = np.asarray(layout.actuator)
        if "placement" in phi:
            strongest = np.asarray(phi["placement"]).argmax(-1)
            actuator = np.where(strongest < self.n_actuators, strongest, -1).astype(np.int32)
        keep = np.ones(len(actuator), bool)
        if "occupancy" in phi:
            keep = np.asarray(self.density(phi)) >= 0.5
        index = np.cumsum(keep) - 1
        groups = {name: index[members[keep[members]]] for name, members in layout.groups.items()}
        return Layout(
            positions=np.asarray(layout.positions)[keep],
            volume=np.asarray(layout.volume)[keep],
            actuator=actuator[keep],
            fiber=layout.fiber,
            region=np.asarray(layout.region)[keep],
            pinned=np.asarray(layout.pinned)[keep],
            groups=groups,
        )

    def to_design(self, phi: dict[str, Any] | None = None, dtype: DTypeLike | None = None) -> Design:
        if phi is None:
            phi = self.initial(dtype or jnp.float32)
        phi = jax.tree.map(lambda x: jnp.asarray(x, dtype), phi)
        design = self.base.to_design(self.modulus(phi))
        weights = self.weights(phi)
        n = weights.shape[0]
        youngs, density = design.youngs_modulus, design.density
        if "occupancy" in phi:
            assert self.geometry is not None
            rho, low, p = self.density(phi), self.geometry.rho_min, self.geometry.penalty
            youngs = youngs.at[:n].multiply(low + (1 - low) * rho**p)
            density = density.at[:n].multiply(low + (1 - low) * rho)
            weights = weights * (rho**p)[:, None]
        scenery = youngs.shape[0] - n
        if scenery:  # the scene's passive bodies hold no actuator
            weights = jnp.concatenate([weights, jnp.zeros((scenery, weights.shape[1]), weights.dtype)])
        return dataclasses.replace(design, youngs_modulus=youngs, density=density, actuator_weights=weights)


def _space(robot: Robot, placement, geometry, modulus: bool) -> BodySpace:
    if placement is not None and robot.n_actuators < 1:
        raise SettingsError(
            f"design=actuators places the robot's actuators, and robot {robot.name!r} has none; "
            f"choose a robot with actuators or design=modulus",
            "design.kind",
        )
    positions = np.asarray(robot.layout.positions, np.float64)
    radius = geometry.filter_radius * robot.config.dx if geometry is not None else None
    return BodySpace(
        base=robot.design_space,
        actuator=np.asarray(robot.layout.actuator),
        placement=placement,
        geometry=geometry,
        modulus_codesigned=bool(modulus),
        filter=Filter.of(positions, radius) if radius is not None else None,
    )


def actuators(robot: Robot, settings: ActuatorsSettings, context: object = None) -> BodySpace:
    """``design=actuators``: where the muscles are (and the modulus, with `settings.modulus`)."""
    return _space(robot, settings, None, settings.modulus)


def geometry(robot: Robot, settings: GeometrySettings, context: object = None) -> BodySpace:
    """``design=geometry``: where the material is (and the modulus, with `settings.modulus`)."""
    return _space(robot, None, settings, settings.modulus)


def everything(robot: Robot, settings: AllSettings, context: object = None) -> BodySpace:
    """``design=all``: actuators, geometry and the modulus."""
    return _space(robot, settings.actuators, settings.geometry, True)

"""Differentiable MLS-MPM simulation in JAX (2D and 3D).

Build a `SimConfig` (static; its `materials`, e.g. `Elastic(max_stretch=3.0)`, give the bodies
their stress laws), a `Body` (particle layout), a `Design` (differentiable materials and
actuator strengths) and an initial `SimState`; then either take single steps with `make_step`, or
run whole rollouts with `make_rollout` (pure, jittable, differentiable) or `simulate` (checked).
"""

from litl.sim.colliders import Collider
from litl.sim.config import Boundary, ConfigError, SimConfig, SimConfigError, Wall
from litl.sim.materials import Clay, Elastic, Fluid, Sand
from litl.sim.rollout import Health, Trajectory, centroid, make_rollout
from litl.sim.safety import (
    SimulationError,
    check_actuation,
    check_time_step,
    raise_if_unhealthy,
    validate,
    wave_speed,
)
from litl.sim.simulate import simulate
from litl.sim.state import Body, Design, Grid, SimState
from litl.sim.step import make_step, rasterize

__all__ = [
    "Body",
    "Boundary",
    "Clay",
    "Collider",
    "ConfigError",
    "Design",
    "Elastic",
    "Fluid",
    "Grid",
    "Health",
    "Sand",
    "SimConfig",
    "SimConfigError",
    "SimState",
    "SimulationError",
    "Trajectory",
    "Wall",
    "centroid",
    "check_actuation",
    "check_time_step",
    "make_rollout",
    "make_step",
    "raise_if_unhealthy",
    "rasterize",
    "simulate",
    "validate",
    "wave_speed",
]

"""Differentiable MLS-MPM simulation in JAX (2D and 3D)."""

from litl.sim.config import Boundary, ConfigError, SimConfig, Wall
from litl.sim.rollout import Health, Trajectory, centroid, make_rollout
from litl.sim.state import Body, Design, Grid, SimState
from litl.sim.step import make_step, rasterize

__all__ = [
    "Body", "Boundary", "ConfigError", "Design", "Grid", "Health", "SimConfig", "SimState",
    "Trajectory", "Wall", "centroid", "make_rollout", "make_step", "rasterize",
]

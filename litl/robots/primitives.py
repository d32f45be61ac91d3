"""Particle sampling of geometric primitives (it lives in `litl.sim.sampling`, where the
simulator's own scenes use it; kept here under its old import path)."""

from litl.sim.sampling import sample_box

__all__ = ["sample_box"]

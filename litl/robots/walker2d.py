"""The reference scene: DiffTaichi's classic 2D MPM walker (`tests/sim/data/walker2d.md`).

It is litl's external check that physics and gradients are right, so every number here follows
that published scene exactly.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from litl.models.open_loop import SinusoidParams, sinusoid_policy
from litl.robots.primitives import sample_box
from litl.robots.robot import Scene
from litl.sim import Body, Boundary, Design, SimConfig, SimState
from litl.sim.materials import Elastic

DX = 1.0 / 128
DT = 1e-3
STEPS = 1023
GRAVITY = 3.8
ACTUATOR_STRENGTH = 4.0
OMEGA = 20.0
OFFSET = (0.1, 0.03)
# (x, y, w, h, actuator id or -1), in the order the particles are generated.
RECTANGLES = (
    (0.0, 0.1, 0.3, 0.1, -1),
    (0.0, 0.0, 0.05, 0.1, 0),
    (0.05, 0.0, 0.05, 0.1, 1),
    (0.2, 0.0, 0.05, 0.1, 2),
    (0.25, 0.0, 0.05, 0.1, 3),
)
N_ACTUATORS = 4


def build(dtype=jnp.float32) -> Scene:
    """The walker scene in the given float dtype (float64 needs `jax.enable_x64`)."""
    blocks, actuators = [], []
    for x, y, w, h, actuator in RECTANGLES:
        points = sample_box((x, y), (w, h), DX, per_cell=2) + np.asarray(OFFSET)
        blocks.append(points)
        actuators.append(np.full(len(points), actuator, np.int32))
    positions = np.concatenate(blocks)
    n = len(positions)
    config = SimConfig(
        grid_shape=(128, 128),
        dx=DX,
        dt=DT,
        gravity=(0.0, -GRAVITY),
        boundary=Boundary.box(2, floor="sticky", sides="sticky", thickness=3),
        materials=(Elastic("fixed_corotated"),),
    )
    body = Body(
        volume=jnp.ones((n,), dtype),
        actuator=jnp.asarray(np.concatenate(actuators)),
        fiber=jnp.asarray(np.tile([0.0, 1.0], (N_ACTUATORS, 1)), dtype),
        pinned=jnp.zeros((n,), bool),
    )
    design = Design.from_lame(
        mu=jnp.full((n,), 10.0, dtype),
        lam=jnp.full((n,), 10.0, dtype),
        density=jnp.ones((n,), dtype),
        actuator_strength=jnp.full((N_ACTUATORS,), ACTUATOR_STRENGTH, dtype),
    )
    state = SimState.at_rest(jnp.asarray(positions, dtype))
    return Scene(config=config, body=body, design=design, state=state)


def policy():
    """The scene's open-loop controller: 4 phase-shifted sinusoids at omega = 20."""
    return sinusoid_policy(omega=OMEGA, dt=DT)


def params(weights, bias, dtype=jnp.float32) -> SinusoidParams:
    return SinusoidParams(weights=jnp.asarray(weights, dtype), bias=jnp.asarray(bias, dtype))


def loss(final_state: SimState):
    """Negative mean x-coordinate of all particles: walking right lowers it."""
    return -jnp.mean(final_state.x[:, 0])

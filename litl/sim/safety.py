"""Checks that turn bad settings and blown-up rollouts into clear errors.

These run outside jit on concrete values: `validate` and `check_time_step` before a simulation,
`raise_if_unhealthy` after one (on the `Health` a rollout returns).
"""

from __future__ import annotations

import numpy as np

from litl.errors import UserError
from litl.sim.config import SimConfig, SimConfigError
from litl.sim.state import Body, Design, SimState

# Elastic CFL number c dt / dx allowed. A lone particle (one that separated from the body, or a
# surface particle) oscillates on its own stencil at omega = 2 c / dx, which symplectic Euler keeps
# stable only for omega dt < 2, i.e. CFL < 1 in the linear regime; fixed-corotated stress stiffens
# under large stretch, so the margin must be real. Measured on the biped with a trained controller:
# at CFL 0.81 a crushed foot particle was ejected, rang and blew up at step 475; at 0.61 and 0.73
# (and on 33 aggressive controllers) every rollout stayed finite. The published walker scene runs
# at 0.746, the largest value litl accepts.
MAX_CFL = 0.75

# Largest active strain an actuator may impose: actuator strength / (lambda + 2 mu) of the softest
# actuated particle, the 1D strain at which elastic stress balances the active stress. Fixed-
# corotated Kirchhoff stress resists compression at most (lambda + 2 mu) / 4 (at J = 1/2) and less
# beyond, so an actuator near that crushes and inverts particles. Measured on the biped (33
# aggressive open-loop controllers, 500 steps): ratio 0.67 (E = 5, strength 4) blew up 32 of 33;
# 0.33 blew up 1 and inverted 2; 0.22 inverted 1 of 33; 0.167 and below kept every particle's
# det F above 0.07 and all rollouts finite. The published walker scene uses 0.133.
MAX_ACTIVE_STRAIN = 0.2


class SimulationError(UserError, RuntimeError):
    """A rollout produced non-finite values or particles left the grid."""


def wave_speed(body: Body, design: Design) -> float:
    """Largest elastic (P-)wave speed sqrt((lambda + 2 mu + |actuator stress|) / density).

    The actuators' strength is counted as extra stiffness: an active stress of that size
    accelerates the material like an elastic stress would.
    """
    mu, lam = (np.asarray(p, np.float64) for p in design.lame())
    density = np.asarray(design.density, np.float64)
    strength = np.abs(np.asarray(design.actuator_strength, np.float64))
    actuator = np.asarray(body.actuator)
    active = np.where(actuator >= 0, strength[np.clip(actuator, 0, None)], 0.0) if strength.size else 0.0
    return float(np.max(np.sqrt((lam + 2 * mu + active) / density)))


def check_time_step(config: SimConfig, body: Body, design: Design) -> float:
    """Raise `SimConfigError` if dt is too large for the stiffest particle; return the CFL number."""
    speed = wave_speed(body, design)
    cfl = speed * config.dt / config.dx
    if not np.isfinite(cfl) or cfl > MAX_CFL:
        limit = MAX_CFL * config.dx / speed
        raise SimConfigError(
            f"time step dt={config.dt:g} is too large for this material: the fastest elastic wave "
            f"(speed {speed:.4g} = sqrt((lambda + 2 mu + actuator strength) / density)) crosses "
            f"{cfl:.3g} cells per step, above the stable limit of {MAX_CFL}. Use dt <= {limit:.3g}, "
            f"or lower Young's modulus / actuator strength, raise density, or coarsen dx."
        )
    return cfl


def check_actuation(body: Body, design: Design) -> float:
    """Raise `SimConfigError` if an actuator can crush its material; return the largest active strain.

    The active strain of a particle is |actuator strength| / (lambda + 2 mu): how far the actuator
    alone would compress the material along its fiber. Above `MAX_ACTIVE_STRAIN` particles get
    crushed and inverted under strong actuation, and rollouts blow up.
    """
    actuator = np.asarray(body.actuator)
    strength = np.abs(np.asarray(design.actuator_strength, np.float64))
    if design.actuator_weights is not None:
        # Placed actuators may reach any particle: each is checked at the strongest one.
        actuator = np.full(actuator.shape, int(np.argmax(strength)) if strength.size else -1)
    if not (actuator >= 0).any() or not strength.size:
        return 0.0
    mu, lam = (np.asarray(p, np.float64) for p in design.lame())
    stiffness = np.broadcast_to(lam + 2 * mu, actuator.shape)
    active = actuator >= 0
    strain = strength[actuator[active]] / stiffness[active]
    worst = int(np.argmax(strain))
    ratio = float(strain[worst])
    if not np.isfinite(ratio) or ratio > MAX_ACTIVE_STRAIN:
        needed = float(strength[actuator[active]][worst]) / MAX_ACTIVE_STRAIN
        raise SimConfigError(
            f"actuators are too strong for the material: actuator strength "
            f"{float(strength[actuator[active]][worst]):.4g} against lambda + 2 mu = "
            f"{float(stiffness[active][worst]):.4g} is an active strain of {ratio:.3g}, above "
            f"{MAX_ACTIVE_STRAIN}; particles would be crushed and inverted. Lower the actuator "
            f"strength, or raise Young's modulus (its lower bound, for co-design) so that "
            f"lambda + 2 mu >= {needed:.4g}."
        )
    return ratio


def _check_actuator_weights(weights, n: int, m: int) -> None:
    """Placed actuators (`Design.actuator_weights`): (n, m), finite, >= 0, rows at most 1."""
    if weights is None:
        return
    if np.shape(weights) != (n, m):
        raise SimConfigError(
            f"design.actuator_weights must have shape (n_particles, n_actuators) = {(n, m)}, "
            f"got {np.shape(weights)}"
        )
    values = np.asarray(weights, np.float64)
    if not np.all(np.isfinite(values)) or values.min() < 0 or values.sum(-1).max() > 1 + 1e-5:
        raise SimConfigError(
            "design.actuator_weights must be finite, >= 0, with every particle's weights "
            "summing to at most 1 (a softmax over the actuators and a passive channel gives "
            "such weights)"
        )


def validate(config: SimConfig, body: Body, design: Design, state: SimState) -> None:
    """Check that body, design and state agree with each other and with the config."""
    dim = config.dim
    n = np.shape(state.x)[0] if np.ndim(state.x) == 2 else None
    if n is None or np.shape(state.x)[1] != dim:
        raise SimConfigError(f"state.x must have shape (n_particles, {dim}), got {np.shape(state.x)}")
    if n == 0:
        raise SimConfigError("the body has no particles")
    expected = {
        "state.v": (state.v, (n, dim)),
        "state.C": (state.C, (n, dim, dim)),
        "state.F": (state.F, (n, dim, dim)),
        "body.volume": (body.volume, (n,)),
        "body.actuator": (body.actuator, (n,)),
        "body.pinned": (body.pinned, (n,)),
        "design.youngs_modulus": (design.youngs_modulus, (n,)),
        "design.poisson_ratio": (design.poisson_ratio, (n,)),
        "design.density": (design.density, (n,)),
    }
    for name, (value, shape) in expected.items():
        if np.shape(value) != shape:
            raise SimConfigError(f"{name} must have shape {shape}, got {np.shape(value)}")
    if body.material is not None:
        if np.shape(body.material) != (n,):
            raise SimConfigError(f"body.material must have shape {(n,)}, got {np.shape(body.material)}")
        ids = np.asarray(body.material)
        count = len(config.materials)
        if ids.min() < 0 or ids.max() >= count:
            raise SimConfigError(
                f"body.material ids must index SimConfig.materials ({count} given: "
                f"{[type(m).__name__ for m in config.materials]}), "
                f"got range [{ids.min()}, {ids.max()}]; add the missing materials to SimConfig.materials"
            )
    if body.observed is not None and np.shape(body.observed) != (n,):
        raise SimConfigError(f"body.observed must have shape {(n,)}, got {np.shape(body.observed)}")
    m = np.shape(body.fiber)[0] if np.ndim(body.fiber) == 2 else -1
    if np.shape(body.fiber) != (m, dim):
        raise SimConfigError(f"body.fiber must have shape (n_actuators, {dim}), got {np.shape(body.fiber)}")
    if np.shape(design.actuator_strength) != (m,):
        raise SimConfigError(
            f"design.actuator_strength must have one entry per actuator ({m}), "
            f"got shape {np.shape(design.actuator_strength)}"
        )
    _check_actuator_weights(design.actuator_weights, n, m)
    actuator = np.asarray(body.actuator)
    if actuator.size and (actuator.min() < -1 or actuator.max() >= m):
        raise SimConfigError(
            f"body.actuator ids must be -1 (passive) or in [0, {m}), got range "
            f"[{actuator.min()}, {actuator.max()}]"
        )
    if m and not np.allclose(np.linalg.norm(np.asarray(body.fiber), axis=-1), 1.0, atol=1e-5):
        raise SimConfigError("every body.fiber direction must be a unit vector")
    positive = {
        "body.volume": body.volume,
        "design.youngs_modulus": design.youngs_modulus,
        "design.density": design.density,
    }
    for name, given in positive.items():
        array = np.asarray(given)
        if not (np.all(np.isfinite(array)) and np.all(array > 0)):
            raise SimConfigError(f"{name} must be finite and > 0 for every particle (min {array.min():g})")
    nu = np.asarray(design.poisson_ratio)
    if not (np.all(nu > -1) and np.all(nu < 0.5)):
        raise SimConfigError(
            f"design.poisson_ratio must lie in (-1, 0.5) (0.5 is incompressible and makes lambda "
            f"infinite), got range [{nu.min():g}, {nu.max():g}]"
        )
    for name in ("x", "v", "C", "F"):
        if not np.all(np.isfinite(np.asarray(getattr(state, name)))):
            raise SimConfigError(f"state.{name} contains NaN or infinity")
    cells = np.asarray(state.x, np.float64) / config.dx - 0.5
    upper = np.asarray(config.grid_shape) - 3
    outside = ~np.all((cells >= 0) & (cells < upper + 1), axis=-1)
    if outside.any():
        first = int(np.argmax(outside))
        raise SimConfigError(
            f"{int(outside.sum())} particles lie outside the grid's interior (e.g. particle {first} "
            f"at {np.asarray(state.x)[first].tolist()}); the domain is [0, {config.domain_size}] and "
            f"particles need 1.5 cells of margin: move the body or enlarge grid_shape/dx"
        )


def escape_margins(config: SimConfig, positions) -> dict[str, float]:
    """How close particles came to leaving the grid: for each face of the domain, the smallest
    distance, in cells, between any particle of `positions` and the line beyond which its stencil
    would leave the grid (where a rollout's `first_escape_step` fires). A body resting against a
    wall keeps about 1.46 cells; less means it pressed into the wall's layer.

    Args:
      config: the simulation's grid.
      positions: (..., n, d) particle positions, e.g. a recorded rollout's frames.

    Returns:
      {"x_low": ..., "x_high": ..., "y_low" (the floor), "y_high", and "z_low", "z_high" in 3D}.
    """
    cells = np.asarray(positions, np.float64) / config.dx
    cells = cells.reshape(-1, config.dim)
    margins = {}
    for axis, (name, n) in enumerate(zip("xyz", config.grid_shape, strict=False)):
        # A particle's stencil starts at floor(x - 0.5) and must lie in [0, n - 3]: x in [0.5, n - 1.5).
        margins[f"{name}_low"] = float(cells[:, axis].min() - 0.5)
        margins[f"{name}_high"] = float(n - 1.5 - cells[:, axis].max())
    return margins


def raise_if_unhealthy(health, steps: int | None = None) -> None:
    """Raise `SimulationError` if a rollout's `Health` (possibly batched) reports a failure."""
    nonfinite = np.atleast_1d(np.asarray(health.first_nonfinite_step))
    escaped = np.atleast_1d(np.asarray(health.first_escape_step))
    of = f" of {steps}" if steps else ""
    problems: list[str] = []
    for index, (bad, out) in enumerate(zip(nonfinite, escaped, strict=True)):
        where = f" (batch entry {index})" if nonfinite.size > 1 else ""
        found = []
        if out >= 0:
            found.append(
                (
                    out,
                    (
                        f"particles left the grid at step {out}{of}{where}: enlarge the grid, move the body "
                        f"away from the edges, or use closed walls instead of 'open' faces"
                    ),
                )
            )
        if bad >= 0:
            found.append(
                (
                    bad,
                    (
                        f"non-finite values (NaN/inf) first appeared at step {bad}{of}{where}: the "
                        f"simulation blew up; reduce dt, stiffness or actuator strength, or check the "
                        f"controller output"
                    ),
                )
            )
        # The earlier failure is the cause; the later one usually its consequence.
        problems.extend(message for _, message in sorted(found, key=lambda item: item[0]))
    if problems:
        raise SimulationError("; ".join(problems))

"""Physics checks against published measurements: the scenes and what they measure.

* `dam_break`: a water column (`litl.sim.materials.Fluid`) against the left wall of a box, released
  at t = 0; its surge front Z = x / a against T = n t sqrt(g / a) (a the column's width, n^2 a its
  height), as Martin & Moyce (1952) measured it (`MARTIN_MOYCE_TABLE_2`, the n^2 = 2 column).
* `granular_collapse`: a column of sand (`litl.sim.materials.Sand`) of aspect ratio
  a = H0 / L0 against the left wall, released at t = 0 on a rough floor; its run-out
  (L_inf - L0) / L0 and final height against the scalings of Lube et al. (2005) and
  Lajeunesse et al. (2005) for quasi-2D channels, and the slope of its deposit against the
  friction angle.

Both are used at small size by the tests and at a size that resolves them by
``benchmarks/materials.py`` (docs/results). Units: metres, seconds, kg; gravity 9.8 down.
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np

from litl.sim.config import Boundary, SimConfig, Wall, WallKind
from litl.sim.materials import Fluid, Sand
from litl.sim.rollout import make_rollout
from litl.sim.sampling import sample_box
from litl.sim.state import Body, Design, SimState

GRAVITY = 9.8
SAND_DENSITY = 1500.0  # kg/m^3, a packed sand's bulk density
# Sand's Young's modulus is set so that the body's own weight strains it elastically by this much,
# E = rho g H / strain. Stiffer sand is not more accurate in MPM: measured on a heap 10 degrees
# below its friction angle at dx 1/256, E = 1e6 (strain 7e-4) let it creep 16 cells in 1 s (in
# float64 too: not round-off), while E = 1e5 kept its slope; the grid's velocity noise strains
# particles by more than such a stiff elastic range, and sand pulled apart keeps no stress.
SAND_STRAIN_UNDER_WEIGHT = 0.01
THICKNESS = 3  # the box's wall thickness in cells; bodies start on its inner faces


@dataclasses.dataclass(frozen=True)
class Collapse:
    """What a released column did.

    Attributes:
      times: (k,) seconds at which `fronts` were taken.
      fronts: (k,) the surge front's distance from the left wall's face (the 99.5th percentile of
        the particles' x, so one splashed particle does not count).
      runout: the front at the end.
      height: the deposit's height at the end (99.5th percentile of y within one column width of
        the wall).
      kinetic: (k,) kinetic energy per unit mass at each time (at rest: near 0).
      positions: (n, 2) particle positions at the end.
      volume: (k,) the body's volume over its initial volume at each time (the mean of det F).
    """

    times: np.ndarray
    fronts: np.ndarray
    runout: float
    height: float
    kinetic: np.ndarray
    positions: np.ndarray
    volume: np.ndarray


def column(width: float, height: float, n_grid: int) -> np.ndarray:
    """Particles (2 x 2 per cell) of a `width` x `height` column standing on the floor against the
    left wall of `release`'s box."""
    dx = 1.0 / n_grid
    return sample_box([THICKNESS * dx] * 2, [width, height], dx, per_cell=2)


def wedge(base: float, angle: float, n_grid: int) -> np.ndarray:
    """Particles of a right triangle against the left wall: `base` long on the floor, its free
    surface falling from the wall at `angle` degrees (a heap's half)."""
    dx = 1.0 / n_grid
    wall = THICKNESS * dx
    height = base * math.tan(math.radians(angle))
    x = sample_box([wall, wall], [base, height], dx, per_cell=2)
    return x[(x[:, 1] - wall) <= height * (1 - (x[:, 0] - wall) / base)]


def release(
    material,
    positions: np.ndarray,
    width: float,
    n_grid: int,
    seconds: float,
    youngs: float,
    poisson: float,
    density: float = 1000.0,
    floor: Wall | WallKind = "sticky",
    cfl: float = 0.4,
    frames: int = 50,
    domain: tuple[float, float] = (1.0, 0.5),
    dtype=jnp.float32,
) -> Collapse:
    """Release particles of `material` at `positions` (2 x 2 per cell; `column`, `wedge`) in a 2D
    box of `domain` (metres; `n_grid` cells per metre) and follow them for `seconds`; `width` is
    the body's initial extent from the left wall (where `Collapse.height` is measured)."""
    dx = 1.0 / n_grid
    grid = tuple(int(round(side / dx)) for side in domain)
    wall = THICKNESS * dx
    x = positions
    n = len(x)
    design = Design.uniform(n, youngs, poisson, density, [], dtype)
    body = Body(
        volume=jnp.full((n,), (dx / 2) ** 2, dtype),
        actuator=jnp.full((n,), -1, jnp.int32),
        fiber=jnp.zeros((0, 2), dtype),
        pinned=jnp.zeros((n,), bool),
    )
    mu, lam = (float(p[0]) for p in design.lame())
    dt = cfl * dx / math.sqrt((lam + 2 * mu) / density)
    config = SimConfig(
        grid,
        dx,
        dt,
        (0.0, -GRAVITY),
        boundary=Boundary.box(2, floor=floor, sides="slip", thickness=THICKNESS),
        materials=(material,),
    )
    steps = max(int(round(seconds / dt / frames)), 1)

    def observe(state: SimState):
        kinetic = 0.5 * jnp.mean(jnp.sum(state.v * state.v, axis=-1))
        return jnp.percentile(state.x[:, 0], 99.5), kinetic, jnp.mean(jnp.linalg.det(state.F))

    rollout = jax.jit(
        make_rollout(config, body, lambda p, s, g: jnp.zeros((0,), dtype), steps, observe=observe)
    )
    state = SimState.at_rest(jnp.asarray(x, dtype))
    fronts, kinetic, volume = [], [], []
    for _ in range(frames):
        state, trajectory = rollout(None, design, state)
        front, energy, ratio = trajectory.observations
        fronts.append(float(front[-1]) - wall)
        kinetic.append(float(energy[-1]))
        volume.append(float(ratio[-1]))
    positions = np.asarray(state.x, np.float64)
    near_wall = positions[:, 0] < wall + width
    top = float(np.percentile(positions[near_wall, 1], 99.5)) - wall if near_wall.any() else 0.0
    return Collapse(
        times=np.arange(1, frames + 1) * steps * dt,
        fronts=np.asarray(fronts),
        runout=fronts[-1],
        height=top,
        kinetic=np.asarray(kinetic),
        positions=positions,
        volume=np.asarray(volume),
    )


def dam_break(
    width: float = 0.1,
    aspect: float = 2.0,
    n_grid: int = 64,
    seconds: float | None = None,
    bulk_modulus: float = 1e6,
    frames: int = 40,
    dtype=jnp.float32,
) -> Collapse:
    """A water column `width` (a) wide and `aspect * width` high released against the left wall (slip
    walls, as the experiment's smooth tank). Water of density 1000 with a bulk modulus well below
    the real one (2.2e9 Pa), a weakly compressible fluid's usual choice: its sound speed
    sqrt(K / rho) must stay several times the surge's speed (about 2 sqrt(g H)).

    `seconds` defaults to T = 3.4 in Martin & Moyce's time (`martin_moyce_time`).
    """
    seconds = seconds if seconds is not None else 3.4 / math.sqrt(aspect * GRAVITY / width)
    # Poisson's ratio 0: the bulk modulus lambda + mu (2D) equals E / 2.
    return release(
        Fluid(),
        column(width, aspect * width, n_grid),
        width,
        n_grid,
        seconds,
        youngs=2 * bulk_modulus,
        poisson=0.0,
        floor="slip",
        frames=frames,
        dtype=dtype,
    )


def martin_moyce_time(times, width: float, aspect: float) -> np.ndarray:
    """Martin & Moyce's nondimensional time T = n t sqrt(g / a) of a column a wide and n^2 a high
    (n^2 = `aspect`): t sqrt(2 g / a) for their Table 2's column, t sqrt(g / a) for the square one.
    With n in it, the shallow-water (Ritter) front is Z = 1 + 2 T for every column."""
    return np.asarray(times) * math.sqrt(aspect * GRAVITY / width)


# Martin & Moyce (1952), Phil. Trans. R. Soc. A 244, 312-324, Table 2: the surge front of a water
# column n^2 = 2 (a = 2.25 in) as Z = z / a against T = t sqrt(2 g / a). Transcribed from the
# copies in open-source solvers' validation scripts (Lethe, NGA2, Ocellaris), which agree to 0.01.
MARTIN_MOYCE_TABLE_2 = (
    (0.41, 1.11),
    (0.84, 1.22),
    (1.19, 1.44),
    (1.43, 1.67),
    (1.63, 1.89),
    (1.83, 2.11),
    (1.98, 2.33),
    (2.20, 2.56),
    (2.32, 2.78),
    (2.51, 3.00),
    (2.65, 3.22),
    (2.83, 3.44),
    (2.98, 3.67),
    (3.11, 3.89),
    (3.33, 4.11),
)


def lube_runout(aspect: float) -> tuple[float, float]:
    """(L_inf - L0) / L0 of a quasi-2D granular column collapse by Lube et al. (2005, Phys. Rev. E
    72, 041301) as a range: 1.2 a for a < 1.8, 1.9 a^(2/3) for a > 2.8; in the transition
    between them, the range the two fits span (they published no law there)."""
    if aspect < 1.8:
        return 1.2 * aspect, 1.2 * aspect
    if aspect > 2.8:
        return 1.9 * aspect ** (2 / 3), 1.9 * aspect ** (2 / 3)
    fits = sorted((1.2 * aspect, 1.9 * aspect ** (2 / 3)))
    return fits[0], fits[1]


def sand_wedge(
    angle: float,
    friction_angle: float = 30.0,
    base: float = 0.4,
    n_grid: int = 64,
    seconds: float = 0.5,
    youngs: float | None = None,
    dtype=jnp.float32,
) -> Collapse:
    """A sand heap's half (`wedge`) whose surface slopes at `angle` degrees, left under gravity for
    `seconds`: below the angle of repose it stands, above it the surface avalanches. `youngs`
    (None: its weight strains it by `SAND_STRAIN_UNDER_WEIGHT`)."""
    height = base * math.tan(math.radians(angle))
    return _release_sand(
        friction_angle,
        wedge(base, angle, n_grid),
        base,
        height,
        n_grid,
        seconds,
        youngs,
        10,
        (1.0, 0.5),
        dtype,
    )


def deposit_front(positions: np.ndarray, dx: float, thickness: float, wall: float = THICKNESS) -> float:
    """The run-out of a deposit (its distance from the left wall's face) to where it thins below
    `thickness`: the end of the first stretch of cell columns, from the wall on, whose highest
    particle lies `thickness` or more above the floor (the lone grains beyond it do not count)."""
    floor = wall * dx
    columns = np.floor(positions[:, 0] / dx).astype(int)
    first = int(np.floor(floor / dx))
    tops = np.full(columns.max() + 1, -np.inf)
    np.maximum.at(tops, columns, positions[:, 1])
    thick = tops[first:] - floor >= thickness
    end = int(np.argmin(thick)) if not thick.all() else len(thick)
    return end * dx + first * dx - floor


def deposit_slope(positions: np.ndarray, dx: float, wall: float = THICKNESS) -> float:
    """The angle (degrees) of a deposit's free surface: a line fitted to the surface heights (the
    highest particle per cell column) where the surface lies between 20% and 80% of its height."""
    inside = positions[:, 0] > wall * dx
    x, y = positions[inside, 0], positions[inside, 1]
    columns = np.floor(x / dx).astype(int)
    order = np.unique(columns)
    surface = np.array([y[columns == c].max() for c in order])
    centers = (order + 0.5) * dx
    low, high = wall * dx, surface.max()
    span = high - low
    keep = (surface > low + 0.2 * span) & (surface < low + 0.8 * span)
    if keep.sum() < 3:
        return float("nan")
    slope = np.polyfit(centers[keep], surface[keep], 1)[0]
    return float(np.degrees(np.arctan(abs(slope))))


def granular_collapse(
    aspect: float,
    width: float = 0.1,
    n_grid: int = 64,
    friction_angle: float = 30.0,
    seconds: float | None = None,
    youngs: float | None = None,
    frames: int = 40,
    dtype=jnp.float32,
) -> Collapse:
    """A sand column `width` (L0) wide and `aspect * width` (H0) high released against the left
    wall on a sticky (rough) floor, as the channel experiments' rough base. Density 1500 kg/m^3;
    `youngs` (None: the column's weight strains it by `SAND_STRAIN_UNDER_WEIGHT`).

    `seconds` defaults to long enough to come to rest: 4 free-fall times of the column plus 0.3 s.
    """
    height = aspect * width
    seconds = seconds if seconds is not None else 4 * math.sqrt(2 * height / GRAVITY) + 0.3
    # Room for twice Lube's run-out (plane-strain simulations run further than channel experiments).
    length = max(1.0, width * (1 + 2 * lube_runout(aspect)[1]) + 0.1)
    domain = (math.ceil(length * 4) / 4, max(0.5, math.ceil((height + 0.1) * 4) / 4))
    return _release_sand(
        friction_angle,
        column(width, height, n_grid),
        width,
        height,
        n_grid,
        seconds,
        youngs,
        frames,
        domain,
        dtype,
    )


def _release_sand(friction_angle, positions, width, height, n_grid, seconds, youngs, frames, domain, dtype):
    """`release` of sand on a sticky (rough) floor, `youngs` None: its weight (`height` tall)
    strains it by `SAND_STRAIN_UNDER_WEIGHT`."""
    return release(
        Sand(friction_angle),
        positions,
        width,
        n_grid,
        seconds,
        youngs=youngs or SAND_DENSITY * GRAVITY * height / SAND_STRAIN_UNDER_WEIGHT,
        poisson=0.3,
        density=SAND_DENSITY,
        floor="sticky",
        frames=frames,
        domain=domain,
        dtype=dtype,
    )

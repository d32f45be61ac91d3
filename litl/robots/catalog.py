"""The paper's robots (Figs. 4 and 6), built from shapes, a PNG image and 3D primitives.

Every robot is defined in physical units (2D domain 1 x 1, 3D domain 2 x 1 x 1, axis 1 up) and
sampled at a grid spacing `dx` (2 particles per cell per axis). The time step follows dx and the
material so that the stiffest allowed design keeps the same CFL number (`Material.time_step`), and
a rollout lasts the same simulated time at any resolution: refine dx for paper-scale runs,
coarsen it for quick ones.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from importlib import resources
from typing import Any

import numpy as np

from litl.errors import UserError
from litl.robots.image import layout_from_png, layout_from_voxels
from litl.robots.robot import Material, Robot, place
from litl.robots.shapes import Box, Ellipse, Extrusion, Part, Polygon, sample_parts
from litl.robots.tasks import Locomotion, Reach, Task
from litl.sim import Boundary, SimConfig, SimConfigError
from litl.sim.materials import Elastic

GRAVITY = 3.8
UP = (0.0, 1.0)


class UnknownRobotError(UserError, KeyError):
    """No robot is registered under that name."""

    def __str__(self):
        return str(self.args[0])


@dataclasses.dataclass(frozen=True)
class Entry:
    """How to build one registered robot."""

    build: Callable[[float], Robot]
    dim: int
    default_dx: float
    summary: str


# The coarsest grid spacing the robots fit in (16 cells across the unit domain).
MAX_DX = 1 / 16
# Each dimension's default grid spacing (the paper-scale resolution).
PAPER_DX = {2: 1 / 128, 3: 1 / 32}


def simulation(
    dim: int, dx: float, duration: float, gravity: float = GRAVITY, material: Material = Material()
):
    """(SimConfig, steps) for the standard domain at spacing dx, with the time step of the
    stiffest design `material` allows (`Material.time_step`) and its strain limit."""
    extent = (1.0, 1.0) if dim == 2 else (2.0, 1.0, 1.0)
    if isinstance(dx, bool) or not isinstance(dx, (int, float)) or not 0 < dx <= MAX_DX:
        raise SimConfigError(
            f"dx={dx!r} is not a usable grid spacing: it must be positive and at most 1/16 "
            f"(16 cells across the unit domain; coarser grids cannot hold the robots), e.g. "
            f"robot.dx=0.03125 (1/32), 0.015625 (1/64) or 0.0078125 (1/128)"
        )
    cells = [e / dx for e in extent]
    if any(abs(c - round(c)) > 1e-6 for c in cells):
        raise SimConfigError(
            f"dx={dx!r} must divide the domain {extent} into whole cells, e.g. 1/32, 1/64 or 1/128"
        )
    dt = material.time_step(dx)
    up = np.zeros(dim)
    up[1] = -gravity
    config = SimConfig(
        grid_shape=tuple(int(round(c)) for c in cells),
        dx=dx,
        dt=dt,
        gravity=tuple(up),
        boundary=Boundary.box(dim, thickness=3),
        materials=(Elastic(max_stretch=material.stretch_limit),),
    )
    return config, max(int(round(duration / dt)), 1)


def from_image(path, dx: float, legend=None, width: float | None = None, name: str | None = None) -> Robot:
    """A 2D robot from a drawing (`litl.robots.image`): its legend `legend`, or the one beside it
    (``<path>.json``, as `litl.robots.image.write_png` writes it), or litl's palette; `width`,
    its length along x, or the legend's note ``_width``. A ``.npz`` file is a 3D robot's voxels
    (`litl.robots.image.write_voxels`), its particles as saved. It walks along x
    (`Locomotion`) for 1 s.

    Raises:
      LayoutError: an unreadable drawing or legend, or no width given or noted.
    """
    import json
    import pathlib

    from litl.robots.layout import LayoutError

    path = pathlib.Path(path)
    if path.suffix == ".npz":  # a 3D robot's voxels (`litl.robots.image.write_voxels`)
        config, steps = simulation(3, dx, duration=1.0)
        return Robot(
            name or path.stem,
            place(layout_from_voxels(path), config, x=start_x(dx)),
            config,
            task=Task(Locomotion()),
            steps=steps,
            description=f"3D robot from the voxels in {path.name}. Task: run along x.",
        )
    beside = path.with_suffix(".json")
    if legend is None and beside.is_file():
        legend = beside
    if width is None and legend is not None:
        try:
            noted = json.loads(pathlib.Path(legend).read_text()).get("_width")
        except (OSError, ValueError, AttributeError):
            noted = None
        width = float(noted) if noted is not None else None
    if width is None:
        raise LayoutError(
            f"robot.image={path}: how long is the robot along x? set robot.width=<length> (e.g. "
            f"0.3 of the unit domain); a legend written by litl notes it as _width"
        )
    config, steps = simulation(2, dx, duration=1.0)
    layout = layout_from_png(path, width=width, dx=dx, legend=legend)
    return Robot(
        name or path.stem,
        place(layout, config, x=start_x(dx)),
        config,
        task=Task(Locomotion()),
        steps=steps,
        description=f"2D robot drawn in {path.name}, {width:g} wide. Task: run right.",
    )


def start_x(dx: float) -> float:
    """Left edge of a walker: 0.1, or one cell clear of the 3-cell side wall on coarse grids."""
    return max(0.1, 4.5 * dx)


def _legged_2d(torso, legs, torso_regions=2):
    """Parts of a 2D walker: a torso box split in `torso_regions` design regions along x, and legs.

    Each leg (x, width, height) gets two actuators (its front and back halves, fibers vertical) and
    its own design region.
    """
    (x0, y0), (w, h) = torso
    parts = [
        Part(Box((x0 + i * w / torso_regions, y0), (w / torso_regions, h)), region=i)
        for i in range(torso_regions)
    ]
    for k, (x, width, height) in enumerate(legs):
        region = torso_regions + k
        for half in range(2):
            parts.append(
                Part(
                    Box((x + half * width / 2, y0 - height), (width / 2, height)),
                    actuator=2 * k + half,
                    fiber=UP,
                    region=region,
                )
            )
    return parts


def biped(dx: float) -> Robot:
    config, steps = simulation(2, dx, duration=1.0)
    parts = _legged_2d(torso=((0.0, 0.12), (0.24, 0.08)), legs=[(0.0, 0.06, 0.12), (0.18, 0.06, 0.12)])
    return Robot(
        "biped",
        place(sample_parts(parts, dx), config, x=start_x(dx)),
        config,
        task=Task(Locomotion()),
        steps=steps,
        description=(
            "2D biped (Fig. 4b): torso 0.24 x 0.08 on two legs 0.06 x 0.12, each leg two vertical "
            "actuators (front/back half), 4 actuators; 4 design regions (torso front/back, each leg) "
            "for co-design of Young's modulus in [15, 30]. Task: run right (centroid distance), 1 s."
        ),
    )


ARM: dict[str, Any] = dict(
    width=0.08, length=0.24, segments=3, strength=1.5, duration=1.0, target=(0.1, -0.02)
)


def arm(dx: float) -> Robot:
    width, length, segments = ARM["width"], ARM["length"], ARM["segments"]
    material = Material(actuator_strength=ARM["strength"])
    config, steps = simulation(2, dx, duration=ARM["duration"], gravity=0.0, material=material)
    base_x = 0.5 - width / 2
    parts = [Part(Box((base_x - 0.03, 0.0), (width + 0.06, 0.04)), pinned=True, region=0)]
    segment = length / segments
    for s in range(segments):
        y = 0.04 + s * segment
        for side in range(2):
            parts.append(
                Part(
                    Box((base_x + side * width / 2, y), (width / 2, segment)),
                    actuator=2 * s + side,
                    fiber=UP,
                    region=1 + s,
                )
            )
    parts.append(Part(Box((base_x, 0.04 + length - 0.04), (width, 0.04)), groups=("tip",)))
    layout = place(sample_parts(parts, dx), config)
    tip = layout.positions[layout.groups["tip"]].mean(axis=0)
    target = tuple(tip + np.asarray(ARM["target"]))
    return Robot(
        "arm",
        layout,
        config,
        material=material,
        task=Task(Reach("tip", target)),
        steps=steps,
        description=(
            f"2D arm (Fig. 4a): a {width} x {length} column on a pinned base, no gravity; "
            f"{segments} segments with a left and a right vertical actuator each "
            f"({2 * segments} actuators, strength {ARM['strength']}). Task: at the end of "
            f"{ARM['duration']} s the centroid of the top 0.04 ('tip') must be at a point "
            f"{ARM['target'][0]} right of and {-ARM['target'][1]} below its rest position; the "
            f"actuators cannot bend it there statically, so it must swing."
        ),
    )


def elephant(dx: float) -> Robot:
    config, steps = simulation(2, dx, duration=1.0)
    parts = _legged_2d(torso=((0.0, 0.12), (0.26, 0.12)), legs=[(0.0, 0.06, 0.12), (0.18, 0.06, 0.12)])
    # Head and trunk overlap the torso's front region and share it (the elephant is pure control).
    head = Part(Ellipse((0.29, 0.21), (0.06, 0.05)), region=1)
    trunk = [
        Part(Box((0.31, 0.06 + 0.04 * i), (0.03, 0.04)), actuator=4 + i, fiber=UP, region=1) for i in range(3)
    ]
    tip = Part(Box((0.31, 0.06), (0.03, 0.03)), groups=("trunk_tip",))
    layout = place(sample_parts(parts + [head, *trunk, tip], dx), config, x=start_x(dx))
    tip_at = layout.positions[layout.groups["trunk_tip"]].mean(axis=0)
    target = (tip_at[0] + 0.25, tip_at[1] + 0.12)
    task = Task((Locomotion(weight=1.0), Reach("trunk_tip", target, weight=10.0)))
    return Robot(
        "elephant",
        layout,
        config,
        task=task,
        steps=steps,
        description=(
            "2D 'elephant' (Fig. 4c): torso 0.26 x 0.12 on two legs (two actuators each), an "
            "elliptic head and a 0.03-wide trunk of three actuated segments (7 actuators, 4 "
            "regions: torso back, torso front with head and trunk, legs). Task: walk right (weight 1) "
            "while the trunk tip ('trunk_tip') reaches a point 0.25 right of and 0.12 above its start "
            "(squared distance, weight 10)."
        ),
    )


def bunny(dx: float) -> Robot:
    config, steps = simulation(2, dx, duration=1.0)
    parts = _legged_2d(torso=((0.0, 0.1), (0.22, 0.1)), legs=[(0.0, 0.07, 0.1), (0.15, 0.07, 0.1)])
    # Head and ears overlap the torso's front region and share it; the arms only touch it.
    head = Part(Ellipse((0.24, 0.23), 0.05), region=1)
    ears = [Part(Ellipse((0.22 + 0.035 * i, 0.3), (0.012, 0.045)), region=1) for i in range(2)]
    arms = []
    for i, (name, y) in enumerate((("left_hand", 0.15), ("right_hand", 0.11))):
        arms.append(Part(Box((0.22, y), (0.08, 0.025)), actuator=4 + i, fiber=(1.0, 0.0), region=4))
        arms.append(Part(Box((0.27, y), (0.03, 0.025)), groups=(name,)))
    layout = place(sample_parts(parts + [head, *ears, *arms], dx), config, x=start_x(dx))
    targets = {}
    for name, lift in (("left_hand", 0.15), ("right_hand", 0.05)):
        at = layout.positions[layout.groups[name]].mean(axis=0)
        targets[name] = (at[0] + 0.2, at[1] + lift)
    task = Task(
        (Locomotion(weight=1.0), *(Reach(name, target, weight=5.0) for name, target in targets.items()))
    )
    return Robot(
        "bunny",
        layout,
        config,
        task=task,
        steps=steps,
        description=(
            "2D 'bunny' (Fig. 4d): torso 0.22 x 0.1 on two legs (two actuators each), round head "
            "with two ears, two forward arms 0.08 x 0.025 with a horizontal actuator each (6 "
            "actuators, 5 regions: torso back/front with head, legs, arms). Task: walk forward "
            "(weight 1) while the two hands ('left_hand', 'right_hand') reach points 0.2 ahead and "
            "0.15 / 0.05 higher (weight 5 each)."
        ),
    )


RHINO_WIDTH = 0.36


def rhino(dx: float) -> Robot:
    config, steps = simulation(2, dx, duration=1.0)
    data = resources.files("litl.robots") / "data"
    layout = layout_from_png(data / "rhino.png", width=RHINO_WIDTH, dx=dx, legend=data / "rhino.json")
    return Robot(
        "rhino",
        place(layout, config, x=start_x(dx)),
        config,
        task=Task(Locomotion()),
        steps=steps,
        description=(
            f"2D rhino (Fig. 6), read from the package's rhino.png with its legend rhino.json, "
            f"scaled to {RHINO_WIDTH} wide: body, horn, four legs with two actuators each "
            f"(8 actuators). Task: run right."
        ),
    )


def _legs_3d(positions, width, depth, height, first_actuator, first_region):
    """Box legs below y = 0 at (x, z) corners, each split into front/back actuated halves."""
    parts = []
    for k, (x, z) in enumerate(positions):
        for half in range(2):
            parts.append(
                Part(
                    Box((x + half * width / 2, -height, z), (width / 2, height, depth)),
                    actuator=first_actuator + 2 * k + half,
                    fiber=(0.0, 1.0, 0.0),
                    region=first_region + k,
                )
            )
    return parts


# The 3D walkers' torsos span their legs like plates on four (six) posts: at the 2D robots' E = 20
# their middles sagged under gravity to the floor within 1 s, passively (torso mid-bottom 0.060 above
# the floor on average over 0.5-1 s, touching it after the first landing). Twice the stiffness
# halves the sag (0.083, never below 0.041); twice the actuator strength keeps the actuation strain.
# The 3D walkers are purely elastic (max_stretch inf): no 3D rollout has blown up the way a torn
# 2D leg particle did at dx 1/128, and on XLA:CPU the strain limit costs the 3D step far more than
# the 2D one (benchmarks/sim_speed.py quadruped3d: forward+backward 16.6 s -> 24.0 s, against
# +10% for the 2D walker). `robot.material.max_stretch=3` turns it on.
WALKER_3D_MATERIAL = Material(
    youngs_modulus=40.0, youngs_modulus_bounds=(30.0, 60.0), actuator_strength=6.0, max_stretch=math.inf
)
# The curved quadruped's arch resists its legs splaying only by bending: at E 30-60 the learned
# controller flattened it and the body stretched forward (0.19 per second, feet creeping, slip
# 0.25-0.43); at E 40-100, actuator strength 9 (the same actuation strain) the arch held and it
# bounded 0.29 per second, feet lifted 62-79% (docs/results/2026-11-26-curved-quadruped.md).
CURVED_3D_MATERIAL = Material(
    youngs_modulus=60.0, youngs_modulus_bounds=(40.0, 100.0), actuator_strength=9.0, max_stretch=math.inf
)


def _walker_3d(name, dx, torso_parts, leg_xs, width, leg, description, material=WALKER_3D_MATERIAL):
    config, steps = simulation(3, dx, duration=1.0, material=material)
    leg_w, leg_h = leg
    corners = [(x, z) for x in leg_xs for z in (0.0, width - leg_w)]
    parts = torso_parts + _legs_3d(corners, leg_w, leg_w, leg_h, 0, 1)
    layout = place(sample_parts(parts, dx), config, x=max(0.2, start_x(dx)))
    return Robot(
        name, layout, config, material=material, task=Task(Locomotion()), steps=steps, description=description
    )


def quadruped(dx: float) -> Robot:
    length, width = 0.4, 0.2
    torso = [Part(Box((0.0, 0.0, 0.0), (length, 0.08, width)), region=0)]
    return _walker_3d(
        "quadruped",
        dx,
        torso,
        (0.0, length - 0.08),
        width,
        (0.08, 0.1),
        "3D quadruped (Fig. 6): torso 0.4 x 0.08 x 0.2 on four 0.08 x 0.1 x 0.08 legs, each with "
        "front/back vertical actuators (8 actuators). Task: run toward +x.",
    )


def curved_quadruped(dx: float) -> Robot:
    length, width = 0.44, 0.2
    # Side view of an arched back: the band between two elliptic arcs, extruded across the width.
    angles = np.linspace(0.0, np.pi, 24)
    outer = np.column_stack([length / 2 * (1 - np.cos(angles)), 0.14 * np.sin(angles)])
    inner = np.column_stack(
        [length / 2 + (length / 2 - 0.08) * -np.cos(angles[::-1]), 0.06 * np.sin(angles[::-1])]
    )
    arch = Polygon(tuple(map(tuple, np.concatenate([outer, inner]))))
    head = Ellipse((length, 0.09, width / 2), (0.06, 0.05, 0.06))
    torso = [Part(Extrusion(arch, 0.0, width), region=0), Part(head, region=0)]
    return _walker_3d(
        "curved_quadruped",
        dx,
        torso,
        (0.0, length - 0.08),
        width,
        (0.08, 0.08),
        "3D curved quadruped (Fig. 6): an arched back (a 0.44-long band between two elliptic arcs, "
        "0.14 high, extruded 0.2 across) with a round head, standing on four 0.08 x 0.08 x 0.08 "
        "legs with front/back actuators (8 actuators); E 60 in [40, 100], actuator strength 9. "
        "Task: run toward +x.",
        material=CURVED_3D_MATERIAL,
    )


def hexapod(dx: float) -> Robot:
    length, width = 0.5, 0.2
    torso = [Part(Box((0.0, 0.0, 0.0), (length, 0.07, width)), region=0)]
    return _walker_3d(
        "hexapod",
        dx,
        torso,
        (0.0, (length - 0.07) / 2, length - 0.07),
        width,
        (0.07, 0.09),
        "3D hexapod (Fig. 6): torso 0.5 x 0.07 x 0.2 on six 0.07 x 0.09 x 0.07 legs, three per "
        "side, each with front/back vertical actuators (12 actuators). Task: run toward +x.",
    )


ROBOTS: dict[str, Entry] = {
    "arm": Entry(arm, 2, PAPER_DX[2], "2D arm with a pinned base reaching a target by swinging"),
    "biped": Entry(biped, 2, PAPER_DX[2], "2D biped running right; co-design of 4 regions"),
    "elephant": Entry(elephant, 2, PAPER_DX[2], "2D elephant walking right while its trunk reaches"),
    "bunny": Entry(bunny, 2, PAPER_DX[2], "2D bunny walking while two hands reach two targets"),
    "rhino": Entry(rhino, 2, PAPER_DX[2], "2D rhino from a PNG, running right"),
    "quadruped": Entry(quadruped, 3, PAPER_DX[3], "3D quadruped running toward +x"),
    "curved_quadruped": Entry(curved_quadruped, 3, PAPER_DX[3], "3D arched quadruped running toward +x"),
    "hexapod": Entry(hexapod, 3, PAPER_DX[3], "3D hexapod running toward +x"),
}


def register(
    name: str,
    build: Callable[[float], Robot],
    dim: int,
    default_dx: float | None = None,
    summary: str = "",
    replace: bool = False,
) -> None:
    """Make a robot of your own reachable as `litl.robots.get(name)` and from the CLI.

    From the CLI, name the module that calls `register` (importable from the working directory
    or installed): ``python -m litl robot.name=<name> robot.module=<module>``.

    Args:
      name: the robot's name.
      build: ``build(dx) -> Robot`` at grid spacing dx (the catalog's `simulation(dim, dx,
        duration)` gives its domain, time step and walls).
      dim: 2 or 3.
      default_dx: grid spacing of `get(name)` without dx (default: 1/128 in 2D, 1/32 in 3D, the
        catalog's paper resolutions).
      summary: a one-line description.
      replace: allow replacing a robot of the same name (e.g. re-running a notebook cell).

    Raises:
      ValueError: an empty name, a name already taken (without `replace`), a `build` that is not
        callable, or `dim` not 2 or 3.
    """
    if not isinstance(name, str) or not name.strip():
        raise ValueError(f"a robot's name must be a non-empty string, got {name!r}")
    if name in ROBOTS and not replace:
        raise ValueError(
            f"a robot named {name!r} is already registered; choose another name or pass replace=True"
        )
    if not callable(build):
        raise ValueError(f"build must be a function build(dx) -> Robot, got {build!r}")
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got {dim!r}")
    dx = default_dx if default_dx is not None else PAPER_DX[dim]
    ROBOTS[name] = Entry(build, dim, dx, summary)


def names() -> list[str]:
    """Names of the registered robots."""
    return sorted(ROBOTS)


def get(name: str, dx: float | None = None) -> Robot:
    """The registered robot `name`, sampled at grid spacing `dx` (default: the robot's own).

    Raises:
      UnknownRobotError: for an unknown name (the message lists the known ones).
    """
    if name not in ROBOTS:
        raise UnknownRobotError(
            f"unknown robot {name!r}; choose one of {names()} (or register "
            f"your own with litl.robots.register)"
        )
    entry = ROBOTS[name]
    return entry.build(entry.default_dx if dx is None else dx)

"""Worlds: the ground a robot walks on, as colliders added to its scene (`litl.sim.colliders`).

A world is terrain ahead of the robot, starting `gap` cells past its front (its largest x), so the
robot starts on the flat floor as in the empty box and meets the terrain when it walks:

* ``flat``: the empty box (no collider; today's scenes, bit for bit);
* ``slope``: the ground rises at `angle` degrees;
* ``steps``: stairs of `step_height` risers every `step_length` (each riser one cell wide);
* ``bumps``: a random piecewise-linear profile, heights in [0, `amplitude`] above the floor
  every `wavelength` / 2, drawn from `seed` (at least one grid cell: a lower bump holds no node
  the floor wall does not);
* ``sand``, ``water``: a layer `depth` deep on the whole floor, a second body of Drucker-Prager
  sand (`friction_angle`) or water (`litl.sim.materials`), `density` times the robot's; the robot
  starts on top of it (`bed`). Its observers see the robot's part of the grid unless
  `observe` is ``scene``;
* ``push_box``: an elastic box of side `box_size` on the floor `gap` cells ahead of the robot,
  `density` times the robot's; the task becomes the box's: the squared distance of its centroid to
  a target `push` ahead of its start (`litl.robots.tasks.Push`) at the end.

In 3D the profile is the same for every z. The terrain's contact is `contact` (sticky, as the
catalog's floors, slip or friction with coefficient `friction`). Its flat part lies under the
box's floor wall (it holds the same grid nodes), so only the terrain ahead adds contact. The robot
keeps its own task (distance along x, which on a slope is the distance along it times cos θ),
except in push_box.

`with_world(robot, world)` returns the robot in that world (idempotent); the command line's
`world=` group and `litl.loop.run` call it with `Config.world`.
"""

from __future__ import annotations

import dataclasses
import json
import math
from typing import Any

import numpy as np

from litl.robots.robot import Robot
from litl.robots.scenery import Scenery
from litl.robots.tasks import Push, Task
from litl.sim.colliders import Collider, HeightField
from litl.sim.config import SimConfigError, Wall
from litl.sim.materials import Elastic, Fluid, Sand
from litl.sim.sampling import sample_box


def terrain(world, robot: Robot) -> tuple[Collider, ...]:
    """The colliders of `world` (a `litl.config.WorldConfig`) in front of `robot`."""
    kind = str(getattr(world.kind, "value", world.kind))
    if kind in ("flat", "sand", "water", "push_box"):
        return ()
    config = robot.config
    assert config.boundary is not None  # SimConfig sets the default box
    dx, length = config.dx, config.domain_size[0]
    floor = (config.boundary.thickness - 2) * dx  # with a one-cell band: the floor wall's nodes
    start = float(robot.layout.bounds()[1][0]) + world.gap * dx
    if start >= length - 4 * dx:
        raise SimConfigError(
            f"world={kind}: the robot's front is at x = {start - world.gap * dx:.3g}, which leaves no room "
            f"for terrain in a domain {length:.3g} long; use a smaller world.gap or another robot"
        )
    xs, heights = [0.0, start], [floor, floor]
    if kind == "slope":
        xs.append(length)
        heights.append(floor + (length - start) * math.tan(math.radians(world.angle)))
    elif kind == "steps":
        x, height = start, floor
        while x + dx < length:
            height += world.step_height
            xs += [x + dx]
            heights += [height]
            x += world.step_length
            xs += [min(x, length)]
            heights += [height]
    elif kind == "bumps":
        if world.amplitude < dx:
            # A bump acts on the nodes within one cell of its surface: one lower than a cell above
            # the floor holds no node the floor wall does not already hold.
            raise SimConfigError(
                f"world.amplitude={world.amplitude:g} is below one grid cell (dx = {dx:g}): bumps that "
                f"low hold no grid node above the floor wall, so the robot would walk on the flat "
                f"box; use world.amplitude >= {dx:g}"
            )
        rng = np.random.default_rng(world.seed)
        x = start
        while x < length:
            x = min(x + world.wavelength / 2, length)
            xs.append(x)
            heights.append(floor + world.amplitude * float(rng.uniform()))
    else:
        raise SimConfigError(
            f"world.kind={kind!r}: unknown world; choose one of flat, slope, steps, bumps, sand, water, "
            f"push_box"
        )
    top = config.domain_size[1] - (config.boundary.thickness + 2) * dx
    if max(heights) > top:
        raise SimConfigError(
            f"world={kind}: its terrain reaches y = {max(heights):.3g}, above the room under the "
            f"ceiling ({top:.3g}); use a smaller world.angle, world.step_height or world.amplitude"
        )
    contact = Wall(world.contact, world.friction if world.contact == "friction" else 0.0)
    return (Collider(HeightField(tuple(xs), tuple(heights), dim=robot.dim), contact),)


def bed(world, robot: Robot) -> Scenery:
    """The second body of a `sand` or `water` world: a layer `world.depth` deep on the whole floor
    (2 particles per cell per axis), of `world.density` times the robot's density. Its stiffness
    is set so that its P-wave speed equals the robot's fastest (`Material.max_wave_speed`): the
    robot's time step holds for it unchanged. (Sand that stiff is strained by its own weight by
    about 1.5% on the biped, the range `litl.sim.validation` found robust; water's sound speed is
    then about 10x the robots' walking speeds.)"""
    kind = str(getattr(world.kind, "value", world.kind))
    config = robot.config
    assert config.boundary is not None  # SimConfig sets the default box
    dx, dim = config.dx, config.dim
    wall = config.boundary.thickness * dx
    room = config.domain_size[1] - 2 * wall - (robot.layout.bounds()[1][1] - robot.layout.bounds()[0][1])
    if world.depth >= room - 2 * dx:
        raise SimConfigError(
            f"world.depth={world.depth:g}: a {kind} layer that deep leaves the robot no room under the "
            f"ceiling (at most {max(room - 2 * dx, 0):.3g} here); use a smaller world.depth"
        )
    if world.depth < dx:
        raise SimConfigError(
            f"world.depth={world.depth:g} is thinner than one grid cell (dx = {dx:g}); "
            f"use world.depth >= {dx:g}"
        )
    lower = [wall] * dim
    size = [length - 2 * wall for length in config.domain_size]
    size[1] = world.depth
    positions = sample_box(lower, size, dx, per_cell=2)
    density = world.density * robot.material.density
    speed = robot.material.max_wave_speed()
    if kind == "sand":
        nu = 0.3
        stiffness = (1 - nu) / ((1 + nu) * (1 - 2 * nu))  # (lambda + 2 mu) / E
        material: object = Sand(world.friction_angle)
    else:
        nu, stiffness, material = 0.0, 1.0, Fluid()
    return Scenery(
        name=kind,
        positions=positions,
        # The layer's volume shared by its particles: a depth that is not a whole number of cells
        # spaces the rows further apart than (dx / 2), and the density must still be the stated one.
        volume=float(np.prod(size)) / len(positions),
        material=material,
        youngs_modulus=density * speed * speed / stiffness,
        poisson_ratio=nu,
        density=density,
    )


def box(world, robot: Robot) -> tuple[Scenery, Task]:
    """The push_box world's box and the task of pushing it: an elastic cube (square in 2D) of side
    `world.box_size` on the floor, `world.gap` cells past the robot's front (centred on it in z),
    2 particles per cell per axis, `world.density` times the robot's density, as stiff as the
    robot's stiffest design allows (its P-wave speed the robot's fastest: dt unchanged), of the
    robot's elastic material (one material in the scene: the simulator's single-material step)."""
    config = robot.config
    assert config.boundary is not None  # SimConfig sets the default box
    dx, dim = config.dx, config.dim
    wall = config.boundary.thickness * dx
    low, high = robot.layout.bounds()
    lower = np.array(low, np.float64)
    lower[0] = high[0] + world.gap * dx + dx
    lower[1] = wall
    size = np.full(dim, float(world.box_size))
    if dim == 3:
        lower[2] = (low[2] + high[2] - world.box_size) / 2
    room = config.domain_size[0] - wall - 2 * dx
    if lower[0] + world.box_size > room or world.box_size < 2 * dx:
        raise SimConfigError(
            f"world.box_size={world.box_size:g}, world.gap={world.gap:g}: the box must be at least two "
            f"cells wide ({2 * dx:g}) and fit between the robot's front ({high[0]:.3g}) and the wall "
            f"({room:.3g}); choose a smaller box or gap"
        )
    if lower[0] + world.box_size + world.push > room:
        raise SimConfigError(
            f"world.push={world.push:g}: the target lies beyond the wall (the box would end at "
            f"{lower[0] + world.box_size + world.push:.3g}, the wall is at {room:.3g}); push it less far"
        )
    positions = sample_box(lower, size, dx, per_cell=2)
    density = world.density * robot.material.density
    speed, nu = robot.material.max_wave_speed(), 0.3
    stiffness = (1 - nu) / ((1 + nu) * (1 - 2 * nu))  # (lambda + 2 mu) / E
    body = Scenery(
        name="box",
        positions=positions,
        volume=float(np.prod(size)) / len(positions),
        material=Elastic(robot.config.constitutive_model, robot.config.max_stretch),  # the robot's
        youngs_modulus=density * speed * speed / stiffness,
        poisson_ratio=nu,
        density=density,
    )
    target = positions.mean(axis=0)
    target[0] += world.push
    return body, Task(Push("box", tuple(target)))


def sets_task(world) -> bool:
    """Whether `world` brings its own task in place of the robot's (push_box: push the box)."""
    return str(getattr(world.kind, "value", world.kind)) == "push_box"


def task_record(task: Task | None) -> list[dict[str, Any]]:
    """`task` as run.json records it: each term's kind and fields (none: no task)."""
    terms = task.terms if task is not None else ()
    return [
        {"term": type(term).__name__, **json.loads(json.dumps(dataclasses.asdict(term)))} for term in terms
    ]


def with_world(robot: Robot, world) -> Robot:
    """`robot` in `world` (a `litl.config.WorldConfig`): the world's terrain is added to its
    scene's colliders (after its own), or its sand or water under it (the robot lifted onto it);
    a robot already in it is returned as it is."""
    kind = str(getattr(world.kind, "value", world.kind))
    if kind in ("sand", "water"):
        if robot.scenery:
            return robot
        layer = bed(world, robot)
        lift = np.zeros(robot.dim)
        lift[1] = world.depth
        config = robot.config
        own = Elastic(config.constitutive_model, config.max_stretch)
        config = dataclasses.replace(config, materials=(own, layer.material))
        return dataclasses.replace(
            robot,
            layout=robot.layout.translated(lift),
            config=config,
            scenery=(layer,),
            observe_scenery=str(getattr(world.observe, "value", world.observe)) == "scene",
        )
    if kind == "push_box":
        if robot.scenery:
            return robot
        body, task = box(world, robot)
        config = robot.config
        own = Elastic(config.constitutive_model, config.max_stretch)
        config = dataclasses.replace(config, materials=(own,))  # the box is of the robot's material
        observe = str(getattr(world.observe, "value", world.observe)) == "scene"
        return dataclasses.replace(robot, config=config, scenery=(body,), task=task, observe_scenery=observe)
    colliders = terrain(world, robot)
    boundary = robot.config.boundary
    assert boundary is not None  # SimConfig sets the default box
    if not colliders or boundary.colliders[-len(colliders) :] == colliders:
        return robot
    boundary = dataclasses.replace(boundary, colliders=boundary.colliders + colliders)
    config = dataclasses.replace(robot.config, boundary=boundary)
    return dataclasses.replace(robot, config=config)

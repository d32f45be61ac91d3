"""The co-designed body beside the body as built (`draw_body`): what a design space changed.

A run with a body design space (``design=actuators|geometry|all``, `litl.designs`) writes it as
``body.png`` (`litl.viz.run_pictures.draw_run`); ``python -m litl.replay`` as
``<name>_design.png`` for every design space. Panels, left to right, each drawn by `draw_robot`
(`draw_robot_3d` in 3D) with every particle a square of its own size, the view fitted to the body:

* ``as built``: the robot's own body, each actuator in its colour, passive material grey;
* ``placement`` (``design=actuators``, ``all``): every particle in the colour of its strongest
  channel (the actuator, or the passive channel, that holds its largest logit), as transparent
  as it has lost material where the geometry is co-designed too;
* ``material`` (``design=geometry``): the robot's own actuators, each particle as opaque as its
  material (`litl.designs.BodySpace.density`: 1 kept, 0 removed);
* ``modulus`` (where the space co-designs it: ``design=modulus``, ``all``, ``.modulus=true``):
  the Young's modulus per region on ``viridis`` over the design bounds, with a colour bar.

A legend below the panels names every channel (``actuator 0`` ... ``actuator m-1``,
``passive``, ``pinned`` where the robot has pinned particles); its ``gid`` is ``"body_legend"``,
each panel's Axes carries its name as its ``gid``. Figures are bare matplotlib `Figure`s (not
pyplot's): saved with `path=` or ``figure.savefig``.
"""

from __future__ import annotations

import dataclasses
import pathlib
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from litl.robots.layout import Layout
from litl.viz.robots import PASSIVE_COLOR, PINNED_COLOR, actuator_colors, draw, particle_side

PANEL_WIDTH = 4.5  # inches per panel: at 100 dpi, 450 pixels, a particle of the rhino ~6 pixels


def body_parts(space, phi) -> dict[str, np.ndarray]:
    """What design φ of `space` changed, as drawn: ``channel`` (n,) each particle's strongest
    channel (its actuator, -1 passive) where the placement is co-designed, ``material`` (n,) in
    [0, 1] where the geometry is, ``modulus`` (R,) the Young's modulus per region where the
    modulus is (φ of the robot's own space, `litl.robots.design.DesignSpace`, is the modulus)."""
    if not isinstance(phi, dict):
        return {"modulus": np.asarray(phi, np.float64)}
    parts = {}
    if "placement" in phi:
        strongest = np.asarray(phi["placement"]).argmax(-1)
        parts["channel"] = np.where(strongest < space.n_actuators, strongest, -1).astype(np.int32)
    if "occupancy" in phi:
        parts["material"] = np.asarray(space.density(phi), np.float64)
    if "youngs_modulus" in phi:
        parts["modulus"] = np.asarray(phi["youngs_modulus"], np.float64)
    return parts


def body_panels(layout: Layout, parts: dict[str, np.ndarray], bounds) -> list[tuple[str, str, Layout, dict]]:
    """(name, title, layout, `draw_robot` keywords) of each panel that `parts` (`body_parts`) asks."""
    opacity = parts.get("material")
    panels: list[tuple[str, str, Layout, dict]] = [("as built", "as built", layout, {})]
    if "channel" in parts:
        placed = dataclasses.replace(layout, actuator=parts["channel"])
        moved = np.mean(parts["channel"] != layout.actuator)
        faded = ", faint: material removed" if opacity is not None else ""
        title = f"co-designed: strongest channel ({moved:.0%} moved){faded}"
        panels.append(("placement", title, placed, {"opacity": opacity}))
    elif opacity is not None:
        title = f"co-designed: material (opaque: kept; volume {opacity.mean():.2f})"
        panels.append(("material", title, layout, {"opacity": opacity}))
    if "modulus" in parts:
        modulus = parts["modulus"]
        values = f" [{', '.join(f'{v:.3g}' for v in modulus)}]" if len(modulus) <= 6 else ""
        coloring = {"stiffness": modulus, "stiffness_range": bounds, "colorbar": True, "opacity": opacity}
        panels.append(("modulus", f"co-designed: E per region{values}", layout, coloring))
    return panels


def draw_body(robot, phi, space=None, path=None, title: str | None = None) -> Figure:
    """The co-designed body (design φ of `space`) beside the body as built, with a legend.

    Args:
      robot: the `Robot` whose body was co-designed (2D or 3D).
      phi: its design φ, of one seed (a dict of the body's parts, or the modulus per region).
      space: the design space φ belongs to; None: the robot's (`Robot.design_space`).
      path: if given, save the figure there (100 dpi, at least 900 pixels wide: two panels).
      title: the figure's title; None: the robot's name.

    Returns:
      The figure, one Axes per panel (module docstring), each with its panel's name as gid.
    """
    space = robot.design_space if space is None else space
    layout = robot.layout
    panels = body_panels(layout, body_parts(space, phi), space.bounds)
    figure = _figure(layout, len(panels))
    for ax, (name, heading, drawn, keywords) in zip(figure.axes, panels, strict=True):
        ax.set_gid(name)
        draw(drawn, ax, show_targets=False, **keywords)
        ax.set_title(heading, fontsize=9)
    legend = figure.legend(
        handles=_legend_handles(layout), loc="lower center", ncol=min(layout.n_actuators + 2, 6), fontsize=9
    )
    legend.set_gid("body_legend")
    figure.suptitle(robot.name if title is None else title, fontsize=10)
    if path is not None:
        path = pathlib.Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        figure.savefig(path, dpi=100)
    return figure


def _figure(layout: Layout, panels: int) -> Figure:
    """A bare figure of `panels` Axes side by side, sized to the body's aspect, room for a legend."""
    extent = np.ptp(layout.positions, axis=0) + 2.0 * particle_side(layout)
    aspect = float(np.clip(extent[1] / extent[0], 0.3, 1.5))
    height = PANEL_WIDTH * aspect + 1.6
    figure = Figure(figsize=(PANEL_WIDTH * panels, height))
    FigureCanvasAgg(figure)
    keywords: dict[str, Any] = {"projection": "3d"} if layout.dim == 3 else {}
    for k in range(panels):
        figure.add_subplot(1, panels, k + 1, **keywords)
    width = PANEL_WIDTH * panels
    figure.subplots_adjust(
        left=0.7 / width, right=1.0 - 0.2 / width, bottom=1.0 / height, top=1.0 - 0.6 / height, wspace=0.3
    )
    return figure


def _legend_handles(layout: Layout) -> list[Patch]:
    """A patch per channel: each actuator's colour, passive grey, and pinned where there are any."""
    colours = actuator_colors(layout.n_actuators)
    handles = [Patch(color=colours[k], label=f"actuator {k}") for k in range(layout.n_actuators)]
    handles.append(Patch(color=PASSIVE_COLOR, label="passive"))
    if np.any(layout.pinned):
        handles.append(Patch(color=PINNED_COLOR, label="pinned"))
    return handles

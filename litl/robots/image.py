"""Robots from images: every pixel's colour says what the material there is.

Draw the robot's side view in any image editor with a hard-edged pencil (anti-aliasing invents
colours between two neighbours), save it as PNG, and map colours to roles with a legend.

Default palette (used when no legend is given; white and transparent pixels are always empty):

    #000000 black    passive body
    #808080 grey     pinned body (held fixed, e.g. an arm's base)
    #ff0000 red      actuator 0      #ff00ff magenta  actuator 3      #8000ff purple  actuator 6
    #0000ff blue     actuator 1      #00ffff cyan     actuator 4      #00ff00 green   actuator 7
    #ffff00 yellow   actuator 2      #ff8000 orange   actuator 5

Actuator fibers point up; design regions are 0 for passive pixels and 1 + k for actuator k.

A legend (a JSON file or a dict) replaces the palette. Keys are colours ``"#rrggbb"``, values say
what the colour is, with the keys ``actuator`` (id), ``fiber`` ([x, y]), ``region`` (id),
``groups`` (list of names) and ``pinned`` (bool); ``{}`` is passive body in region 0, and the
string ``"empty"`` marks a background colour; keys that start with ``_`` are notes, not colours
(`write_png` records the drawing's scale in ``_spacing`` and ``_width``):

    {"#000000": {}, "#ff0000": {"actuator": 0, "region": 1},
     "#00a000": {"groups": ["horn"]}, "#c0c0ff": "empty"}
"""

from __future__ import annotations

import json
import os
import pathlib
from collections.abc import Mapping
from typing import Any

import numpy as np

from litl.robots.layout import Layout, LayoutError
from litl.robots.shapes import LabelMerger, check_labels, lattice

ACTUATOR_COLOURS = ("#ff0000", "#0000ff", "#ffff00", "#ff00ff", "#00ffff", "#ff8000", "#8000ff", "#00ff00")
EMPTY_COLOURS = ("#ffffff",)
LEGEND_KEYS = {"actuator", "fiber", "region", "groups", "pinned"}


def default_legend() -> dict:
    """The default palette as a legend."""
    legend: dict[str, dict[str, Any]] = {"#000000": {}, "#808080": {"pinned": True}}
    for k, colour in enumerate(ACTUATOR_COLOURS):
        legend[colour] = {"actuator": k, "region": k + 1}
    return legend


def _colour(key) -> tuple[int, int, int]:
    text = str(key).strip().lower()
    if len(text) != 7 or text[0] != "#":
        raise LayoutError(f"legend colour {key!r} must be written '#rrggbb'")
    try:
        return int(text[1:3], 16), int(text[3:5], 16), int(text[5:7], 16)
    except ValueError:
        raise LayoutError(f"legend colour {key!r} is not hexadecimal '#rrggbb'") from None


def read_legend(legend) -> dict[tuple[int, int, int], dict | str]:
    """Parse a legend (path to JSON, or mapping) into {rgb: role}, checking every entry."""
    if legend is None:
        legend = default_legend()
    elif not isinstance(legend, Mapping):
        try:
            legend = json.loads(
                legend.read_text() if hasattr(legend, "read_text") else pathlib.Path(legend).read_text()
            )
        except (OSError, json.JSONDecodeError) as error:
            raise LayoutError(f"cannot read legend {legend}: {error}") from None
        if not isinstance(legend, dict):
            raise LayoutError('a legend file must hold a JSON object {"#rrggbb": {...}}')
    parsed: dict[tuple[int, int, int], dict | str] = {}
    for key, role in legend.items():
        if str(key).startswith("_"):  # a note (write_png records the drawing's scale so)
            continue
        rgb = _colour(key)
        if role == "empty":
            parsed[rgb] = "empty"
            continue
        if not isinstance(role, Mapping) or set(role) - LEGEND_KEYS:
            raise LayoutError(
                f'legend entry {key}: {role!r} must be "empty" or an object with keys from '
                f"{sorted(LEGEND_KEYS)}"
            )
        parsed[rgb] = dict(role)
    return parsed


def read_image(path) -> tuple[np.ndarray, np.ndarray]:
    """(H, W, 3) uint8 RGB and (H, W) bool opacity of an image file, row 0 at the top."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as image:
            rgba = np.asarray(image.convert("RGBA"))
    except FileNotFoundError:
        raise LayoutError(f"image file {os.fspath(path)!r} does not exist") from None
    except (UnidentifiedImageError, OSError) as error:
        raise LayoutError(f"{os.fspath(path)!r} is not a readable image (PNG expected): {error}") from None
    return rgba[..., :3], rgba[..., 3] >= 128


def layout_from_pixels(
    rgb, opaque, width: float, dx: float, legend=None, per_cell: int = 2, source: str = "image"
) -> Layout:
    """Layout from an RGB pixel array (H, W, 3), row 0 at the top; see `layout_from_png`."""
    roles = read_legend(legend)
    rgb = np.asarray(rgb, np.uint8)
    empty = ~np.asarray(opaque, bool)
    for written in EMPTY_COLOURS:
        empty |= np.all(rgb == _colour(written), axis=-1)
    for colour, role in roles.items():
        if role == "empty":
            empty |= np.all(rgb == colour, axis=-1)
    if empty.all():
        raise LayoutError(f"{source} has no robot pixels: everything is white, transparent or empty")
    rows, cols = np.nonzero(~empty)
    rgb, empty = (a[rows.min() : rows.max() + 1, cols.min() : cols.max() + 1] for a in (rgb, empty))
    known = np.zeros(empty.shape, bool)
    for colour in roles:
        known |= np.all(rgb == colour, axis=-1)
    unknown = ~empty & ~known
    if unknown.any():
        r, c = np.argwhere(unknown)[0]
        found = sorted({"#{:02x}{:02x}{:02x}".format(*p) for p in rgb[unknown]})
        raise LayoutError(
            f"{source}: {int(unknown.sum())} pixels have colours not in the legend, e.g. "
            f"{found[:5]} (first at row {r + rows.min()}, column {c + cols.min()}). Add them to the "
            f"legend, or repaint them with a palette colour (draw without anti-aliasing)."
        )
    if not (np.isfinite(width) and width > 0):
        raise LayoutError(f"the robot's width must be a positive length, got {width!r}")
    height_px, width_px = empty.shape
    pixel = width / width_px
    spacing = dx / per_cell
    points = lattice((0.0, 0.0), (width, height_px * pixel), spacing)
    column = np.minimum((points[:, 0] / pixel).astype(int), width_px - 1)
    row = height_px - 1 - np.minimum((points[:, 1] / pixel).astype(int), height_px - 1)
    inside = (points[:, 0] < width) & (points[:, 1] < height_px * pixel)
    sampled = rgb[row, column]
    labels = LabelMerger(len(points))
    for colour, role in roles.items():
        if isinstance(role, str):  # "empty", the only other role
            continue
        mask = inside & ~empty[row, column] & np.all(sampled == colour, axis=-1)
        if not mask.any():
            continue
        name = "#{:02x}{:02x}{:02x}".format(*colour)
        actuator, region = role.get("actuator"), role.get("region", 0)
        fiber = role.get("fiber", (0.0, 1.0) if actuator is not None else None)
        try:
            fiber = check_labels(actuator, fiber, region, dim=2)
        except LayoutError as error:
            raise LayoutError(f"legend entry {name}: {error}") from None
        labels.add(
            name,
            mask,
            actuator,
            fiber,
            region,
            tuple(role.get("groups", ())),
            bool(role.get("pinned", False)),
            points,
        )
    if not labels.occupied.any():
        raise LayoutError(
            f"{source} is too small for dx={dx:g}: no particle landed on a robot pixel; make the "
            f"robot wider or refine dx"
        )
    return labels.layout(points, spacing**2)


def layout_from_png(path, width: float, dx: float, legend=None, per_cell: int = 2) -> Layout:
    """Build a 2D layout from a PNG drawing.

    The drawing's non-empty pixels are cropped to their bounding box and scaled so the robot is
    `width` long along x (pixels are square); the image's top is "up". Particles sit on a lattice
    of spacing ``dx / per_cell`` and take the role of the pixel they fall in.

    Args:
      path: PNG file.
      width: physical width of the robot (domain units).
      dx: simulator grid spacing.
      legend: JSON file path or dict mapping colours to roles (see the module doc); None: default
        palette.
      per_cell: particles per grid cell per axis.
    """
    rgb, opaque = read_image(path)
    return layout_from_pixels(rgb, opaque, width, dx, legend, per_cell, source=os.fspath(path))


def write_png(layout: Layout, path, spacing: float | None = None) -> tuple[pathlib.Path, pathlib.Path]:
    """Write a 2D layout as a drawing that `layout_from_png` reads back: one pixel per particle
    (`spacing`: the particles' lattice spacing, found from their positions when None), in litl's
    palette where a role is one of its entries (black passive, grey pinned, actuator k in its
    colour with region k + 1 and an upward fiber) and in further colours otherwise, each named in
    the legend written beside it (``<path>.json``: actuator, fiber, region, groups, pinned).

    Returns (png path, legend path). Read it back with ``layout_from_png(png, width, dx,
    legend=<legend path>)``, `width` the image's width in pixels times `spacing` and `dx` the
    spacing times the particles per cell (the legend records both)."""
    from PIL import Image

    positions = np.asarray(layout.positions, np.float64)
    if positions.shape[1] != 2:
        raise LayoutError(f"write_png draws a 2D robot; this layout is {positions.shape[1]}D")
    spacing = float(spacing) if spacing is not None else _lattice_spacing(positions)
    cells = np.rint((positions - positions.min(0)) / spacing).astype(np.int64)
    width_px, height_px = (int(c) + 1 for c in cells.max(0))
    if len(np.unique(cells, axis=0)) != len(cells):
        raise LayoutError(f"two particles share a pixel at spacing {spacing:g}: pass the lattice spacing")
    roles, role_of = _roles(layout)
    colours = _role_colours(roles)
    pixels = np.full((height_px, width_px, 3), 255, np.uint8)
    rgb = np.asarray([_colour(colours[role]) for role in roles], np.uint8)
    pixels[height_px - 1 - cells[:, 1], cells[:, 0]] = rgb[role_of]
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(pixels, "RGB").save(path)
    legend = {colours[role]: _legend_entry(role, layout) for role in roles}
    legend_path = path.with_suffix(".json")
    notes = {"_spacing": spacing, "_width": width_px * spacing}
    legend_path.write_text(json.dumps({**legend, **notes}, indent=1))
    return path, legend_path


def _lattice_spacing(positions: np.ndarray) -> float:
    """The smallest distance between two distinct x (or y) coordinates of the particles."""
    steps = [np.diff(np.unique(np.round(positions[:, axis], 12))) for axis in range(2)]
    found = np.concatenate([s[s > 1e-12] for s in steps])
    if not found.size:
        raise LayoutError("cannot find the particles' spacing: pass spacing=")
    return float(found.min())


def _roles(layout: Layout) -> tuple[list[tuple], np.ndarray]:
    """Each distinct (actuator, region, pinned, groups) of the particles, and each particle's."""
    n = len(layout.positions)
    member: list[list[str]] = [[] for _ in range(n)]
    for name, indices in sorted(layout.groups.items()):
        for i in np.asarray(indices):
            member[int(i)].append(name)
    keys = [
        (int(layout.actuator[i]), int(layout.region[i]), bool(layout.pinned[i]), tuple(member[i]))
        for i in range(n)
    ]
    roles = sorted(set(keys))
    index = {role: k for k, role in enumerate(roles)}
    return roles, np.asarray([index[key] for key in keys])


def _role_colours(roles: list[tuple]) -> dict[tuple, str]:
    """litl's palette colour where the role is the palette's, else a colour no other role has."""
    palette = default_legend()
    colours: dict[tuple, str] = {}
    for role in roles:
        actuator, region, pinned, groups = role
        if groups:
            continue
        if actuator < 0 and region == 0:
            colours[role] = "#808080" if pinned else "#000000"
        elif 0 <= actuator < len(ACTUATOR_COLOURS) and region == actuator + 1 and not pinned:
            colours[role] = ACTUATOR_COLOURS[actuator]
    taken = set(colours.values()) | set(palette) | set(EMPTY_COLOURS)
    candidate = 0
    for role in roles:
        while role not in colours:
            candidate += 1
            red, green, blue = (
                (candidate * 97) % 251,
                (candidate * 57 + 40) % 239,
                (candidate * 31 + 80) % 233,
            )
            colour = f"#{red:02x}{green:02x}{blue:02x}"
            if colour not in taken:
                colours[role] = colour
                taken.add(colour)
    return colours


def _legend_entry(role: tuple, layout: Layout) -> dict:
    actuator, region, pinned, groups = role
    entry: dict[str, Any] = {"region": region}
    if actuator >= 0:
        entry["actuator"] = actuator
        entry["fiber"] = [float(f) for f in np.asarray(layout.fiber)[actuator]]
    if pinned:
        entry["pinned"] = True
    if groups:
        entry["groups"] = list(groups)
    return entry


def write_voxels(layout: Layout, path, spacing: float | None = None) -> pathlib.Path:
    """Write a 3D layout as voxels that `layout_from_voxels` reads back (`.npz`): each particle's
    lattice cell (`spacing`: the particles' lattice spacing, found from their positions when
    None), actuator, region and pin, the actuators' fibers and the named groups."""
    positions = np.asarray(layout.positions, np.float64)
    if positions.shape[1] != 3:
        raise LayoutError(f"write_voxels writes a 3D robot; this layout is {positions.shape[1]}D (write_png)")
    spacing = float(spacing) if spacing is not None else _lattice_spacing(positions)
    cells = np.rint((positions - positions.min(0)) / spacing).astype(np.int64)
    if len(np.unique(cells, axis=0)) != len(cells):
        raise LayoutError(f"two particles share a voxel at spacing {spacing:g}: pass the lattice spacing")
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays: dict[str, Any] = {
        "cells": cells,
        "spacing": np.asarray(spacing),
        "actuator": np.asarray(layout.actuator),
        "region": np.asarray(layout.region),
        "pinned": np.asarray(layout.pinned),
        "fiber": np.asarray(layout.fiber),
    }
    arrays.update({f"group:{name}": np.asarray(members) for name, members in layout.groups.items()})
    with open(path, "wb") as out:
        np.savez_compressed(out, **arrays)
    return path


def layout_from_voxels(path) -> Layout:
    """The 3D layout `write_voxels` wrote: one particle per voxel, as saved."""
    try:
        with np.load(path) as saved:
            data = {key: saved[key] for key in saved.files}
    except (OSError, ValueError) as error:
        raise LayoutError(f"{os.fspath(path)!r} is not a voxel file litl wrote (.npz): {error}") from None
    missing = {"cells", "spacing", "actuator", "region", "pinned", "fiber"} - set(data)
    if missing:
        raise LayoutError(
            f"{os.fspath(path)!r} lacks {sorted(missing)}: write it with litl.robots.image.write_voxels"
        )
    spacing = float(data["spacing"])
    return Layout(
        positions=(data["cells"] + 0.5) * spacing,
        volume=np.full(len(data["cells"]), spacing**3),
        actuator=data["actuator"],
        fiber=data["fiber"],
        region=data["region"],
        pinned=data["pinned"],
        groups={key.partition(":")[2]: value for key, value in data.items() if key.startswith("group:")},
    )

"""Builders from primitives and voxels: coverage, labels, and conflicting-label errors."""

import numpy as np
import pytest

from litl.robots import Box, Circle, Ellipse, Extrusion, LayoutError, Part, Polygon, Voxels, sample_parts

DX = 1 / 64
SPACING = DX / 2


def test_box_is_filled_exactly_on_the_grid_aligned_lattice():
    layout = sample_parts([Part(Box((0.25, 0.125), (0.25, 0.125)))], DX)
    assert layout.n_particles == (0.25 / SPACING) * (0.125 / SPACING)
    assert layout.volume.sum() == pytest.approx(0.25 * 0.125)
    assert layout.n_actuators == 0 and layout.n_regions == 1 and not layout.pinned.any()


@pytest.mark.parametrize(
    "shape, area",
    [
        (Circle((0.5, 0.5), 0.2), np.pi * 0.04),
        (Ellipse((0.5, 0.5), (0.3, 0.1)), np.pi * 0.03),
        (Polygon(((0.1, 0.1), (0.7, 0.1), (0.1, 0.5))), 0.5 * 0.6 * 0.4),
        (Polygon(((0.1, 0.1), (0.1, 0.5), (0.7, 0.1))), 0.5 * 0.6 * 0.4),  # clockwise
    ],
)
def test_curved_and_polygonal_shapes_cover_their_area(shape, area):
    layout = sample_parts([Part(shape)], DX)
    assert layout.volume.sum() == pytest.approx(area, rel=0.03)
    assert np.all(shape.contains(layout.positions))


def test_3d_box_ellipsoid_extrusion_and_voxels():
    box = sample_parts([Part(Box((0, 0, 0), (0.25, 0.125, 0.125)))], DX)
    assert box.dim == 3 and box.volume.sum() == pytest.approx(0.25 * 0.125 * 0.125)
    ball = sample_parts([Part(Ellipse((0.3, 0.3, 0.3), 0.15))], DX)
    assert ball.volume.sum() == pytest.approx(4 / 3 * np.pi * 0.15**3, rel=0.03)
    triangle = Polygon(((0.0, 0.0), (0.5, 0.0), (0.0, 0.25)))
    prism = sample_parts([Part(Extrusion(triangle, 0.0, 0.125))], DX)
    assert prism.volume.sum() == pytest.approx(0.5 * 0.5 * 0.25 * 0.125, rel=0.03)
    occupied = np.zeros((4, 2, 3), bool)
    occupied[:, 0, :] = True  # a 4 x 1 x 3 slab ...
    occupied[0, 1, 0] = True  # ... with one voxel on top
    voxels = sample_parts([Part(Voxels(occupied, voxel_size=DX))], DX)
    assert voxels.n_particles == 13 * 8 and voxels.volume.sum() == pytest.approx(13 * DX**3)


def test_labels_merge_across_overlapping_parts():
    body = Part(Box((0, 0), (0.5, 0.25)), groups="body")  # region left to others: 0
    muscle = Part(Box((0, 0), (0.125, 0.25)), actuator=0, fiber=(1, 1))
    tip = Part(Box((0.375, 0), (0.125, 0.25)), actuator=1, region=1, groups=("tip", "front"))
    anchor = Part(Box((0.25, 0), (0.125, 0.0625)), pinned=True)
    layout = sample_parts([body, muscle, tip, anchor], DX)
    assert layout.n_particles == (0.5 / SPACING) * (0.25 / SPACING)  # overlaps not doubled
    np.testing.assert_allclose(layout.fiber, [[2**-0.5, 2**-0.5], [0, 1]])
    x = layout.positions[:, 0]
    assert np.all(layout.actuator[x < 0.125] == 0) and np.all(layout.actuator[x > 0.375] == 1)
    assert np.all(layout.actuator[(x > 0.125) & (x < 0.375)] == -1)
    assert np.all(layout.region[x > 0.375] == 1) and np.all(layout.region[x < 0.375] == 0)
    assert len(layout.groups["body"]) == layout.n_particles
    np.testing.assert_array_equal(layout.groups["tip"], layout.groups["front"])
    assert layout.pinned.sum() == (0.125 / SPACING) * (0.0625 / SPACING)


def test_conflicting_labels_are_refused_with_the_place_and_the_parts():
    with pytest.raises(LayoutError, match="conflicting labels: part 1 and part 0 .* actuator 1 and 0"):
        sample_parts(
            [Part(Box((0, 0), (0.25, 0.25)), actuator=0), Part(Box((0.125, 0), (0.25, 0.25)), actuator=1)], DX
        )
    with pytest.raises(LayoutError, match="region 2 and 1"):
        sample_parts(
            [Part(Box((0, 0), (0.25, 0.25)), region=1), Part(Box((0.125, 0), (0.25, 0.25)), region=2)], DX
        )
    with pytest.raises(LayoutError, match="two fiber directions"):
        sample_parts(
            [
                Part(Box((0, 0), (0.25, 0.25)), actuator=0, fiber=(1, 0)),
                Part(Box((0.5, 0), (0.25, 0.25)), actuator=0, fiber=(0, 1)),
            ],
            DX,
        )


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: sample_parts([Part(Box((0, 0), (0.2, 0.2)), actuator=1)], DX), "missing \\[0\\]"),
        (lambda: sample_parts([], DX), "at least one part"),
        (
            lambda: sample_parts([Part(Box((0, 0), (0.2, 0.2))), Part(Box((0, 0, 0), (0.2, 0.2, 0.2)))], DX),
            "same dimension",
        ),
        (lambda: sample_parts([Part(Box((0, 0), (0.2, 0.2)))], -0.1), "dx > 0"),
        (
            lambda: sample_parts([Part(Box((0, 0), (0.2, 0.2))), Part(Circle((0.5, 0.5), 0.001))], DX),
            "part 1 .*covers no particle",
        ),
        (lambda: Box((0, 0), (0.2, -0.1)), "positive sizes"),
        (lambda: Box((0, 0), (0.2,)), "2 finite numbers"),
        (lambda: Ellipse((0, 0), (0.1, 0.1, 0.1)), "one positive radius"),
        (lambda: Polygon(((0, 0), (1, 1))), "at least 3"),
        (lambda: Polygon(((0, 0), (1, 1), (2, 2))), "zero area"),
        (lambda: Extrusion(Box((0, 0, 0), (1, 1, 1)), 0, 1), "2D profile"),
        (lambda: Extrusion(Box((0, 0), (1, 1)), 1, 0), "z_min < z_max"),
        (lambda: Voxels(np.zeros((3, 3, 3), bool), 0.1), "no occupied cell"),
        (lambda: Voxels(np.ones((3, 3, 3)), 0.1), "bool array"),
        (lambda: Part(Box((0, 0), (1, 1)), actuator=-2), "actuator id"),
        (lambda: Part(Box((0, 0), (1, 1)), fiber=(0, 1)), "passive part"),
        (lambda: Part(Box((0, 0), (1, 1)), actuator=0, fiber=(0, 0)), "zero vector"),
    ],
)
def test_bad_shapes_and_parts_fail_clearly(make, message):
    with pytest.raises(LayoutError, match=message):
        make()


def test_extruding_a_2d_layout_keeps_labels_and_volume():
    flat = sample_parts(
        [Part(Box((0, 0), (0.25, 0.125)), groups="all"), Part(Box((0, 0), (0.125, 0.125)), actuator=0)], DX
    )
    solid = flat.extruded(depth=0.125, spacing=SPACING)
    assert solid.dim == 3 and solid.n_particles == flat.n_particles * 16
    assert solid.volume.sum() == pytest.approx(flat.volume.sum() * 0.125)
    np.testing.assert_allclose(solid.fiber, [[0, 1, 0]])
    assert len(solid.groups["all"]) == solid.n_particles
    np.testing.assert_array_equal(solid.actuator[: flat.n_particles], flat.actuator)


def test_a_group_without_particles_or_with_foreign_indices_is_refused_by_name():
    import dataclasses

    layout = sample_parts([Part(Box((0, 0), (0.25, 0.125)), groups="body")], DX)
    with pytest.raises(LayoutError, match="group 'hand' holds no particle"):
        dataclasses.replace(layout, groups={"body": layout.groups["body"], "hand": np.array([], np.int64)})
    n = layout.n_particles
    with pytest.raises(
        LayoutError, match=rf"group 'body' holds particle indices outside \[0, {n}\): \[{n}\]"
    ):
        dataclasses.replace(layout, groups={"body": np.array([0, n])})

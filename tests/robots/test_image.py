"""Robots from PNG drawings: palette, legend, scaling, and every bad-input error."""

import json

import numpy as np
import pytest
from PIL import Image

import litl.robots
from litl.robots import LayoutError, layout_from_png

DX = 1 / 64


def save(tmp_path, pixels, name="robot.png", mode="RGB"):
    path = tmp_path / name
    Image.fromarray(np.asarray(pixels, np.uint8), mode).save(path)
    return path


def drawing():
    """10 x 20 pixels: a white margin, a black 16 x 4 torso, a red and a blue leg, a grey foot."""
    image = np.full((10, 20, 3), 255, np.uint8)
    image[1:5, 2:18] = 0  # torso
    image[5:9, 2:4] = (255, 0, 0)  # actuator 0
    image[5:9, 14:16] = (0, 0, 255)  # actuator 1
    image[9, 14:16] = (128, 128, 128)  # pinned
    return image


def test_default_palette_scales_crops_and_labels(tmp_path):
    # The robot's pixels span 16 columns; width 0.5 makes a pixel 1/32 = 2 grid cells wide.
    layout = layout_from_png(save(tmp_path, drawing()), width=0.5, dx=DX)
    spacing = DX / 2
    per_pixel = (1 / 32 / spacing) ** 2
    assert layout.n_particles == (16 * 4 + 8 + 8 + 2) * per_pixel
    assert layout.n_actuators == 2 and np.all(layout.actuator[layout.actuator >= 0] < 2)
    assert (layout.actuator == 0).sum() == 8 * per_pixel
    assert layout.pinned.sum() == 2 * per_pixel
    np.testing.assert_allclose(layout.fiber, [[0, 1], [0, 1]])
    low, high = layout.bounds()
    np.testing.assert_allclose(high - low + spacing, [0.5, 9 / 32])  # cropped to 16 x 9 pixels
    # The image's top is up: the torso is above the legs.
    torso = layout.positions[layout.actuator == -1][:, 1].max()
    assert torso > layout.positions[layout.actuator == 0][:, 1].max()
    assert layout.region.max() == 2  # default: passive 0, actuator k in region k + 1


def test_a_legend_file_maps_colours_to_actuators_groups_regions_and_background(tmp_path):
    image = drawing()
    image[0, :] = (200, 200, 255)  # a sky line declared empty
    image[1:3, 16:18] = (0, 160, 0)  # the nose: a named group
    legend = {
        "#000000": {},
        "#c8c8ff": "empty",
        "#00a000": {"groups": ["nose"], "region": 3},
        "#ff0000": {"actuator": 1, "fiber": [1, 0], "region": 1},
        "#0000ff": {"actuator": 0, "region": 2},
        "#808080": {"pinned": True, "region": 2},
    }
    (tmp_path / "legend.json").write_text(json.dumps(legend))
    layout = layout_from_png(save(tmp_path, image), 0.5, DX, legend=tmp_path / "legend.json")
    np.testing.assert_allclose(layout.fiber, [[0, 1], [1, 0]])
    assert layout.n_regions == 4 and len(layout.groups["nose"]) == 4 * (2**2) ** 2
    nose = layout.positions[layout.groups["nose"]]
    assert nose[:, 0].min() > layout.positions[:, 0].mean()
    assert layout.bounds()[1][1] - layout.bounds()[0][1] < 9 / 32  # the sky row is not body


def test_transparent_pixels_are_empty(tmp_path):
    rgba = np.zeros((6, 6, 4), np.uint8)
    rgba[2:4, 1:5] = (0, 0, 0, 255)
    layout = layout_from_png(save(tmp_path, rgba, mode="RGBA"), width=0.25, dx=DX)
    assert layout.volume.sum() == pytest.approx(0.25 * 0.125)


def test_the_rhino_comes_from_package_data():
    robot = litl.robots.get("rhino", dx=1 / 64)
    assert robot.n_actuators == 8 and "horn" in robot.layout.groups
    assert robot.layout.bounds()[1][0] - robot.layout.bounds()[0][0] == pytest.approx(0.36, abs=2 / 64)


@pytest.mark.parametrize(
    "edit, legend, message",
    [
        (lambda im: im.fill(255), None, "no robot pixels"),
        (
            lambda im: im.__setitem__((2, 5), (10, 200, 30)),
            None,
            "1 pixels have colours not in the legend, e.g. \\['#0ac81e'\\] \\(first at row 2, column 5\\)",
        ),
        (lambda im: None, {"#000000": {}}, "not in the legend"),
        (lambda im: None, {"#00000": {}}, "'#rrggbb'"),
        (lambda im: None, {"#000000": {"colour": 3}}, "keys from"),
        (
            lambda im: None,
            {"#000000": {}, "#ff0000": {"actuator": 1}, "#0000ff": {"actuator": 2}, "#808080": {}},
            "missing \\[0\\]",
        ),
        (
            lambda im: None,
            {
                "#000000": {"actuator": 0},
                "#ff0000": {"actuator": 0, "fiber": [1, 0]},
                "#0000ff": {},
                "#808080": {},
            },
            "two fiber directions",
        ),
    ],
)
def test_bad_drawings_and_legends_fail_clearly(tmp_path, edit, legend, message):
    image = drawing()
    edit(image)
    with pytest.raises(LayoutError, match=message):
        layout_from_png(save(tmp_path, image), 0.5, DX, legend=legend)


def test_files_that_are_not_images_or_legends_fail_clearly(tmp_path):
    (tmp_path / "notes.png").write_text("not an image")
    with pytest.raises(LayoutError, match="not a readable image"):
        layout_from_png(tmp_path / "notes.png", 0.5, DX)
    with pytest.raises(LayoutError, match="does not exist"):
        layout_from_png(tmp_path / "missing.png", 0.5, DX)
    (tmp_path / "legend.json").write_text("{not json")
    with pytest.raises(LayoutError, match="cannot read legend"):
        layout_from_png(save(tmp_path, drawing()), 0.5, DX, legend=tmp_path / "legend.json")
    with pytest.raises(LayoutError, match="positive length"):
        layout_from_png(save(tmp_path, drawing()), -1.0, DX)
    with pytest.raises(LayoutError, match="too small for dx"):
        layout_from_png(save(tmp_path, drawing()), 0.001, DX)


@pytest.mark.parametrize(
    "role, message",
    [
        ({"actuator": 0, "fiber": [0, 0]}, "legend entry #ff0000: fiber direction must not be the zero"),
        ({"actuator": -1}, "legend entry #ff0000: actuator id must be an integer >= 0"),
        ({"actuator": 0, "region": "front"}, "legend entry #ff0000: region id must be an integer"),
        ({"fiber": [1, 0]}, "legend entry #ff0000: a fiber direction was given for a passive part"),
    ],
)
def test_malformed_legend_labels_name_the_colour(tmp_path, role, message):
    legend = {"#000000": {}, "#0000ff": {"actuator": 1}, "#808080": {}, "#ff0000": role}
    with pytest.raises(LayoutError, match=message):
        layout_from_png(save(tmp_path, drawing()), 0.5, DX, legend=legend)

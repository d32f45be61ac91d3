"""The co-designed body drawn where a user looks (`litl.viz.bodies.draw_body`): beside the body as
built, each particle in its strongest channel's colour with a legend naming the channels, its
material as opacity, the modulus where the space co-designs it; written as body.png by a run and
as <name>_design.png by the replay, which names a run that lacks the design space asked for."""

import json

import jax.numpy as jnp
import numpy as np
import pytest
from matplotlib.colors import to_rgba
from PIL import Image

import litl.designs
from litl.app import compose, run_experiment
from litl.replay import main, replay
from litl.viz.bodies import draw_body
from litl.viz.robots import PASSIVE_COLOR, actuator_colors
from tests.loop.tiny import tiny_robot

# The smallest run that ends with a body picture: the smoke biped (131 particles), one seed, one
# iteration, an open-loop controller (no observer to train).
SMOKE = [
    "+scale=smoke",
    "controller=sinusoid",
    "seeds=1",
    "loop.episodes=1",
    "loop.iterations=1",
    "output.progress=false",
    "output.animation=false",
]


@pytest.fixture(scope="module")
def smoke_runs(tmp_path_factory):
    """{design kind: its finished smoke run's directory}, each run once, when a test first asks."""
    root, done = tmp_path_factory.mktemp("bodies"), {}

    def finished(kind: str):
        if kind not in done:
            run_experiment(compose([f"design={kind}", *SMOKE]), root / kind)
            done[kind] = root / kind
        return done[kind]

    return finished


def _particles(ax) -> np.ndarray:
    """(n, 4) RGBA of the particles drawn on `ax`."""
    (scatter,) = [c for c in ax.collections if c.get_gid() == "particles"]
    return scatter.get_facecolors()


def test_the_body_picture_colours_each_particle_by_its_strongest_channel_with_a_legend_naming_them():
    robot = litl.designs.apply(tiny_robot(), "actuators")
    space, layout = robot.design_space, robot.layout
    phi = dict(space.initial())
    # Every passive particle's strongest channel becomes actuator 1: the placement moved.
    passive = np.flatnonzero(layout.actuator < 0)
    phi["placement"] = phi["placement"].at[passive, 1].set(10.0)
    figure = draw_body(robot, phi)
    built, placed = figure.axes
    assert (built.get_gid(), placed.get_gid()) == ("as built", "placement")
    colours = actuator_colors(layout.n_actuators)
    channel = np.where(layout.actuator >= 0, layout.actuator, 1)
    own = ~layout.pinned
    np.testing.assert_allclose(_particles(placed)[own], colours[channel][own])
    # The body as built keeps its own passive material grey.
    kept = passive[~layout.pinned[passive]]
    np.testing.assert_allclose(_particles(built)[kept], np.tile(to_rgba(PASSIVE_COLOR), (len(kept), 1)))
    (legend,) = [child for child in figure.get_children() if child.get_gid() == "body_legend"]
    labels = [text.get_text() for text in legend.get_texts()]
    assert labels[: layout.n_actuators + 1] == [f"actuator {k}" for k in range(layout.n_actuators)] + [
        "passive"
    ]
    assert "moved" in placed.get_title()  # the share of particles whose channel moved


def test_the_body_picture_shows_material_as_opacity_and_the_modulus_only_where_it_is_codesigned():
    robot = litl.designs.apply(tiny_robot(), "all")
    space = robot.design_space
    phi = dict(space.initial())
    low = robot.layout.positions[:, 1] < np.median(robot.layout.positions[:, 1])
    phi["occupancy"] = jnp.where(jnp.asarray(low), 0.0, 1.0)  # the lower half removed
    phi["youngs_modulus"] = jnp.linspace(*space.bounds, space.n_regions)
    figure = draw_body(robot, phi)
    assert [ax.get_gid() for ax in figure.axes[:3]] == ["as built", "placement", "modulus"]
    density = np.asarray(space.density(phi))
    assert density[low].max() < 0.5 < density[~low].min()  # the projection kept the two apart
    for ax in figure.axes[1:3]:
        np.testing.assert_allclose(_particles(ax)[:, 3], density, atol=1e-6)
    np.testing.assert_allclose(_particles(figure.axes[0])[:, 3], 1.0)  # as built: all material
    # A space that leaves the modulus alone draws no modulus panel.
    actuators = litl.designs.apply(tiny_robot(), "actuators")
    assert "modulus" not in [
        ax.get_gid() for ax in draw_body(actuators, actuators.design_space.initial()).axes
    ]


@pytest.mark.parametrize("kind, panels", [("actuators", 2), ("all", 3)])
def test_a_run_that_codesigns_the_body_leaves_a_readable_body_picture(smoke_runs, kind, panels):
    run_dir = smoke_runs(kind)
    with Image.open(run_dir / "body.png") as picture:
        picture.verify()  # a whole PNG
    with Image.open(run_dir / "body.png") as picture:
        width, height = picture.size
        pixels = np.asarray(picture.convert("L"))
    # 450 pixels a panel: the 8-cell-wide biped's particles each some 10 pixels across.
    assert width == 450 * panels and height > 250
    assert pixels.std() > 10  # a picture, not a blank


def test_the_replay_draws_what_the_design_space_changed(smoke_runs, tmp_path):
    run_dir = smoke_runs("actuators")
    summary = replay(run_dir, out=tmp_path / "seed0.gif", design="actuators")
    assert "design_note" not in summary  # the run co-designed the space asked for
    with Image.open(tmp_path / "seed0_design.png") as picture:
        assert picture.size[0] == 900  # the body as built and its placement, no modulus panel


def test_a_replay_asked_for_a_body_an_old_run_never_designed_names_the_run_and_draws_what_it_holds(
    smoke_runs, tmp_path, capsys
):
    run_dir = smoke_runs("modulus")  # run.json has no design section, as before design spaces
    assert "design" not in json.loads((run_dir / "run.json").read_text())["config"]
    out = tmp_path / "seed0.gif"
    assert main([str(run_dir), "--design", "actuators", "--out", str(out), "--stride", "10"]) == 0
    err = capsys.readouterr().err
    assert f"{run_dir}: its run.json has no design section" in err
    assert "no actuator placement to draw" in err and "Traceback" not in err
    summary = json.loads(out.with_suffix(".json").read_text())
    assert "no design section" in summary["design_note"]
    with Image.open(tmp_path / "seed0_design.png") as picture:
        assert picture.size[0] == 900  # the body as built and its modulus


def test_an_unknown_design_space_asked_of_the_replay_is_refused_naming_the_choices(smoke_runs, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main([str(smoke_runs("modulus")), "--design", "muscles"])
    assert exit_info.value.code == 2
    assert "--design muscles: choose one of" in capsys.readouterr().err


def _share_of_colour(path, colour, columns: slice) -> float:
    """The share of the picture's pixels in `columns` within 8 levels of `colour` (RGB, 0-1)."""
    with Image.open(path) as picture:
        pixels = np.asarray(picture.convert("RGB"), float)[:, columns]
    target = np.asarray(to_rgba(colour)[:3]) * 255
    return float((np.abs(pixels - target).max(-1) < 8).mean())


def test_a_run_of_several_seeds_draws_every_seeds_own_body(tmp_path):
    import collections
    import types

    from litl.viz.run_pictures import draw_seed_bodies

    robot = litl.designs.apply(tiny_robot(), "actuators")
    phi = dict(robot.design_space.initial())
    moved = dict(phi)  # seed 7's passive particles all became actuator 1's muscle
    passive = np.flatnonzero(robot.layout.actuator < 0)
    moved["placement"] = phi["placement"].at[passive, 1].set(10.0)
    States = collections.namedtuple("States", "design")
    states = States(design={k: jnp.stack([phi[k], moved[k]]) for k in phi})
    context = types.SimpleNamespace(seed_ids=[3, 7], record={"design": {"kind": "actuators"}})
    written = draw_seed_bodies(robot, states, 0, context, tmp_path)
    assert written == [tmp_path / "body.png", tmp_path / "bodies/seed3.png", tmp_path / "bodies/seed7.png"]
    muscle = actuator_colors(robot.layout.n_actuators)[1]
    with Image.open(tmp_path / "bodies/seed3.png") as picture:
        width = picture.size[0]
    placement = slice(width // 2, width)  # the right panel: the final placement
    # Seed 7's placement panel shows actuator 1's colour where seed 3's shows passive grey.
    assert _share_of_colour(tmp_path / "bodies/seed7.png", muscle, placement) > 2 * _share_of_colour(
        tmp_path / "bodies/seed3.png", muscle, placement
    )
    assert (tmp_path / "body.png").read_bytes() == (tmp_path / "bodies/seed3.png").read_bytes()

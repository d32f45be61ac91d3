"""Pictures of robots and animations of rollouts: artists, colours, files and clear errors."""

import dataclasses

import matplotlib

matplotlib.use("Agg")

import jax.numpy as jnp  # noqa: E402
import matplotlib.animation as manimation  # noqa: E402
import matplotlib.colors as mcolors  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from PIL import Image  # noqa: E402

from litl.models.open_loop import SinusoidParams, sinusoid_policy  # noqa: E402
from litl.robots.robot import Robot, place  # noqa: E402
from litl.robots.shapes import Box, Part, sample_parts  # noqa: E402
from litl.robots.tasks import Locomotion, Reach, Task  # noqa: E402
from litl.sim import Boundary, SimConfig, Wall  # noqa: E402
from litl.sim.colliders import Box as SolidBox  # noqa: E402
from litl.sim.colliders import Collider  # noqa: E402
from litl.viz import (  # noqa: E402
    VizError,
    animate_rollout,
    draw,
    draw_robot,
    draw_robot_3d,
    particle_colors,
    record_rollout,
    rollout_limits,
)
from litl.viz.robots import PINNED_COLOR  # noqa: E402


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


@pytest.fixture(scope="module")
def robot2d():
    """A table walker: passive top, two actuated legs (one pinned foot), two reach targets."""
    # Open ceiling: three walls are drawn.
    config = SimConfig(
        grid_shape=(64, 64),
        dx=1 / 64,
        dt=1e-3,
        gravity=(0, -3.8),
        boundary=Boundary((Wall(), Wall(), Wall(), Wall("open")), thickness=2),
    )
    layout = sample_parts(
        [
            Part(Box((0, 0.1), (0.2, 0.06)), region=0, groups=("top",)),
            Part(Box((0, 0), (0.05, 0.1)), actuator=0, region=1, groups=("foot",)),
            Part(Box((0.15, 0), (0.05, 0.1)), actuator=1, region=2),
            Part(Box((0.15, 0), (0.05, 0.02)), actuator=1, region=2, pinned=True),
        ],
        dx=config.dx,
    )
    task = Task((Locomotion(), Reach("foot", (0.5, 0.3)), Reach("top", (0.6, 0.6))))
    return Robot("demo", place(layout, config, x=0.1), config, task=task)


@pytest.fixture(scope="module")
def robot3d():
    config = SimConfig(
        grid_shape=(32, 32, 32),
        dx=1 / 32,
        dt=1e-3,
        gravity=(0, -3.8, 0),
        boundary=Boundary.box(3, thickness=2),
    )
    layout = sample_parts(
        [
            Part(Box((0, 0.1, 0), (0.2, 0.06, 0.1)), region=0),
            Part(Box((0, 0, 0), (0.05, 0.1, 0.1)), actuator=0, region=1, groups=("foot",)),
            Part(Box((0.15, 0, 0), (0.05, 0.1, 0.1)), actuator=1, region=1),
        ],
        dx=config.dx,
    )
    task = Task((Locomotion(), Reach("foot", (0.6, 0.3, 0.5))))
    return Robot("demo3d", place(layout, config, x=0.2), config, task=task)


@pytest.fixture(scope="module")
def recorded(robot2d):
    """A 20-step open-loop rollout of the 2D robot, every 4th step kept."""
    m = robot2d.n_actuators
    params = SinusoidParams(weights=jnp.eye(m, 4) * 2.0, bias=jnp.zeros(m))
    policy = sinusoid_policy(omega=20.0, dt=robot2d.config.dt)
    return record_rollout(robot2d, policy, params, steps=20, stride=4)


def with_gid(ax, gid):
    return [artist for artist in ax.get_children() if artist.get_gid() == gid]


def particle_facecolors(ax):
    (particles,) = with_gid(ax, "particles")
    return np.asarray(particles.get_facecolors())


# ---------------------------------------------------------------------------- 2D pictures


def test_draw_robot_saves_a_picture_with_targets_walls_and_particles(robot2d, tmp_path):
    ax = draw_robot(robot2d)
    path = tmp_path / "robot.png"
    ax.figure.savefig(path)
    assert path.stat().st_size > 1000
    assert Image.open(path).size[0] > 100

    targets = with_gid(ax, "target")
    assert len(targets) == 2  # one green circle per reach term
    assert sorted(tuple(np.round(t.center, 6)) for t in targets) == [(0.5, 0.3), (0.6, 0.6)]
    crosses = with_gid(ax, "reach_group")
    assert len(crosses) == 2 and all(c.get_marker() == "x" for c in crosses)
    foot = robot2d.layout.positions[robot2d.layout.groups["foot"]].mean(axis=0)
    assert any(np.allclose(np.ravel(c.get_xydata()), foot) for c in crosses)
    assert len(with_gid(ax, "wall")) == 3  # the open ceiling is not drawn
    assert len(particle_facecolors(ax)) == robot2d.layout.n_particles
    assert ax.get_xlim() == (0.0, 1.0) and ax.get_ylim() == (0.0, 1.0)
    assert ax.get_aspect() == 1.0

    bare = draw_robot(robot2d, show_targets=False)
    assert not with_gid(bare, "target") and not with_gid(bare, "reach_group")


def test_actuation_recolours_actuated_particles_only(robot2d):
    layout = robot2d.layout
    plain = particle_facecolors(draw_robot(robot2d))
    acted = particle_facecolors(draw_robot(robot2d, actuation=[1.0, -1.0], colorbar=True))
    passive = layout.actuator < 0
    moving = (layout.actuator >= 0) & ~layout.pinned
    np.testing.assert_allclose(acted[passive], plain[passive])
    pinned = np.broadcast_to(mcolors.to_rgba(PINNED_COLOR), (layout.pinned.sum(), 4))
    assert len(pinned) > 0
    np.testing.assert_allclose(acted[layout.pinned], pinned)
    np.testing.assert_allclose(plain[layout.pinned], pinned)
    assert np.all(np.any(np.abs(acted[moving] - plain[moving]) > 0.05, axis=1))
    # +1 contracts (blue), -1 expands (red).
    contracting = acted[(layout.actuator == 0) & ~layout.pinned]
    expanding = acted[(layout.actuator == 1) & ~layout.pinned]
    assert np.all(contracting[:, 2] > contracting[:, 0])
    assert np.all(expanding[:, 0] > expanding[:, 2])
    # Distinct colours per actuator without actuation.
    assert not np.allclose(
        plain[moving & (layout.actuator == 0)][0], plain[moving & (layout.actuator == 1)][0]
    )


def test_show_regions_colours_by_design_region(robot2d):
    layout = robot2d.layout
    colors = particle_facecolors(draw_robot(robot2d, show_regions=True))
    free = ~layout.pinned
    firsts = []
    for region in range(layout.n_regions):
        in_region = colors[free & (layout.region == region)]
        np.testing.assert_allclose(in_region, in_region[:1].repeat(len(in_region), 0))
        firsts.append(tuple(in_region[0]))
    assert len(set(firsts)) == layout.n_regions
    with pytest.raises(VizError, match="only one"):
        particle_colors(layout, actuation=[0.0, 0.0], show_regions=True)


def test_stiffness_colours_each_region_by_its_youngs_modulus(robot2d, tmp_path):
    layout = robot2d.layout
    stiffness = np.asarray([15.0, 30.0, 22.5])  # E per region, on the scale [15, 30]
    ax = draw_robot(robot2d, stiffness=stiffness, stiffness_range=(15.0, 30.0), colorbar=True)
    colors = particle_facecolors(ax)
    viridis = plt.get_cmap("viridis")
    free = ~layout.pinned
    for region, value in zip(range(3), (0.0, 1.0, 0.5), strict=True):
        np.testing.assert_allclose(
            colors[free & (layout.region == region)],
            np.broadcast_to(viridis(value), (np.sum(free & (layout.region == region)), 4)),
        )
    assert ax.figure.axes[-1].get_ylabel() == "Young's modulus E of the region"
    with pytest.raises(VizError, match="one value per design region, shape \\(3,\\)"):
        particle_colors(layout, stiffness=[20.0])
    with pytest.raises(VizError, match="only one"):
        particle_colors(layout, actuation=[0.0, 0.0], stiffness=stiffness)
    path = animate_rollout(
        robot2d,
        np.repeat(layout.positions[None], 2, 0),
        np.zeros((2, layout.n_actuators)),
        tmp_path / "stiff.gif",
        stiffness=stiffness,
        stiffness_range=(15.0, 30.0),
    )
    assert path.stat().st_size > 0


def test_positions_are_drawn_and_a_layout_can_stand_in_for_a_robot(robot2d):
    moved = robot2d.layout.positions + np.array([0.3, 0.2])
    (particles,) = with_gid(draw_robot(robot2d, positions=moved), "particles")
    np.testing.assert_allclose(particles.get_offsets(), moved)

    ax = draw_robot(robot2d.layout, config=robot2d.config, task=robot2d.task)
    assert len(with_gid(ax, "target")) == 2 and len(with_gid(ax, "wall")) == 3
    # No config: no walls, the view fits the particles.
    ax = draw_robot(robot2d.layout)
    assert not with_gid(ax, "wall") and not with_gid(ax, "target")
    low, high = robot2d.layout.bounds()
    assert ax.get_xlim()[0] < low[0] and ax.get_xlim()[1] > high[0]
    pinned_base = dataclasses.replace(
        robot2d.config, boundary=Boundary.box(2, thickness=2, pinned_boxes=[((0.1, 0.03), (0.2, 0.06))])
    )
    ax = draw_robot(robot2d.layout, config=pinned_base)
    assert len(with_gid(ax, "pinned_box")) == 1 and len(with_gid(ax, "wall")) == 4
    with pytest.raises(VizError, match="bare Layout"):
        draw_robot(robot2d, config=robot2d.config)


def test_bad_inputs_fail_clearly(robot2d, robot3d):
    n = robot2d.layout.n_particles
    with pytest.raises(VizError, match=rf"\(n_particles, dim\) = \({n}, 2\)"):
        draw_robot(robot2d, positions=np.zeros((n, 3)))
    with pytest.raises(VizError, match=r"\(n_actuators,\) = \(2,\)"):
        draw_robot(robot2d, actuation=[0.5])
    with pytest.raises(VizError, match="3D; use draw_robot_3d"):
        draw_robot(robot3d)
    with pytest.raises(VizError, match="2D; use draw_robot to"):
        draw_robot_3d(robot2d)
    with pytest.raises(VizError, match="3D Axes"):
        draw_robot_3d(robot3d, ax=plt.figure().add_subplot())
    with pytest.raises(VizError, match="2D Axes"):
        draw_robot(robot2d, ax=plt.figure().add_subplot(projection="3d"))
    with pytest.raises(VizError, match="Robot or a Layout"):
        draw_robot(np.zeros((3, 2)))


# ---------------------------------------------------------------------------- 3D pictures


def test_draw_robot_3d(robot3d, tmp_path):
    layout = robot3d.layout
    ax = draw_robot_3d(robot3d, actuation=[1.0, -1.0])
    path = tmp_path / "robot3d.png"
    ax.figure.savefig(path)
    assert path.stat().st_size > 1000
    assert ax.name == "3d"
    assert len(with_gid(ax, "target")) == 1 and len(with_gid(ax, "reach_group")) == 1
    assert len(with_gid(ax, "wall")) == 1  # the floor plane
    (particles,) = with_gid(ax, "particles")
    # mplot3d draws the simulation's "up" axis (1) vertically.
    np.testing.assert_allclose(np.asarray(particles._offsets3d).T, layout.positions[:, [0, 2, 1]])
    assert ax.get_zlim() == (0.0, 1.0)
    # The dispatcher picks the 3D drawing.
    assert draw(robot3d).name == "3d"


# ---------------------------------------------------------------------------- animations


def test_record_rollout_shapes(robot2d, recorded):
    positions, actuation = recorded
    assert positions.shape == (5, robot2d.layout.n_particles, 2)
    assert actuation.shape == (5, robot2d.n_actuators)
    assert np.all(np.isfinite(positions)) and np.all(np.abs(actuation) <= 1)
    assert not np.allclose(positions[-1], robot2d.layout.positions)
    with pytest.raises(VizError, match="stride"):
        record_rollout(robot2d, None, None, steps=4, stride=5)


def test_gif_of_a_rollout(robot2d, recorded, tmp_path):
    positions, actuation = recorded
    path = tmp_path / "new" / "folder" / "walk.gif"
    assert animate_rollout(robot2d, positions, actuation, path, fps=10, stride=2, dpi=40) == path
    with Image.open(path) as gif:
        assert gif.n_frames == 3  # frames 0, 2, 4 of 5
    assert sorted(p.name for p in path.parent.iterdir()) == ["walk.gif"]  # no temporary left


def test_a_moving_collider_is_drawn_where_it_is_at_each_frame(robot2d, recorded, tmp_path):
    paddle = Collider(SolidBox((0.8, 0.1), (0.9, 0.4)), Wall("slip"), velocity=(-0.5, 0.0))
    boundary = dataclasses.replace(robot2d.config.boundary, colliders=(paddle,))
    robot = dataclasses.replace(robot2d, config=dataclasses.replace(robot2d.config, boundary=boundary))

    def left_edge(time):
        (solid,) = with_gid(draw_robot(robot, time=time), "moving_collider")
        return min(path.vertices[:, 0].min() for path in solid.get_paths() if len(path.vertices))

    assert left_edge(0.0) == pytest.approx(0.8, abs=0.01)
    assert left_edge(0.2) == pytest.approx(0.7, abs=0.01)
    positions, actuation = recorded
    path = animate_rollout(robot, positions, actuation, tmp_path / "paddle.gif", dpi=30, frame_seconds=0.1)
    with Image.open(path) as gif:
        assert gif.n_frames == 5
    with pytest.raises(VizError, match="frame_seconds must be positive"):
        animate_rollout(robot, positions, actuation, tmp_path / "x.gif", frame_seconds=0.0)


def test_gif_3d(robot3d, tmp_path):
    rest = robot3d.layout.positions
    positions = np.stack([rest + [0.01 * t, 0, 0] for t in range(2)])
    actuation = np.array([[1.0, -1.0], [-1.0, 1.0]])
    path = animate_rollout(robot3d, positions, actuation, tmp_path / "walk3d.gif", dpi=30)
    with Image.open(path) as gif:
        assert gif.n_frames == 2


def test_3d_views_frame_the_rollout_not_the_whole_domain(robot3d):
    rest = robot3d.layout.positions
    positions = np.stack([rest, rest + [0.3, 0.05, 0.0]])
    limits = rollout_limits(positions, robot3d.config, margin=0.1)
    low, high = positions.min((0, 1)), positions.max((0, 1))
    domain = np.asarray(robot3d.config.domain_size)
    np.testing.assert_allclose(limits[:, 1], np.minimum(high + 0.1, domain))
    np.testing.assert_allclose(limits[[0, 2], 0], np.maximum(low[[0, 2]] - 0.1, 0.0))
    assert limits[1, 0] == 0.0  # down to the floor
    ax = draw_robot_3d(robot3d, positions=positions[1], limits=limits)
    assert ax.get_xlim() == tuple(limits[0]) and ax.get_zlim() == tuple(limits[1])
    with pytest.raises(VizError, match=r"\(3, 2\)"):
        draw_robot_3d(robot3d, limits=[(0, 1), (0, 1)])


def test_animation_errors_leave_no_file(robot2d, recorded, tmp_path, monkeypatch):
    positions, actuation = recorded
    n, m = robot2d.layout.n_particles, robot2d.n_actuators
    with pytest.raises(VizError, match=r"\.gif or \.mp4"):
        animate_rollout(robot2d, positions, actuation, tmp_path / "walk.avi")
    with pytest.raises(VizError, match=rf"\(T, {n}, 2\)"):
        animate_rollout(robot2d, positions[0], actuation, tmp_path / "walk.gif")
    with pytest.raises(VizError, match=rf"\(5, {m}\)"):
        animate_rollout(robot2d, positions, actuation[:3], tmp_path / "walk.gif")
    with pytest.raises(VizError, match="stride"):
        animate_rollout(robot2d, positions, actuation, tmp_path / "walk.gif", stride=0)

    def broken_finish(writer):  # the disk fills up halfway through writing the GIF
        with open(writer.outfile, "wb") as partial:
            partial.write(b"GIF89a")
        raise RuntimeError("disk full")

    monkeypatch.setattr(manimation.PillowWriter, "finish", broken_finish)
    with pytest.raises(RuntimeError, match="disk full"):
        animate_rollout(robot2d, positions, actuation, tmp_path / "walk.gif")
    assert list(tmp_path.iterdir()) == []


def test_mp4_needs_ffmpeg(robot2d, recorded, tmp_path, monkeypatch):
    positions, actuation = recorded
    path = tmp_path / "walk.mp4"
    if manimation.writers.is_available("ffmpeg"):
        animate_rollout(robot2d, positions[:2], actuation[:2], path, dpi=40)
        assert path.stat().st_size > 0
        monkeypatch.setattr(manimation.writers, "is_available", lambda name: False)
        path.unlink()
    with pytest.raises(VizError, match="install it .* or write a .gif"):
        animate_rollout(robot2d, positions, actuation, path)
    assert not path.exists()

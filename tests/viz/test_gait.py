"""Gait numbers from recorded positions: feet found per leg, lifts counted, stepping vs sliding."""

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

import litl.robots  # noqa: E402
from litl.viz import VizError, draw_gait, find_feet, measure_gait  # noqa: E402


@pytest.mark.parametrize("name, legs", [("biped", 2), ("quadruped", 4), ("hexapod", 6)])
def test_one_foot_per_leg(name, legs):
    robot = litl.robots.get(name, dx=1 / 32 if name == "biped" else None)
    feet = find_feet(robot.layout)
    assert len(feet) == legs
    rest = robot.layout.positions
    assert all(np.ptp(rest[foot, 1]) < 0.05 for foot in feet)
    assert [rest[f, 0].mean() for f in feet] == sorted(rest[f, 0].mean() for f in feet)


def stepping_and_sliding(layout, frames=20):
    """Foot 0 steps 0.1 forward while lifted in frames 5-9; foot 1 slides 0.1 along the floor."""
    feet = find_feet(layout)
    positions = np.repeat(np.asarray(layout.positions)[None], frames, axis=0)
    for t in range(frames):
        lifted = 5 <= t <= 9
        step = 0.1 * np.clip((t - 4) / 5, 0, 1)
        positions[t, feet[0], 1] += 0.05 * lifted
        positions[t, feet[0], 0] += step
        positions[t, feet[1], 0] += 0.1 * t / (frames - 1)
    return positions


def test_stepping_has_no_slip_and_sliding_is_all_slip():
    layout = litl.robots.get("biped", dx=1 / 32).layout
    gait = measure_gait(stepping_and_sliding(layout), layout, frame_dt=0.05)
    stepping, sliding = gait["feet"]
    assert stepping["liftoffs"] == 1 and stepping["lifted_fraction"] == pytest.approx(5 / 20)
    assert stepping["travel"] == pytest.approx(0.1) and stepping["slip"] == pytest.approx(0.0)
    assert stepping["max_height"] == pytest.approx(0.05)
    assert sliding["liftoffs"] == 0 and sliding["lifted_fraction"] == 0.0
    assert sliding["slip"] == pytest.approx(1.0) and sliding["travel"] == pytest.approx(0.1)
    assert gait["duration"] == pytest.approx(0.95)


def test_a_steady_pace_is_told_from_a_lunge_and_a_stretch():
    """late_speed: a body moving at 0.4 per second keeps it; one that lunges 0.2 forward in its
    first half and stands keeps none. stance_change: the front foot pushed 0.1 ahead of the body
    (a stretch) shows as a 0.1 longer stance; the moving body's stance stays as it was."""
    layout = litl.robots.get("quadruped").layout
    rest = np.asarray(layout.positions)
    frames, dt = 21, 0.05
    times = np.arange(frames) * dt
    steady = rest[None] + np.array([1.0, 0, 0]) * 0.4 * times[:, None, None]
    lunge = rest[None] + np.array([1.0, 0, 0]) * 0.2 * np.clip(times / 0.4, 0, 1)[:, None, None]
    stretch = np.repeat(rest[None], frames, axis=0)
    front = find_feet(layout)[-1]
    stretch[:, front, 0] += 0.1 * times[:, None] / times[-1]
    moving, lunging = (measure_gait(p, layout, dt) for p in (steady, lunge))
    stretching = measure_gait(stretch, layout, dt)
    assert moving["late_speed"] == pytest.approx(0.4) and moving["centroid_travel"] == pytest.approx(0.4)
    assert moving["stance_change"] == pytest.approx(0.0, abs=1e-12)
    assert lunging["late_speed"] == pytest.approx(0.0, abs=1e-12)
    assert lunging["centroid_travel"] == pytest.approx(0.2)
    assert stretching["stance_change"] == pytest.approx(0.1)


def test_a_still_robot_has_no_slip_to_report(tmp_path):
    robot = litl.robots.get("biped", dx=1 / 32)
    still = np.repeat(np.asarray(robot.layout.positions)[None], 3, axis=0)
    fig, gait = draw_gait(robot, still, frame_dt=0.1, path=tmp_path / "gait.png")
    assert [foot["slip"] for foot in gait["feet"]] == [None, None]
    assert (tmp_path / "gait.png").stat().st_size > 1000


def test_gait_pictures_of_2d_and_3d_robots(tmp_path):
    biped = litl.robots.get("biped", dx=1 / 32)
    draw_gait(biped, stepping_and_sliding(biped.layout), 0.05, path=tmp_path / "biped.png")
    quadruped = litl.robots.get("quadruped")
    moved = np.asarray(quadruped.layout.positions)[None] + np.linspace(0, 0.1, 4)[:, None, None]
    _, gait = draw_gait(quadruped, moved, 0.1, path=tmp_path / "quadruped.png", frames=3)
    assert len(gait["feet"]) == 4 and gait["centroid_travel"] == pytest.approx(0.1)
    assert (tmp_path / "biped.png").stat().st_size > 1000
    assert (tmp_path / "quadruped.png").stat().st_size > 1000


def test_bad_gait_inputs_say_what_is_wrong():
    layout = litl.robots.get("biped", dx=1 / 32).layout
    one_frame = np.asarray(layout.positions)[None]
    with pytest.raises(VizError, match="T >= 2 frames"):
        measure_gait(one_frame, layout, 0.1)
    with pytest.raises(VizError, match="frame_dt must be a positive"):
        measure_gait(np.repeat(one_frame, 2, axis=0), layout, 0.0)
    with pytest.raises(VizError, match="frames must be a positive integer"):
        draw_gait(layout, np.repeat(one_frame, 2, axis=0), 0.1, frames=0)

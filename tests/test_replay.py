"""`python -m litl.replay`: a saved robot simulated again reproduces the run's recorded loss, and
its animation, design picture and summary are written; bad requests fail clearly."""

import json

import numpy as np
import pytest
from PIL import Image

from litl.loop.run import run
from litl.replay import ReplayError, main, replay
from tests.loop.tiny import tiny_config, tiny_robot


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory):
    """A Python API run (no .hydra record): k-means, two seeds, one episode."""
    run_dir = tmp_path_factory.mktemp("replay") / "run"
    run(tiny_robot(), tiny_config(observer={"kind": "kmeans"}, loop={"episodes": 1}), run_dir, progress=False)
    return run_dir


def test_replay_reproduces_the_recorded_final_and_best_losses(finished_run, tmp_path):
    final = json.loads((finished_run / "final.json").read_text())
    # The two seeds' final losses (about 1e-4 apart) differ far beyond the tolerance below (about
    # 1e-8): a replay of the wrong seed's parameters cannot pass for the right one.
    assert abs(final[0]["task_loss"] - final[1]["task_loss"]) > 1e-6
    for seed in (0, 1):
        summary = replay(finished_run, seed=seed, out=tmp_path / f"seed{seed}.gif")
        # The loss simulated again against the one the run wrote (final.json, the run's own forward
        # simulation of its final parameters). The replay is another program than the run's (one
        # seed, not vmapped): equal to float32 rounding, rel=1e-5.
        assert summary["task_loss"] == pytest.approx(final[seed]["task_loss"], rel=1e-5, abs=1e-8)
        assert summary["recorded_loss"] == final[seed]["task_loss"]  # and reported beside it
        assert summary["steps"] == summary["run_steps"] == 40
        assert summary["components"]["distance"] == pytest.approx(-summary["task_loss"], abs=1e-6)
        # The walker stands on the floor (its feet a cell or so above the escape line) and is
        # far from the other walls.
        margins = summary["escape_margin_cells"]
        assert set(margins) == {"x_low", "x_high", "y_low", "y_high"}
        assert 1.0 < margins["y_low"] < 3.0 and min(margins.values()) == margins["y_low"]
    best = replay(finished_run, seed=1, which="best", out=tmp_path / "best.gif")
    assert best["task_loss"] == pytest.approx(best["recorded_loss"], abs=1e-6)


def test_replay_writes_animation_design_picture_and_summary(finished_run, tmp_path, capsys):
    out = tmp_path / "walk.gif"
    assert (
        main(
            [
                str(finished_run),
                "--seed",
                "1",
                "--steps",
                "60",
                "--out",
                str(out),
                "--color",
                "stiffness",
                "--stride",
                "5",
                "--gait",
            ]
        )
        == 0
    )
    summary = json.loads(out.with_suffix(".json").read_text())
    # --gait: the gait picture, its numbers in the summary and a line that says them.
    assert (tmp_path / "walk_gait.png").stat().st_size > 1000
    gait = summary["gait"]
    assert len(gait["feet"]) == 2 and np.isfinite([gait["late_speed"], gait["stance_change"]]).all()
    assert "per second over the second half" in capsys.readouterr().out
    assert summary["steps"] == 60 and summary["seed"] == 1
    with Image.open(out) as gif:
        assert gif.n_frames == 12  # 60 steps, one frame per 5
    design = np.asarray(Image.open(tmp_path / "walk_design.png"))
    assert design.shape[0] > 200 and design.std() > 10  # a picture, not a blank
    low, high = summary["design_bounds"]
    assert all(low <= e <= high for e in summary["design"])


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--seed", "7"], "seed 7: the run has seeds \\[0, 1\\]"),
        (["--out", "walk.png"], "use a .gif or .mp4"),
        (["--steps", "0"], "--steps 0: must be a positive integer"),
    ],
)
def test_bad_requests_fail_clearly(finished_run, tmp_path, capsys, arguments, message):
    with pytest.raises(SystemExit) as exit_info:
        main([str(finished_run), *arguments])
    assert exit_info.value.code == 2
    import re

    assert re.search(f"^litl.replay: error: .*{message}", capsys.readouterr().err, re.M)


def test_a_directory_that_is_not_a_finished_run_is_refused(tmp_path):
    with pytest.raises(ReplayError, match="no final/ parameters"):
        replay(tmp_path)
    (tmp_path / "final").mkdir()
    with pytest.raises(ReplayError, match="run.json cannot be read"):
        replay(tmp_path)


def test_a_run_from_before_the_strain_limit_replays_without_it(finished_run, tmp_path):
    import shutil

    from litl.replay import load_run_config

    robot, _ = load_run_config(finished_run)
    saved = json.loads((finished_run / "run.json").read_text())
    assert robot.config.max_stretch == saved["max_stretch"] == saved["material"]["max_stretch"] == 3.0
    older = tmp_path / "older"
    shutil.copytree(finished_run, older)
    # What run.json held before the limit existed.
    del saved["max_stretch"], saved["material"]["max_stretch"]
    (older / "run.json").write_text(json.dumps(saved))
    robot, _ = load_run_config(older)
    assert robot.config.max_stretch is None


def test_a_shifted_robot_run_from_python_replays_where_it_stood(tmp_path):
    from litl.replay import load_run_config

    shifted = tiny_robot().shifted(0.2)
    run_dir = tmp_path / "shifted"
    run(
        shifted,
        tiny_config(observer={"kind": "kmeans"}, seeds=1, loop={"episodes": 1}),
        run_dir,
        progress=False,
    )
    robot, _ = load_run_config(run_dir)  # no .hydra: the robot is rebuilt by name, then placed
    np.testing.assert_allclose(robot.layout.positions, shifted.layout.positions, atol=1e-12)
    final = json.loads((run_dir / "final.json").read_text())
    summary = replay(run_dir, out=tmp_path / "walk.gif")
    assert summary["task_loss"] == pytest.approx(final[0]["task_loss"], rel=1e-5, abs=1e-8)
    # a run.json from before the origin was recorded rebuilds the robot where its definition is
    saved = json.loads((run_dir / "run.json").read_text())
    del saved["origin"]
    (run_dir / "run.json").write_text(json.dumps(saved))
    robot, _ = load_run_config(run_dir)
    np.testing.assert_allclose(robot.layout.positions, tiny_robot().layout.positions, atol=1e-12)
    # a robot that stood elsewhere along y is not one litl can rebuild: refused, saying so
    saved["origin"] = [0.2, 0.5]
    (run_dir / "run.json").write_text(json.dumps(saved))
    with pytest.raises(ReplayError, match="moved along more than x"):
        load_run_config(run_dir)

"""The claims suite's plan (estimated time and memory per cell, jobs at once) and its scales."""

import pytest

from litl.app import compose
from litl.claims import plan
from litl.claims.cli import main
from litl.claims.suite import SCALES, ClaimsError, cells


def fake_measure(config):
    # Bigger robots cost more: an iteration's time follows the particles (here: the panel).
    return plan.Measurement(compile_s=10.0, iteration_s=0.5, device_bytes=3 * 2**30)


def test_the_paper_scale_runs_the_presets_as_they_are(tmp_path):
    suite = [c for c in cells(["fig4b"], ["litl"]) if c.variant.name == "vae"]
    (cell,) = suite
    config = compose(cell.overrides(SCALES["paper"], 10))
    assert config.robot.resolution.value == "paper" or config.robot.dx == pytest.approx(1 / 128)
    assert (config.seeds, config.loop.episodes, config.loop.iterations) == (10, 20, 10)
    demo = compose(cell.overrides(SCALES["demo"], 10))
    assert (demo.loop.episodes, demo.loop.iterations) == (6, 10)
    # --episodes: a longer run at the same scale, every other setting the scale's.
    longer = compose(cell.overrides(SCALES["demo"].with_episodes(10), 10))
    assert (longer.loop.episodes, longer.loop.iterations, longer.robot.dx) == (10, 10, demo.robot.dx)
    assert compose(cell.overrides(SCALES["paper"].with_episodes(3), 10)).loop.episodes == 3
    assert SCALES["demo"].label == "demo scale"
    assert SCALES["demo"].with_episodes(10).label == "demo scale, 10 episodes"
    assert SCALES["paper"].with_episodes(3).label == "paper scale, 3 episodes"


def test_the_plan_estimates_each_unfinished_cell_and_the_total(tmp_path):
    suite = cells(["fig4b", "fig4d"], ["litl"])
    measured = []

    def measure_once(config):
        measured.append(config)
        return fake_measure(config)

    planned = plan.plan(tmp_path, suite, lambda c: compose(c.overrides(SCALES["paper"], 10)), measure_once)
    assert len(measured) == 2  # one measurement per panel
    assert len(planned) == len(suite) == 6
    # 20 x 10 iterations of 0.5 s and one compilation.
    assert all(p.seconds == pytest.approx(10 + 200 * 0.5) for p in planned)
    assert plan.wall_time(planned, 1) == pytest.approx(6 * 110)
    assert plan.wall_time(planned, 4) == pytest.approx(2 * 110)
    lines = plan.describe(planned, 4)
    assert lines[0].startswith("  litl/fig4b/vae: 2000 records left, ~2 min, 3,072 MiB")
    assert (
        lines[-1] == "  6 cells, ~11 min one at a time; ~4 min with 4 at once "
        "(estimates from one measured iteration per panel)"
    )


def test_jobs_are_refused_below_one_or_beyond_the_devices_memory():
    planned = [plan.PlannedCell(cell, 10, 60.0, 3 * 2**30) for cell in cells(["fig4b"], ["litl"])]
    plan.check_jobs(planned, 3, 16 * 2**30)  # 9 GiB of 16: fits
    with pytest.raises(ClaimsError, match="--jobs must be at least 1; got 0"):
        plan.check_jobs(planned, 0, 16 * 2**30)
    with pytest.raises(
        ClaimsError, match=r"--jobs 3: the 3 largest cells need 9.0 GiB .* use --jobs 2 or fewer"
    ):
        plan.check_jobs(planned, 3, 8 * 2**30)
    plan.check_jobs(planned, 8, None)  # a device that does not report its memory: not refused


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--jobs", "0"], "--jobs must be at least 1"),
        (["--scale", "huge"], "invalid choice: 'huge'"),
        (["--episodes", "0"], "--episodes must be at least 1"),
    ],
)
def test_bad_scale_or_jobs_stop_before_anything_runs(tmp_path, capsys, argv, message):
    with pytest.raises(SystemExit) as exit_info:
        main(["--out", str(tmp_path / "out"), "--panels", "fig4b", *argv])
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_the_paper_scale_lists_its_commands(tmp_path, capsys):
    assert (
        main(["--out", str(tmp_path), "--scale", "paper", "--panels", "fig4b", "--methods", "litl", "--list"])
        == 0
    )
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 3 and all("seeds=10" in line and "resolution=demo" not in line for line in lines)


def test_a_suite_of_another_episode_count_is_refused_where_runs_of_the_first_lie(tmp_path, capsys):
    import json

    run_dir = tmp_path / "runs" / "litl" / "fig4b" / "vae"
    run_dir.mkdir(parents=True)
    size = {"seeds": 10, "loop": {"episodes": 6, "iterations": 10}}
    (run_dir / "run.json").write_text(json.dumps({"config": size}))
    argv = ["--out", str(tmp_path), "--panels", "fig4b", "--methods", "litl", "--report-only"]
    with pytest.raises(SystemExit) as exit_info:
        main([*argv, "--episodes", "10"])
    assert exit_info.value.code == 2
    assert "loop.episodes=6" in capsys.readouterr().err

"""End-to-end learning-in-the-loop runs at tiny size: observers, ablations, metrics, resume."""

import json
import pathlib
import signal
import subprocess
import sys
import time

import jax
import numpy as np
import pytest

from litl.config import SettingsError
from litl.loop.run import RunDirectoryError, load_final, run
from tests.loop.tiny import tiny_config, tiny_robot
from tests.processes import child_environment

ROOT = pathlib.Path(__file__).resolve().parents[2]
KEYS = {
    "seed",
    "episode",
    "iteration",
    "step",
    "task_loss",
    "task/distance",
    "design",
    "design_mean",
    "design_min",
    "design_max",
    "recon_loss_train",
    "recon_loss_val",
    "kl",
    "learning_epochs",
    "retrain_change",
    "wall_s",
    "first_nonfinite_step",
}


def without_time(records):
    return [{k: v for k, v in r.items() if k != "wall_s"} for r in records]


def read_metrics(run_dir):
    return [json.loads(line) for line in (pathlib.Path(run_dir) / "metrics.jsonl").read_text().splitlines()]


@pytest.fixture(scope="module")
def vae_run(tmp_path_factory):
    return run(
        tiny_robot(), tiny_config(loop={"episodes": 3}), tmp_path_factory.mktemp("vae"), progress=False
    )


@pytest.mark.gpu
def test_vae_run_writes_every_iteration_of_every_seed(vae_run):
    records = read_metrics(vae_run.run_dir)
    assert without_time(records) == without_time(vae_run.metrics)
    assert len(records) == 3 * 2 * 2  # episodes x iterations x seeds
    assert [(r["episode"], r["iteration"], r["seed"]) for r in records[:4]] == [
        (0, 0, 0),
        (0, 0, 1),
        (0, 1, 0),
        (0, 1, 1),
    ]
    for r in records:
        assert set(r) >= KEYS
        assert np.isfinite(r["task_loss"]) and r["first_nonfinite_step"] == -1
        assert r["learning_epochs"] >= 1 and r["recon_loss_val"] > 0 and r["kl"] > 0
        assert 5.0 <= r["design_min"] <= r["design_max"] <= 30.0 and len(r["design"]) == 4
        # Table 1: measured on iteration 1 of every episode that follows a learning phase.
        assert (r["retrain_change"] is not None) == (r["iteration"] == 1 and r["episode"] >= 1)
    # The seeds differ, and the design moved (co-design is on by default).
    assert records[0]["task_loss"] != records[1]["task_loss"]
    assert records[-1]["design"] != records[0]["design"]
    # The observer was retrained: its statistics change between episodes.
    assert records[0]["recon_loss_val"] != records[4]["recon_loss_val"]
    # learning.jsonl: the initial training (phase 0) and one phase after each episode, per seed.
    phases = [json.loads(line) for line in (vae_run.run_dir / "learning.jsonl").read_text().splitlines()]
    assert [(p["phase"], p["seed"]) for p in phases] == [(k, s) for k in range(4) for s in (0, 1)]
    for p in phases:
        assert len(p["val_recon_history"]) == p["epochs_used"] >= 1 and p["steps_per_epoch"] >= 1
    assert phases[2]["recon_loss_val"] == records[4]["recon_loss_val"]  # phase 1 serves episode 1


def test_final_parameters_are_saved_and_load(vae_run):
    final = load_final(vae_run.run_dir, tiny_robot(), tiny_config(loop={"episodes": 3}))
    np.testing.assert_array_equal(final["design"], vae_run.state.design)
    for a, b in zip(
        jax.tree.leaves(final["controller"]), jax.tree.leaves(vae_run.state.controller), strict=True
    ):
        np.testing.assert_array_equal(a, b)
    assert (vae_run.run_dir / "run.json").exists()


def test_best_parameters_are_saved_and_load(vae_run):
    """best.json names each seed's lowest task loss and its step; `which="best"` loads them."""
    best = json.loads((vae_run.run_dir / "best.json").read_text())
    assert [b["seed"] for b in best] == [0, 1]
    for entry in best:
        losses = [r["task_loss"] for r in vae_run.metrics if r["seed"] == entry["seed"]]
        # One value of one program, but XLA may compute it twice (into the metrics, into `best`)
        # and round the copies apart (the older CPU emitters the tests use: by 8e-10 of -8.6e-5).
        assert entry["task_loss"] == pytest.approx(min(losses), rel=1e-4)
        assert entry["step"] == int(np.argmin(losses))
    saved = load_final(vae_run.run_dir, tiny_robot(), tiny_config(loop={"episodes": 3}), which="best")
    np.testing.assert_array_equal(saved["design"], vae_run.state.best.design)
    for a, b in zip(
        jax.tree.leaves(saved["controller"]), jax.tree.leaves(vae_run.state.best.controller), strict=True
    ):
        np.testing.assert_array_equal(a, b)


@pytest.mark.slow
@pytest.mark.gpu
def test_resume_after_sigkill_gives_identical_results(vae_run, tmp_path, deterministic):
    run_dir = tmp_path / "killed"
    process = subprocess.Popen(
        [sys.executable, "-m", "tests.loop.tiny", str(run_dir), "3"],
        cwd=ROOT,
        env=child_environment(),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    deadline = time.monotonic() + 300
    metrics = run_dir / "metrics.jsonl"
    # Kill inside episode 2 (4 lines per episode): after its first iteration was written.
    while not (metrics.exists() and metrics.read_text().count("\n") >= 5):
        assert process.poll() is None, process.stderr.read().decode()[-2000:]
        assert time.monotonic() < deadline, "the run never reached its second episode"
        time.sleep(0.002)
    process.send_signal(signal.SIGKILL)
    assert process.wait() == -signal.SIGKILL
    written = len(read_metrics(run_dir))
    assert written < len(vae_run.metrics), "the run finished before it was killed"

    resumed = run(tiny_robot(), tiny_config(loop={"episodes": 3}), run_dir, progress=False)
    assert without_time(read_metrics(run_dir)) == without_time(read_metrics(vae_run.run_dir))
    learning = lambda d: without_time(
        [json.loads(line) for line in (d / "learning.jsonl").read_text().splitlines()]
    )
    assert learning(run_dir) == learning(vae_run.run_dir)
    for a, b in zip(jax.tree.leaves(resumed.state), jax.tree.leaves(vae_run.state), strict=True):
        np.testing.assert_array_equal(a, b)  # bitwise


def test_a_run_directory_refuses_other_settings(vae_run):
    before = (vae_run.run_dir / "metrics.jsonl").read_text()
    with pytest.raises(
        RunDirectoryError, match="other settings .*'config.loop.alpha'.*choose a new run directory"
    ):
        run(tiny_robot(), tiny_config(loop={"episodes": 3, "alpha": 0.9}), vae_run.run_dir, progress=False)
    assert (vae_run.run_dir / "metrics.jsonl").read_text() == before


def test_a_run_from_before_the_strain_limit_resumes_only_without_it(vae_run, tmp_path):
    import dataclasses
    import shutil

    older = tmp_path / "older"
    shutil.copytree(vae_run.run_dir, older)
    saved = json.loads((older / "run.json").read_text())
    del saved["max_stretch"], saved["material"]["max_stretch"]  # run.json before the limit
    (older / "run.json").write_text(json.dumps(saved))
    before = (older / "metrics.jsonl").read_text()
    with pytest.raises(RunDirectoryError, match=r"other settings .*'material.max_stretch', 'max_stretch'"):
        run(tiny_robot(), tiny_config(loop={"episodes": 3}), older, progress=False)
    assert (older / "metrics.jsonl").read_text() == before
    elastic = tiny_robot().with_material(dataclasses.replace(tiny_robot().material, max_stretch=float("inf")))
    assert elastic.config.max_stretch is None
    resumed = run(elastic, tiny_config(loop={"episodes": 3}), older, progress=False)
    assert len(resumed.metrics) == len(vae_run.metrics)  # nothing left to run: it was finished


def test_an_unusable_logger_fails_before_any_directory_is_made(tmp_path, monkeypatch):
    from litl.config import SettingsError

    monkeypatch.setitem(sys.modules, "wandb", None)  # `import wandb` fails, installed or not
    run_dir = tmp_path / "outputs" / "demo" / "biped"
    with pytest.raises(SettingsError, match="logger=wandb needs the Weights & Biases package"):
        run(tiny_robot(), tiny_config(output={"logger": "wandb"}), run_dir, progress=False)
    assert not (tmp_path / "outputs").exists()


@pytest.mark.gpu
def test_kmeans_baseline_runs_without_learning(tmp_path):
    result = run(tiny_robot(), tiny_config(observer={"kind": "kmeans"}), tmp_path, progress=False)
    assert len(result.metrics) == 2 * 2 * 2
    for r in result.metrics:
        # It does not learn: no learning statistics, only the loop's update_accepted.
        assert np.isfinite(r["task_loss"]) and "recon_loss_val" not in r and "learning_epochs" not in r
        assert r["update_accepted"] and r["retrain_change"] is None
    assert result.state.observer.averaging.shape == (2, 3, tiny_robot().layout.n_particles)


@pytest.mark.gpu
def test_open_loop_sinusoid_baseline_learns_without_an_observer(tmp_path):
    from litl.config import SettingsError
    from litl.report import write_report

    # The design fixed (loop.codesign=false), so that only the sinusoids' own learning moves the loss.
    config = tiny_config(
        observer={"kind": "none"},
        controller={"kind": "sinusoid", "learning_rate": 0.1},
        loop={"codesign": False},
    )
    result = run(tiny_robot(), config, tmp_path, progress=False)
    for seed in (0, 1):
        records = [r for r in result.metrics if r["seed"] == seed]
        losses = np.asarray([r["task_loss"] for r in records])
        # Gradient steps of a small learning rate on a smooth loss: it falls at every iteration, by
        # about 5e-5 each (2026-12-05), four orders above float32 rounding of losses near 1e-4.
        assert np.all(np.isfinite(losses)) and np.all(np.diff(losses) < 0), losses
        assert all(r["design"] == records[0]["design"] for r in records)  # the design never moved
    assert all("learning_epochs" not in r and "recon_loss_val" not in r for r in result.metrics)
    assert result.state.controller["params"]["weights"].shape == (2, tiny_robot().n_actuators, 4)
    report = write_report(tmp_path)
    assert [g["label"] for g in report.summary["groups"]] == ["sinusoid, control only"]
    with pytest.raises(SettingsError, match="reads no observer.*observer none"):
        tiny_config(controller={"kind": "sinusoid"})


def test_the_closed_loop_controller_reads_a_clock_unless_switched_off():
    """By default the MLP sees (sin, cos) of a clock at the sinusoid baseline's frequency beside
    the features; controller.period=None gives the features-only controller."""
    import jax.numpy as jnp

    from litl.config import CLOCK_PERIOD
    from litl.loop.algorithm import make_algorithm

    assert tiny_config().controller.mlp.period == pytest.approx(2 * np.pi / 30)
    times = jnp.linspace(0.0, CLOCK_PERIOD, 5)
    for period, clocked in ((CLOCK_PERIOD, True), (None, False)):
        algorithm = make_algorithm(
            tiny_robot(),
            tiny_config(observer={"kind": "kmeans"}, controller={"mlp": {"period": period}}).algorithm,
        )
        params = algorithm.init(0).controller
        features = jnp.full((algorithm.n_features,), 0.3)  # a robot whose state holds still
        actuation = np.stack([algorithm.controller.apply(params, features, time=t) for t in times])
        assert (np.ptp(actuation, axis=0).max() > 1e-3) == clocked
        # One period later the clock reads the same.
        np.testing.assert_allclose(actuation[-1], actuation[0], atol=1e-5)
    # The controller takes the configured input gain on the features (0.2 by default).
    for scale in (None, 1.0):
        changes = {} if scale is None else {"controller": {"mlp": {"feature_scale": scale}}}
        algorithm = make_algorithm(
            tiny_robot(), tiny_config(observer={"kind": "kmeans"}, **changes).algorithm
        )
        assert algorithm.controller.feature_scale == (0.2 if scale is None else scale)


def test_learned_observer_sees_a_window_that_follows_the_robot():
    """At dx 1/64 the VAE reads a 32 x 32 window around the centroid, and stores those windows."""
    import litl.robots
    from litl.loop.algorithm import make_algorithm

    robot = litl.robots.get("biped", dx=1 / 64)
    algorithm = make_algorithm(
        robot, tiny_config(seeds=1, sim={"steps": 20}, observer={"vae": {"window": 0.5}}).algorithm
    )
    assert algorithm.model.grid_shape == (32, 32)
    state, _ = jax.jit(algorithm.bootstrap)(algorithm.init(0))
    fields = np.asarray(state.buffer.fields[: int(state.buffer.count)])
    assert fields.shape[1:] == (32, 32, 2) and len(fields) == 2
    # The robot (nonzero velocity) sits in the middle of the window, not at an edge: its
    # occupied nodes' centre is within a few nodes of the window's centre horizontally.
    occupied = np.argwhere(np.any(fields[-1] != 0, axis=-1))
    assert abs(occupied[:, 0].mean() - 16) < 3
    # Vertically the window is clamped at the floor (centred on the robot it would start ~10 nodes
    # below the grid): its rows are the grid's first 32, so the robot's lowest occupied node is
    # where its feet stand in the grid (node 4; the B-spline stencil and 20 steps of motion move
    # it by a node or two).
    feet = np.asarray(robot.layout.positions)[:, 1].min() * 64
    assert abs(occupied[:, 1].min() - feet) <= 2
    assert algorithm.steps == 20


@pytest.mark.gpu
def test_plain_autoencoder_simultaneous_and_control_only(tmp_path):
    config = tiny_config(observer={"kind": "ae"}, loop={"schedule": "simultaneous", "codesign": False})
    result = run(tiny_robot(), config, tmp_path, progress=False)
    first = result.metrics[0]
    for r in result.metrics:
        assert r["kl"] == 0.0  # a plain autoencoder
        assert np.isfinite(r["simultaneous_recon_loss"])  # an observer step per iteration
        assert r["recon_loss_val"] == first["recon_loss_val"] or r["seed"] != first["seed"]
        assert r["retrain_change"] is None  # no learning phases
        assert r["design"] == [20.0] * 4  # control only
    assert result.metrics[0]["simultaneous_recon_loss"] != result.metrics[-2]["simultaneous_recon_loss"]


def test_one_shot_observer_without_replay(tmp_path):
    config = tiny_config(loop={"schedule": "one_shot", "replay_buffer": False})
    result = run(tiny_robot(), config, tmp_path, progress=False)
    for seed in (0, 1):
        stats = {(r["recon_loss_val"], r["learning_epochs"]) for r in result.metrics if r["seed"] == seed}
        assert len(stats) == 1  # learned once, at the start
    # Without replay the buffer holds only the latest rollout's 40 / 10 snapshots.
    np.testing.assert_array_equal(result.state.buffer.count, [4, 4])


def test_a_tight_memory_budget_segments_the_backward_pass_and_changes_no_result(tmp_path, capsys):
    plain = run(
        tiny_robot(),
        tiny_config(observer={"kind": "kmeans"}, sim={"checkpoint_every": None}),
        tmp_path / "plain",
        progress=False,
    )
    capsys.readouterr()
    # 40 steps of the 32 x 32 biped keep 0.27 MiB per seed, 0.12 MiB in segments of 10 steps
    # (k-means reads particles, not the grid): 0.4 MiB for the two seeds fits only the latter.
    tight = run(
        tiny_robot(),
        tiny_config(observer={"kind": "kmeans"}, sim={"memory_budget": 0.4 / 1024}),
        tmp_path / "tight",
        progress=False,
    )
    said = capsys.readouterr().err
    assert "segments of 10 steps" in said and "sim.memory_budget" in said
    for a, b in zip(plain.metrics, tight.metrics, strict=True):
        assert a["task_loss"] == pytest.approx(b["task_loss"], rel=1e-5, abs=1e-7)
    # The budget is not a result: a run resumes with another.
    resumed = run(tiny_robot(), tiny_config(observer={"kind": "kmeans"}), tmp_path / "tight", progress=False)
    assert len(resumed.metrics) == len(tight.metrics)


def test_checkpoint_every_must_be_a_multiple_of_the_snapshot_stride(tmp_path):
    with pytest.raises(SettingsError, match="sim.checkpoint_every=15 must be a multiple"):
        run(tiny_robot(), tiny_config(sim={"checkpoint_every": 15}), tmp_path, progress=False)

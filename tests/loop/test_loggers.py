"""Live logs: TensorBoard event files that mirror metrics.jsonl and learning.jsonl (scalars per
seed, reconstruction losses per learning epoch, snapshot images at episode boundaries), rewritten
on resume; a logger that cannot be used is refused before the run starts."""

import json
import struct

import pytest

from litl.config import SettingsError
from litl.loop.loggers import check_kind
from litl.loop.run import run
from tests.loop.tiny import tiny_config, tiny_robot


def read_events(directory):
    """{tag: {step: value or 'image'}} from the TFRecord event files in `directory`."""
    from tensorboardX.proto.event_pb2 import Event

    found = {}
    for path in sorted(directory.glob("events.out.tfevents.*")):
        data = path.read_bytes()
        offset = 0
        while offset < len(data):
            (length,) = struct.unpack("<Q", data[offset : offset + 8])
            event = Event.FromString(data[offset + 12 : offset + 12 + length])
            offset += 12 + length + 4
            for value in event.summary.value:
                kind = "image" if value.HasField("image") else value.simple_value
                found.setdefault(value.tag, {})[event.step] = kind
    return found


@pytest.fixture(scope="module")
def logged_run(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("logged") / "run"
    run(tiny_robot(), tiny_config(), run_dir, progress=False)
    return run_dir


def test_event_files_mirror_the_metrics_per_seed(logged_run):
    metrics = [json.loads(line) for line in (logged_run / "metrics.jsonl").read_text().splitlines()]
    learning = [json.loads(line) for line in (logged_run / "learning.jsonl").read_text().splitlines()]
    for seed in (0, 1):
        events = read_events(logged_run / "tensorboard" / f"seed{seed}")
        mine = [r for r in metrics if r["seed"] == seed]
        assert events["task/loss"] == pytest.approx({r["step"]: r["task_loss"] for r in mine})
        assert set(events["task/distance"]) == {r["step"] for r in mine}
        for tag in (
            "design/mean",
            "design/max",
            "gradients/controller_norm",
            "gradients/design_norm",
            "learning/recon_loss_val",
            "learning/recon_explained",
            "learning/active_units",
            "learning/velocity_r2_x",
        ):
            assert tag in events, tag
        phases = [r for r in learning if r["seed"] == seed]
        assert sorted(events["learning/recon_loss_val"]) == [r["phase"] * 2 for r in phases]
        # One point per learning epoch, on the axis of SGD steps since the run began.
        epochs = sum(r["epochs_used"] for r in phases)
        assert len(events["learning/val_recon_by_sgd_step"]) == epochs
        assert max(events["learning/val_recon_by_sgd_step"]) == sum(r["sgd_steps"] for r in phases)
    # Images of the first seed's snapshots and reconstructions at every episode boundary.
    images = read_events(logged_run / "tensorboard" / "seed0")["observer/snapshots"]
    assert images == {0: "image", 2: "image", 4: "image"}


def test_a_resumed_run_rewrites_its_logs_from_the_records(logged_run, tmp_path):
    import shutil

    copy = tmp_path / "copy"
    shutil.copytree(logged_run, copy)
    (copy / "tensorboard" / "seed0" / "stale").mkdir()  # replaced, not appended to
    run(tiny_robot(), tiny_config(), copy, progress=False)  # finished: nothing to do
    assert not (copy / "tensorboard" / "seed0" / "stale").exists()
    events = read_events(copy / "tensorboard" / "seed0")
    assert events["task/loss"] == read_events(logged_run / "tensorboard" / "seed0")["task/loss"]


def test_loggers_that_cannot_be_used_are_refused_up_front(tmp_path):
    with pytest.raises(SettingsError, match="choose one of"):
        check_kind("tensorbored")
    try:
        import wandb  # noqa: F401
    except ImportError:
        with pytest.raises(SettingsError, match="logger=wandb needs the Weights & Biases package"):
            run(tiny_robot(), tiny_config(output={"logger": "wandb"}), tmp_path / "w", progress=False)
        assert not (tmp_path / "w" / "run.json").exists()


class _FakeWandbRun:
    def __init__(self, resumed):
        self.resumed, self.logged, self.metrics, self.finished = resumed, [], [], False

    def define_metric(self, name, **options):
        self.metrics.append((name, options))

    def log(self, values):
        self.logged.append(values)

    def finish(self):
        self.finished = True


@pytest.mark.parametrize("resumed", [False, True])
def test_wandb_logs_per_seed_against_litl_steps_and_restores_only_a_new_run(tmp_path, monkeypatch, resumed):
    """Without the wandb package installed: a stand-in module records what the logger sends."""
    import sys
    import types

    from litl.loop.loggers import make_logger

    fake_run = _FakeWandbRun(resumed)
    fake = types.ModuleType("wandb")
    fake.init = lambda **options: fake_run
    fake.Image = lambda pixels: ("image", pixels.shape)
    monkeypatch.setitem(sys.modules, "wandb", fake)
    logger = make_logger("wandb", tmp_path, seeds=[3, 4], iterations=2)
    assert ("*", {"step_metric": "litl_step"}) in fake_run.metrics
    history = [{"seed": 3, "step": 0, "task_loss": -0.1}, {"seed": 4, "step": 0, "task_loss": -0.2}]
    phase = {
        "seed": 4,
        "phase": 0,
        "steps_per_epoch": 5,
        "sgd_steps": 10,
        "val_recon_history": [0.3, 0.2],
        "recon_explained": 0.5,
    }
    logger.restore(history, [phase])
    assert (fake_run.logged == []) == resumed  # a resumed W&B run holds its history already
    logger.iteration([{"seed": 4, "step": 1, "task_loss": -0.25}])
    last = fake_run.logged[-1]
    assert last["litl_step"] == 1 and last["seed4/task/loss"] == -0.25
    # The next phase's per-epoch curve continues after the restored phase's 10 SGD steps.
    logger.phase([{**phase, "phase": 1, "val_recon_history": [0.1]}])
    curve = [v for v in fake_run.logged if "seed4/learning/val_recon_by_sgd_step" in v]
    assert curve[-1]["litl_step"] == 15
    logger.close()
    assert fake_run.finished

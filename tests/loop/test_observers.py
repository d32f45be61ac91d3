"""The observer interface: the built-in observers through it, and a fourth one added from outside
(one module) that runs through the CLI, the report and the pictures."""

import json
import os
import pathlib
import re
import subprocess
import sys

import jax
import jax.numpy as jnp
import pytest

from litl.config import SettingsError
from litl.loop import observers
from tests.loop.tiny import tiny_config, tiny_robot

ROOT = pathlib.Path(__file__).resolve().parents[2]

# The guide's example module: a fixed random projection of the grid velocity field.
GUIDE = ROOT / "docs" / "guide" / "observers.md"
(PROJECTION_MODULE,) = [
    block
    for block in re.findall(r"```python\n(.*?)```", GUIDE.read_text(), re.S)
    if block.startswith("# my_observers.py")
]


def test_builtin_observers_through_the_interface():
    robot = tiny_robot()
    config = robot.config
    for name, n_features, learned in (
        ("vae", 4, True),
        ("ae", 4, True),
        ("kmeans", 2 * 3 * 2, False),
        ("none", 0, False),
    ):
        observer = observers.make(name, robot, tiny_config(observer={"kind": name}), config, jnp.float32)
        assert (observer.n_features, observer.learned) == (n_features, learned), name
        params = observer.init(jax.random.key(0), 0)
        state = robot.initial_state()
        field = jnp.zeros(config.grid_shape + (config.dim,))
        assert observer.features(params, state, field).shape == (n_features,), name


def test_register_refuses_a_taken_or_empty_name_and_config_names_the_choices():
    with pytest.raises(ValueError, match="already registered"):
        observers.register("vae", lambda *args: None)
    with pytest.raises(ValueError, match="non-empty string"):
        observers.register("", lambda *args: None)
    with pytest.raises(SettingsError, match="observer.kind='vea': unknown observer; choose one of .*kmeans"):
        observers.check_kind(tiny_config(observer={"kind": "vea"}))


def test_a_fourth_observer_runs_through_the_cli_report_and_pictures(tmp_path):
    (tmp_path / "my_observers.py").write_text(PROJECTION_MODULE)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    run_dir = tmp_path / "run"
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "litl",
            "observer.kind=random_projection",
            "observer.module=my_observers",
            "observer.vae.latent_dim=3",
            "+scale=smoke",
            "loop.episodes=1",
            "output.progress=false",
            f"hydra.run.dir={run_dir}",
        ],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    settings = json.loads((run_dir / "run.json").read_text())
    assert settings["observer"] == {"learned": False, "reads": ["observer.vae"]}
    assert settings["config"]["observer"]["kind"] == "random_projection"
    records = [json.loads(line) for line in (run_dir / "metrics.jsonl").read_text().splitlines()]
    assert len(records) == 2 and all(r["recon_loss_val"] is None for r in records)
    for name in ("robot.png", "robot.gif", "task_loss.png"):
        assert (run_dir / name).stat().st_size > 0, name
    report = subprocess.run(
        [sys.executable, "-m", "litl.report", str(run_dir)],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert report.returncode == 0, report.stderr[-3000:]
    assert "random_projection" in (run_dir / "summary.md").read_text()

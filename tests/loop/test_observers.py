"""The observer interface: the built-in observers through it, and a fourth one added from outside
(one module) that runs through the CLI, the report and the pictures."""

import json
import pathlib
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.config import SettingsError
from litl.loop import observers
from tests.guide import guide_block
from tests.loop.tiny import tiny_config, tiny_robot
from tests.processes import child_environment

ROOT = pathlib.Path(__file__).resolve().parents[2]

# The guide's example module: a fixed random projection of the grid velocity field.
PROJECTION_MODULE = guide_block("observers.md", "# my_observers.py")


def test_builtin_observers_through_the_interface():
    robot = tiny_robot()
    config = robot.config
    for name, n_features, learned in (
        ("vae", 4, True),
        ("ae", 4, True),
        ("kmeans", 2 * 3 * 2, False),
        ("pca", 8, True),
        ("none", 0, False),
    ):
        context = observers.ObserverContext(config, jnp.float32, tiny_config().loop.learning)
        observer = observers.make(tiny_config(observer={"kind": name}).observer, robot, context)
        assert (observer.n_features, observer.learned) == (n_features, learned), name
        params = observer.init(jax.random.key(0), 0)
        state = robot.initial_state()
        field = jnp.zeros(config.grid_shape + (config.dim,))
        assert observer.features(params, state, field).shape == (n_features,), name


def test_each_observer_says_which_grid_field_it_reads_and_the_loop_follows_it():
    from litl.loop import make_algorithm
    from litl.observers import GridField
    from litl.sim.fields import grid_velocity

    robot = tiny_robot()
    # The VAE's section says mass-weighted; only the VAE reads it. PCA reads its own key, and
    # k-means and no observer read no grid field at all.
    changes = {"vae": {"field": "mass_weighted"}, "pca": {"field": "velocity"}}
    expected = {"vae": GridField.mass_weighted, "ae": GridField.mass_weighted, "pca": GridField.velocity}
    for name in ("vae", "ae", "pca", "kmeans", "none"):
        config = tiny_config(observer={"kind": name, **changes})
        context = observers.ObserverContext(robot.config, jnp.float32, config.loop.learning)
        observer = observers.make(config.observer, robot, context)
        assert observer.field == expected.get(name), name
        plain = make_algorithm(robot, config.algorithm).field is grid_velocity
        assert plain == (expected.get(name) != GridField.mass_weighted), name


def test_register_refuses_a_taken_or_empty_name_and_config_names_the_choices():
    with pytest.raises(SettingsError, match="'vae' is already registered .*replace=True"):
        observers.register("vae", lambda robot, settings, context: None)
    with pytest.raises(SettingsError, match="must be an identifier"):
        observers.register("", lambda robot, settings, context: None)
    with pytest.raises(SettingsError, match="settings must be a frozen dataclass"):
        observers.register("odd", lambda robot, settings, context: None, settings=dict)
    with pytest.raises(SettingsError, match=r"factory\(robot, settings, context\) since"):
        observers.register("old", lambda robot, config, sim_config, dtype: None)  # the old signature
    assert "odd" not in observers.names() and "old" not in observers.names()
    with pytest.raises(SettingsError, match="observer.kind='vea': unknown observer; choose one of .*kmeans"):
        tiny_config(observer={"kind": "vea"})


def test_settings_that_would_break_a_run_late_are_refused_when_registered_or_configured(user_module):
    """A plain frozen dataclass as an observer's settings (its values would be neither checked nor
    written to run.json) is refused at register() with one line saying to subclass Settings; a
    default value run.json cannot hold is refused at register(), and such a value given later
    when the observer is configured, before any run starts."""
    import dataclasses
    from typing import Any

    from litl.settings import Settings

    def factory(robot, settings, context):
        return None

    @dataclasses.dataclass(frozen=True)
    class Plain:
        features: int = 4

    with pytest.raises(
        SettingsError,
        match="^observer 'plain': settings Plain is a plain dataclass; subclass litl.settings.Settings",
    ) as refused:
        observers.register("plain", factory, Plain)
    assert "\n" not in str(refused.value)

    @dataclasses.dataclass(frozen=True)
    class FloatType(Settings):
        dtype: Any = np.float32  # a type, not a value run.json can hold

    with pytest.raises(
        SettingsError,
        match=r"^observer.float_type.dtype=<class 'numpy.float32'>: cannot be written to run.json",
    ) as refused:
        observers.register("float_type", factory, FloatType)
    assert refused.value.key == "observer.float_type.dtype"

    @dataclasses.dataclass(frozen=True)
    class Required(Settings):
        features: int

    with pytest.raises(SettingsError, match="cannot be built from its defaults.*every field needs a default"):
        observers.register("required", factory, Required)
    assert not {"plain", "float_type", "required"} & set(observers.names())

    @dataclasses.dataclass(frozen=True)
    class Loose(Settings):
        extra: Any = None  # what its annotation admits is its own check's to say

    observers.register("loose", factory, Loose)
    assert tiny_config(observer={"loose": {"extra": [1, "a", None]}}).observer.loose.extra == (1, "a", None)
    with pytest.raises(SettingsError, match=r"^observer.loose.extra=\{1, 2\}: cannot be written to run.json"):
        tiny_config(observer={"kind": "loose", "loose": {"extra": {1, 2}}})


def test_a_fourth_observer_runs_through_the_cli_report_and_pictures(tmp_path):
    (tmp_path / "my_observers.py").write_text(PROJECTION_MODULE)
    env = child_environment()
    run_dir = tmp_path / "run"
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "litl",
            "observer=random_projection",  # an option of the group once its module is imported
            "observer.module=my_observers",
            "observer.random_projection.features=3",
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
    assert settings["observer"] == {"learned": False, "reads": ["observer.random_projection"]}
    assert settings["config"]["observer"] == {
        "kind": "random_projection",
        "module": "my_observers",
        "random_projection": {"features": 3},  # its own section, and only it
    }
    records = [json.loads(line) for line in (run_dir / "metrics.jsonl").read_text().splitlines()]
    # It does not learn: no statistics of its own in the records (the loop's update_accepted only).
    assert len(records) == 2 and all("recon_loss_val" not in r and r["update_accepted"] for r in records)
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


@pytest.fixture
def user_module(tmp_path, monkeypatch):
    """The guide's module importable from tmp_path; the registries as they were afterwards."""
    from litl.controllers import CONTROLLERS
    from litl.observers import OBSERVERS

    (tmp_path / "my_observers.py").write_text(PROJECTION_MODULE)
    (tmp_path / "registers_nothing.py").write_text("X = 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    for registry in (OBSERVERS, CONTROLLERS):
        monkeypatch.setattr(registry, "_entries", dict(registry._entries))
    yield
    for name in ("my_observers", "registers_nothing"):
        sys.modules.pop(name, None)


def test_a_users_observer_has_its_own_checked_settings_from_the_command_line(user_module):
    from litl.app import compose

    base = ["observer=random_projection", "observer.module=my_observers"]
    config = compose([*base, "observer.random_projection.features=5"])
    assert config.observer.kind == "random_projection" and config.observer.random_projection.features == 5
    assert config.observer.section == config.observer.random_projection
    assert config.run_settings()["observer"] == {
        "kind": "random_projection",
        "module": "my_observers",
        "random_projection": {"features": 5},
    }
    # The same from Python, and the built-ins' sections are still there (presets set them).
    same = tiny_config(observer={"kind": "random_projection", "random_projection": {"features": 5}})
    assert same.observer.random_projection == config.observer.random_projection
    assert same.observer.vae.latent_dim == 4
    # Bad input: an unknown key names the observer and its valid keys; a wrong type and a value
    # its own check refuses name the key in full.
    with pytest.raises(SettingsError, match=r"(?s)width.*random_projection.*\['features'\]"):
        compose([*base, "observer.random_projection.width=3"])
    with pytest.raises(SettingsError, match="observer.random_projection.features"):
        compose([*base, "observer.random_projection.features=abc"])
    with pytest.raises(
        SettingsError, match="^observer.random_projection.features=0: must be a positive integer"
    ):
        compose([*base, "observer.random_projection.features=0"])
    with pytest.raises(
        SettingsError, match="observer.random_projection.features='3': must be a positive integer"
    ):
        tiny_config(observer={"kind": "random_projection", "random_projection": {"features": "3"}})
    with pytest.raises(SettingsError, match=r"unknown setting\(s\) \['observer.random_projection.width'\]"):
        tiny_config(observer={"random_projection": {"width": 3}})
    # A module that registers nothing of that name, and one that cannot be imported.
    with pytest.raises(SettingsError, match="observer.module='registers_nothing' registered no observer"):
        compose(["observer.kind=random_projection2", "observer.module=registers_nothing"])
    with pytest.raises(SettingsError, match="observer.module='no_such_module' could not be imported"):
        compose(["observer.module=no_such_module"])


def test_a_registered_controller_with_its_own_settings_runs_the_loop(user_module, tmp_path):
    """Controllers register like observers: a user's open-loop controller with one setting."""
    import dataclasses

    from litl import controllers
    from litl.app import compose
    from litl.loop.run import run
    from litl.models.open_loop import SinusoidController
    from litl.settings import Settings

    @dataclasses.dataclass(frozen=True)
    class SlowWave(Settings):
        omega: float = 5.0

        def check(self):
            self._positive_numbers("omega")

    def slow_wave(robot, settings, context):
        return controllers.Controller(SinusoidController(robot.n_actuators, omega=settings.omega))

    controllers.register("slow_wave", slow_wave, SlowWave, open_loop=True)
    config = compose(["controller.kind=slow_wave", "controller.slow_wave.omega=2.5", "observer=none"])
    assert config.controller.slow_wave.omega == 2.5
    with pytest.raises(SettingsError, match="the slow_wave controller is open loop"):
        compose(["controller.kind=slow_wave"])
    with pytest.raises(SettingsError, match="controller.slow_wave.omega=-1.0: must be a positive number"):
        compose(["controller.kind=slow_wave", "controller.slow_wave.omega=-1", "observer=none"])
    tiny = tiny_config(
        observer={"kind": "none"}, controller={"kind": "slow_wave", "slow_wave": {"omega": 2.5}}
    )
    result = run(
        tiny_robot(),
        dataclasses.replace(tiny, loop=dataclasses.replace(tiny.loop, episodes=1)),
        tmp_path,
        progress=False,
    )
    recorded = json.loads((tmp_path / "run.json").read_text())["config"]["controller"]
    assert recorded == {
        "kind": "slow_wave",
        "module": None,
        "learning_rate": tiny.controller.learning_rate,
        "slow_wave": {"omega": 2.5},
    }
    assert all(np.isfinite(r["task_loss"]) for r in result.metrics)


def mean_speed_observer(robot, settings, context):
    """A toy learning observer, defined here and registered from the test: its one feature is the
    window's mean speed over a scale it learns (each phase: the buffer's mean speed)."""
    from litl.models.replay_buffer import valid_mask
    from litl.models.window import Window
    from litl.observers import Learner, Observer

    sim_config, dtype = context.sim, context.dtype
    window = Window.around(sim_config.grid_shape, sim_config.dx, 0.5)

    def features(scale, state, grid_velocity):
        field = window.crop(grid_velocity, jnp.mean(state.x, axis=0))
        return jnp.mean(jnp.linalg.norm(field, axis=-1))[None] / scale

    def phase(scale, buffer, key):
        mask = valid_mask(buffer)
        speeds = jnp.mean(
            jnp.linalg.norm(buffer.fields, axis=-1), axis=tuple(range(1, buffer.fields.ndim - 1))
        )
        mean = jnp.sum(jnp.where(mask, speeds, 0.0)) / jnp.maximum(jnp.sum(mask), 1)
        learned = jnp.maximum(mean, 1e-6).astype(scale.dtype)
        return learned, {"mean_speed": mean, "snapshots": jnp.sum(mask)}

    def pictures(robot, algorithm, state, run_dir, stride):
        path = run_dir / "mean_speed.txt"
        path.write_text(f"{float(state.observer):.6g}\n")
        return [path]

    learner = Learner(
        window=window,
        phase=phase,
        step=None,
        optimizer_init=lambda scale: (),
        empty_statistics=lambda dtype, dim: {
            "mean_speed": jnp.full((), jnp.nan, dtype),
            "snapshots": jnp.zeros((), jnp.int32),
        },
    )
    return Observer(
        n_features=1,
        init=lambda key, seed: jnp.ones((), dtype),
        features=features,
        learner=learner,
        pictures=pictures,
    )


def test_a_learning_observer_defined_here_runs_through_the_loop_and_the_pictures(tmp_path):
    from litl.loop.run import run
    from litl.viz.run_pictures import draw_run

    observers.register("mean_speed", mean_speed_observer, replace=True)
    config = tiny_config(observer={"kind": "mean_speed"}, seeds=1)
    result = run(tiny_robot(), config, tmp_path, progress=False)
    phases = [json.loads(line) for line in (tmp_path / "learning.jsonl").read_text().splitlines()]
    assert [p["phase"] for p in phases] == [0, 1, 2]
    assert all(
        set(p) == {"seed", "phase", "mean_speed", "snapshots", "update_accepted", "wall_s"} for p in phases
    )
    assert phases[-1]["snapshots"] > phases[0]["snapshots"] > 0
    # Its statistics are repeated in every iteration's record, as written out by its learner.
    assert all("mean_speed" in r for r in result.metrics)
    assert float(result.state.observer[0]) != 1.0  # it learned a scale
    written = draw_run(tiny_robot(), config.context(), result, tmp_path, animation=False)
    assert (tmp_path / "mean_speed.txt") in written


def test_pca_runs_through_the_loop_report_and_pictures(tmp_path):
    from litl.loop.run import run
    from litl.viz.run_pictures import draw_run

    config = tiny_config(observer={"kind": "pca", "pca": {"components": 3}}, seeds=1)
    result = run(tiny_robot(), config, tmp_path, progress=False)
    settings = json.loads((tmp_path / "run.json").read_text())
    assert settings["observer"] == {"learned": True, "reads": ["observer.pca", "loop.learning"]}
    phases = [json.loads(line) for line in (tmp_path / "learning.jsonl").read_text().splitlines()]
    assert len(phases) == 3 and all(0.0 <= p["recon_explained"] <= 1.0 for p in phases[1:])
    assert all(r["recon_loss_val"] is not None for r in result.metrics)
    written = draw_run(tiny_robot(), config.context(), result, tmp_path, animation=False)
    for name in ("pca.png", "recon_loss.png", "task_loss.png"):
        assert (tmp_path / name) in written, name

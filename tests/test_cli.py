"""`python -m litl` end to end in fresh processes: the default job (smoke-sized), the ways out of a
bad setting (exit status, one line, no directory left), and sweeps with the basic, joblib (a robot
of every kind at smoke scale) and submitit_local launchers. What a setting's check says is tested
in process (`compose`, as the command line composes), where it costs no start of a process.

The processes run from a temporary directory, so they import the installed package when litl is
installed (the README's commands install it non-editable) and the source tree otherwise.
"""

import importlib.metadata
import importlib.util
import json
import os
import pathlib
import re
import subprocess
import sys

import pytest

from tests.processes import child_environment

ROOT = pathlib.Path(__file__).resolve().parents[1]
QUIET = ["output.pictures=false", "output.animation=false", "output.progress=false"]


def litl_command(args, cwd, timeout=600):
    env = dict(os.environ)
    try:
        importlib.metadata.distribution("litl")
    except importlib.metadata.PackageNotFoundError:
        env = child_environment()
    return subprocess.run(
        [sys.executable, "-m", "litl", *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def gallery_script():
    """notebooks/gallery/make_gallery.py as a module (it is a script, not part of the package)."""
    spec = importlib.util.spec_from_file_location(
        "make_gallery", ROOT / "notebooks" / "gallery" / "make_gallery.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def run_dirs(root):
    return sorted(p.parent for p in pathlib.Path(root).rglob("metrics.jsonl"))


@pytest.mark.slow
def test_default_job_at_smoke_scale_leaves_metrics_plots_animation_and_checkpoint(tmp_path):
    done = litl_command(["+scale=smoke", "seeds=2"], tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    (run_dir,) = run_dirs(tmp_path / "outputs")
    # outputs/<experiment>/<robot>/<observer>/<time>
    assert run_dir.relative_to(tmp_path).parts[:4] == ("outputs", "demo", "biped", "vae")
    records = [json.loads(line) for line in (run_dir / "metrics.jsonl").read_text().splitlines()]
    assert len(records) == 2 * 2 * 2 and {r["seed"] for r in records} == {0, 1}
    for name in (
        "task_loss.png",
        "recon_loss.png",
        "recon_sgd.png",
        "learning.jsonl",
        "robot.png",
        "robot.gif",
        "snapshots.png",
        "latent_sweeps.png",
        "saliency.gif",
        "summary.md",
        "table1.csv",
    ):
        assert (run_dir / name).stat().st_size > 0, name
    assert (run_dir / "checkpoints" / "2").is_dir() and (run_dir / "final").is_dir()
    assert "- seeds=2" in (run_dir / ".hydra" / "overrides.yaml").read_text()
    assert "final task loss per seed" in done.stderr
    # The picture-making at the end says what it draws (output.progress is on by default).
    assert "pictures: the report" in done.stderr and "pictures: robot.gif" in done.stderr
    # Quiet logs: no TPU probe, no matplotlib INFO chatter.
    assert "Unable to initialize backend" not in done.stderr
    assert "[matplotlib" not in done.stderr and "INFO" not in done.stderr
    # The README's gallery script draws from such a run (its `main`, in this process: the
    # script's own command line is argparse's).
    gallery = gallery_script()
    assert gallery.main(["--demo", str(run_dir), "--out", str(tmp_path / "gallery")]) == 0
    for name in (
        "robots.png",
        "task_loss.png",
        "robot.gif",
        "saliency.gif",
        "snapshots.png",
        "latent_sweeps.png",
    ):
        assert (tmp_path / "gallery" / name).stat().st_size > 1000, name
    # ... and replays a folder of runs (the 3D walkers') into walker_<run>.gif, demo skipped
    # (each by `litl.replay`'s `main`, in the script's process).
    assert (
        gallery.main(["--no-demo", "--walkers", str(run_dir.parent), "--out", str(tmp_path / "walkers")]) == 0
    )
    assert sorted(p.name for p in (tmp_path / "walkers").iterdir()) == [
        f"walker_{run_dir.name}.gif",
        f"walker_{run_dir.name}_gait.png",
    ]
    # A CLI run replays from its .hydra record: seed 1's final parameters give final.json's loss
    # (`python -m litl.replay`'s `main`, in this process).
    from litl.replay import main as replay_main

    assert replay_main([str(run_dir), "--seed", "1"]) == 0
    summary = json.loads((run_dir / "replay" / "seed1.json").read_text())
    assert summary["recorded_loss"] == json.loads((run_dir / "final.json").read_text())[1]["task_loss"]
    # The replay is another program than the run's (one seed, not vmapped): to float32 rounding.
    assert summary["task_loss"] == pytest.approx(summary["recorded_loss"], rel=1e-5, abs=1e-8)
    assert (run_dir / "replay" / "seed1.gif").stat().st_size > 1000


@pytest.mark.slow
def test_the_papers_method_runs_in_a_preset_with_its_pictures(tmp_path):
    """`method=paper` (the whole grid, ReLU, plain velocities, features only, full gradient, no
    safeguards) runs a paper preset end to end, pictures included (two of the preset's ten
    seeds: that a preset's seed count survives +scale=smoke is checked in process below)."""
    done = litl_command(
        [
            "experiment=fig4b_biped",
            "method=paper",
            "+scale=smoke",
            "seeds=2",
            "output.animation=false",
            "output.progress=false",
        ],
        tmp_path,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    (fig4b,) = run_dirs(tmp_path / "outputs")
    assert fig4b.relative_to(tmp_path).parts[:2] == ("outputs", "fig4b_biped")
    recorded = json.loads((fig4b / "run.json").read_text())
    assert recorded["config"]["method"] == "paper"
    assert recorded["config"]["observer"]["vae"]["window"] is None
    records = [json.loads(line) for line in (fig4b / "metrics.jsonl").read_text().splitlines()]
    assert len(records) == 2 * 2 * 2 and {r["seed"] for r in records} == {0, 1}
    assert all(r["task_loss"] is not None for r in records)
    assert (fig4b / "snapshots.png").stat().st_size > 0


@pytest.mark.parametrize(
    "override, message",
    [
        ("loop.episods=3", "Key 'episods' not in 'LoopConfig'"),
        ("loop.episodes=abc", "Value 'abc' of type 'str' could not be converted to Integer"),
        ("robot=bipd", "Could not find 'robot/bipd'"),
        ("observer=vea", "Could not find 'observer/vea'"),
        ("observer.kind=vea", "observer.kind='vea': unknown observer"),
        ("seeds=0", "^seeds=0: must be a positive integer"),
        ("robot.resolution=tiny", "Invalid value 'tiny', expected one of \\[paper, demo, smoke\\]"),
        (
            "controller.kind=mpl",
            r"controller.kind='mpl': unknown controller; choose one of "
            r"\['mlp', 'sinusoid', 'latent_mpc', 'latent_ilqr', 'latent_lqr'\]",
        ),
        ("loop.schedule=oneshot", "expected one of \\[alternating, one_shot, simultaneous\\]"),
        ("robot.module=no_such_module", "robot.module='no_such_module' could not be imported"),
        ("robot.dx=0.03", "must divide the domain"),
        ("loop.alpha=1.5", "loop.alpha=1.5: must lie in \\(0, 1\\]"),
        ("observer.vae.field=speed", "Invalid value 'speed', expected one of \\[velocity, mass_weighted\\]"),
        ("method=papr", "Could not find 'method/papr'"),
        ("robot.material.bounds=[40,80]", "robot.material.bounds=\\(40.0, 80.0\\): need 0 < E_min"),
        ("experiment=fig9", "Could not find 'experiment/fig9'"),
        ("robot.material.max_stretch=1", "robot.material.max_stretch=1.0: max_stretch must be a number > 1"),
    ],
)
def test_bad_settings_fail_early_with_a_clear_message(override, message):
    """What `python -m litl` checks before it runs anything (`run_experiment`: compose, the
    robot, the observer), in process: a `UserError` with the message the CLI prints. The CLI's
    own ways out (exit status, one line, no traceback, no directory left) are checked below."""
    from litl.app import build_robot, check_observer, compose
    from litl.errors import UserError

    with pytest.raises(UserError, match=message):
        config = compose([override, "+scale=smoke"])
        build_robot(config)
        check_observer(config)


@pytest.mark.parametrize(
    "override, message, status",
    [
        # litl's own check: one line, exit status 2, the run directory Hydra made removed again.
        ("seeds=0", "^litl: error: seeds=0: must be a positive integer$", 2),
        # Hydra's: its message, before any directory is made.
        ("robot=bipd", "^In 'config': Could not find 'robot/bipd'$", 1),
    ],
)
def test_bad_settings_on_the_command_line_exit_with_one_clear_message(tmp_path, override, message, status):
    done = litl_command([override, "+scale=smoke"], tmp_path, timeout=300)
    assert done.returncode == status
    assert re.search(message, done.stderr, re.M), done.stderr[-2000:]
    assert "Traceback" not in done.stderr, done.stderr[-2000:]
    assert not (tmp_path / "outputs").exists()  # a failed start leaves no empty directory
    assert not list(tmp_path.rglob("metrics.jsonl"))


@pytest.mark.parametrize(
    "override, message",
    [
        ("observer.vae.latent_dim=0", "^observer.vae.latent_dim=0: must be a positive integer"),
        ("loop.learning.batch_size=0", "^loop.learning.batch_size=0: must be a positive integer"),
        ("controller.mlp.feature_scale=0", "^controller.mlp.feature_scale=0.0: must be a positive number"),
        (
            "loop.safeguards.update_tolerance=-0.1",
            "^loop.safeguards.update_tolerance=-0.1: must be a number >= 0, or null",
        ),
        ("observer.vae.momentum_weight=-1", "^observer.vae.momentum_weight=-1.0: must be a number >= 0"),
        (
            "loop.safeguards.final_learning_rate_fraction=1.5",
            "^loop.safeguards.final_learning_rate_fraction=1.5: must lie in \\[0, 1\\]",
        ),
        ("robot.dx=0", "dx=0.0 is not a usable grid spacing.*robot.dx=0.03125"),
        ("loop.buffer_capacity=1", "needs at least 2 snapshots.*raise loop.buffer_capacity"),
        ("loop.replay_capacity=1", "needs at least 2 snapshots.*raise loop.buffer_capacity"),
    ],
)
def test_bad_values_are_refused_naming_the_key_as_typed(override, message):
    """The same checks as the CLI's, in process (the CLI path is covered above)."""
    from litl.app import build_robot, compose
    from litl.loop import make_algorithm

    with pytest.raises(ValueError, match=message):
        config = compose([override, "+scale=smoke"])
        make_algorithm(build_robot(config), config.algorithm)


def test_help_explains_every_group_and_hides_the_schema(tmp_path):
    done = litl_command(["--help"], tmp_path, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    described, options = done.stdout.split("== Options of each group ==")
    groups = sorted(
        p.name for p in (ROOT / "litl" / "conf").iterdir() if p.is_dir() and p.name != "__pycache__"
    )
    assert len(groups) == 16
    for group in groups:
        # A sentence in the group list, and its options below.
        assert re.search(rf"^{group} +\S.{{20,}}", described, re.M), group
        assert re.search(rf"^{group}: \w", options, re.M), group
    assert "schema" not in done.stdout
    assert "loop.episodes=3" in done.stdout and "python -m litl.replay" in done.stdout


def test_material_and_design_bounds_from_the_command_line(tmp_path):
    """robot.material.* reach the design space; dt follows the stiffest allowed E; run.json
    records the material (a resumed run must match it)."""
    from litl.app import compose, run_experiment

    config = compose(
        [
            "+scale=smoke",
            "observer=kmeans",
            "robot.material.bounds=[15,60]",
            "robot.material.youngs_modulus=30",
            "loop.episodes=1",
            "loop.iterations=1",
            "output.pictures=false",
            "output.animation=false",
            "output.progress=false",
        ]
    )
    result = run_experiment(config, tmp_path)
    saved = json.loads((tmp_path / "run.json").read_text())
    assert saved["material"]["youngs_modulus_bounds"] == [15.0, 60.0]
    assert saved["dt"] == 0.072 / 32 < 0.1 / 32  # E_max 60 instead of 30
    assert saved["material"]["max_stretch"] == 3.0  # the catalog's strain limit
    # φ0 = 30 in each region (the metrics hold φ after one Adam step of at most 0.5)
    assert result.metrics[0]["design"] == pytest.approx([30.0] * 4, abs=0.5)


@pytest.mark.parametrize("value, limit", [("inf", None), ("2.5", 2.5)])
def test_the_strain_limit_from_the_command_line(value, limit):
    from litl.app import build_robot, compose

    assert build_robot(compose([])).config.max_stretch == 3.0
    robot = build_robot(compose([f"robot.material.max_stretch={value}"]))
    assert robot.config.max_stretch == limit
    assert robot.config.dt == build_robot(compose([])).config.dt


def test_experiment_presets_compose_at_paper_scale_and_shrink_with_smoke():
    from litl.app import build_robot, compose

    paper = compose(["experiment=fig4b_biped"])
    assert paper.seeds == 10 and paper.loop.episodes == 20 and paper.robot.resolution == "paper"
    assert build_robot(paper).config.dx == 1 / 128 and paper.loop.codesign
    smoke = compose(["experiment=fig4a_arm", "+scale=smoke"])
    assert smoke.robot.name == "arm" and smoke.loop.episodes == 2 and smoke.seeds == 10
    assert not smoke.loop.codesign and build_robot(smoke).config.dx == 1 / 32
    # The paper method's preset keeps its ten seeds at smoke scale (its CLI run above sets 2).
    assert compose(["experiment=fig4b_biped", "method=paper", "+scale=smoke"]).seeds == 10
    variant = compose(["experiment=fig4a_arm", "variant=vae_one_shot"])
    assert variant.observer.kind == "vae" and variant.loop.schedule == "one_shot"
    sized = compose(["variant=kmeans", "size=s4"])
    assert sized.observer.kind == "kmeans" and sized.observer.kmeans.clusters == 4
    demo = compose([])
    assert demo.experiment.name == "demo" and build_robot(demo).config.dx == 1 / 64


def test_every_experiment_preset_composes():
    from litl.app import build_robot, compose

    presets = sorted(p.stem for p in (ROOT / "litl" / "conf" / "experiment").glob("*.yaml"))
    assert {
        "fig4a_arm",
        "fig4b_biped",
        "fig4c_elephant",
        "fig4d_bunny",
        "table1_biped",
        "fig5_recon",
        "fig6_demos",
        "fig8_latent",
    } <= set(presets)
    for preset in presets:
        settings = compose([f"experiment={preset}", "+scale=smoke"])
        assert settings.experiment.name == preset and settings.experiment.paper_scale
        build_robot(settings)


@pytest.mark.parametrize("launcher", ["basic", "submitit_local"])
def test_sweeps_run_every_job_with_each_launcher(tmp_path, launcher):
    args = ["-m", "+scale=smoke", "observer=kmeans", "seed=0,1", f"hydra/launcher={launcher}", *QUIET]
    if launcher == "submitit_local":
        args += ["hydra.launcher.timeout_min=10"]
    done = litl_command(args, tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    dirs = run_dirs(tmp_path / "multirun")
    assert len(dirs) == 2
    seeds = {json.loads((d / "metrics.jsonl").read_text().splitlines()[0])["seed"] for d in dirs}
    assert seeds == {0, 1}
    if launcher == "basic":
        # Every job of a sweep labels litl's lines with its number (`set_label`); the basic
        # launcher runs the jobs in this process, so their lines reach its stderr.
        ours = [line for line in done.stderr.splitlines() if "litl: " in line]
        assert ours and all(re.match(r"\[job [01]\] litl: ", line) for line in ours), ours
        for job in (0, 1):
            assert f"[job {job}] litl: final task loss per seed" in done.stderr


def test_biped_compare_preset_runs_vae_kmeans_and_the_open_loop_baseline():
    from omegaconf import OmegaConf

    from litl.app import compose

    preset = OmegaConf.load(ROOT / "litl" / "conf" / "experiment" / "biped_compare.yaml")
    assert preset.hydra.sweeper.params.variant.split(",") == ["vae", "kmeans", "sinusoid"]
    for variant, observer, controller in (
        ("vae", "vae", "mlp"),
        ("kmeans", "kmeans", "mlp"),
        ("sinusoid", "none", "sinusoid"),
    ):
        config = compose(["experiment=biped_compare", f"variant={variant}"])
        assert (config.observer.kind, config.controller.kind) == (observer, controller)
        assert config.seeds >= 5 and config.loop.episodes * config.loop.iterations == 100
    assert compose(["experiment=biped_compare"]).robot.resolution == "demo"
    # controller=sinusoid alone is the open-loop baseline (it reads no observer).
    assert compose(["controller=sinusoid"]).observer.kind == "none"


# One robot of each kind of task and construction: the arm reaches, the bunny walks while two
# hands reach (a weighted sum, as the elephant's), the rhino is drawn from a PNG, the hexapod walks
# in 3D. The biped runs in the default job above; every robot, the elephant and the two quadrupeds
# included, is built and simulated in tests/robots/test_catalog.py.
SWEPT_ROBOTS = ("arm", "bunny", "rhino", "hexapod")


@pytest.mark.slow
def test_robots_of_every_kind_run_at_smoke_scale_in_one_sweep(tmp_path):
    """`+scale=smoke` runs the robots through the CLI: one sweep with the joblib launcher, two
    jobs at a time (k-means and one iteration keep it to ~10 s of compilation per 2D robot, ~20 s
    in 3D; the default job above runs the VAE at smoke scale)."""
    names = SWEPT_ROBOTS
    done = litl_command(
        [
            "-m",
            "+scale=smoke",
            f"robot={','.join(names)}",
            "observer=kmeans",
            "loop.episodes=1",
            "loop.iterations=1",
            "hydra/launcher=joblib",
            "hydra.launcher.n_jobs=2",
            *QUIET,
        ],
        tmp_path,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    dirs = run_dirs(tmp_path / "multirun")
    runs = [json.loads((d / "run.json").read_text()) for d in dirs]
    assert sorted(r["robot"] for r in runs) == sorted(names)
    for d, r in zip(dirs, runs, strict=True):
        assert len((d / "metrics.jsonl").read_text().splitlines()) == 1, d
        assert r["dx"] == (1 / 32 if len(r["grid_shape"]) == 2 else 1 / 16), r["robot"]


def test_a_robot_of_your_own_runs_from_the_cli(tmp_path):
    from tests.robots.test_register import STOOL_MODULE

    (tmp_path / "my_robots.py").write_text(STOOL_MODULE)
    done = litl_command(
        [
            "robot.name=stool",
            "robot.module=my_robots",
            "+scale=smoke",
            "observer=kmeans",
            "loop.episodes=1",
            "loop.iterations=1",
            *QUIET,
        ],
        tmp_path,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    (run_dir,) = run_dirs(tmp_path / "outputs")
    assert json.loads((run_dir / "run.json").read_text())["robot"] == "stool"


def test_a_misspelt_robot_of_your_own_is_named_with_its_module(tmp_path, monkeypatch):
    """In process (the exit status of such an error is checked above): the module is imported,
    registers its robot, and the message says it registered none of the name asked for."""
    from litl.app import build_robot, compose
    from litl.errors import UserError
    from litl.robots import catalog
    from tests.robots.test_register import STOOL_MODULE

    (tmp_path / "my_robots.py").write_text(STOOL_MODULE)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(catalog, "ROBOTS", dict(catalog.ROBOTS))  # the registration is undone
    try:
        with pytest.raises(UserError, match="unknown robot 'stol'.*registered no robot"):
            build_robot(compose(["robot.name=stol", "robot.module=my_robots"]))
        assert "stool" in catalog.ROBOTS  # the module was imported
    finally:
        sys.modules.pop("my_robots", None)

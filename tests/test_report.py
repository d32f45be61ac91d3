"""Reports over synthetic run directories: bands, labels, files, Table 1 and clear CLI errors."""

import csv
import dataclasses
import json
import math

import numpy as np
import pytest
from PIL import Image

from litl.config import Config
from litl.report import (
    confidence_band,
    curves,
    group_runs,
    labels,
    load_runs,
    main,
    t_quantile,
    write_report,
)
from litl.report.runs import Run
from litl.report.summary import format_number

# A loop config as `run.json` stores it; tests override fields per run.
LOOP = {
    "episodes": 3,
    "iterations": 4,
    "seeds": 3,
    "seed": 0,
    "steps": None,
    "observer": "vae",
    "latent_dim": 8,
    "channels": [8, 16, 32, 32, 64],
    "clusters": 6,
    "controller_widths": [64, 64],
    "controller_period": None,
    "learning_rate": 0.01,
    "design_learning_rate": 0.5,
    "snapshot_stride": 10,
    "replay_capacity": 1000,
    "learning": {"max_epochs": 100, "batch_size": 32, "patience": 5},
    "alpha": 0.5,
    "replay": True,
    "one_shot": False,
    "simultaneous": False,
    "codesign": True,
    "dtype": "float32",
}


def write_run(
    path, robot="biped", seeds=(0, 1, 2), episodes=3, iterations=4, final=1.0, unhealthy=None, **loop
):
    """A run directory with made-up metrics: the loss falls from 2 + final to about `final`.

    `unhealthy` = (seed, step) from which that seed's simulation reports non-finite values.
    """
    loop = {
        **LOOP,
        "episodes": episodes,
        "iterations": iterations,
        "seeds": len(seeds),
        "seed": seeds[0],
        **loop,
    }
    learned = loop["observer"] != "kmeans"
    path.mkdir(parents=True)
    (path / "run.json").write_text(
        json.dumps(
            {
                "robot": robot,
                "particles": 100,
                "grid_shape": [32, 32],
                "dx": 1 / 32,
                "dt": 1e-3,
                "steps": 40,
                "loop": loop,
            }
        )
    )
    rng = np.random.default_rng(seeds[0])
    lines = []
    for episode in range(episodes):
        for iteration in range(iterations):
            step = episode * iterations + iteration
            for seed in seeds:
                loss = final + 2 * math.exp(-step / 3) + 0.05 * rng.standard_normal()
                bad = unhealthy is not None and seed == unhealthy[0] and step >= unhealthy[1]
                lines.append(
                    json.dumps(
                        {
                            "seed": seed,
                            "episode": episode,
                            "iteration": iteration,
                            "step": step,
                            "task_loss": None if bad else loss,
                            "task/distance": -loss,
                            "task/reach_tip": loss / 2,
                            "design": [1.0, 2.0],
                            "design_mean": 1.5,
                            "recon_loss_train": 0.1 / (episode + 1) if learned else None,
                            "recon_loss_val": 0.12 / (episode + 1) if learned else None,
                            "kl": 0.01 if learned else None,
                            "learning_epochs": 5,
                            "retrain_change": (
                                -0.01 * episode + 0.001 * seed
                                if learned and episode and iteration == 1
                                else None
                            ),
                            "controller_grad_norm": 1.0,
                            "design_grad_norm": 1.0,
                            "first_nonfinite_step": 7 if bad else -1,
                            "first_escape_step": -1,
                            "wall_s": 0.1 * step,
                        }
                    )
                )
    (path / "metrics.jsonl").write_text("\n".join(lines) + "\n")
    if learned:  # one learning phase per episode boundary, 3 epochs of 2 SGD steps each
        phases = [
            json.dumps(
                {
                    "seed": seed,
                    "phase": phase,
                    "epochs_used": 3,
                    "best_epoch": 3,
                    "steps_per_epoch": 2,
                    "recon_loss_train": 0.1,
                    "recon_loss_val": 0.1,
                    "kl": 0.01,
                    "val_recon_history": [0.3 / (phase + e + 1) for e in range(3)],
                }
            )
            for phase in range(episodes)
            for seed in seeds
        ]
        (path / "learning.jsonl").write_text("\n".join(phases) + "\n")
    return path


def fake_run(robot="biped", **loop) -> Run:
    return Run(
        path=None, settings={"robot": robot, "dx": 1 / 32, "steps": 40, "loop": {**LOOP, **loop}}, records=()
    )


def test_t_quantiles_match_tables():
    np.testing.assert_allclose(t_quantile(0.95, [1, 9, 29]), [6.3138, 1.8331, 1.6991], atol=1e-4)


def test_band_matches_hand_computation_for_ten_seeds():
    values = np.stack([np.arange(10.0), np.arange(10.0) ** 2], axis=1)  # (seeds, iterations)
    mean, low, high = confidence_band(values, level=0.9)
    for column in range(2):
        x = values[:, column]
        half = 1.8331 * x.std(ddof=1) / math.sqrt(10)
        assert mean[column] == pytest.approx(x.mean())
        assert high[column] - mean[column] == pytest.approx(half, rel=1e-4)
        assert mean[column] - low[column] == pytest.approx(half, rel=1e-4)


def test_band_skips_missing_values_and_collapses_with_one_seed():
    values = np.array([[1.0, 2.0, np.nan], [3.0, np.nan, np.nan]])
    mean, low, high = confidence_band(values)
    assert mean[0] == 2.0 and low[0] < 2.0 < high[0]
    assert mean[1] == low[1] == high[1] == 2.0  # one seed: no band
    assert np.isnan(mean[2])
    with pytest.raises(ValueError, match="level"):
        confidence_band(values, level=90)


def test_runs_recorded_by_the_config_model_are_labelled_like_older_ones():
    """run.json holds `Config.run_settings()` (nested, dotted keys in labels); files written
    before it (one flat 'loop' object) read the same."""

    def current(**changes):
        config = Config().replace(**changes)
        return Run(
            path=None,
            settings={
                "robot": "biped",
                "dx": 1 / 32,
                "steps": 40,
                "config": json.loads(json.dumps(config.run_settings())),
            },
            records=(),
        )

    runs = [
        current(),
        current(observer={"kind": "kmeans"}),
        current(loop={"replay_buffer": False}),
        current(loop={"schedule": "one_shot"}),
        current(loop={"alpha": 1.0}),
        current(observer={"vae": {"latent_dim": 4}}),
    ]
    assert labels(runs) == [
        "vae r=8",
        "kmeans",
        "vae r=8, no replay",
        "vae r=8, one-shot",
        "vae r=8, α=1",
        "vae r=4",
    ]
    old = [
        fake_run(),
        fake_run(observer="kmeans"),
        fake_run(replay=False),
        fake_run(one_shot=True),
        fake_run(alpha=1.0),
        fake_run(latent_dim=4),
    ]
    assert labels(old) == labels(runs)
    assert runs[3].config["loop.schedule"] == old[3].config["loop.schedule"] == "one_shot"


def test_runs_in_worlds_are_labelled_by_the_world_and_its_own_settings():
    def in_world(**world):
        config = Config().replace(world=world) if world else Config()
        settings = {"robot": "biped", "dx": 1 / 32, "steps": 40}
        return Run(
            path=None,
            settings={**settings, "config": json.loads(json.dumps(config.run_settings()))},
            records=(),
        )

    slope20 = in_world(kind="slope", slope={"angle": 20.0})
    runs = [in_world(), in_world(kind="sand"), in_world(kind="slope"), slope20]
    assert labels(runs) == [
        "vae world=flat",
        "vae world=sand",
        "vae world=slope world.slope.angle=10",
        "vae world=slope world.slope.angle=20",
    ]
    # Settings a world does not read do not tell its runs apart.
    assert labels([in_world(kind="sand"), in_world(kind="sand", slope={"angle": 20.0})]) == ["vae", "vae"]


def test_runs_of_other_design_spaces_are_labelled_by_the_space_and_its_own_settings():
    def with_design(**design):
        config = Config().replace(design=design) if design else Config()
        settings = {"robot": "biped", "dx": 1 / 32, "steps": 40}
        return Run(
            path=None,
            settings={**settings, "config": json.loads(json.dumps(config.run_settings()))},
            records=(),
        )

    runs = [
        with_design(),
        with_design(kind="actuators"),
        with_design(kind="all"),
        with_design(kind="actuators", actuators={"sharpness": 2.0}),
    ]
    assert labels(runs) == [
        "vae design=modulus",
        "vae design=actuators design.actuators.sharpness=4",
        "vae design=all",
        "vae design=actuators design.actuators.sharpness=2",
    ]


def test_labels_name_observer_and_ablations():
    runs = [
        fake_run(),
        fake_run(observer="kmeans"),
        fake_run(replay=False),
        fake_run(one_shot=True),
        fake_run(simultaneous=True),
        fake_run(alpha=1.0),
        fake_run(codesign=False),
        fake_run(replay=False, alpha=1, codesign=False),
        fake_run(observer="kmeans", codesign=False, alpha=1.0),
        fake_run(seed=5, seeds=2),
    ]
    assert labels(runs) == [
        "vae",
        "kmeans",
        "vae, no replay",
        "vae, one-shot",
        "vae, simultaneous",
        "vae, α=1",
        "vae, control only",
        "vae, no replay, α=1, control only",
        "kmeans, control only",
        "vae",
    ]


def test_labels_name_sizes_only_where_runs_differ_and_per_robot():
    runs = [
        fake_run(latent_dim=4),
        fake_run(latent_dim=8),
        fake_run(observer="kmeans"),
        fake_run(observer="kmeans", clusters=12, latent_dim=4),
        fake_run("arm", latent_dim=4),
        fake_run("arm", observer="kmeans"),
    ]
    assert labels(runs) == ["vae r=4", "vae r=8", "kmeans k=6", "kmeans k=12", "vae", "kmeans"]
    sweep = [
        fake_run(learning_rate=0.01),
        fake_run(learning_rate=0.02, replay=False),
        dataclasses.replace(fake_run(), settings={**fake_run().settings, "dx": 1 / 64}),
    ]
    assert labels(sweep) == ["vae dx=1/32 lr=0.01", "vae dx=1/32 lr=0.02, no replay", "vae dx=1/64 lr=0.01"]


def test_labels_follow_the_settings_an_observer_reads_as_recorded_in_run_json():
    """A run.json that records its observer's reads (`Observer.reads`) labels by those alone,
    whatever the observer's name."""

    def run(**loop):
        settings = fake_run(observer="projection", **loop).settings
        return Run(
            path=None,
            settings={**settings, "observer": {"learned": False, "reads": ["latent_dim"]}},
            records=(),
        )

    runs = [run(latent_dim=3), run(latent_dim=5), run(latent_dim=5, clusters=2)]
    assert labels(runs) == ["projection r=3", "projection r=5", "projection r=5"]
    assert not runs[0].learned


def test_multirun_with_two_observers_writes_every_file(tmp_path):
    sweep = tmp_path / "multirun" / "2024-05-01"
    write_run(sweep / "0", observer="vae", final=0.5)
    write_run(sweep / "1", observer="kmeans", final=1.5)
    (tmp_path / "multirun" / "multirun.yaml").write_text("hydra: {}\n")
    out = tmp_path / "report"
    assert main([str(tmp_path / "multirun"), "--out", str(out)]) == 0
    for name in (
        "task_loss.png",
        "components.png",
        "recon_loss.png",
        "recon_sgd.png",
        "table1.md",
        "table1.csv",
        "summary.md",
        "summary.json",
    ):
        assert (out / name).stat().st_size > 0, name
    assert Image.open(out / "task_loss.png").size[0] > 100

    with open(out / "table1.csv") as file:
        rows = list(csv.DictReader(file))
    # Learning phases after episodes 0 and 1 of the vae run only (k-means never retrains).
    assert [(r["label"], r["retrain"], r["n"]) for r in rows] == [("vae", "1", "3"), ("vae", "2", "3")]
    assert float(rows[1]["mean"]) == pytest.approx(-0.02 + 0.001)
    assert float(rows[0]["std"]) == pytest.approx(0.001)

    summary = json.loads((out / "summary.json").read_text())
    assert summary["best"]["biped"]["label"] == "vae"
    assert [(g["label"], g["seeds"]) for g in summary["groups"]] == [("vae", 3), ("kmeans", 3)]
    vae_final = summary["groups"][0]["final_task_loss"]
    assert vae_final["n"] == 3 and vae_final["half_width"] > 0
    text = (out / "summary.md").read_text()
    assert "**vae**" in text and "task_loss.png" in text and "90%" in text


def test_seeds_in_separate_run_dirs_are_pooled(tmp_path):
    for job, seed in enumerate((0, 1, 2, 3)):
        write_run(tmp_path / str(job), seeds=(seed,), observer="kmeans" if job % 2 else "vae")
    groups = group_runs(load_runs(tmp_path))
    assert [(g.label, g.n_seeds) for g in groups] == [("vae", 2), ("kmeans", 2)]
    (vae, _) = curves(groups)
    assert vae.n.tolist() == [2] * 12 and np.all(vae.high >= vae.low)


def test_single_run_single_seed(tmp_path, capsys):
    run_dir = write_run(tmp_path / "run", seeds=(4,))
    assert main([str(run_dir)]) == 0
    out = capsys.readouterr().out
    assert str(run_dir / "summary.md") in out and "biped / vae" in out
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["best"]["biped"] == {
        "label": "vae",
        "compared": 1,
        "overlaps_runner_up": False,
        "no_interval": [],
    }
    final = summary["groups"][0]["final_task_loss"]
    assert final["n"] == 1 and final["mean"] is not None
    assert final["low"] is final["high"] is final["half_width"] is None  # no interval
    notes = "\n".join(summary["notes"])
    assert "one seed only" in notes and "no confidence band" in notes
    assert "one seed, no CI" in (run_dir / "summary.md").read_text()


def best_claims(text: str) -> list[str]:
    """The lines of a summary (markdown or terminal) that name a best or lowest label."""
    return [
        line
        for line in text.splitlines()
        if ("lowest" in line or "best" in line.lower()) and not line.startswith(("#", "|"))
    ]


def test_one_seed_each_and_a_tiny_difference_is_not_called_a_win(tmp_path, capsys):
    """Two one-seed runs whose final losses differ by 1e-6 (the same made-up noise): neither has
    a confidence interval, so the report names the lower one only with that caveat."""
    write_run(tmp_path / "0", seeds=(0,), observer="vae", final=1.0)
    write_run(tmp_path / "1", seeds=(0,), observer="kmeans", final=1.0 + 1e-6)
    assert main([str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    summary = json.loads((tmp_path / "summary.json").read_text())
    vae, kmeans = summary["groups"]
    assert kmeans["final_task_loss"]["mean"] - vae["final_task_loss"]["mean"] == pytest.approx(1e-6, rel=1e-3)
    assert vae["final_task_loss"]["low"] is None and kmeans["final_task_loss"]["low"] is None
    assert summary["best"]["biped"] == {
        "label": "vae",
        "compared": 2,
        "overlaps_runner_up": False,
        "no_interval": ["vae", "kmeans"],
    }
    markdown = (tmp_path / "summary.md").read_text()
    assert "does not overlap" not in markdown and "**vae**" not in markdown
    for text in (markdown, printed):
        claims = best_claims(text)
        assert claims and all(
            "one seed each: no confidence interval, the difference cannot be judged" in line
            for line in claims
        ), claims
    assert (
        "lowest final task loss for biped: vae (one seed each: no confidence interval, the "
        "difference cannot be judged)"
    ) in printed


def test_one_seed_against_several_cannot_be_judged_either(tmp_path, capsys):
    write_run(tmp_path / "0", seeds=(0, 1, 2), observer="vae", final=0.5)
    write_run(tmp_path / "1", seeds=(7,), observer="kmeans", final=1.5)
    assert main([str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    assert (
        "lowest final task loss for biped: vae (kmeans has one seed with a final task loss: "
        "no confidence interval, the difference cannot be judged)"
    ) in printed
    markdown = (tmp_path / "summary.md").read_text()
    assert "of 2 labels; kmeans has one seed with a final task loss: no confidence" in markdown


def test_overlapping_intervals_of_three_seeds_carry_the_caveat(tmp_path, capsys):
    """Three seeds each with the same noise, means 1e-3 apart: the 90% intervals overlap."""
    write_run(tmp_path / "0", observer="vae", final=1.0)
    write_run(tmp_path / "1", observer="kmeans", final=1.0 + 1e-3)
    assert main([str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["best"]["biped"] == {
        "label": "vae",
        "compared": 2,
        "overlaps_runner_up": True,
        "no_interval": [],
    }
    assert (
        "lowest final task loss for biped: vae (its 90% interval overlaps the runner-up's: "
        "the difference is not clear at this level)"
    ) in printed
    (claim,) = best_claims((tmp_path / "summary.md").read_text())
    assert "overlaps the runner-up's, so the difference is not clear at this level" in claim


def test_clearly_separated_intervals_are_called_so(tmp_path, capsys):
    write_run(tmp_path / "0", observer="vae", final=0.5)
    write_run(tmp_path / "1", observer="kmeans", final=1.5)
    assert main([str(tmp_path)]) == 0
    assert (
        "lowest final task loss for biped: vae (its 90% interval does not overlap the runner-up's)"
    ) in capsys.readouterr().out
    assert "does not overlap the runner-up's" in (tmp_path / "summary.md").read_text()


def test_numbers_never_print_as_negative_zero():
    assert format_number(-0.0) == "0" and format_number(0.0) == "0"
    assert format_number(-0.0, ".3e") == "0.000e+00"
    assert format_number(-1e-7, ".3f") == "0.000"  # rounded away: no sign left
    assert format_number(-1e-7) == "-1e-07"  # significant digits keep it
    assert format_number(-0.25) == "-0.25"
    assert format_number(None) == format_number(math.nan) == "—"


def test_unhealthy_seed_is_reported_and_left_out_of_the_mean(tmp_path):
    run_dir = write_run(tmp_path / "run", seeds=(0, 1), unhealthy=(1, 10))
    summary = write_report(run_dir).summary
    notes = "\n".join(summary["notes"])
    assert "seed 1 blew up" in notes and "in 2 of 12 iterations, first at iteration 10" in notes
    assert "2 of 24 task-loss values are missing" in notes
    assert summary["groups"][0]["final_task_loss"]["n"] == 1


def test_kmeans_only_writes_no_recon_plot_and_empty_table(tmp_path):
    write_run(tmp_path / "run", observer="kmeans")
    report = write_report(tmp_path)
    names = {p.name for p in report.files}
    assert "recon_loss.png" not in names and "recon_sgd.png" not in names
    assert "task_loss.png" in names
    assert (tmp_path / "table1.csv").read_text().strip() == "robot,label,retrain,mean,std,n"
    assert "No retraining measurements" in (tmp_path / "table1.md").read_text()


def run_cli_error(args, capsys) -> str:
    with pytest.raises(SystemExit) as exit_info:
        main(args)
    assert exit_info.value.code == 2
    return capsys.readouterr().err


def test_missing_path_is_a_clear_error(tmp_path, capsys):
    err = run_cli_error([str(tmp_path / "nowhere")], capsys)
    assert "does not exist" in err and "Traceback" not in err


def test_directory_without_runs_is_a_clear_error(tmp_path, capsys):
    (tmp_path / "0").mkdir()
    (tmp_path / "0" / "run.json").write_text("{}")  # no metrics.jsonl: not a run
    assert "no runs found" in run_cli_error([str(tmp_path)], capsys)


def test_malformed_metrics_line_names_file_and_line(tmp_path, capsys):
    run_dir = write_run(tmp_path / "run")
    lines = (run_dir / "metrics.jsonl").read_text().splitlines()
    lines[4] = lines[4][:20]  # cut off, as by a crash mid-write
    (run_dir / "metrics.jsonl").write_text("\n".join(lines) + "\n")
    err = run_cli_error([str(tmp_path)], capsys)
    assert f"{run_dir / 'metrics.jsonl'}, line 5: not valid JSON" in err


def test_bad_level_is_a_clear_error(tmp_path, capsys):
    write_run(tmp_path / "run")
    assert "--level" in run_cli_error([str(tmp_path), "--level", "90"], capsys)


@pytest.mark.parametrize(
    "line, message",
    [
        ('{"seed": 0, "task_loss": 1.0}', "line 2: missing step"),
        ('{"seed": null, "step": 0, "task_loss": 1.0}', "line 2: seed and step must be integers"),
        ("[1, 2]", "line 2: expected a JSON object"),
    ],
)
def test_bad_metrics_records_name_the_line(tmp_path, capsys, line, message):
    run_dir = write_run(tmp_path / "run", episodes=1, iterations=1, seeds=(0,))
    with open(run_dir / "metrics.jsonl", "a") as file:
        file.write(line + "\n")
    assert message in run_cli_error([str(tmp_path)], capsys)


def test_unreadable_settings_and_runs_without_metrics(tmp_path, capsys):
    empty = write_run(tmp_path / "0")
    (empty / "metrics.jsonl").write_text("")
    assert "have no metrics yet" in run_cli_error([str(tmp_path)], capsys)
    write_run(tmp_path / "1")
    assert "0 has no metrics yet; left out" in "\n".join(write_report(tmp_path).summary["notes"])
    (empty / "run.json").write_text("{not json")
    assert f"{empty / 'run.json'}: cannot be read" in run_cli_error([str(tmp_path)], capsys)


def test_runs_that_differ_in_any_setting_their_observer_reads_are_not_pooled():
    """What an observer reads is its config's sections (observer.vae, loop.learning), so a key
    added to them (observer.vae.field) tells runs apart without a hand list; runs that differ in
    their method are named by it, not by the keys the method sets."""

    def current(reads=("observer.vae", "loop.learning"), config=None, **changes):
        config = config or Config().replace(**changes)
        return Run(
            path=None,
            settings={
                "robot": "biped",
                "dx": 1 / 32,
                "steps": 40,
                "config": json.loads(json.dumps(config.run_settings())),
                "observer": {"learned": True, "reads": list(reads)},
            },
            records=(),
        )

    runs = [current(), current(observer={"vae": {"field": "velocity"}})]
    assert labels(runs) == ["vae observer.vae.field=mass_weighted", "vae observer.vae.field=velocity"]
    assert len(group_runs(runs)) == 2
    # An older run.json listed single keys and missed the field: its observer's sections count.
    older = [
        current(reads=["observer.latent_dim", "observer.window", "loop.learning"]),
        current(
            reads=["observer.latent_dim", "observer.window", "loop.learning"],
            observer={"vae": {"field": "velocity"}},
        ),
    ]
    assert labels(older) == labels(runs)
    # Two methods: labelled by the method; a key set apart from the method is still named.
    methods = [
        current(),
        current(config=Config.for_method("paper")),
        current(config=Config.for_method("paper").replace(observer={"vae": {"latent_dim": 4}})),
    ]
    assert labels(methods) == ["vae method=litl r=8", "vae method=paper r=8", "vae method=paper r=4"]

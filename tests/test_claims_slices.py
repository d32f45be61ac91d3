"""A claims cell in seed slices: cutting, reading a cell as the union of its slices, refusing
what cannot be pooled, and the whole route through Hydra's submitit_local launcher at smoke size."""

import csv
import json
import pathlib
import shutil

import numpy as np
import pytest

from litl.claims import SCALES, cells
from litl.claims.cli import main
from litl.claims.launch import launcher_overrides
from litl.claims.slices import Slice, cut, read_cell, seed_ranges
from litl.claims.suite import ClaimsError
from litl.claims.tables import load_groups
from litl.report.stats import curves

VAE = cells(("fig4b",), ("paper",))[0]


def write_slice(
    cell_dir, first, count, *, episodes=2, iterations=2, commit="abc", lr=0.1, records=None, ended=True
):
    """A slice directory as litl writes one: run.json, metrics.jsonl (one record per seed and
    iteration, its task loss made from the seed), final.json when `ended`."""
    run_dir = cell_dir / f"seeds-{first}-{first + count - 1}"
    run_dir.mkdir(parents=True)
    config = {"seeds": count, "seed": first, "loop": {"episodes": episodes, "iterations": iterations}}
    config["controller"] = {"kind": "mlp", "learning_rate": lr}
    settings = {"robot": "biped", "config": config, "provenance": {"commit": commit, "dirty": False}}
    (run_dir / "run.json").write_text(json.dumps(settings))
    lines = []
    for seed in range(first, first + count):
        for step in range(episodes * iterations):
            lines.append({"seed": seed, "step": step, "task_loss": -0.01 * seed - 0.001 * step})
    lines = lines if records is None else lines[:records]
    (run_dir / "metrics.jsonl").write_text("".join(json.dumps(r) + "\n" for r in lines))
    if ended:
        (run_dir / "final.json").write_text("[]")
    return run_dir


@pytest.mark.parametrize(
    "size, expected",
    [(2, [(0, 2), (2, 2), (4, 1)]), (5, [(0, 5)]), (1, [(0, 1)] + [(s, 1) for s in range(1, 5)])],
)
def test_a_cell_is_cut_into_slices_of_k_seeds_the_last_one_smaller(size, expected):
    pieces = cut(VAE, range(0, 5), size)
    assert [(p.first, p.count) for p in pieces] == expected
    assert pieces[0].dir_name == f"seeds-0-{expected[0][1] - 1}"
    overrides = Slice(VAE, 10, 2).overrides(SCALES["smoke"])
    assert overrides[-1] == "seed=10" and "seeds=2" in overrides


@pytest.mark.parametrize("size", [0, -1, 6])
def test_a_slice_size_out_of_range_is_refused_with_the_numbers(size):
    with pytest.raises(ClaimsError, match=f"between 1 and the 5 seeds.*got {size}"):
        cut(VAE, range(5), size)


def test_a_cell_reads_as_the_union_of_its_finished_slices_and_names_the_seeds_it_lacks(tmp_path):
    write_slice(tmp_path, 0, 2)
    write_slice(tmp_path, 4, 2)
    write_slice(tmp_path, 2, 2, records=3, ended=False)  # under way
    found = read_cell(tmp_path, range(6), 2, 2)
    assert [run.path.name for run in found.runs] == ["seeds-0-1", "seeds-4-5"]
    assert found.missing == (2, 3) and not found.complete
    assert [p.name for p in found.unfinished] == ["seeds-2-3"]
    assert seed_ranges([0, 1, 2, 3, 6, 8, 9]) == "0-3, 6, 8-9"


def test_seeds_outside_the_asked_ones_are_refused_not_pooled(tmp_path):
    write_slice(tmp_path, 0, 2)
    write_slice(tmp_path, 4, 2)
    with pytest.raises(ClaimsError, match=r"holds seeds 4-5 \(seeds-4-5\).*asks for seeds 0-3"):
        read_cell(tmp_path, range(4), 2, 2)


def test_a_seed_in_two_slices_is_refused_naming_both(tmp_path):
    write_slice(tmp_path, 0, 2)
    write_slice(tmp_path, 1, 2)
    with pytest.raises(ClaimsError, match="seed 1 is in two slices.*seeds-0-1 and seeds-1-2"):
        read_cell(tmp_path, range(3), 2, 2)


def test_slices_of_different_commits_or_settings_are_refused_naming_them(tmp_path):
    write_slice(tmp_path / "a", 0, 2)
    write_slice(tmp_path / "a", 2, 2, commit="def")
    with pytest.raises(
        ClaimsError, match="seeds-0-1 and .*seeds-2-3 were made by different commits.*abc and def"
    ):
        read_cell(tmp_path / "a", range(4), 2, 2)
    write_slice(tmp_path / "b", 0, 2)
    write_slice(tmp_path / "b", 2, 2, lr=0.2)
    with pytest.raises(
        ClaimsError, match=r"different settings \(controller.learning_rate: 0.1 against 0.2\)"
    ):
        read_cell(tmp_path / "b", range(4), 2, 2)


def test_a_slice_of_another_size_is_refused(tmp_path):
    write_slice(tmp_path, 0, 2, episodes=3)
    with pytest.raises(ClaimsError, match="seeds-0-1 was run with loop.episodes=3 loop.iterations=2.*2 x 2"):
        read_cell(tmp_path, range(2), 2, 2)


@pytest.mark.parametrize("records, message", [(5, "holds 5 records.*say 8"), (None, "holds seeds \\[7\\]")])
def test_a_slice_edited_by_hand_is_refused_by_name(tmp_path, records, message):
    run_dir = write_slice(tmp_path, 0, 2, records=records)
    if records is None:  # a record of a seed the slice does not run
        with open(run_dir / "metrics.jsonl", "a") as file:
            file.write(json.dumps({"seed": 7, "step": 0, "task_loss": 0.0}) + "\n")
    with pytest.raises(ClaimsError, match=f"seeds-0-1: metrics.jsonl {message}"):
        read_cell(tmp_path, range(2), 2, 2)


@pytest.mark.parametrize(
    "launcher, jobs, options, message",
    [
        ("slurmish", 1, [], "unknown launcher 'slurmish'"),
        ("submitit_local", 2, [], "--jobs 2 runs slices with joblib's launcher"),
        ("basic", 0, [], "--jobs must be at least 1"),
        ("submitit_slurm", 1, ["partition=cpu"], "hydra.launcher.<key>=<value>"),
    ],
)
def test_bad_launcher_settings_are_refused(launcher, jobs, options, message):
    with pytest.raises(ClaimsError, match=message):
        launcher_overrides(launcher, jobs, options)


def test_launcher_settings_become_hydra_overrides():
    assert launcher_overrides("basic", 3, []) == ["hydra/launcher=joblib", "hydra.launcher.n_jobs=3"]
    assert launcher_overrides("submitit_local", 1, [])[1].startswith("hydra.launcher.timeout_min=")
    slurm = launcher_overrides("submitit_slurm", 1, ["hydra.launcher.partition=cpu"])
    assert slurm == ["hydra/launcher=submitit_slurm", "hydra.launcher.partition=cpu"]


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--slice-seeds", "0"], "between 1 and the 2 seeds"),
        (["--slice-seeds", "3"], "got 3"),
        (["--dry-run"], "give --slice-seeds"),
        (["--variants", "kmeans,lasso"], "unknown variant(s) ['lasso']"),
        (["--first-seed", "-1", "--slice-seeds", "1"], "--first-seed must be 0 or more"),
    ],
)
def test_bad_slice_arguments_are_refused_before_anything_runs(tmp_path, capsys, argv, message):
    with pytest.raises(SystemExit) as exit_info:
        main(
            [
                "--out",
                str(tmp_path / "out"),
                "--scale",
                "smoke",
                "--panels",
                "fig4b",
                "--methods",
                "paper",
                *argv,
            ]
        )
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_report_only_over_a_folder_without_a_cells_slices_says_so_and_judges_nothing_of_it(tmp_path, capsys):
    out = tmp_path / "out"
    argv = ["--out", str(out), "--scale", "smoke", "--panels", "fig4b", "--methods", "paper", "--report-only"]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "not judged: paper/fig4b/vae: no slice yet" in err
    rows = list(csv.DictReader((out / "claims.csv").read_text().splitlines()))
    assert all(r["verdict"] == "no data" for r in rows)


def _merged(sliced: pathlib.Path, whole: pathlib.Path) -> None:
    """`whole`: the cells of `sliced` with each cell's per-seed records in one run directory."""
    for cell_dir in sorted((sliced / "runs").glob("*/*/*")):
        parts = sorted(cell_dir.glob("seeds-*"), key=lambda p: int(p.name.split("-")[1]))
        target = whole / cell_dir.relative_to(sliced)
        target.mkdir(parents=True)
        settings = json.loads((parts[0] / "run.json").read_text())
        settings["config"]["seeds"] = sum(
            json.loads((p / "run.json").read_text())["config"]["seeds"] for p in parts
        )
        settings["config"]["seed"] = 0
        (target / "run.json").write_text(json.dumps(settings))
        for name in ("metrics.jsonl", "learning.jsonl"):
            text = "".join((p / name).read_text() for p in parts if (p / name).exists())
            if text:
                (target / name).write_text(text)


@pytest.mark.slow
def test_a_cell_in_two_slices_runs_through_submitit_local_and_judges_as_one_directory(tmp_path, capsys):
    """The done-when of the slices: two one-seed slices per cell, run as jobs of one Hydra
    multirun with submitit_local; the verdicts, Table 1 and curves read from the slices equal
    those read from the same per-seed records merged into one directory per cell; a second call
    runs nothing; --dry-run for more seeds estimates them from the finished slices' rate."""
    sliced = tmp_path / "sliced"
    argv = ["--scale", "smoke", "--panels", "fig4b", "--methods", "paper", "--variants", "vae,kmeans"]
    argv += ["--seeds", "2", "--slice-seeds", "1"]
    assert main(["--out", str(sliced), *argv, "--launcher", "submitit_local"]) == 0
    printed = capsys.readouterr().out
    assert "4 slice(s) to run" in printed and "paper/fig4b/vae/seeds-1-1: ~" in printed
    assert "hydra/launcher=submitit_local" in printed
    for name in ("vae", "kmeans"):
        for seed in (0, 1):
            run_dir = sliced / f"runs/paper/fig4b/{name}/seeds-{seed}-{seed}"
            timing = json.loads((run_dir / "timing.json").read_text())
            assert timing["finished"] and timing["seconds"] > 0 and timing["expected_s"] > 0
            assert {
                json.loads(line)["seed"] for line in (run_dir / "metrics.jsonl").read_text().splitlines()
            } == {seed}
    logs = "".join(p.read_text() for p in sliced.glob("launches/*/.submitit/*/*_log.out"))
    assert "slice paper/fig4b/vae/seeds-0-0 starts, expected ~" in logs and "finished in" in logs
    whole = tmp_path / "whole"
    _merged(sliced, whole)
    report = ["--scale", "smoke", "--panels", "fig4b", "--methods", "paper", "--variants", "vae,kmeans"]
    report += ["--seeds", "2", "--report-only"]
    assert main(["--out", str(whole), *report]) == 0
    capsys.readouterr()
    judged = {}
    for out in (sliced, whole):
        rows = list(csv.DictReader((out / "claims.csv").read_text().splitlines()))
        judged[out.name] = rows
        # Every claim is judged on both seeds, but the one against the sinusoids (not run here).
        assert [r["claim"] for r in rows if r["verdict"] == "no data"] == ["4b-vae-beats-open-loop"]
        assert all(r["a_n"] == "2" for r in rows if r["verdict"] != "no data")
    assert judged["sliced"] == judged["whole"]
    assert (sliced / "table1.md").read_text() == (whole / "table1.md").read_text()
    from litl.app import compose

    suite = cells(("fig4b",), ("paper",))[:2]
    configs = {cell.name: compose(cell.overrides(SCALES["smoke"], 2)) for cell in suite}
    groups = [load_groups(out, suite, lambda cell: configs[cell.name])[0] for out in (sliced, whole)]
    for variant in ("vae", "kmeans"):
        a, b = (g[("paper", "fig4b")][variant] for g in groups)
        assert len(a.runs) == 2 and len(b.runs) == 1
        for key in ("task_loss", "controller_grad_norm"):
            (x,), (y,) = curves([a], key), curves([b], key)
            np.testing.assert_array_equal(x.steps, y.steps)
            np.testing.assert_array_equal(x.mean, y.mean)
            np.testing.assert_array_equal(x.low, y.low)
    # Everything finished: a second call plans and runs nothing.
    assert main(["--out", str(sliced), *argv, "--launcher", "submitit_local"]) == 0
    assert "slice(s) to run" not in capsys.readouterr().out
    # Two more seeds: their expected time comes from the finished slices' rate.
    more = [a if a != "2" else "4" for a in argv]
    assert main(["--out", str(sliced), *more, "--dry-run"]) == 0
    printed = capsys.readouterr().out
    assert "paper/fig4b/kmeans/seeds-3-3: ~" in printed and "rate of this cell's finished slices" in printed
    assert not (sliced / "runs/paper/fig4b/kmeans/seeds-2-2").exists()
    shutil.rmtree(whole)


def test_the_records_of_finished_slices_are_copied_without_their_checkpoints(tmp_path):
    out, dest = tmp_path / "out", tmp_path / "kept"
    cell_dir = VAE.run_dir(out)
    done = write_slice(cell_dir, 0, 2)
    (done / "checkpoints" / "4").mkdir(parents=True)
    (done / "checkpoints" / "4" / "state").write_bytes(b"\0" * 1000)
    (done / "timing.json").write_text('{"seconds": 12.0, "finished": true}')
    write_slice(cell_dir, 2, 2, records=3, ended=False)  # under way: not copied
    write_slice(cell_dir, 4, 1, ended=False)  # every record, its final evaluation under way: not copied
    from litl.claims.slices import copy_records

    written = copy_records(out, VAE, dest)
    assert [p.name for p in written] == ["seeds-0-1"]
    kept = dest / done.relative_to(out)
    assert sorted(p.name for p in kept.iterdir()) == [
        "final.json",
        "metrics.jsonl",
        "run.json",
        "timing.json",
    ]
    assert (kept / "metrics.jsonl").read_text() == (done / "metrics.jsonl").read_text()
    assert copy_records(out, VAE, dest) == []  # already there: left as it is


def test_a_slice_under_way_made_by_another_commit_is_not_resumed(tmp_path, capsys):
    out = tmp_path / "out"
    write_slice(VAE.run_dir(out), 0, 1, commit="0" * 40, records=1, ended=False)
    argv = ["--out", str(out), "--scale", "smoke", "--panels", "fig4b", "--methods", "paper"]
    with pytest.raises(SystemExit) as exit_info:
        main([*argv, "--variants", "vae", "--seeds", "2", "--slice-seeds", "1", "--dry-run"])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err
    assert (
        "paper/fig4b/vae" in error and "seeds-0-0) was started by" in error and "Nothing was changed" in error
    )
    assert sorted(p.name for p in VAE.run_dir(out).iterdir()) == ["seeds-0-0"]

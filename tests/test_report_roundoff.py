"""A report knows a run that did not move: a task loss that never left round-off is not a result
(the rule `litl.gradcheck` applies, `litl.report.roundoff`), and "the last N iterations" is never longer
than the run."""

import json

import numpy as np
import pytest

from litl import gradcheck
from litl.report import main, roundoff
from tests.test_report import write_run


def still_run(path, seeds=(0, 1), episodes=2, iterations=2, level=-5e-9, **loop):
    """A run like a `+scale=smoke` biped run whose robot hardly moved: every task loss about
    `level` (4 iterations by default)."""
    write_run(path, seeds=seeds, episodes=episodes, iterations=iterations, **loop)
    rng = np.random.default_rng(0)
    records = [json.loads(line) for line in (path / "metrics.jsonl").read_text().splitlines()]
    for record in records:
        record["task_loss"] = level * (1 + 0.2 * rng.standard_normal())
        record["task/distance"] = -record["task_loss"]
    (path / "metrics.jsonl").write_text("\n".join(json.dumps(r) for r in records) + "\n")
    return path


def test_the_round_off_rule_is_the_float_types_and_gradchecks():
    assert roundoff.threshold("float32") == pytest.approx(np.finfo(np.float32).eps)
    assert roundoff.threshold(np.float64) == roundoff.STILL == 1e-9
    assert roundoff.hardly_moved([-5e-9, 3e-9, float("nan")], "float32")
    assert not roundoff.hardly_moved([-5e-9, 3e-9], "float64")
    assert not roundoff.hardly_moved([-5e-9, -1e-3], "float32")  # it moved once: a result
    assert not roundoff.hardly_moved([float("nan")], "float32")  # nothing measured: not judged
    assert gradcheck.hardly_moved is roundoff.hardly_moved  # one rule, not two
    with pytest.raises(ValueError, match="float dtype, got 'int32'"):
        roundoff.threshold("int32")


def test_a_run_that_never_left_round_off_is_not_a_result(tmp_path, capsys):
    run = still_run(tmp_path / "smoke")
    assert main([str(run)]) == 0
    printed = capsys.readouterr().out
    summary = json.loads((run / "summary.json").read_text())
    (group,) = summary["groups"]
    assert group["not_a_result"] and "never left round-off" in group["not_a_result"]
    assert group["round_off"]["seeds"] == ["seed 0", "seed 1"]
    assert group["round_off"]["threshold"] == pytest.approx(1.19e-7, rel=1e-2)
    assert summary["best"]["biped"]["label"] is None
    markdown = (run / "summary.md").read_text()
    rows = [line for line in markdown.splitlines() if line.startswith("| biped | vae |")]
    assert len(rows) == 2 and all("**not a result**" in row for row in rows)
    assert all("±" not in row for row in rows)  # no interval
    assert rows[1].split("|")[5:7] == [" — ", " — "]  # no best or worst seed
    assert "no result: the task loss of every label (vae) never left round-off" in markdown
    # Four iterations: the window says four, never ten.
    assert "mean over its last 4 iterations" in markdown and "10 iterations" not in markdown
    assert group["last10_task_loss"]["iterations"] == 4
    assert "not a result" in printed and "no result for biped" in printed
    assert "lowest final task loss" not in printed


def test_in_float64_the_same_numbers_are_a_result(tmp_path):
    """The threshold follows the run's float type: 5e-9 is above float64's (gradcheck's) 1e-9."""
    run = still_run(tmp_path / "double", dtype="float64")
    assert main([str(run)]) == 0
    summary = json.loads((run / "summary.json").read_text())
    assert summary["groups"][0]["not_a_result"] is None
    assert summary["best"]["biped"]["label"] == "vae"


def test_a_still_label_is_left_out_of_the_comparison(tmp_path, capsys):
    write_run(tmp_path / "0", observer="vae", final=1.0)
    still_run(tmp_path / "1", seeds=(0, 1, 2), episodes=3, iterations=4, observer="kmeans")
    assert main([str(tmp_path)]) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["best"]["biped"] == {
        "label": "vae",
        "compared": 1,
        "overlaps_runner_up": False,
        "no_interval": [],
        "not_results": ["kmeans"],
    }
    markdown = (tmp_path / "summary.md").read_text()
    assert "not compared, never left round-off: kmeans" in markdown
    assert "mean over its last 10 iterations" in markdown  # 12 iterations: the full window


def test_one_still_seed_among_moving_ones_is_named(tmp_path):
    run = write_run(tmp_path / "run", seeds=(0, 1, 2))
    records = [json.loads(line) for line in (run / "metrics.jsonl").read_text().splitlines()]
    for record in records:
        if record["seed"] == 2:
            record["task_loss"] = -4e-9
    (run / "metrics.jsonl").write_text("\n".join(json.dumps(r) for r in records) + "\n")
    assert main([str(run)]) == 0
    summary = json.loads((run / "summary.json").read_text())
    assert summary["groups"][0]["not_a_result"] is None
    assert any("of seed 2 never left round-off" in note for note in summary["notes"])

"""`python -m litl.claims`: verdict rules on made-up seeds, and the whole command at smoke size."""

import csv
import json
import os
import pathlib
import signal
import time

import numpy as np
import pytest

import litl
from litl.claims import CLAIMS, cells, judge, welch_p_lower
from litl.claims.cli import main
from litl.claims.suite import SCALES, run_suite
from litl.claims.verdicts import CONTRADICTED, HOLDS, NO_DATA, NOT_RESOLVED
from litl.report.runs import Group, Run


def group(name: str, finals, iterations: int = 10, retrain=None) -> Group:
    """A group whose seed s ends at `finals[s]` (constant over its last iterations), with
    `retrain[s]` as every retrain_change if given."""
    records = []
    for seed, final in enumerate(finals):
        for step in range(2 * iterations):
            episode, iteration = divmod(step, iterations)
            loss = final + (1.0 if episode == 0 else 0.0) * (iterations - iteration) / iterations
            records.append(
                {
                    "seed": seed,
                    "step": step,
                    "episode": episode,
                    "iteration": iteration,
                    "task_loss": loss,
                    "retrain_change": (
                        retrain[seed] if retrain is not None and episode > 0 and iteration == 1 else None
                    ),
                }
            )
    return Group("biped", name, (Run(pathlib.Path(name), {"robot": "biped"}, tuple(records)),))


def claim(claim_id):
    return next(c for c in CLAIMS if c.id == claim_id)


LOW = [-1.0, -1.1, -0.9, -1.05, -0.95]
HIGH = [-0.5, -0.6, -0.4, -0.55, -0.45]
SAME = [-0.98, -1.12, -0.88, -1.02, -0.97]


def test_welch_p_value_matches_a_hand_computed_one():
    # Two samples of 3 with equal variance 1 and means 0 and 3: t = -3 / sqrt(2/3),
    # Welch's dof = 4, one-sided p = P(T_4 < -3.674) = 0.0107.
    assert welch_p_lower([-1, 0, 1], [2, 3, 4]) == pytest.approx(0.01066, abs=2e-4)
    assert np.isnan(welch_p_lower([1.0], [2.0, 3.0]))


@pytest.mark.parametrize(
    "a, b, verdict", [(LOW, HIGH, HOLDS), (HIGH, LOW, CONTRADICTED), (SAME, LOW, NOT_RESOLVED)]
)
def test_beats_holds_is_contradicted_or_unresolved_by_the_seeds(a, b, verdict):
    result = judge(
        claim("4b-vae-beats-kmeans"), "litl", {"vae": group("vae", a), "kmeans": group("kmeans", b)}
    )
    assert result.verdict == verdict
    assert result.a.mean == pytest.approx(np.mean(a))
    assert result.a.low < result.a.mean < result.a.high


# Tight seeds (sd 0.008) against which a competitor's margin is 0.1: every seed of `group` makes
# a progress of 1.0 from its first iteration to its final task loss.
TIGHT = [-1.0, -1.01, -0.99, -1.005, -0.995]


@pytest.mark.parametrize(
    "shift, verdict",
    [(0.02, HOLDS), (-0.5, HOLDS), (0.3, CONTRADICTED), (0.1, NOT_RESOLVED)],
)
def test_competitive_is_non_inferiority_within_a_tenth_of_the_references_progress(shift, verdict):
    a = [x + shift for x in TIGHT]
    result = judge(
        claim("4a-kmeans-competitive"), "paper", {"kmeans": group("kmeans", a), "vae": group("vae", TIGHT)}
    )
    assert result.margin == pytest.approx(0.1)
    assert result.verdict == verdict
    assert result.difference == pytest.approx(shift)
    # Holds when the 95% interval lies below the margin; contradicted when it lies above it.
    assert (result.difference_high < 0.1) == (verdict == HOLDS)
    assert (result.difference_low > 0.1) == (verdict == CONTRADICTED)


@pytest.mark.parametrize(
    "changes, verdict",
    [
        ([0.001, -0.002, 0.0, 0.001, -0.001], HOLDS),  # next to 1.0 progress per episode
        ([-0.5, -0.6, -0.55, -0.45, -0.5], CONTRADICTED),
        ([0.1, -0.4, 0.05, -0.3, 0.0], NOT_RESOLVED),
    ],
)
def test_retraining_claim_weighs_the_change_against_an_episodes_progress(changes, verdict):
    result = judge(claim("table1-retraining"), "litl", {"vae": group("vae", LOW, retrain=changes)})
    assert result.verdict == verdict
    assert result.b.mean == pytest.approx(0.45)  # (0.9 in episode 0 + 0 in episode 1) / 2


def test_a_claim_without_runs_says_no_data():
    result = judge(claim("4b-vae-beats-kmeans"), "litl", {"vae": group("vae", LOW)})
    assert result.verdict == NO_DATA and "kmeans" in result.rule
    one_seed = judge(
        claim("4b-vae-beats-kmeans"), "litl", {"vae": group("vae", LOW[:1]), "kmeans": group("kmeans", HIGH)}
    )
    assert one_seed.verdict == NO_DATA


def test_every_claim_names_variants_its_panel_runs():
    for c in CLAIMS:
        suite = cells(comparators=("pca",)) if c.comparator else cells()
        panel_cells = [cell for cell in suite if cell.panel.name == c.panel]
        names = {cell.variant.name for cell in panel_cells}
        assert c.a in names and (c.b is None or c.b in names), c.id
    assert {cell.method for cell in cells()} == {"litl", "paper"}


def test_the_pca_comparator_is_off_by_default_and_judged_only_where_it_ran():
    from litl.claims.tables import verdicts

    assert not [cell for cell in cells() if cell.variant.name == "pca"]
    added = [cell.name for cell in cells(comparators=("pca",)) if cell.variant.name == "pca"]
    assert added == ["litl/fig4b/pca", "litl/fig4d/pca", "paper/fig4b/pca", "paper/fig4d/pca"]
    biped = {"vae": group("vae", LOW), "kmeans": group("kmeans", HIGH), "sinusoid": group("sinusoid", HIGH)}
    without = [v.claim.id for v in verdicts({("litl", "fig4b"): biped}, ["litl"], cut=None)]
    assert "4b-vae-beats-pca" not in without
    with_pca = verdicts({("litl", "fig4b"): {**biped, "pca": group("pca", HIGH)}}, ["litl"], cut=None)
    (pca,) = [v for v in with_pca if v.claim.id == "4b-vae-beats-pca"]
    assert pca.verdict == HOLDS and len(with_pca) == len(without) + 1


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--comparators", "lasso"], "unknown comparator"),
        (["--panels", "fig9"], "unknown panel"),
        (["--methods", "mine"], "unknown method"),
        (["--seeds", "1"], "at least 2"),
    ],
)
def test_bad_arguments_are_refused_before_anything_runs(tmp_path, capsys, argv, message):
    with pytest.raises(SystemExit) as exit_info:
        main(["--out", str(tmp_path / "out"), "--scale", "smoke", *argv])
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_a_run_of_another_size_in_out_is_refused_before_anything_runs(tmp_path, capsys):
    out = tmp_path / "claims"
    old = out / "runs/paper/fig4b/kmeans"
    old.mkdir(parents=True)
    (old / "run.json").write_text(
        json.dumps({"config": {"seeds": 2, "loop": {"episodes": 10, "iterations": 10}}})
    )
    with pytest.raises(SystemExit) as exit_info:
        main(["--out", str(out), "--scale", "smoke", "--panels", "fig4b", "--methods", "paper"])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err
    assert "was run with seeds=2 loop.episodes=10 loop.iterations=10" in error
    assert "another --out" in error
    assert sorted(p.name for p in out.rglob("*")) == ["fig4b", "kmeans", "paper", "run.json", "runs"]


def test_a_cell_stopped_by_kill_keeps_its_time_and_resuming_adds_to_it(tmp_path, monkeypatch):
    import litl.app

    parts = []

    def part_of_a_run(config, run_dir):  # one record, 0.2 s; the first part gets SIGTERM
        parts.append(run_dir)
        run_dir.mkdir(parents=True, exist_ok=True)
        with open(run_dir / "metrics.jsonl", "a") as file:
            file.write("{}\n")
        time.sleep(0.2)
        if len(parts) == 1:
            os.kill(os.getpid(), signal.SIGTERM)

    monkeypatch.setattr(litl.app, "run_experiment", part_of_a_run)
    handler = signal.getsignal(signal.SIGTERM)
    suite = cells(("fig4b",), ("paper",))[:1]
    with pytest.raises(KeyboardInterrupt):
        run_suite(tmp_path, suite, SCALES["smoke"], 2, say=lambda *_: None)
    first = json.loads((tmp_path / "timings.json").read_text())["paper/fig4b/vae"]
    assert first >= 0.2
    assert signal.getsignal(signal.SIGTERM) == handler  # the caller's handler is back
    assert run_suite(tmp_path, suite, SCALES["smoke"], 2, say=lambda *_: None) == {"paper/fig4b/vae": "ran"}
    assert json.loads((tmp_path / "timings.json").read_text())["paper/fig4b/vae"] >= first + 0.2


@pytest.mark.slow
def test_a_quick_suite_runs_two_cells_at_once_resumes_and_writes_every_result(tmp_path, capsys):
    """The whole command at smoke size, its cells two at a time (each `python -m litl` in a
    process of its own; one at a time they run in this process, as the SIGTERM test above runs
    them), then again: everything finished, it plans and runs nothing and writes the same."""
    out = tmp_path / "claims"
    argv = ["--out", str(out), "--scale", "smoke", "--panels", "fig4b", "--methods", "paper"]
    assert main([*argv, "--jobs", "2"]) == 0
    printed = capsys.readouterr().out
    assert "litl.claims: the plan (smoke scale, 2 seeds):" in printed and "with 2 at once" in printed
    for name in ("claims.md", "claims.csv", "table1.md", "fig4b.png", "timings.json"):
        assert (out / name).stat().st_size > 0, name
    with open(out / "claims.csv") as file:
        rows = list(csv.DictReader(file))
    # The optional comparator (--comparators pca) did not run: its claim is not in the table.
    assert [r["claim"] for r in rows] == [c.id for c in CLAIMS if c.panel == "fig4b" and not c.comparator]
    assert all(r["method"] == "paper" and r["verdict"] for r in rows)
    assert all(int(r["a_n"]) == 2 for r in rows)
    timings = json.loads((out / "timings.json").read_text())
    assert set(timings) == {"paper/fig4b/vae", "paper/fig4b/kmeans", "paper/fig4b/sinusoid"}
    run = json.loads((out / "runs/paper/fig4b/vae/run.json").read_text())
    assert run["config"]["method"] == "paper" and run["config"]["seeds"] == 2
    # The table names the litl and the material that made its cells (the paper's: elastic).
    commit = run["provenance"]["commit"] or ""
    assert all(r["commit"] == commit and r["material"] == "elastic (no strain limit)" for r in rows)
    text = (out / "claims.md").read_text()
    assert f"Made by {litl.records.provenance.describe(run['provenance'])}." in text
    assert "Material: elastic (no strain limit) (paper)." in text
    # Each cell's failures, time and origin.
    cell_rows = [line for line in text.splitlines() if line.startswith("| paper/fig4b/")]
    assert [row.split(" | ")[0] for row in cell_rows] == [
        "| paper/fig4b/vae",
        "| paper/fig4b/kmeans",
        "| paper/fig4b/sinusoid",
    ]
    assert all(row.split(" | ")[1] == "2" and "elastic" in row for row in cell_rows)
    metrics = (out / "runs/paper/fig4b/vae/metrics.jsonl").read_text()
    capsys.readouterr()
    # A second call finds every run finished: it plans nothing, runs nothing and writes the same
    # verdicts.
    assert main([*argv, "--jobs", "2"]) == 0
    printed = capsys.readouterr().out
    assert "litl.claims: [" not in printed and "the plan" not in printed
    assert (out / "runs/paper/fig4b/vae/metrics.jsonl").read_text() == metrics
    with open(out / "claims.csv") as file:
        assert list(csv.DictReader(file)) == rows
    # Its title names the runs' size (it once said "demo size" of every scale).
    assert (out / "table1.md").read_text().startswith("# Table 1 at smoke scale")

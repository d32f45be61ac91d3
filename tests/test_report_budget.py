"""`litl.report.budget`: task loss against simulated steps by the stated counting rule, the steps
to reach a fraction of the reference's distance, and the verdicts with Holm."""

import dataclasses
import json

import numpy as np
import pytest

from litl.report.budget import compare, curve, main, reaching
from litl.report.runs import load_run

STEPS = 10  # a rollout's simulation steps


def write_run(path, config, records, final):
    path.mkdir(parents=True)
    (path / "run.json").write_text(json.dumps({"robot": "biped", "steps": STEPS, "config": config}))
    (path / "metrics.jsonl").write_text("".join(json.dumps(r) + "\n" for r in records))
    (path / "final.json").write_text(json.dumps([{"seed": s, "task_loss": v} for s, v in final.items()]))
    return path


def litl_run(tmp_path, finals):
    """2 episodes x 2 iterations of a VAE run (it retrains: one evaluation per episode)."""
    config = {"observer": {"kind": "vae"}, "loop": {"episodes": 2, "iterations": 2}}
    records = [
        {"seed": s, "step": i, "task_loss": finals[s] * (i + 1) / 4, "wall_s": float(i)}
        for i in range(4)
        for s in finals
    ]
    path = write_run(tmp_path / "litl", config, records, finals)
    settings = json.loads((path / "run.json").read_text())
    settings["observer"] = {"learned": True, "reads": ["observer.vae", "loop.learning"]}
    (path / "run.json").write_text(json.dumps(settings))
    return path


def baseline_run(tmp_path, finals):
    """A baseline recording its own simulated steps: 3 rounds of 100 steps, task loss falling to
    the final value at its last round."""
    config = {"observer": {"kind": "none"}, "baseline": {"kind": "ppo"}}
    records = [
        {"seed": s, "step": r, "task_loss": finals[s] * r / 2, "simulated_steps": 100 * (r + 1), "wall_s": r}
        for r in range(3)
        for s in finals
    ]
    return write_run(tmp_path / "ppo", config, records, finals)


def test_a_litl_iteration_counts_forward_and_backward_and_evaluations_count_forward(tmp_path):
    run = load_run(litl_run(tmp_path, {0: -1.0, 1: -0.9}))
    c = curve(run, backward_cost=2.0)
    # iterations 1..4 at 3 x 10 steps each; the bootstrap's rollout (10) before them; one
    # evaluation (10 steps) after each episode of 2; the final evaluation (10) at the end
    np.testing.assert_allclose(c.steps[0], [40, 80, 110, 160])
    assert c.label == "vae" and list(c.final) == [-1.0, -0.9]
    ppo = curve(load_run(baseline_run(tmp_path, {0: -0.5, 1: -0.4})), backward_cost=2.0)
    np.testing.assert_allclose(ppo.steps[1], [100, 200, 300])
    steps, wall, seeds = reaching(ppo, -0.45)  # seed 0 reaches it at its last round, seed 1 never
    assert (steps, wall, seeds) == (300.0, 2.0, 1)


def test_the_observer_checks_two_rollouts_count_at_every_learning_phase(tmp_path):
    path = litl_run(tmp_path, {0: -1.0, 1: -0.9})
    settings = json.loads((path / "run.json").read_text())
    settings["config"]["loop"]["safeguards"] = {"update_tolerance": 0.1}
    (path / "run.json").write_text(json.dumps(settings))
    c = curve(load_run(path), backward_cost=2.0)
    # + 2 rollouts at the bootstrap's phase and after each episode's evaluation
    np.testing.assert_allclose(c.steps[0], [30 + 30, 60 + 30 + 30, 90 + 30 + 30, 120 + 30 + 60 + 10])
    # An unfinished run (no final.json) has no final evaluation yet.
    (path / "final.json").unlink()
    assert curve(load_run(path), backward_cost=2.0).steps[0][-1] == 120 + 30 + 60


def test_the_reference_beats_a_clearly_worse_method_and_holm_adjusts_upwards(tmp_path):
    rng = np.random.default_rng(0)
    good = {s: float(-1.0 + 0.05 * rng.standard_normal()) for s in range(10)}
    bad = {s: float(-0.5 + 0.05 * rng.standard_normal()) for s in range(10)}
    curves = [
        curve(load_run(litl_run(tmp_path, good)), 2.0),
        curve(load_run(baseline_run(tmp_path, bad)), 2.0),
    ]
    rows = compare(curves, "vae")
    assert rows[0]["budget"] == 160 and rows[1]["budget_x"] == pytest.approx(300 / 160)
    tests, holm = rows[1]["tests"], rows[1]["holm"]
    assert tests["end"].verdict == "holds" and holm["end"] >= tests["end"].test_p
    assert rows[1]["after_holm"]["end"] == "holds"
    # at the reference's budget (160 steps) the baseline is at its first round: loss 0
    assert rows[1]["at_reference_budget"] == pytest.approx(0.0)
    assert rows[0]["reach"][1.0][2] >= 1


def test_a_verdict_that_does_not_survive_holm_is_shown_as_not_resolved(tmp_path):
    # Two baselines each behind the reference at p 0.038 and 0.043 alone; with the two tests at
    # the reference's budget (p ~1e-9) Holm's family is 4, and both end tests adjust to 0.075.
    rng = np.random.default_rng(114)
    good, first, second = (-1.0 + 0.1 * rng.standard_normal(10), -0.9 + 0.1 * rng.standard_normal(10),
                           -0.9 + 0.1 * rng.standard_normal(10))  # fmt: skip
    curves = [curve(load_run(litl_run(tmp_path, dict(enumerate(map(float, good))))), 2.0)]
    for name, finals in (("first", first), ("second", second)):
        curves.append(
            curve(load_run(baseline_run(tmp_path / name, dict(enumerate(map(float, finals))))), 2.0)
        )
    for row in compare(curves, "vae")[1:]:
        test, holm = row["tests"]["end"], row["holm"]["end"]
        assert test.verdict == "holds" and test.test_p < 0.05 <= holm
        assert row["after_holm"]["end"] == "not resolved"
        assert row["after_holm"]["same_budget"] == "holds"


def test_fractions_are_of_the_references_progress_also_for_a_reaching_error(tmp_path):
    # The reference's error falls from 1.0 (first record) to 0.2 (final): 50% of its progress is
    # an error of 0.6, which the baseline (falling 1.0 -> 0.5 -> 0.0 in three rounds) reaches at
    # its last round, 300 steps.
    ref = curve(load_run(litl_run(tmp_path, {0: 0.2, 1: 0.2})), 2.0)
    ref = dataclasses.replace(ref, loss=[np.array([1.0, 0.7, 0.4, 0.2])] * 2)
    base = curve(load_run(baseline_run(tmp_path, {0: 1.0, 1: 1.0})), 2.0)
    base = dataclasses.replace(base, loss=[np.array([1.0, 0.7, 0.0])] * 2, final=np.array([0.0, 0.0]))
    rows = compare([ref, base], "vae")
    assert rows[1]["reach"][0.5][0] == 300.0 and rows[1]["reach"][0.5][2] == 2
    assert rows[0]["reach"][0.5][2] == 2  # the reference reaches its own half-way point


def test_the_command_writes_the_plot_and_the_table_and_refuses_a_bad_cost(tmp_path, capsys):
    litl_dir = litl_run(tmp_path, {0: -1.0, 1: -0.9, 2: -0.95})
    ppo_dir = baseline_run(tmp_path, {0: -0.5, 1: -0.4, 2: -0.45})
    out = tmp_path / "out"
    assert main([f"litl={litl_dir}", str(ppo_dir), "--backward-cost", "2", "--out", str(out)]) == 0
    assert (out / "budget.png").stat().st_size > 0
    table = (out / "budget.md").read_text()
    assert "| litl | 3 |" in table and "| ppo | 3 |" in table and "Reference: litl" in table
    with pytest.raises(SystemExit):
        main([str(litl_dir), "--backward-cost", "-1"])
    assert "a backward step costs >= 0 forward steps" in capsys.readouterr().err

"""A seed that ends stuck at its last good parameters still has a result (`litl.records.stuck`): the
final line, final.json, the report and the claims tables give its last good loss, marked stuck;
the seed beside it is reported as before."""

import contextlib
import dataclasses
import importlib
import io
import json

import jax.numpy as jnp
import numpy as np
import pytest

from litl.app import run_experiment
from litl.claims.markdown import claims_markdown
from litl.claims.verdicts import CLAIMS, final_losses, judge
from litl.report import write_report
from litl.report.runs import Group, load_run
from tests.loop.tiny import tiny_config

# Where runs build their programs (`litl.loop.programs`).
PROGRAMS = importlib.import_module("litl.loop.programs")
STUCK_FROM = 4  # seed 0's iterations 4 and 5 (the last two) fail


@pytest.fixture(scope="module")
def stuck_run(tmp_path_factory):
    """The tiny biped (no observer), 2 seeds x 6 iterations; seed 0's design is blown up from
    iteration STUCK_FROM on, so its last two iterations are skipped and it ends stuck there.
    Returns (run directory, result, the final lines on stderr)."""
    run_dir = tmp_path_factory.mktemp("stuck")
    config = tiny_config(
        observer={"kind": "none"},
        loop={"episodes": 2, "iterations": 3},
        robot={"dx": 1 / 32},
        output={"pictures": False, "animation": False, "progress": False, "logger": "none"},
    )
    make_algorithm = PROGRAMS.make_algorithm

    def poisoned(*args, **kwargs):
        algorithm = make_algorithm(*args, **kwargs)
        # Without an observer nothing splits a seed's key during the optimization: it tells
        # seed 0 from seed 1 inside the vmapped iteration.
        seed0 = np.asarray(algorithm.init(0).key)

        def optimize(state, iterations_in_run=None):
            blow = jnp.all(state.key == seed0) & (state.iteration >= STUCK_FROM)
            design = jnp.where(blow, jnp.full_like(state.design, 1e7), state.design)
            return algorithm.optimize(state.replace(design=design), iterations_in_run)

        return dataclasses.replace(algorithm, optimize=optimize)

    err = io.StringIO()
    with pytest.MonkeyPatch.context() as patch, contextlib.redirect_stderr(err):
        patch.setattr(PROGRAMS, "make_algorithm", poisoned)
        # The poisoned programs are neither taken from nor left in the shared ones.
        patch.setenv(PROGRAMS.SWITCH, "0")
        result = run_experiment(config, run_dir)
    return run_dir, result, err.getvalue()


def _losses(result, seed):
    return [r["task_loss"] for r in result.metrics if r["seed"] == seed]


def test_the_stuck_seed_skipped_its_last_iterations_and_the_other_did_not(stuck_run):
    _, result, _ = stuck_run
    skipped = {s: [r["skipped"] for r in result.metrics if r["seed"] == s] for s in (0, 1)}
    assert skipped[0][:STUCK_FROM] == [None] * STUCK_FROM
    assert all(reason is not None for reason in skipped[0][STUCK_FROM:])
    assert skipped[1] == [None] * 6


def test_the_final_line_gives_the_stuck_seeds_last_good_loss(stuck_run):
    run_dir, result, err = stuck_run
    good = _losses(result, 0)[STUCK_FROM - 1]
    other = _losses(result, 1)[-1]
    line = next(line for line in err.splitlines() if "final task loss per seed" in line)
    assert f"[{good + 0.0:.6g} (stuck), {other + 0.0:.6g}]" in line
    assert "n/a" not in line
    assert (
        f"seed 0 ended stuck at its last good parameters (its last 2 iteration(s) were skipped); "
        f"its loss is that of iteration {STUCK_FROM - 1}, its last good one" in err
    )
    assert "seed 1 ended stuck" not in err


def test_final_json_marks_the_stuck_seed_and_leaves_the_other_as_it_was(stuck_run):
    run_dir, result, _ = stuck_run
    final = json.loads((run_dir / "final.json").read_text())
    stuck, other = final
    assert stuck["seed"] == 0 and stuck["stuck"] is True
    assert stuck["task_loss"] == _losses(result, 0)[STUCK_FROM - 1]
    assert stuck["skipped_at_end"] == 2 and stuck["last_good_step"] == STUCK_FROM - 1
    # Its final parameters are its last good step retaken shorter after each failure (the
    # poison is in the iteration, not in them): their own forward simulation is finite.
    assert np.isfinite(stuck["final_parameters_loss"])
    assert set(other) == {"seed", "task_loss"} and other["seed"] == 1
    assert np.isfinite(other["task_loss"])


def test_the_report_counts_the_stuck_seed_with_its_last_good_loss(stuck_run, tmp_path):
    run_dir, result, _ = stuck_run
    report = write_report(run_dir, tmp_path)
    (group,) = report.summary["groups"]
    assert group["final_task_loss"]["n"] == 2
    good = _losses(result, 0)[STUCK_FROM - 1]
    assert group["final_task_loss"]["mean"] == pytest.approx((good + _losses(result, 1)[-1]) / 2)
    assert group["stuck"] == [
        {"run": ".", "seed": 0, "skipped_at_end": 2, "last_good_step": STUCK_FROM - 1, "per_seed_index": 0}
    ]
    # The window is the seed's iterations up to its last good one.
    window = group["last10_task_loss"]
    assert window["per_seed"][0] == pytest.approx(np.mean(_losses(result, 0)[:STUCK_FROM]))
    text = (tmp_path / "summary.md").read_text()
    assert "(stuck)" in text and "1 seed(s) stuck: their last good loss" in text
    assert "seed 0 ended stuck at its last good parameters" in text


def test_the_claims_tables_count_and_mark_the_stuck_seed(stuck_run):
    run_dir, _, _ = stuck_run
    run = load_run(run_dir)
    group = Group(run.robot, "vae", (run,))
    assert np.isfinite(final_losses(group)).all()
    claim = next(c for c in CLAIMS if c.id == "4b-vae-beats-kmeans")
    verdict = judge(claim, "litl", {"vae": group, "kmeans": group})
    assert verdict.a is not None and verdict.a.n == 2 and verdict.a.stuck == 1
    text = claims_markdown([verdict], 0.9, "test", [], {})
    assert "(n=2, 1 stuck)" in text and "*k stuck*" in text


def test_the_replay_compares_a_stuck_seed_with_its_final_parameters_own_loss(stuck_run):
    from litl.replay import recorded_loss

    run_dir, _, _ = stuck_run
    final = json.loads((run_dir / "final.json").read_text())
    assert recorded_loss(run_dir, "final", 0) == final[0]["final_parameters_loss"]
    assert recorded_loss(run_dir, "final", 0) != final[0]["task_loss"]
    assert recorded_loss(run_dir, "final", 1) == final[1]["task_loss"]


def test_final_parameters_that_fail_after_a_healthy_last_iteration_keep_that_iterations_loss(tmp_path):
    # Seed 0's last iteration was healthy, but the update it made gives parameters whose forward
    # simulation fails (NaN); seed 1's final parameters are fine.
    records = [
        {"seed": seed, "step": step, "task_loss": -0.1 * (step + 1) - seed, "skipped": None}
        for seed in (0, 1)
        for step in range(3)
    ]
    from litl.loop.run_directory import save_final_losses

    save_final_losses(tmp_path, np.array([np.nan, -1.5]), [0, 1], records)
    failed, other = json.loads((tmp_path / "final.json").read_text())
    assert failed == {
        "seed": 0,
        "task_loss": pytest.approx(-0.3),
        "final_parameters_failed": True,
        "last_good_step": 2,
        "final_parameters_loss": None,
    }
    assert other == {"seed": 1, "task_loss": -1.5}
    from litl.replay import recorded_loss

    assert recorded_loss(tmp_path, "final", 0) is None
    assert recorded_loss(tmp_path, "final", 1) == -1.5

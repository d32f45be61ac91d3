"""`litl.records.stuck`: a seed whose last iterations were skipped reports its last good task loss, marked
stuck; the report's final values and windows follow the same rule, and a run that never sticks
is reported exactly as before."""

import math
import pathlib

import numpy as np
import pytest

from litl.records.stuck import seed_end, seed_ends, shown
from litl.report.runs import Group, Run
from litl.report.stats import final_values, final_window_values, series_ends
from litl.report.summary import summarize, summary_markdown


def record(step, loss, skipped=None, seed=0):
    return {"seed": seed, "step": step, "task_loss": loss, "skipped": skipped}


def test_a_seed_that_did_not_skip_its_last_iteration_reports_that_iterations_loss():
    end = seed_end(0, [record(0, -0.1), record(1, None, "particles_escaped"), record(2, -0.3)])
    assert (end.task_loss, end.stuck, end.skipped_at_end, end.last_good_step) == (-0.3, False, 0, 2)
    assert shown(end) == "-0.3"


def test_a_seed_stuck_at_its_end_reports_its_last_good_loss():
    records = [
        record(0, -0.1),
        record(1, -0.31),
        record(2, None, "particles_escaped"),
        # A skipped iteration's finite loss (its gradient was not finite) is not a good one.
        record(3, -0.5, "gradient_nonfinite"),
        record(4, math.nan, "simulation_nonfinite"),
    ]
    end = seed_end(0, records)
    assert (end.task_loss, end.stuck, end.skipped_at_end, end.last_good_step) == (-0.31, True, 3, 1)
    assert shown(end) == "-0.31 (stuck)"


def test_only_a_seed_that_never_had_a_finite_loss_has_none():
    end = seed_end(3, [record(0, None, "particles_escaped"), record(1, None, "particles_escaped")])
    assert end.task_loss is None and end.stuck and end.last_good_step is None
    assert shown(end) == "n/a"
    assert shown(seed_end(0, [record(0, -0.0)])) == "0"  # never "-0"


def test_seed_ends_sorts_each_seeds_records_by_step():
    records = [record(1, None, "loss_nonfinite", seed=5), record(0, -2.0, seed=5), record(0, -1.0, seed=6)]
    ends = seed_ends(records)
    assert ends[5].stuck and ends[5].task_loss == -2.0 and not ends[6].stuck


def _group(rows) -> Group:
    """rows[seed] = [(loss, skipped), ...] by step; a report Run (null losses as NaN)."""
    records = tuple(
        {
            "seed": seed,
            "step": step,
            "task_loss": math.nan if loss is None else loss,
            "skipped": skipped,
        }
        for seed, row in enumerate(rows)
        for step, (loss, skipped) in enumerate(row)
    )
    return Group("biped", "vae", (Run(pathlib.Path("run"), {"robot": "biped"}, records),))


HEALTHY = [(-0.1 * t, None) for t in range(12)]
STUCK = [(-0.1 * t, None) for t in range(8)] + [(None, "particles_escaped")] * 4


def test_the_report_takes_a_stuck_seeds_values_up_to_its_last_good_iteration():
    group = _group([HEALTHY, STUCK])
    assert [end.stuck for _, end in series_ends(group)] == [False, True]
    np.testing.assert_allclose(final_values(group), [-1.1, -0.7])
    # The healthy seed's window is its last 10 iterations; the stuck one's, the 10 up to its
    # last good iteration (7), of which it has 8.
    np.testing.assert_allclose(
        final_window_values(group, last=10),
        [np.mean([-0.1 * t for t in range(2, 12)]), np.mean([-0.1 * t for t in range(8)])],
    )
    np.testing.assert_allclose(final_window_values(group, last=3), [-1.0, -0.6])


def test_the_summary_marks_stuck_seeds_and_a_run_that_never_sticks_is_reported_as_before():
    stuck = summarize(list(_group([HEALTHY, STUCK]).runs), [_group([HEALTHY, STUCK])], pathlib.Path("."), 0.9)
    (entry,) = stuck["groups"]
    assert entry["stuck"] == [
        {"run": "run", "seed": 1, "skipped_at_end": 4, "last_good_step": 7, "per_seed_index": 1}
    ]
    assert entry["final_task_loss"]["n"] == 2
    assert any("seed 1 ended stuck at its last good parameters" in note for note in stuck["notes"])
    stuck["files"] = []
    text = summary_markdown(stuck)
    assert "-0.35 (stuck)" in text and "1 seed(s) stuck: their last good loss" in text

    healthy_group = _group([HEALTHY, HEALTHY])
    healthy = summarize(list(healthy_group.runs), [healthy_group], pathlib.Path("."), 0.9)
    (entry,) = healthy["groups"]
    assert "stuck" not in entry and not any("stuck" in note for note in healthy["notes"])
    healthy["files"] = []
    assert "stuck" not in summary_markdown(healthy)
    # Skips that are not at the end change nothing either: the window leaves them out as before.
    skipped_inside = [*HEALTHY[:5], (None, "particles_escaped"), *HEALTHY[6:]]
    group = _group([skipped_inside])
    window = [-0.1 * t for t in range(2, 12) if t != 5]
    assert final_window_values(group, last=10)[0] == pytest.approx(np.mean(window))
    assert final_values(group)[0] == pytest.approx(-1.1)

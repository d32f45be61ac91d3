"""`python -m litl.report DIR [--out OUT] [--level 0.9]`: write a report and print its summary."""

from __future__ import annotations

import argparse
import sys

from litl.errors import exit_on_user_error
from litl.records.formatting import format_number
from litl.report.summary import unjudged_reason, write_report


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m litl.report",
        description="Aggregate the seeds and runs of a run or Hydra multirun directory into the "
        "paper's plots (task loss with confidence bands, reconstruction loss), "
        "Table 1 (markdown and CSV) and a summary (markdown and JSON).",
    )
    parser.add_argument("dir", help="a run directory or a multirun directory holding several")
    parser.add_argument("--out", default=None, help="where to write the report (default: DIR)")
    parser.add_argument(
        "--level", type=float, default=0.9, help="confidence level of the bands and intervals (default: 0.9)"
    )
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; returns 0, or exits with status 2 and a one-line message on bad input."""
    parser = _parser()
    args = parser.parse_args(argv)
    # Bad input (or an unreadable DIR, an unwritable --out) is the user's to fix: a message, not
    # a traceback.
    with exit_on_user_error(parser.prog, os_errors=True):
        report = write_report(args.dir, args.out, args.level)
    print(report.summary_path)
    groups = report.summary["groups"]
    width = max(len(f"{g['robot']} / {g['label']}") for g in groups)
    print(f"{'robot / label':<{width}}  seeds  final task loss (mean ± {args.level:.0%} CI)")
    for g in groups:
        final = g["final_task_loss"]
        half = (
            f" ± {format_number(final['half_width'])}"
            if final["half_width"] is not None
            else " (one seed, no CI)"
        )
        value = f"{format_number(final['mean'])}{half}"
        if g.get("not_a_result"):
            value = "not a result: the task loss never left round-off (summary.md)"
        print(f"{g['robot'] + ' / ' + g['label']:<{width}}  {g['seeds']:>5}  {value}")
    for robot, best in report.summary["best"].items():
        if best["label"] is None:
            print(f"no result for {robot}: the task loss never left round-off")
        elif best["compared"] > 1:
            unjudged = unjudged_reason(best)
            if unjudged:
                caveat = f" ({unjudged})"
            elif best["overlaps_runner_up"]:
                caveat = (
                    f" (its {args.level:.0%} interval overlaps the runner-up's: the "
                    f"difference is not clear at this level)"
                )
            else:
                caveat = f" (its {args.level:.0%} interval does not overlap the runner-up's)"
            print(f"lowest final task loss for {robot}: {best['label']}{caveat}")
    sys.stdout.flush()
    return 0

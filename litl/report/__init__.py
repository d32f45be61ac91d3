"""Reports over runs: the paper's plots, Table 1 and a summary, from run directories.

    python -m litl.report outputs/multirun/2024-05-01/12-00-00 [--out report] [--level 0.9]

or from Python:

    from litl.report import write_report, load_runs, group_runs, curves
    report = write_report("outputs/biped")          # writes the files, returns the numbers
    groups = group_runs(load_runs("outputs/biped"))  # runs pooled by robot and label
    task = curves(groups, "task_loss", level=0.9)    # mean and Student-t band per label

Every directory at or below the given one that holds `run.json` and `metrics.jsonl` (see
`litl.loop.run`) is a run. Each run is labelled by what distinguishes it (observer, settings that
differ between runs of the same robot, non-default ablation switches); runs of one robot with the
same label are pooled as seeds. Written files: `task_loss.png`, `components.png` (tasks with
several terms), `design.png` (a co-designed body's figures, ``design=actuators|geometry|all``),
`recon_loss.png` and `recon_sgd.png` (learned observers: per optimization
iteration, and per SGD step of every learning phase, Fig. 5), `table1.md`, `table1.csv`, `summary.md`,
`summary.json`.
"""

from litl.report.cli import main
from litl.report.runs import (
    Group,
    ReportError,
    Run,
    find_run_dirs,
    group_runs,
    labels,
    load_run,
    load_runs,
    read_metrics,
)
from litl.report.stats import (
    Curve,
    components,
    confidence_band,
    curves,
    final_values,
    series,
    t_quantile,
    table1,
)
from litl.report.summary import Report, summarize, summary_markdown, write_report

__all__ = [
    "Curve",
    "Group",
    "Report",
    "ReportError",
    "Run",
    "components",
    "confidence_band",
    "curves",
    "final_values",
    "find_run_dirs",
    "group_runs",
    "labels",
    "load_run",
    "load_runs",
    "main",
    "read_metrics",
    "series",
    "summarize",
    "summary_markdown",
    "t_quantile",
    "table1",
    "write_report",
]

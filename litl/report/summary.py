"""Writing a whole report: plots, Table 1 (markdown and CSV), summary.md and summary.json."""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import os
import pathlib
from typing import Any

import numpy as np

from litl.records.formatting import format_number
from litl.report import figures
from litl.report.roundoff import hardly_moved, threshold
from litl.report.runs import Group, ReportError, Run, group_runs, load_runs
from litl.report.stats import (
    body_figures,
    components,
    confidence_band,
    curves,
    final_values,
    final_window_values,
    series,
    series_ends,
    table1,
)

# The final performance of a seed: the mean of its last this many iterations.
FINAL_WINDOW = 10


@dataclasses.dataclass(frozen=True)
class Report:
    """What `write_report` wrote.

    Attributes:
      summary: the numbers of `summary.json` (NaN as None).
      files: every file written, summary.md first.
    """

    summary: dict[str, Any]
    files: tuple[pathlib.Path, ...]

    @property
    def summary_path(self) -> pathlib.Path:
        return self.files[0]


def _number(value: float | np.ndarray) -> float | None:
    value = float(value)
    return value if math.isfinite(value) else None


def _interval(
    mean: float | np.ndarray, low: float | np.ndarray, high: float | np.ndarray, n: int
) -> dict[str, Any]:
    """A mean with its confidence interval; with fewer than two values there is no interval
    (low, high and half_width are None), however close `confidence_band` collapsed it."""
    if n < 2:
        return {"mean": _number(mean), "low": None, "high": None, "half_width": None}
    return {
        "mean": _number(mean),
        "low": _number(low),
        "high": _number(high),
        "half_width": _number(high - mean),
    }


def unjudged_reason(best: dict[str, Any]) -> str | None:
    """Why the best label of `summary["best"]` cannot be told from the runner-up, or None.

    A label whose final task loss comes from a single seed has no confidence interval, so however
    small the difference in means (1e-6 between two one-seed runs), nothing says it is real.
    """
    lacking = best.get("no_interval") or []
    if best["compared"] < 2 or not lacking:
        return None
    if len(lacking) == 2:
        return "one seed each: no confidence interval, the difference cannot be judged"
    return (
        f"{lacking[0]} has one seed with a final task loss: no confidence interval, the "
        f"difference cannot be judged"
    )


def _relative(path: pathlib.Path, source: pathlib.Path) -> str:
    try:
        return str(path.relative_to(source)) or "."
    except ValueError:
        return str(path)


def _health_notes(group: Group, source: pathlib.Path) -> list[str]:
    notes = []
    for run in group.runs:
        for seed in run.seeds:
            records = [r for r in run.records if int(r["seed"]) == seed]
            for key, what in (
                ("first_nonfinite_step", "blew up (non-finite values)"),
                ("first_escape_step", "lost particles off the grid"),
            ):
                bad = [r for r in records if isinstance(r.get(key), (int, float)) and r[key] >= 0]
                if bad:
                    notes.append(
                        f"{group.robot} / {group.label}: {_relative(run.path, source)} seed "
                        f"{seed} {what} in {len(bad)} of {len(records)} iterations, first at "
                        f"iteration {min(int(r['step']) for r in bad)}"
                    )
    return notes


def _stuck(group: Group, source: pathlib.Path) -> tuple[list[dict[str, Any]], list[str]]:
    """The seeds of `group` that ended stuck (`litl.records.stuck`: their last iterations skipped),
    with `per_seed_index` their place in `per_seed`, and a note for each."""
    stuck, notes = [], []
    for row, (index, end) in enumerate(series_ends(group)):
        if not end.stuck:
            continue
        where = _relative(group.runs[index].path, source)
        stuck.append(
            {
                "run": where,
                "seed": end.seed,
                "skipped_at_end": end.skipped_at_end,
                "last_good_step": end.last_good_step,
                "per_seed_index": row,
            }
        )
        result = (
            "it never had a finite task loss"
            if end.last_good_step is None
            else f"its final task loss is its last good one, up to iteration {end.last_good_step}"
        )
        notes.append(
            f"{group.robot} / {group.label}: {where} seed {end.seed} ended stuck at its last good "
            f"parameters (its last {end.skipped_at_end} iteration(s) were skipped); {result}"
        )
    return stuck, notes


def _missing_notes(group: Group, steps: np.ndarray, values: np.ndarray) -> list[str]:
    notes = []
    missing = int(np.isnan(values).sum())
    if missing:
        notes.append(
            f"{group.robot} / {group.label}: {missing} of {values.size} task-loss values "
            f"are missing (null: non-finite, or a seed without that iteration); means "
            f"and bands use the seeds that have them"
        )
    return notes


def _round_off(group: Group, source: pathlib.Path) -> dict[str, Any]:
    """The seeds of `group` whose task loss never left round-off (`litl.report.roundoff`, the rule
    `litl.gradcheck` applies), with the threshold of each run's float type."""
    still, thresholds = [], set()
    for run in group.runs:
        dtype = str(run.config.get("sim.dtype") or "float32")
        thresholds.add(threshold(dtype))
        for seed in run.seeds:
            losses = [
                r.get("task_loss")
                for r in run.records
                if int(r["seed"]) == seed and not isinstance(r.get("skipped"), str)
            ]
            finite = [float(v) for v in losses if isinstance(v, (int, float))]
            if hardly_moved(finite, dtype):
                where = _relative(run.path, source)
                still.append(f"seed {seed}" if where == "." else f"{where} seed {seed}")
    return {"seeds": still, "threshold": max(thresholds)}


def _group_entry(group: Group, source: pathlib.Path, level: float) -> tuple[dict[str, Any], list[str]]:
    """One group's entry of `summarize` (its final task loss, last-iterations window, round-off
    and stuck seeds), and the notes it adds."""
    notes = []
    final = final_values(group, "task_loss")
    mean, low, high = confidence_band(final, level)
    n = int(np.isfinite(final).sum())
    steps, values = series(group, "task_loss")
    window_length = max(1, min(FINAL_WINDOW, len(steps)))
    window = final_window_values(group, "task_loss", window_length)
    window_mean, window_low, window_high = confidence_band(window, level)
    finite_window = window[np.isfinite(window)]
    round_off = _round_off(group, source)
    stuck, stuck_notes = _stuck(group, source)
    not_a_result = None
    if round_off["seeds"] and len(round_off["seeds"]) == group.n_seeds:
        not_a_result = (
            f"the task loss never left round-off (every value of every seed is below "
            f"{round_off['threshold']:.2g} in magnitude): the robot hardly moved, so there is "
            f"nothing to compare"
        )
        notes.append(f"{group.robot} / {group.label}: not a result: {not_a_result}")
    elif round_off["seeds"]:
        notes.append(
            f"{group.robot} / {group.label}: the task loss of {', '.join(round_off['seeds'])} "
            f"never left round-off (below {round_off['threshold']:.2g} in magnitude)"
        )
    entry = {
        "robot": group.robot,
        "label": group.label,
        "observer": group.runs[0].observer,
        "seeds": group.n_seeds,
        "runs": [_relative(run.path, source) for run in group.runs],
        "iterations": int(steps[-1]) + 1 if len(steps) else 0,
        "final_task_loss": {**_interval(mean, low, high, n), "n": n},
        "round_off": round_off,
        "not_a_result": not_a_result,
        f"last{FINAL_WINDOW}_task_loss": {
            "iterations": window_length,
            **_interval(window_mean, window_low, window_high, finite_window.size),
            "per_seed": [_number(v) for v in window],
            "best": _number(finite_window.min()) if finite_window.size else None,
            "worst": _number(finite_window.max()) if finite_window.size else None,
        },
        # (only when there are some: a run that never sticks keeps its keys)
        **({"stuck": stuck} if stuck else {}),
    }
    if group.n_seeds < 2:
        notes.append(
            f"{group.robot} / {group.label}: one seed only, so its curves have no "
            f"confidence band (the band needs at least 2 seeds)"
        )
    notes += _health_notes(group, source) + stuck_notes + _missing_notes(group, steps, values)
    return entry, notes


def _best(robot: str, entries: list[dict[str, Any]]) -> dict[str, Any] | None:
    """`summarize`'s `best` of one robot (None: no label has a final task loss or a reason)."""
    ranked = sorted(
        (
            e
            for e in entries
            if e["robot"] == robot and e["final_task_loss"]["mean"] is not None and not e["not_a_result"]
        ),
        key=lambda e: e["final_task_loss"]["mean"],
    )
    not_results = [e["label"] for e in entries if e["robot"] == robot and e["not_a_result"]]
    if not ranked:
        if not_results:
            return {
                "label": None,
                "compared": 0,
                "overlaps_runner_up": False,
                "no_interval": [],
                "not_results": not_results,
            }
        return None
    # Only the best and the runner-up are compared; a label without an interval (one seed)
    # makes the comparison impossible to judge, not a win.
    no_interval = [e["label"] for e in ranked[:2] if e["final_task_loss"]["low"] is None]
    overlaps = (
        len(ranked) > 1
        and not no_interval
        and ranked[1]["final_task_loss"]["low"] <= ranked[0]["final_task_loss"]["high"]
    )
    return {
        "label": ranked[0]["label"],
        "compared": len(ranked),
        "overlaps_runner_up": bool(overlaps),
        "no_interval": no_interval if len(ranked) > 1 else [],
        # (only when there are some: the common case keeps its four keys)
        **({"not_results": not_results} if not_results else {}),
    }


def summarize(runs: list[Run], groups: list[Group], source: pathlib.Path, level: float) -> dict[str, Any]:
    """The numbers of a report, as stored in `summary.json` (figures are added by the caller).

    Each group's final task loss has its mean and Student-t interval at `level` (low, high,
    half_width: None with fewer than two seeds); a seed that ended stuck (`litl.records.stuck`) counts
    with its last good loss and is listed in the group's `stuck` (absent when none is). `best`
    names, per robot, the label with the
    lowest mean final task loss: `compared` (labels with a final task loss),
    `overlaps_runner_up` (its interval overlaps the runner-up's) and `no_interval` (which of
    the two have no interval; then the difference cannot be judged, see `unjudged_reason`).

    A group none of whose seeds' task loss ever left round-off (`round_off`: those seeds and
    the threshold) is `not_a_result` (the reason; None otherwise) and is left out of `best`.
    The last-iterations window is never longer than the run (`iterations` in it).
    """
    notes: list[str] = []
    entries: list[dict[str, Any]] = []
    for group in groups:
        entry, group_notes = _group_entry(group, source, level)
        entries.append(entry)
        notes += group_notes
    best = {}
    for robot in dict.fromkeys(e["robot"] for e in entries):
        found = _best(robot, entries)
        if found is not None:
            best[robot] = found
    return {
        "source": str(source),
        "level": level,
        "runs": [
            {
                "path": _relative(run.path, source),
                "robot": run.robot,
                "label": label,
                "observer": run.observer,
                "seeds": run.seeds,
                "records": len(run.records),
            }
            for run, label in _run_labels(runs, groups)
        ],
        "groups": entries,
        "best": best,
        "notes": notes,
    }


def _run_labels(runs: list[Run], groups: list[Group]) -> list[tuple[Run, str]]:
    label_of = {id(run): group.label for group in groups for run in group.runs}
    return [(run, label_of[id(run)]) for run in runs if id(run) in label_of]


def _table1_markdown(rows: list[dict[str, Any]]) -> str:
    lines = [
        "# Table 1: change of the task objective after retraining plus one optimization step",
        "",
        "retrain_change = task loss before the retraining − task loss after it and one "
        "optimization step; negative: retraining cost progress (as in the paper). Mean and "
        "sample standard deviation over seeds.",
        "",
    ]
    if not rows:
        lines.append(
            "No retraining measurements: they need a learned observer (vae, ae) with "
            "learning phases (not one-shot or simultaneous), at least two episodes and "
            "two iterations per episode."
        )
    for robot, label in dict.fromkeys((r["robot"], r["label"]) for r in rows):
        lines += [f"## {robot} — {label}", "", "| retrain | mean | std | n |", "|---:|---:|---:|---:|"]
        lines += [
            f"| {r['retrain']} | {format_number(r['mean'], '.3e')} | {format_number(r['std'], '.3e')} | "
            f"{r['n']} |"
            for r in rows
            if (r["robot"], r["label"]) == (robot, label)
        ]
        lines.append("")
    return "\n".join(lines).rstrip() + "\n"


def _write_table1(rows: list[dict[str, Any]], out: pathlib.Path) -> list[pathlib.Path]:
    (out / "table1.md").write_text(_table1_markdown(rows))
    with open(out / "table1.csv", "w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=["robot", "label", "retrain", "mean", "std", "n"])
        writer.writeheader()
        for row in rows:
            writer.writerow(
                {k: ("" if isinstance(v, float) and not math.isfinite(v) else v) for k, v in row.items()}
            )
    return [out / "table1.md", out / "table1.csv"]


def _best_lines(robot: str, best: dict[str, Any]) -> list[str]:
    """The "Best label" lines of one robot."""
    lines: list[str] = []
    unjudged = unjudged_reason(best)
    not_results = best.get("not_results") or []
    if best["label"] is None:
        lines.append(
            f"- {robot}: no result: the task loss of every label ({', '.join(not_results)}) "
            f"never left round-off."
        )
        return lines
    if not_results:
        lines.append(f"- {robot}: not compared, never left round-off: {', '.join(not_results)}.")
    if best["compared"] < 2:
        lines.append(f"- {robot}: only one label with a final task loss ({best['label']}).")
    elif unjudged:
        lines.append(
            f"- {robot}: {best['label']} has the lowest mean final task loss of "
            f"{best['compared']} labels; {unjudged}."
        )
    else:
        caveat = (
            " — but its confidence interval overlaps the runner-up's, so the "
            "difference is not clear at this level"
            if best["overlaps_runner_up"]
            else "; its confidence interval does not overlap the runner-up's"
        )
        lines.append(
            f"- {robot}: **{best['label']}** has the lowest final task loss of "
            f"{best['compared']} labels{caveat}."
        )
    return lines


def summary_markdown(summary: dict[str, Any]) -> str:
    """The human-readable summary of a report."""
    level = f"{summary['level']:.0%}"
    lines = [
        "# litl report",
        "",
        f"Source: `{summary['source']}`",
        "",
        f"{len(summary['runs'])} run(s), {len(summary['groups'])} label(s). Curves and "
        f"intervals: mean over seeds with a {level} Student-t confidence interval.",
        "",
        "## Runs",
        "",
        "| run | robot | label | seeds | records |",
        "|---|---|---|---|---:|",
    ]
    lines += [
        f"| `{r['path']}` | {r['robot']} | {r['label']} | "
        f"{', '.join(map(str, r['seeds']))} | {r['records']} |"
        for r in summary["runs"]
    ]
    lines += [
        "",
        f"## Final task loss (lower is better; mean ± {level} CI half-width)",
        "",
        "| robot | label | seeds | iterations | final task loss |",
        "|---|---|---:|---:|---|",
    ]
    for e in summary["groups"]:
        final = e["final_task_loss"]
        half = f" ± {format_number(final['half_width'])}" if final["n"] > 1 else " (one seed, no CI)"
        value = f"{format_number(final['mean'])}{half}"
        if e.get("stuck"):
            value += f"; {len(e['stuck'])} seed(s) stuck: their last good loss"
        if e.get("not_a_result"):
            value = f"**not a result**: {e['not_a_result']}"
        lines.append(f"| {e['robot']} | {e['label']} | {e['seeds']} | {e['iterations']} | {value} |")
    windows = {e[f"last{FINAL_WINDOW}_task_loss"].get("iterations", FINAL_WINDOW) for e in summary["groups"]}
    over = f"its last {windows.pop()} iterations" if len(windows) == 1 else "its last iterations (n below)"
    lines += [
        "",
        f"## Final task loss, each seed's mean over {over}",
        "",
        f"| robot | label | iterations | mean ± {level} CI half-width | best seed | worst seed | per seed |",
        "|---|---|---:|---|---|---|---|",
    ]
    for e in summary["groups"]:
        window = e[f"last{FINAL_WINDOW}_task_loss"]
        stuck_rows = {s["per_seed_index"] for s in e.get("stuck", [])}
        per_seed = ", ".join(
            format_number(v) + (" (stuck)" if i in stuck_rows else "")
            for i, v in enumerate(window["per_seed"])
        )
        n = window.get("iterations", FINAL_WINDOW)
        if e.get("not_a_result"):
            lines.append(f"| {e['robot']} | {e['label']} | {n} | **not a result** | — | — | {per_seed} |")
            continue
        half = "" if window["half_width"] is None else f" ± {format_number(window['half_width'])}"
        lines.append(
            f"| {e['robot']} | {e['label']} | {n} | {format_number(window['mean'])}{half} | "
            f"{format_number(window['best'])} | {format_number(window['worst'])} | {per_seed} |"
        )
    lines += ["", "## Best label", ""]
    for robot, best in summary["best"].items():
        lines += _best_lines(robot, best)
    lines += ["", "## Files", ""] + [f"- `{name}`" for name in summary["files"]]
    lines += ["", "## Notes", ""] + ([f"- {note}" for note in summary["notes"]] or ["- none"])
    return "\n".join(lines) + "\n"


def write_report(
    source: str | os.PathLike[str], out: str | os.PathLike[str] | None = None, level: float = 0.9
) -> Report:
    """Read every run under `source` and write the report into `out` (default: `source`).

    Writes `task_loss.png`, `components.png` (if a task has several terms), `design.png` (if a
    design space recorded figures of the body: ``design=actuators|geometry|all``),
    `recon_loss.png` (if a learned observer recorded a reconstruction loss), `table1.md`,
    `table1.csv`, `summary.md` and `summary.json`.

    Raises:
      ReportError: no runs, no metrics, or a malformed file (the message names it).
    """
    source = pathlib.Path(source)
    if not (isinstance(level, (int, float)) and 0 < level < 1):
        raise ReportError(f"--level must lie in (0, 1), e.g. 0.9; got {level!r}")
    loaded = load_runs(source)
    runs = [run for run in loaded if run.records]
    if not runs:
        raise ReportError(
            f"the {len(loaded)} run(s) in {source} have no metrics yet (empty "
            f"metrics.jsonl); wait for the first optimization iteration"
        )
    out = pathlib.Path(out) if out is not None else source
    out.mkdir(parents=True, exist_ok=True)
    groups = group_runs(runs)
    summary = summarize(runs, groups, source, level)
    summary["notes"] = [
        f"{_relative(run.path, source)} has no metrics yet; left out" for run in loaded if not run.records
    ] + summary["notes"]
    colors = figures.label_colors([g.label for g in groups])
    task_curves = curves(groups, "task_loss", level)
    written = []
    if task_curves:
        written.append(figures.plot_task_loss(task_curves, out / "task_loss.png", colors, level))
    else:
        summary["notes"].append(
            "no iteration of any seed finished healthy (all skipped): task_loss.png was not written"
        )
    several = [g for g in groups if len(components(g)) > 1]
    if several:
        component_curves = [c for g in several for key in components(g) for c in curves([g], key, level)]
        written.append(figures.plot_components(component_curves, out / "components.png", colors, level))
    body_curves = [c for g in groups for key in body_figures(g) for c in curves([g], key, level)]
    if body_curves:
        written.append(figures.plot_body(body_curves, out / "design.png", colors, level))
    learned = [g for g in groups if g.learned]
    val = curves(learned, "recon_loss_val", level)
    train = curves(learned, "recon_loss_train", level)
    if val or train:
        written.append(figures.plot_recon_loss(val, train, out / "recon_loss.png", colors, level))
    else:
        summary["notes"].append(
            "no learned observer (vae, ae) recorded a reconstruction loss: recon_loss.png was not written"
        )
    per_step = figures.plot_recon_sgd(learned, out / "recon_sgd.png", colors) if learned else None
    if per_step:
        written.append(per_step)
    rows = table1(groups)
    written += _write_table1(rows, out)
    if not rows:
        summary["notes"].append("no retraining measurements (retrain_change): Table 1 is empty")
    summary["table1"] = [{k: (_number(v) if isinstance(v, float) else v) for k, v in r.items()} for r in rows]
    summary["files"] = [p.name for p in written] + ["summary.md", "summary.json"]
    (out / "summary.md").write_text(summary_markdown(summary))
    (out / "summary.json").write_text(json.dumps(summary, indent=1, allow_nan=False) + "\n")
    return Report(summary=summary, files=(out / "summary.md", out / "summary.json", *written))

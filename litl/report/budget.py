"""Task loss against simulated steps: litl's runs and the baselines' (`litl.optimizers`) on one
axis, the comparison of what gradients buy.

    python -m litl.report.budget RUN_DIR [RUN_DIR ...] --backward-cost 2.81 --out DIR

The counting rule: a forward simulation step counts 1, a backward step `--backward-cost` forward
steps (measured by `benchmarks/backward_cost.py` for the same rollout). A litl iteration is one
forward and one backward pass through its rollout, (1 + backward cost) x steps. Every other
rollout litl simulates counts its forward steps: the bootstrap rollout that fills the replay
buffer (before the first iteration); per learning phase (the bootstrap's, and one after every
episode when the observer retrains) the evaluation without a gradient (Table 1's "before", after
every episode) and, with `loop.safeguards.update_tolerance` set, the observer check's two rollouts
(the controller with the old and the updated observer); and the final evaluation of the last
parameters (`final.json`), added to the run's last point.
Baselines record their own `simulated_steps` (forward only). Network updates (the VAE's training,
PPO's epochs) simulate nothing: their time is in the wall clock, reported beside.

Writes `budget.png` (mean task loss with a 90% band over seeds against simulated steps per seed,
log axis) and `budget.md`: per method the budget, the final task loss (mean, 90% interval), the
steps and wall time to reach fixed fractions of the reference's progress (from its mean first
task loss to its mean final one: for a walker whose loss starts near 0, its distance; for a
reaching error, how much of the error it removed), and the verdict
of "reference beats method" by the claims suite's rule (Welch two-sided at 0.05, Holm over the
table) at the end of each run and at the reference's own budget.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import pathlib
from typing import Any

import numpy as np

from litl.backend import device_of
from litl.report.runs import Run, load_runs

FRACTIONS = (0.5, 0.9, 1.0)


@dataclasses.dataclass(frozen=True)
class Curve:
    """One run's seeds: `steps[s]` simulated steps per seed and `loss[s]` the task loss there,
    `wall[s]` the run's wall clock (all its seeds together), `final[s]` the final task loss."""

    label: str
    seeds: list[int]
    steps: list[np.ndarray]
    loss: list[np.ndarray]
    wall: list[np.ndarray]
    final: np.ndarray
    device: str = "—"

    @property
    def budget(self) -> float:
        return float(np.median([s[-1] for s in self.steps]))


def curve(run: Run, backward_cost: float, label: str | None = None) -> Curve:
    """The run's task loss against simulated steps per seed (see the module docstring)."""
    import json

    # A method that runs in rounds counts its simulated steps in its records; litl's loop does not.
    counted = any("simulated_steps" in r for r in run.records)
    final_file = run.path / "final.json"
    steps, loss, wall, seeds = [], [], [], run.seeds
    for seed in seeds:
        rows = sorted((r for r in run.records if int(r["seed"]) == seed), key=lambda r: int(r["step"]))
        if counted:
            steps.append(np.array([float(r["simulated_steps"]) for r in rows]))
        else:
            steps.append(litl_steps(run, rows, backward_cost, final_file.exists()))
        loss.append(np.array([float(r["task_loss"]) for r in rows]))
        wall.append(np.array([float(r.get("wall_s", math.nan)) for r in rows]))
    by_seed = {}
    if final_file.exists():
        by_seed = {int(f["seed"]): f["task_loss"] for f in json.loads(final_file.read_text())}
    final = np.full(len(seeds), math.nan)
    for s, seed in enumerate(seeds):
        value = by_seed.get(seed, loss[s][-1] if len(loss[s]) else None)
        final[s] = math.nan if value is None else float(value)
    device = device_of(run.settings.get("backend")) or "—"
    return Curve(label or run.head, seeds, steps, loss, wall, final, device)


def litl_steps(run: Run, rows: list[dict[str, Any]], backward_cost: float, finished: bool) -> np.ndarray:
    """(len(rows),) the forward-step equivalents a litl seed had simulated by each of its metrics
    records (ascending steps), by the module docstring's rule."""
    rollout = int(run.settings["steps"])
    iterations = int(run.config.get("loop.iterations", 1))
    learned = bool(run.learned)
    retrains = learned and str(run.config.get("loop.schedule", "alternating")) == "alternating"
    checked = run.config.get("loop.safeguards.update_tolerance") is not None
    # Rollouts each learning phase adds: the observer check's two, where it is on.
    per_phase = 2 * checked
    done = np.array([int(r["step"]) + 1 for r in rows], np.float64)
    episodes_done = done // iterations
    startup = 1 + per_phase * learned  # the bootstrap's rollout, and its phase's check
    after_episodes = episodes_done * retrains * (1 + per_phase)  # Table 1's "before" and the check
    result: np.ndarray = done * rollout * (1 + backward_cost) + (startup + after_episodes) * rollout
    if finished and len(result):
        result[-1] += rollout  # the final evaluation (final.json)
    return result


def at_steps(c: Curve, grid: np.ndarray) -> np.ndarray:
    """(seeds, len(grid)) each seed's task loss at its last record at or before each grid point
    (NaN before its first)."""
    out = np.full((len(c.seeds), len(grid)), np.nan)
    for s, (steps, loss) in enumerate(zip(c.steps, c.loss, strict=True)):
        index = np.searchsorted(steps, grid, side="right") - 1
        out[s] = np.where(index >= 0, loss[np.clip(index, 0, None)], np.nan)
    return out


def reaching(c: Curve, target: float) -> tuple[float, float, int]:
    """Median simulated steps and wall seconds at which the seeds first reach task loss <=
    `target`, over the seeds that do, and how many do."""
    steps, walls = [], []
    for s_steps, s_loss, s_wall in zip(c.steps, c.loss, c.wall, strict=True):
        hit = np.flatnonzero(s_loss <= target)
        if hit.size:
            steps.append(s_steps[hit[0]])
            walls.append(s_wall[hit[0]])
    if not steps:
        return math.nan, math.nan, 0
    return float(np.median(steps)), float(np.median(walls)), len(steps)


def compare(curves: list[Curve], reference: str, level: float = 0.9) -> list[dict[str, Any]]:
    """One row per curve: budget, final loss with its interval, steps/wall to reach FRACTIONS of
    the reference's progress (its mean first task loss to its mean final one), and the verdicts
    against the reference (Holm over all)."""
    from litl.claims.rules import after_holm, beats
    from litl.claims.stats import holm, summarize
    from litl.report.stats import confidence_band

    ref = next(c for c in curves if c.label == reference)
    start = float(np.nanmean([loss[0] for loss in ref.loss if len(loss)]))
    progress = start - float(np.nanmean(ref.final))
    rows = []
    for c in curves:
        mean, low, high = confidence_band(c.final[:, None], level)
        row: dict[str, Any] = {
            "label": c.label,
            "seeds": int(np.isfinite(c.final).sum()),
            "budget": c.budget,
            "budget_x": c.budget / ref.budget,
            "final": (float(mean[0]), float(low[0]), float(high[0])),
            "wall_s": float(np.nanmax([w[-1] for w in c.wall])),
            "device": c.device,
            "reach": {f: reaching(c, start - f * progress) for f in FRACTIONS},
        }
        if c.label != reference:
            end = beats(summarize(ref.final), summarize(c.final), reference, c.label)
            at_ref = at_steps(c, np.array([ref.budget]))[:, 0]
            same = beats(summarize(ref.final), summarize(at_ref), reference, c.label)
            row["at_reference_budget"] = float(np.nanmean(at_ref))
            row["tests"] = {"end": end, "same_budget": same}
        rows.append(row)
    tests = [(row, key) for row in rows for key in ("end", "same_budget") if "tests" in row]
    adjusted = holm([row["tests"][key].test_p for row, key in tests])
    for (row, key), p in zip(tests, adjusted, strict=True):
        row.setdefault("holm", {})[key] = float(p)
        # The claims suite's primary verdict: one that survives Holm's correction.
        row.setdefault("after_holm", {})[key] = after_holm(row["tests"][key].verdict, float(p))
    return rows


def markdown(rows: list[dict[str, Any]], reference: str, backward_cost: float) -> str:
    def fmt(x: float, digits: int = 3) -> str:
        return "n/a" if not math.isfinite(x) else f"{x:.{digits}g}"

    lines = [
        f"Counting rule: a forward step 1, a backward step {backward_cost:g} forward steps. "
        f"Reference: {reference}. Verdicts: Welch two-sided at 0.05; the verdict shown is the one "
        "after Holm's correction over the table's tests (the unadjusted one in brackets when it "
        "differs). Wall time is the run's, all seeds together, on the device named: times on "
        "different devices do not compare.",
        "",
        "| method | seeds | simulated steps per seed | × reference | final task loss (90% CI) "
        "| wall (s, all seeds) | device | "
        + " | ".join(f"steps to {f:.0%} of the reference's progress (seeds)" for f in FRACTIONS)
        + f" | loss at the reference's budget | {reference} beats it at the end (p, Holm p) | "
        f"at the reference's budget (p, Holm p) |",
        "|---|---|---|---|---|---|---|" + "---|" * len(FRACTIONS) + "---|---|---|",
    ]
    for row in rows:
        mean, low, high = row["final"]
        reach = " | ".join(
            f"{fmt(s)} ({n})" if n else "never (0)" for s, _, n in (row["reach"][f] for f in FRACTIONS)
        )
        tests = "— | — | —"
        if "tests" in row:
            cells = []
            for key in ("end", "same_budget"):
                test, after = row["tests"][key], row["after_holm"][key]
                unadjusted = "" if test.verdict == after else f" [unadjusted: {test.verdict}]"
                cells.append(f"{after}{unadjusted} ({fmt(test.test_p, 2)}, {fmt(row['holm'][key], 2)})")
            tests = f"{fmt(row['at_reference_budget'])} | {cells[0]} | {cells[1]}"
        lines.append(
            f"| {row['label']} | {row['seeds']} | {fmt(row['budget'])} | {row['budget_x']:.1f} | "
            f"{mean:.3f} [{low:.3f}, {high:.3f}] | {row['wall_s']:.0f} | {row['device']} | {reach} "
            f"| {tests} |"
        )
    return "\n".join(lines) + "\n"


def draw(curves: list[Curve], path: pathlib.Path, title: str, level: float = 0.9) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from litl.report.stats import confidence_band

    top = max(max(s[-1] for s in c.steps) for c in curves)
    bottom = min(min(s[0] for s in c.steps) for c in curves)
    grid = np.geomspace(max(bottom, 1.0), top, 400)
    fig, ax = plt.subplots(figsize=(7, 4.2))
    for c in curves:
        values = at_steps(c, grid)
        inside = grid <= c.budget
        mean, low, high = confidence_band(values[:, inside], level)
        ax.plot(grid[inside], mean, label=f"{c.label} ({len(c.seeds)} seeds)")
        ax.fill_between(grid[inside], low, high, alpha=0.2)
    ax.set_xscale("log")
    ax.set_xlabel("simulated steps per seed (forward-step equivalents)")
    ax.set_ylabel("task loss")
    ax.set_title(title)
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m litl.report.budget",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("runs", nargs="+", help="run directories (LABEL=DIR to name one)")
    parser.add_argument("--backward-cost", type=float, required=True, help="a backward step in forward steps")
    parser.add_argument("--reference", help="the label the others are compared with (default: the first)")
    parser.add_argument("--out", default=".", help="where budget.png and budget.md go")
    parser.add_argument("--title", default="task loss against simulated steps")
    args = parser.parse_args(argv)
    if not (math.isfinite(args.backward_cost) and args.backward_cost >= 0):
        parser.error(f"--backward-cost {args.backward_cost}: a backward step costs >= 0 forward steps")
    curves = []
    for spec in args.runs:
        label, _, path = spec.rpartition("=") if "=" in spec else (None, "", spec)
        for run in load_runs(path):
            curves.append(curve(run, args.backward_cost, label or None))
    reference = args.reference or curves[0].label
    if reference not in {c.label for c in curves}:
        parser.error(f"--reference {reference}: not among the runs' labels {[c.label for c in curves]}")
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    draw(curves, out / "budget.png", args.title)
    text = markdown(compare(curves, reference), reference, args.backward_cost)
    (out / "budget.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

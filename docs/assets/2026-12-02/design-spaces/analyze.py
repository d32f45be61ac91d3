"""The design-spaces page's table from its run directories (docs/results/2026-12-02-design-spaces.md).

    python docs/assets/2026-12-02/design-spaces/analyze.py RUNS_ROOT

RUNS_ROOT holds <observer>/<condition>/ run directories (modulus, actuators, all, fixed). For each:
the final task loss per seed (final.json), its mean with a 90% t-interval, the paired difference
to design=modulus on the same seeds (mean and 90% t-interval), the body's figures at the last
iteration (mean over seeds).
"""

from __future__ import annotations

import json
import pathlib
import sys

import numpy as np

from litl.report.stats import confidence_band

CONDITIONS = ("fixed", "actuators_fixed", "modulus", "actuators", "all")
FIGURES = ("placement/moved", "placement/actuated", "geometry/volume", "geometry/grayness")


def interval(values) -> str:
    mean, low, high = (
        float(np.asarray(v).reshape(-1)[-1]) for v in confidence_band(np.asarray(values)[:, None])
    )
    return f"{mean:.4f} [{low:.4f}, {high:.4f}]"


def main(root: pathlib.Path) -> None:
    for observer in sorted(p.name for p in root.iterdir() if p.is_dir()):
        runs = {c: root / observer / c for c in CONDITIONS if (root / observer / c / "final.json").exists()}
        if not runs:
            continue
        finals = {
            c: {r["seed"]: r["task_loss"] for r in json.loads((d / "final.json").read_text())}
            for c, d in runs.items()
        }
        print(f"\n### {observer}\n")
        print(
            "| condition | final task loss, mean [90% CI] | minus modulus, paired [90% CI] | "
            + " | ".join(FIGURES)
            + " |"
        )
        print("|---|---|---|" + "---|" * len(FIGURES))
        for condition, directory in runs.items():
            seeds = sorted(finals[condition])
            values = np.array([finals[condition][s] for s in seeds])
            paired = "—"
            if condition != "modulus" and "modulus" in finals:
                paired = interval(values - np.array([finals["modulus"][s] for s in seeds]))
            records = [json.loads(line) for line in (directory / "metrics.jsonl").read_text().splitlines()]
            last_step = max(r["step"] for r in records)
            last = [r for r in records if r["step"] == last_step]
            figures = [f"{np.mean([r[f] for r in last]):.3f}" if f in last[0] else "—" for f in FIGURES]
            print(f"| {condition} | {interval(values)} | {paired} | " + " | ".join(figures) + " |")
        for condition in runs:
            shown = ", ".join(f"{finals[condition][s]:.4f}" for s in sorted(finals[condition]))
            print(f"\n{condition} per seed: {shown}")


def observers_compared(root: pathlib.Path, a: str = "vae", b: str = "kmeans") -> None:
    """Per condition, observer `a`'s mean final task loss minus `b`'s, with a 90% Welch interval
    and its two-sided p (the seeds are the same numbers, but each observer starts them apart)."""
    from scipy import stats

    print(f"\n### {a} minus {b}\n")
    print("| condition | difference [90% CI] | two-sided p |")
    print("|---|---|---|")
    for condition in CONDITIONS:
        files = [root / o / condition / "final.json" for o in (a, b)]
        if not all(f.exists() for f in files):
            continue
        x, y = (np.array([r["task_loss"] for r in json.loads(f.read_text())]) for f in files)
        vx, vy = x.var(ddof=1) / len(x), y.var(ddof=1) / len(y)
        difference, se = x.mean() - y.mean(), np.sqrt(vx + vy)
        dof = (vx + vy) ** 2 / (vx**2 / (len(x) - 1) + vy**2 / (len(y) - 1))
        half = stats.t.ppf(0.95, dof) * se
        p = 2 * stats.t.sf(abs(difference / se), dof)
        print(
            f"| {condition} | {difference:+.3f} [{difference - half:+.3f}, "
            f"{difference + half:+.3f}] | {p:.2f} |"
        )


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1]))
    observers_compared(pathlib.Path(sys.argv[1]))

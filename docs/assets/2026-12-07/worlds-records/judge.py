"""The biped-in-worlds table from this folder's records (the four worlds rerun from 9abd5a2).

    python docs/assets/2026-12-07/worlds-records/judge.py > docs/assets/2026-12-07/worlds-records/judge.txt

The page's rules (2026-11-27-biped-in-worlds.md): each seed's distance at its last iteration
(minus `task_loss` of metrics.jsonl's last record per seed); each world against the flat box by
Welch's two-sided t-test, Holm over the three; the co-designed Young's modulus as the last
iteration's `design_mean`, against flat by Welch (not in the family). Also the two other
numbers the pages give for a run: final.json's evaluation after the last update, and the mean of
each seed's last 10 iterations.
"""

import gzip
import json
import pathlib

import numpy as np
from scipy import stats

HERE = pathlib.Path(__file__).parent
WORLDS = ("flat", "sand", "slope", "water")


def records(world: str) -> list[dict]:
    with gzip.open(HERE / world / "metrics.jsonl.gz", "rt") as lines:
        return [json.loads(line) for line in lines]


def per_seed(rows: list[dict], key: str, last: int = 1) -> np.ndarray:
    seeds = sorted({r["seed"] for r in rows})
    out = []
    for seed in seeds:
        mine = sorted((r for r in rows if r["seed"] == seed), key=lambda r: r["step"])
        out.append(np.mean([r[key] for r in mine[-last:]]))
    return np.array(out)


def interval(values) -> str:
    values = np.asarray(values)
    half = stats.t.ppf(0.95, len(values) - 1) * values.std(ddof=1) / np.sqrt(len(values))
    return f"{values.mean():.3f} ± {half:.3f}"


def holm(p):
    p = np.asarray(p)
    order = np.argsort(p)
    adjusted = np.empty_like(p)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, (len(p) - rank) * p[i])
        adjusted[i] = min(running, 1.0)
    return adjusted


def main() -> None:
    present = [w for w in WORLDS if (HERE / w / "metrics.jsonl.gz").exists()]
    data = {w: records(w) for w in present}
    distance = {w: -per_seed(data[w], "task_loss") for w in present}
    modulus = {w: per_seed(data[w], "design_mean") for w in present}
    last10 = {w: -per_seed(data[w], "task_loss", last=10) for w in present}
    final = {
        w: -np.array(
            [
                r["task_loss"]
                for r in sorted(json.loads((HERE / w / "final.json").read_text()), key=lambda r: r["seed"])
            ]
        )
        for w in present
    }
    print("world   distance(last it.)  final.json      last 10         mean E")
    for w in present:
        print(
            f"{w:7s} {interval(distance[w]):17s}  {interval(final[w]):14s}  "
            f"{interval(last10[w]):14s}  {interval(modulus[w])}"
        )
    if "flat" not in present:
        print("flat not run yet: no tests")
        return
    others = [w for w in present if w != "flat"]
    tests = [stats.ttest_ind(distance[w], distance["flat"], equal_var=False) for w in others]
    adjusted = holm([t.pvalue for t in tests]) if len(others) == 3 else [np.nan] * len(others)
    print("\nagainst flat (Welch, two-sided; Holm over the 3)")
    for w, t, a in zip(others, tests, adjusted, strict=True):
        diff = distance[w].mean() - distance["flat"].mean()
        e = stats.ttest_ind(modulus[w], modulus["flat"], equal_var=False).pvalue
        print(
            f"{w:6s} {diff:+.3f} ({100 * diff / distance['flat'].mean():+.0f}%)  p {t.pvalue:.2g}  "
            f"Holm {a:.2g}  E {modulus[w].mean():.1f} (p {e:.2g} vs flat)"
        )


if __name__ == "__main__":
    main()

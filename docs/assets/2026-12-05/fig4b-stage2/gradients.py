"""The controller's gradient norm per cell of a Fig. 4b claims --out (every iteration of every seed).

    python docs/assets/2026-12-05/fig4b-stage2/gradients.py OUT_DIR [OUT.json]

For each cell under OUT_DIR/runs/paper/fig4b/<variant>/ (its slices pooled, or a whole cell's
directory): the median, 90th percentile and largest of `controller_grad_norm` over its finite
values, how many iterations had a non-finite one, and the median by episode. Reads metrics.jsonl
only; run on docs/assets/2026-12-04/fig4b-reading2 it gives the seeds 0-9 table of the
2026-12-05 page (801, 4.4e6, 1.8e16, 57 of 1,000 for the VAE).
"""

from __future__ import annotations

import json
import math
import pathlib
import sys

import numpy as np


def records(cell: pathlib.Path) -> list[dict]:
    rows = []
    for path in sorted(cell.rglob("metrics.jsonl")):
        rows += [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    return rows


def norm(row: dict) -> float:
    value = row.get("controller_grad_norm")
    return float("nan") if value is None else float(value)


def summary(rows: list[dict]) -> dict:
    norms = np.array([norm(r) for r in rows])
    finite = norms[np.isfinite(norms)]
    episodes = sorted({int(r["episode"]) for r in rows})
    by_episode = {}
    for e in episodes:
        values = np.array([norm(r) for r in rows if int(r["episode"]) == e])
        values = values[np.isfinite(values)]
        by_episode[e] = float(np.median(values)) if values.size else math.nan
    return {
        "iterations": int(norms.size),
        "seeds": sorted({int(r["seed"]) for r in rows}),
        "median": float(np.median(finite)),
        "p90": float(np.percentile(finite, 90)),
        "largest": float(finite.max()),
        "non_finite": int(norms.size - finite.size),
        "median_by_episode": by_episode,
    }


def main(out_dir: pathlib.Path, out: pathlib.Path | None = None) -> None:
    cells = sorted(p for p in (out_dir / "runs" / "paper" / "fig4b").iterdir() if p.is_dir())
    result = {cell.name: summary(records(cell)) for cell in cells if records(cell)}
    print("| cell | seeds | median | 90th percentile | largest | non-finite |")
    print("|---|---|---:|---:|---:|---:|")
    for name, s in result.items():
        print(
            f"| {name} | {s['seeds'][0]}-{s['seeds'][-1]} | {s['median']:.3g} | {s['p90']:.3g} | "
            f"{s['largest']:.3g} | {s['non_finite']} of {s['iterations']} |"
        )
    for name, s in result.items():
        print(name, "median by episode:", ", ".join(f"{v:.3g}" for v in s["median_by_episode"].values()))
    if out is not None:
        out.write_text(json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2]) if len(sys.argv) > 2 else None)

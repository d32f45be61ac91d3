"""Choose latent_mpc's horizon and iterations on the tuning run (seeds 100-102, never reported).

    PYTHONPATH=. python docs/assets/2026-12-07/latent-control/tune.py TUNING_RUN_DIR OUT_DIR

The rule, written before it ran (plan.md): every (horizon, iterations) of the grid plans both
held-out goals (walk:-1, reach:0.37) on the three seeds; per goal the combinations are ranked by
their mean over seeds (walk: displacement in the goal's direction, more is better; reach: final
error, less is better); the combination with the lowest mean rank over the two goals is chosen,
ties to the one with fewer model steps per control step. Writes OUT_DIR/tune.json and tune.txt.
"""

import itertools
import json
import pathlib
import sys

import numpy as np

from litl.latent.control import run

GRID = {"horizon": (5, 10, 20), "iterations": (30, 100)}
GOALS = ("walk:-1", "reach:0.37")


def score(summary: dict) -> float:
    seeds = summary["seeds"]
    if summary["goal"]["kind"] == "walk":
        return float(np.mean([s["displacement"] for s in seeds]))
    return -float(np.mean([s["error"] for s in seeds]))  # higher is better for both


def main(run_dir: str, out_dir: str) -> None:
    out = pathlib.Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for horizon, iterations in itertools.product(GRID["horizon"], GRID["iterations"]):
        row = {"horizon": horizon, "iterations": iterations}
        for goal in GOALS:
            summary = run(
                run_dir,
                goal,
                "latent_mpc",
                [f"horizon={horizon}", f"iterations={iterations}"],
                out=out / f"h{horizon}-i{iterations}-{goal.replace(':', '')}.json",
            )
            row[goal] = score(summary)
            row["model_steps"] = summary["model_steps_per_control_step"]
            row[f"{goal} wall_s_per_control_step"] = summary["wall_s_per_control_step"]
        rows.append(row)
        print(row, flush=True)
    for goal in GOALS:
        order = sorted(range(len(rows)), key=lambda i: -rows[i][goal])
        for rank, i in enumerate(order):
            rows[i][f"{goal} rank"] = rank + 1
    for row in rows:
        row["mean_rank"] = float(np.mean([row[f"{g} rank"] for g in GOALS]))
    chosen = min(rows, key=lambda r: (r["mean_rank"], r["model_steps"]))
    (out / "tune.json").write_text(json.dumps({"rows": rows, "chosen": chosen}, indent=1))
    lines = [f"{'horizon':>7} {'iters':>5} {'walk:-1':>9} {'reach err':>9} {'rank':>5}"]
    for r in rows:
        lines.append(
            f"{r['horizon']:7d} {r['iterations']:5d} {r['walk:-1']:+9.4f} "
            f"{-r['reach:0.37']:9.4f} {r['mean_rank']:5.1f}"
        )
    lines.append(f"chosen: horizon={chosen['horizon']} iterations={chosen['iterations']}")
    (out / "tune.txt").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main(*sys.argv[1:3])

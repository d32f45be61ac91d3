"""Each seed of a claims table, not only their means: the stuck seeds drawn, and how each seed's
first learning phase went.

* `plot_stuck_seeds`: for every "gets stuck less" claim with data, one PNG per method and panel
  (``<panel>_seeds_<method>.png``): every seed's task loss against iteration, a subplot per
  compared variant, the seeds stuck near their start by the claim's rule (`litl.claims.verdicts.
  stuck_near_start`) drawn thick and named in the legend.
* `first_phase_markdown`: per learned variant, each seed's first learning phase (phase 0 of its
  learning.jsonl: `recon_explained`, active latent units, SGD steps), and how many seeds learned by
  the paper reading's criterion (`recon_explained` >= 0.2 and >= 4 active units).
"""

from __future__ import annotations

import pathlib
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from litl.claims.verdicts import CLAIMS, progress, stuck_near_start
from litl.report.runs import Group
from litl.report.stats import series

# The first phase "learned" (docs/guide/method.md, "The values the paper's text leaves open").
LEARNED_EXPLAINED = 0.2
LEARNED_UNITS = 4

Groups = Mapping[tuple[str, str], Mapping[str, Group]]


def plot_stuck_seeds(groups: Groups, methods: Sequence[str], out: pathlib.Path) -> list[pathlib.Path]:
    """The PNGs of the stuck seeds (the module docstring); returns the files written."""
    from matplotlib.figure import Figure

    written = []
    for claim in (c for c in CLAIMS if c.kind == "stuck" and c.b is not None):
        for method in methods:
            by_variant = groups.get((method, claim.panel), {})
            b = claim.b or ""
            if claim.a not in by_variant or b not in by_variant:
                continue
            sides = (by_variant[claim.a], by_variant[b])
            flags_a, flags_b, threshold = stuck_near_start(progress(sides[0]), progress(sides[1]))
            figure = Figure(figsize=(10, 4))
            for index, (group, flags) in enumerate(zip(sides, (flags_a, flags_b), strict=True)):
                ax = figure.add_subplot(1, 2, index + 1)
                steps, values = series(group, "task_loss")
                seeds = [seed for run in group.runs for seed in run.seeds]
                for row, (seed, stuck) in enumerate(zip(seeds, flags, strict=True)):
                    ax.plot(
                        steps,
                        values[row],
                        color="tab:red" if stuck else "0.55",
                        lw=2.2 if stuck else 0.8,
                        label=f"seed {seed} (stuck)" if stuck else None,
                        gid="stuck" if stuck else "seed",
                    )
                ax.set_title(f"{group.label}: {int(flags.sum())} of {len(flags)} stuck", fontsize=10)
                ax.set_xlabel("iteration")
                ax.set_ylabel("task loss")
                ax.grid(alpha=0.3)
                if flags.any():
                    ax.legend(fontsize="x-small")
            figure.suptitle(
                f"{claim.panel}, method={method}: stuck = progress below 25% of the pooled median "
                f"({threshold:.3g})",
                fontsize=10,
            )
            figure.tight_layout()
            path = out / f"{claim.panel}_seeds_{method}.png"
            figure.savefig(path, dpi=110)
            written.append(path)
    return written


def first_phase_rows(group: Group) -> list[dict[str, Any]]:
    """Each seed's first learning phase (phase 0 of its run's learning.jsonl), in seed order."""
    rows = []
    for run in group.runs:
        for record in sorted(
            (r for r in run.learning if int(r.get("phase", -1)) == 0), key=lambda r: r["seed"]
        ):
            explained, units = float(record["recon_explained"]), int(record["active_units"])
            rows.append(
                {
                    "seed": int(record["seed"]),
                    "recon_explained": explained,
                    "active_units": units,
                    "sgd_steps": int(record.get("sgd_steps", 0)),
                    "learned": bool(
                        np.isfinite(explained) and explained >= LEARNED_EXPLAINED and units >= LEARNED_UNITS
                    ),
                }
            )
    return rows


def first_phase_markdown(groups: Groups, methods: Sequence[str]) -> str:
    """The first learning phase of every learned variant's seeds, a table per method, panel and
    variant ("" when no variant learns)."""
    lines = []
    for (method, panel), by_variant in groups.items():
        if method not in methods:
            continue
        for name, group in by_variant.items():
            rows = first_phase_rows(group)
            if not rows:
                continue
            learned = sum(r["learned"] for r in rows)
            lines += [
                f"## {panel}, {name}, method={method}: the first phase learned in {learned} of "
                f"{len(rows)} seeds",
                "",
                f"(learned: `recon_explained` >= {LEARNED_EXPLAINED} and >= {LEARNED_UNITS} active "
                f"latent units)",
                "",
                "| seed | recon_explained | active units | SGD steps | learned |",
                "|---:|---:|---:|---:|---|",
                *(
                    f"| {r['seed']} | {r['recon_explained']:.3f} | {r['active_units']} | {r['sgd_steps']} | "
                    f"{'yes' if r['learned'] else 'no'} |"
                    for r in rows
                ),
                "",
            ]
    return ("# The first learning phase, seed by seed\n\n" + "\n".join(lines)) if lines else ""

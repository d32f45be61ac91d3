"""The plan's tests (plan.md, written before the runs: 12 in the first round, 6 in the second, 4
in the third, 2 in the fourth, 14 in the fifth, 4 in the sixth, 13 in the seventh) and its
descriptive cells, from results/ (the biped), arm/results/ (the fifth and seventh rounds' arm)
and shifted/results/ (the sixth and seventh rounds' shifted biped).

    python docs/assets/2026-12-07/latent-control/judge.py > docs/assets/2026-12-07/latent-control/judge.txt

Measures per seed: walk goals, the displacement in the goal's direction (more is better); reach,
the final |x - 0.37| (less is better). Paired t (two-sided) where both cells are the same run's
seeds, Welch between different runs (VAE and PCA; a run retrained for the goal); 90% t
intervals; Holm over each family. results/<obs>/retrained-<goal>.json is `--planner trained` on
the run trained for that goal (retrained/), results/sinusoid/trained-<goal>.json the same for the
open-loop sinusoids trained for it.
"""

import json
import pathlib

import numpy as np
from scipy import stats

HERE = pathlib.Path(__file__).parent / "results"
ARM = pathlib.Path(__file__).parent / "arm" / "results"  # the fifth round's
ARM_GOALS = {"reach0.46": "reach:0.46", "reach0.54": "reach:0.54", "reach0.6": "reach:0.6"}
GOALS = {"walk1": "walk:+1", "walk-1": "walk:-1", "reach0.37": "reach:0.37"}
PLANNERS = (
    "trained",
    "rest",
    "latent_mpc",
    "latent_mpc_linear",
    "latent_lqr",
    "latent_ilqr",
    "oracle_mpc",
    "oracle_mpc_h10",
    "retrained",
)
MODELLED = ("latent_mpc", "latent_mpc_linear", "latent_lqr", "latent_ilqr", "oracle_mpc", "oracle_mpc_h10")


def load(obs: str, planner: str, goal: str, root: pathlib.Path = HERE):
    path = root / obs / f"{planner}-{goal}.json"
    if not path.exists():
        return None
    summary = json.loads(path.read_text())
    seeds = sorted(summary["seeds"], key=lambda s: s["seed"])
    key = "error" if goal.startswith("reach") else "displacement"  # reach0.37-2s too
    return summary, np.array([s[key] for s in seeds])


def interval(values, digits: int = 3) -> str:
    values = np.asarray(values)
    half = stats.t.ppf(0.95, len(values) - 1) * values.std(ddof=1) / np.sqrt(len(values))
    m, f = values.mean(), f"+.{digits}f"
    return f"{m:{f}} [{m - half:{f}}, {m + half:{f}}]"


def holm(p):
    p = np.asarray(p, float)
    order, adjusted, running = np.argsort(p), np.empty(len(p)), 0.0
    for rank, i in enumerate(order):
        running = max(running, (len(p) - rank) * p[i])
        adjusted[i] = min(running, 1.0)
    return adjusted


def cells() -> None:
    print("Cells: mean [90% CI] over seeds (walk: displacement, reach: final error)\n")
    print(f"{'observer':8s} {'planner':18s} " + " ".join(f"{g:>28s}" for g in GOALS.values()))
    for obs in ("vae", "pca", "sinusoid"):
        for planner in PLANNERS:
            row = [load(obs, planner, g) for g in GOALS]
            if all(r is None for r in row):
                continue
            text = " ".join(f"{interval(r[1]) if r is not None else '—':>28s}" for r in row)
            print(f"{obs:8s} {planner:18s} {text}")
    print("\nModel and cost (means over seeds and goals): readout R2, one-step position RMS under the")
    print("planner's own actions / the step's own RMS, compile s, wall s per control step and seed")
    for obs in ("vae", "pca"):
        for planner in MODELLED:
            found = [load(obs, planner, g) for g in GOALS]
            found = [f[0] for f in found if f is not None]
            if not found:
                continue
            seeds = [s for f in found for s in f["seeds"]]
            r2 = np.mean([np.mean(s["readout_r2"]) for s in seeds])
            miss = np.mean([s["one_step_position_rms"] for s in seeds])
            step = np.mean([s["one_step_motion_rms"] for s in seeds])
            compile_s = np.mean([f["compile_s"] for f in found])
            wall = np.mean([f["wall_s_per_control_step"] for f in found])
            print(
                f"{obs:5s} {planner:18s} R2 {r2:.3f}  one-step {miss:.4f} / {step:.4f}  "
                f"compile {compile_s:.0f} s  {wall * 1e3:.1f} ms"
            )


def judge(title: str, family, drop_missing: bool = False) -> None:
    """Each test of `family` (name, cell a, cell b, paired), Holm over the family (`drop_missing`:
    over the tests whose cells ran, the fifth round's rule; else a missing test counts as p 1)."""
    rows = []
    for name, a, b, paired in family:
        x, y = load(*a), load(*b)
        if x is None or y is None:
            rows.append((name, None))
            continue
        x, y = x[1], y[1]
        test = stats.ttest_rel(x, y) if paired else stats.ttest_ind(x, y, equal_var=False)
        text = interval(x - y) if paired else f"{x.mean() - y.mean():+.3f} (Welch)"
        rows.append((name, (text, test.pvalue)))
    ready = [r for r in rows if r[1] is not None]
    over = len(ready) if drop_missing else len(rows)
    print(f"\n{title} ({len(ready)} of {len(rows)} computable), Holm over {over}:")
    adjusted = holm([r[1][1] for r in ready] + ([] if drop_missing else [1.0] * (len(rows) - len(ready))))
    for (name, (text, p)), a in zip(ready, adjusted, strict=False):
        print(f"  {name:48s} {text:34s} p {p:.2g}  Holm {a:.2g}")
    for name, value in rows:
        if value is None:
            print(f"  {name:48s} not run")


def second_round() -> None:
    family = [
        (
            "vae walk:-1: latent_mpc - retrained",
            ("vae", "latent_mpc", "walk-1"),
            ("vae", "retrained", "walk-1"),
            False,
        ),
        (
            "vae reach:0.37: latent_lqr - retrained",
            ("vae", "latent_lqr", "reach0.37"),
            ("vae", "retrained", "reach0.37"),
            False,
        ),
        (
            "vae walk:-1: oracle_mpc_h10 - latent_mpc",
            ("vae", "oracle_mpc_h10", "walk-1"),
            ("vae", "latent_mpc", "walk-1"),
            True,
        ),
        (
            "vae reach:0.37: oracle_mpc_h10 - latent_mpc",
            ("vae", "oracle_mpc_h10", "reach0.37"),
            ("vae", "latent_mpc", "reach0.37"),
            True,
        ),
        (
            "walk:-1: retrained vae - sinusoid",
            ("vae", "retrained", "walk-1"),
            ("sinusoid", "trained", "walk-1"),
            False,
        ),
        (
            "reach:0.37: retrained vae - sinusoid",
            ("vae", "retrained", "reach0.37"),
            ("sinusoid", "trained", "reach0.37"),
            False,
        ),
    ]
    judge("The second round's family", family)


def third_round() -> None:
    family = [
        (
            f"{obs} {GOALS[goal]}: latent_ilqr - latent_mpc",
            (obs, "latent_ilqr", goal),
            (obs, "latent_mpc", goal),
            True,
        )
        for goal in ("walk-1", "reach0.37")
        for obs in ("vae", "pca")
    ]
    judge("The third round's family", family)


def fourth_round() -> None:
    print("\nFourth round: reach:0.37 over 2 s (64 control steps); error mean [90% CI], seeds within")
    print("0.025, seeds stopped (|final speed| < 0.02 per s), mean |final speed|")
    for obs in ("vae", "pca"):
        for planner in ("rest", "latent_lqr", "latent_mpc"):
            found = load(obs, planner, "reach0.37-2s")
            if found is None:
                print(f"  {obs:5s} {planner:12s} not run")
                continue
            speeds = np.array([abs(s["final_speed"]) for s in found[0]["seeds"]])
            errors = found[1]
            print(
                f"  {obs:5s} {planner:12s} {interval(errors)}  within {int(np.sum(errors < 0.025))}/10  "
                f"stopped {int(np.sum(speeds < 0.02))}/10  speed {speeds.mean():.3f}"
            )
    family = [
        (
            f"{obs} reach:0.37 over 2 s: latent_lqr - rest",
            (obs, "latent_lqr", "reach0.37-2s"),
            (obs, "rest", "reach0.37-2s"),
            True,
        )
        for obs in ("vae", "pca")
    ]
    judge("The fourth round's family", family)


def tests() -> None:
    family = []
    for goal in ("walk-1", "reach0.37"):
        for obs in ("vae", "pca"):
            for other in ("rest", "trained"):
                family.append(
                    (
                        f"{obs} {GOALS[goal]}: latent_mpc - {other}",
                        (obs, "latent_mpc", goal),
                        (obs, other, goal),
                        True,
                    )
                )
    for obs in ("vae", "pca"):
        family.append(
            (
                f"{obs} reach:0.37: latent_lqr - rest",
                (obs, "latent_lqr", "reach0.37"),
                (obs, "rest", "reach0.37"),
                True,
            )
        )
    for goal in ("walk-1", "reach0.37"):
        family.append(
            (
                f"latent_mpc {GOALS[goal]}: vae - pca",
                ("vae", "latent_mpc", goal),
                ("pca", "latent_mpc", goal),
                False,
            )
        )
    judge("The plan's family", family)


def fifth_round() -> None:
    print("\nFifth round: the arm's tip, final |x_tip - target| at 1 s, mean [90% CI]; seeds within")
    print("0.01; mean |final speed| of the tip along x")
    print(f"{'observer':8s} {'planner':14s} " + " ".join(f"{g:>44s}" for g in ARM_GOALS.values()))
    for obs in ("vae", "pca", "sinusoid"):
        for planner in (
            "trained",
            "rest",
            "latent_mpc",
            "latent_lqr",
            "latent_ilqr",
            "oracle_mpc_h10",
            "retrained",
        ):
            row = [load(obs, planner, g, ARM) for g in ARM_GOALS]
            if all(r is None for r in row):
                continue
            texts = []
            for r in row:
                if r is None:
                    texts.append("—")
                    continue
                speed = np.mean([abs(s["final_speed"]) for s in r[0]["seeds"]])
                texts.append(f"{interval(r[1], 4)} {int(np.sum(r[1] < 0.01))}/{len(r[1])} {speed:.3f}")
            print(f"{obs:8s} {planner:14s} " + " ".join(f"{t:>44s}" for t in texts))
    family = []
    for goal in ("reach0.46", "reach0.54"):
        cell = lambda obs, planner, goal=goal: (obs, planner, goal, ARM)  # noqa: E731
        g = ARM_GOALS[goal]
        family += [
            (f"arm {g}: latent_mpc - rest", cell("vae", "latent_mpc"), cell("vae", "rest"), True),
            (f"arm {g}: latent_mpc - trained", cell("vae", "latent_mpc"), cell("vae", "trained"), True),
            (f"arm {g}: latent_mpc - retrained", cell("vae", "latent_mpc"), cell("vae", "retrained"), False),
            (
                f"arm {g}: oracle_mpc_h10 - latent_mpc",
                cell("vae", "oracle_mpc_h10"),
                cell("vae", "latent_mpc"),
                True,
            ),
            (f"arm {g}: retrained - sinusoid", cell("vae", "retrained"), cell("sinusoid", "trained"), False),
            (f"arm {g}: latent_lqr - rest", cell("vae", "latent_lqr"), cell("vae", "rest"), True),
            (f"arm {g}: latent_mpc vae - pca", cell("vae", "latent_mpc"), cell("pca", "latent_mpc"), False),
        ]
    judge("The fifth round's family (the arm)", family, drop_missing=True)


SHIFTED = pathlib.Path(__file__).parent / "shifted" / "results"  # the sixth round's


def sixth_round() -> None:
    print("\nSixth round: the biped started 0.3 further right (robot.shift=0.3); displacement in the")
    print("goal's direction after 32 control steps, mean [90% CI]")
    for planner in ("trained", "rest", "latent_mpc", "oracle_mpc_h10", "retrained"):
        row = [load("vae", planner, g, SHIFTED) for g in ("walk-1", "walk1")]
        texts = [interval(r[1]) if r is not None else "—" for r in row]
        print(f"  {planner:16s} walk:-1 {texts[0]:>28s}   walk:+1 {texts[1]:>28s}")
    cell = lambda planner: ("vae", planner, "walk-1", SHIFTED)  # noqa: E731
    family = [
        ("shifted walk:-1: latent_mpc - rest", cell("latent_mpc"), cell("rest"), True),
        ("shifted walk:-1: latent_mpc - retrained", cell("latent_mpc"), cell("retrained"), False),
        ("shifted walk:-1: oracle_mpc_h10 - latent_mpc", cell("oracle_mpc_h10"), cell("latent_mpc"), True),
        (
            "walk:-1: retrained shifted - retrained at the wall",
            cell("retrained"),
            ("vae", "retrained", "walk-1"),
            False,
        ),
    ]
    judge("The sixth round's family (walk -x with room)", family, drop_missing=True)


SEVENTH = {  # the seventh round's latent_mpc cells: name -> what the model was fitted on
    "latent_mpc": "buffer (fifth/sixth round)",
    "latent_mpc-both": "buffer + 32 exploratory episodes",
    "latent_mpc-explored": "32 exploratory episodes",
    "latent_mpc-buffer-better": "buffer, warm_start=better",
}


def seventh_round() -> None:
    print("\nSeventh round: latent_mpc with the model fitted on exploratory episodes, and warm-started")
    print("by the trained MLP. arm: final tip error, seeds within 0.01; shifted biped: displacement")
    print("toward -x. Then the model: readout R2, one-step position RMS / step RMS, transitions,")
    print("compile s, wall ms per control step and seed (exploration and fit included in compile+run)")
    rows = [(ARM, obs, g) for obs in ("vae", "pca", "kmeans") for g in ("reach0.46", "reach0.54")]
    rows += [(SHIFTED, obs, "walk-1") for obs in ("vae", "kmeans")]
    for root, obs, goal in rows:
        rest = load(obs, "rest", goal, root)
        if rest is not None and obs == "kmeans":
            where = "arm" if root == ARM else "shifted"
            print(f"  {where:7s} {obs:6s} {goal:9s} {'rest':34s} {interval(rest[1], 4)}")
        for name, data in SEVENTH.items():
            found = load(obs, name, goal, root)
            if found is None:
                continue
            summary, values = found
            within = f" {int(np.sum(values < 0.01))}/{len(values)}" if goal.startswith("reach") else ""
            seeds = summary["seeds"]
            r2 = np.mean([np.mean(s["readout_r2"]) for s in seeds])
            miss = np.mean([s["one_step_position_rms"] for s in seeds])
            step = np.mean([s["one_step_motion_rms"] for s in seeds])
            where = "arm" if root == ARM else "shifted"
            print(
                f"  {where:7s} {obs:6s} {goal:9s} {data:34s} {interval(values, 4)}{within}  R2 {r2:.2f}  "
                f"{miss:.4f} / {step:.4f}  n {seeds[0]['transitions']}  {summary['compile_s']:.0f} s  "
                f"{summary['wall_s_per_control_step'] * 1e3:.0f} ms"
            )
    print("\nHeld-out exploratory episodes (heldout.py; 16 per seed): RMS error of the task point's")
    print("predicted displacement along x, h = 1, 5, 20 control steps ahead, mean over seeds [90% CI],")
    print("beside the zero-motion prediction's (the RMS displacement itself)")
    for where in ("arm", "shifted"):
        for obs in ("vae", "pca", "kmeans"):
            path = pathlib.Path(__file__).parent / where / "heldout" / f"{obs}.json"
            if not path.exists():
                continue
            found = json.loads(path.read_text())
            for source, parts in found["sources"].items():
                errors = np.asarray(parts["displacement"])
                texts = [interval(errors[:, i], 4) for i in range(errors.shape[1])]
                still = np.mean(parts["zero_motion"], axis=0)
                print(
                    f"  {where:7s} {obs:6s} {source:8s} "
                    + "  ".join(f"h={h}: {t}" for h, t in zip(found["horizons"], texts, strict=True))
                    + "   zero motion "
                    + " ".join(f"{v:.4f}" for v in still)
                )
    family = []
    for goal in ("reach0.46", "reach0.54"):
        cell = lambda obs, name, goal=goal: (obs, name, goal, ARM)  # noqa: E731
        g = ARM_GOALS[goal]
        family += [
            (f"arm {g}: vae both - buffer", cell("vae", "latent_mpc-both"), cell("vae", "latent_mpc"), True),
            (
                f"arm {g}: vae better - previous",
                cell("vae", "latent_mpc-buffer-better"),
                cell("vae", "latent_mpc"),
                True,
            ),
            (
                f"arm {g}: explored vae - kmeans",
                cell("vae", "latent_mpc-explored"),
                cell("kmeans", "latent_mpc-explored"),
                False,
            ),
            (
                f"arm {g}: explored vae - pca",
                cell("vae", "latent_mpc-explored"),
                cell("pca", "latent_mpc-explored"),
                False,
            ),
            (f"arm {g}: vae both - rest", cell("vae", "latent_mpc-both"), cell("vae", "rest"), True),
        ]
    cell = lambda obs, name: (obs, name, "walk-1", SHIFTED)  # noqa: E731
    family += [
        (
            "shifted walk:-1: vae both - buffer",
            cell("vae", "latent_mpc-both"),
            cell("vae", "latent_mpc"),
            True,
        ),
        (
            "shifted walk:-1: vae better - previous",
            cell("vae", "latent_mpc-buffer-better"),
            cell("vae", "latent_mpc"),
            True,
        ),
        (
            "shifted walk:-1: explored vae - kmeans",
            cell("vae", "latent_mpc-explored"),
            cell("kmeans", "latent_mpc-explored"),
            False,
        ),
    ]
    judge("The seventh round's family (is the model the gap?)", family, drop_missing=True)


if __name__ == "__main__":
    cells()
    tests()
    second_round()
    third_round()
    fourth_round()
    fifth_round()
    sixth_round()
    seventh_round()

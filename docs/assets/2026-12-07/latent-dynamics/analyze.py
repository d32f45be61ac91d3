"""The latent dynamics model measured in the loop (loop.dynamics), summarized over seeds.

    python docs/assets/2026-12-07/latent-dynamics/analyze.py OUT_DIR NAME=RUN_DIR [NAME=RUN_DIR ...]

Reads each run's learning.jsonl (its ``dynamics/...`` values; `litl.latent.in_loop`) and writes,
into OUT_DIR: summary.json (per observer, per horizon and model: the last phase's error, mean over
seeds with a 90% Student-t interval, and each model's error over the constant baseline's, paired
per seed), prediction.png (error against horizon, latent and decoded) and phases.png (the h=5
error at every learning phase). Seeds whose value is null are left out and counted.
"""

import json
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from litl.report.stats import confidence_band

COLORS = {"linear": "tab:blue", "mlp": "tab:orange", "constant": "tab:green", "floor": "tab:gray"}
STYLES = ("-", "--", ":")  # one per observer, in the order given


def phases(run_dir: pathlib.Path) -> dict[int, dict[int, dict]]:
    """{seed: {phase: record}} of a run's learning.jsonl."""
    out: dict[int, dict[int, dict]] = {}
    for line in (run_dir / "learning.jsonl").read_text().splitlines():
        record = json.loads(line)
        out.setdefault(record["seed"], {})[record["phase"]] = record
    return out


def value(record: dict, key: str) -> float:
    v = record.get(key)
    return np.nan if v is None else float(v)


def band(values) -> dict:
    values = np.asarray(values, float)
    mean, low, high = confidence_band(values[:, None])
    return {
        "mean": float(mean[0]),
        "ci90": [float(low[0]), float(high[0])],
        "seeds": int(np.isfinite(values).sum()),
    }


def main(out: pathlib.Path, runs: dict[str, pathlib.Path]) -> None:
    out.mkdir(parents=True, exist_ok=True)
    summary: dict = {}
    figure, axes = plt.subplots(1, 2, figsize=(10, 4))
    phase_figure, phase_axis = plt.subplots(figsize=(6, 4))
    for index, (name, run_dir) in enumerate(runs.items()):
        style = STYLES[index % len(STYLES)]
        by_seed = phases(run_dir)
        seeds = sorted(by_seed)
        last = max(by_seed[seeds[0]])
        example = by_seed[seeds[0]][last]
        horizons = sorted(
            int(k.split("h=")[1]) for k in example if k.startswith("dynamics/latent/constant/h=")
        )
        entry: dict = {"run_dir": str(run_dir.name), "seeds": seeds, "phase": last, "horizons": horizons}
        for space in ("latent", "decoded"):
            models = ("linear", "mlp", "constant") + (("floor",) if space == "decoded" else ())
            for model in models:
                for h in horizons:
                    values = [value(by_seed[s][last], f"dynamics/{space}/{model}/h={h}") for s in seeds]
                    entry[f"{space}/{model}/h={h}"] = band(values)
                    if model in ("linear", "mlp"):
                        base = [value(by_seed[s][last], f"dynamics/{space}/constant/h={h}") for s in seeds]
                        ratio = np.asarray(values) / np.asarray(base)
                        entry[f"{space}/{model}_over_constant/h={h}"] = band(ratio)
        for key in (
            "dynamics/field_rms",
            "dynamics/linear/train_rms",
            "dynamics/mlp/epochs",
            "dynamics/rollouts_train",
            "dynamics/rollouts_validation",
        ):
            entry[key.removeprefix("dynamics/")] = band([value(by_seed[s][last], key) for s in seeds])
        entry["mlp_hit_epoch_limit"] = int(
            sum(value(by_seed[s][last], "dynamics/mlp/epochs") >= 2000 for s in seeds)
        )
        entry["recon_explained"] = band([value(by_seed[s][last], "recon_explained") for s in seeds])
        summary[name] = entry
        for axis, space in zip(axes, ("latent", "decoded"), strict=True):
            models = ("linear", "mlp", "constant") + (("floor",) if space == "decoded" else ())
            for model in models:
                means = [entry[f"{space}/{model}/h={h}"]["mean"] for h in horizons]
                lows = [entry[f"{space}/{model}/h={h}"]["ci90"][0] for h in horizons]
                highs = [entry[f"{space}/{model}/h={h}"]["ci90"][1] for h in horizons]
                color = COLORS[model]
                axis.plot(horizons, means, style, color=color, marker="o", label=f"{name} {model}")
                axis.fill_between(horizons, lows, highs, color=color, alpha=0.12)
        # The h=5 (or the middle horizon's) error over the phases, MLP and constant.
        h = horizons[len(horizons) // 2]
        every = sorted(by_seed[seeds[0]])
        for model in ("mlp", "constant"):
            key = f"dynamics/latent/{model}/h={h}"
            values = np.array([[value(by_seed[s].get(p, {}), key) for p in every] for s in seeds])
            mean, low, high = confidence_band(values)
            color = COLORS[model]
            phase_axis.plot(every, mean, style, color=color, marker=".", label=f"{name} {model}, h={h}")
            phase_axis.fill_between(every, low, high, color=color, alpha=0.12)
    for axis, space in zip(axes, ("latent", "decoded"), strict=True):
        axis.set_xlabel("horizon h (snapshots ahead)")
        axis.set_ylabel("RMS error per latent" if space == "latent" else "RMS error per grid value")
        axis.set_title(f"{space}: last phase, mean of seeds, 90% CI")
        axis.legend(fontsize=7)
    figure.tight_layout()
    figure.savefig(out / "prediction.png", dpi=110)
    phase_axis.set_xlabel("learning phase")
    phase_axis.set_ylabel("RMS error per latent")
    phase_axis.set_title("held-out prediction error at every phase (90% CI)")
    phase_axis.legend(fontsize=7)
    phase_figure.tight_layout()
    phase_figure.savefig(out / "phases.png", dpi=110)
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    print(json.dumps(summary, indent=1))


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    named = dict(argument.split("=", 1) for argument in sys.argv[2:])
    main(pathlib.Path(sys.argv[1]), {name: pathlib.Path(path) for name, path in named.items()})

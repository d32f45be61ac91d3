"""Regenerate the gallery (`notebooks/gallery/`) shown on the README from the current code.

    python notebooks/gallery/make_gallery.py                   # runs the demo (about 2 min on CPU)
    python notebooks/gallery/make_gallery.py --demo RUN_DIR    # reuse a finished `python -m litl` run
    python notebooks/gallery/make_gallery.py --compare multirun/biped_compare/<time>
    python notebooks/gallery/make_gallery.py --no-demo --walkers outputs/walkers3d

Writes robots.png (the eight robots), and from the demo run task_loss.png, robot.gif,
saliency.gif, snapshots.png and latent_sweeps.png. With `--compare` (the multirun directory of
`python -m litl -m experiment=biped_compare`) it also writes biped_compare.png, the report's
task-loss bands of that sweep, and compare_<variant>.gif, seed 0 of each variant replayed
(`python -m litl.replay JOB --seed 0`). With `--walkers DIR` (a folder of finished runs, one per
robot, e.g. the 3D walkers: `python -m litl robot=quadruped ... hydra.run.dir=DIR/quadruped`) it
writes walker_<robot>.gif, each run's seed 0 replayed, and walker_<robot>_gait.png, how it walked
(`python -m litl.replay RUN --gait`: side view, each foot's height and travel). `--no-demo` skips
robots.png and the demo's files. Prints each file it wrote.
"""

from __future__ import annotations

import argparse
import pathlib
import shutil
import subprocess
import sys
import tempfile

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

GALLERY = pathlib.Path(__file__).resolve().parent
DEMO_FILES = ("task_loss.png", "robot.gif", "saliency.gif", "snapshots.png", "latent_sweeps.png")


def draw_robots(path: pathlib.Path) -> None:
    """All catalog robots at their default resolution, one panel each."""
    import litl.robots
    from litl.viz import draw

    names = litl.robots.names()
    figure = plt.figure(figsize=(14, 7.5))
    for index, name in enumerate(names):
        robot = litl.robots.get(name)
        projection = "3d" if robot.config.dim == 3 else None
        ax = figure.add_subplot(2, (len(names) + 1) // 2, index + 1, projection=projection)
        draw(robot, ax)
        ax.set_title(name)
    figure.subplots_adjust(left=0.04, right=0.97, wspace=0.3, hspace=0.35)
    figure.savefig(path, dpi=72)
    plt.close(figure)


def run_demo(run_dir: pathlib.Path) -> None:
    """The main command of the README, `python -m litl`, into `run_dir`."""
    command = [sys.executable, "-m", "litl", f"hydra.run.dir={run_dir}"]
    print("running:", " ".join(command), flush=True)
    subprocess.run(command, check=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--demo",
        type=pathlib.Path,
        help="a finished `python -m litl` run directory (default: run the demo now)",
    )
    parser.add_argument(
        "--compare",
        type=pathlib.Path,
        help="the multirun directory of `python -m litl -m experiment=biped_compare`",
    )
    parser.add_argument(
        "--walkers",
        type=pathlib.Path,
        help="a folder of finished runs, one per robot: walker_<robot>.gif and walker_<robot>_gait.png each",
    )
    parser.add_argument("--no-demo", action="store_true", help="skip robots.png and the demo's pictures")
    parser.add_argument("--out", type=pathlib.Path, default=GALLERY, help="where to write")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    if not args.no_demo:
        write_demo(parser, args)
    if args.compare is not None:
        write_compare(parser, args)
    if args.walkers is not None:
        runs = sorted(path.parent for path in args.walkers.glob("*/final.json"))
        if not runs:
            parser.error(f"{args.walkers} holds no finished runs (<robot>/final.json)")
        for run in runs:
            replay_seed0(run, args.out / f"walker_{run.name}.gif", "--gait")
    return 0


def replay_seed0(run: pathlib.Path, out: pathlib.Path, *options: str) -> None:
    """`python -m litl.replay RUN --seed 0 [options]` into `out` (its `main`, in this process:
    replays of the same robot share their compiled programs), keeping only the animation (and the
    gait picture, with --gait)."""
    from litl.replay import main as replay

    replay([str(run), "--seed", "0", "--out", str(out), *options])
    out.with_name(out.stem + "_design.png").unlink(missing_ok=True)
    out.with_suffix(".json").unlink(missing_ok=True)
    for written in (out, out.with_name(out.stem + "_gait.png")):
        if written.exists():
            print(written)


def write_demo(parser, args) -> None:
    draw_robots(args.out / "robots.png")
    print(args.out / "robots.png")

    with tempfile.TemporaryDirectory() as scratch:
        demo = args.demo
        if demo is None:
            demo = pathlib.Path(scratch) / "demo"
            run_demo(demo)
        missing = [name for name in DEMO_FILES if not (demo / name).is_file()]
        if missing:
            parser.error(
                f"{demo} lacks {', '.join(missing)}: give the directory of a finished "
                "`python -m litl` run (with the VAE observer)"
            )
        for name in DEMO_FILES:
            shutil.copyfile(demo / name, args.out / name)
            print(args.out / name)


def write_compare(parser, args) -> None:
    from litl.report import write_report

    with tempfile.TemporaryDirectory() as scratch:
        report = write_report(args.compare, scratch)
        curves = [path for path in report.files if path.name == "task_loss.png"]
        if not curves:
            parser.error(f"no task-loss curves could be drawn from {args.compare}")
        shutil.copyfile(curves[0], args.out / "biped_compare.png")
        print(args.out / "biped_compare.png")
    for job in sorted(path.parent for path in args.compare.glob("*/final.json")):
        replay_seed0(job, args.out / f"compare_{variant_of(job)}.gif")


def variant_of(job: pathlib.Path) -> str:
    """The `variant=` override a sweep job ran with (its job number if none)."""
    overrides = job / ".hydra" / "overrides.yaml"
    if overrides.is_file():
        for line in overrides.read_text().splitlines():
            if line.strip().lstrip("- ").startswith("variant="):
                return line.split("=", 1)[1].strip()
    return job.name


if __name__ == "__main__":
    raise SystemExit(main())

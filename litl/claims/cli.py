"""`python -m litl.claims`: run the paper's claims suite (resuming it) and write the verdicts."""

from __future__ import annotations

import argparse
import dataclasses
import json
import pathlib
import shlex
import sys
from collections.abc import Callable

from litl.claims.failures import cell_records, cells_markdown
from litl.claims.launch import slice_timings
from litl.claims.markdown import claims_markdown
from litl.claims.origins import check_resumable, commits, describe, origins
from litl.claims.seeds import first_phase_markdown, plot_stuck_seeds
from litl.claims.suite import PANEL_NAMES, SCALES, Cell, ClaimsError, Scale, cells, run_suite
from litl.claims.tables import load_groups, plot_panels, table1_markdown, verdicts, write_csv
from litl.claims.verdicts import Verdict
from litl.config import Config
from litl.errors import exit_on_user_error


def _names(text: str) -> tuple[str, ...]:
    return tuple(name.strip() for name in text.split(",") if name.strip())


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m litl.claims",
        description="Run every paper claim's runs (arm, biped, elephant, bunny; both methods; "
        "10 seeds each at demo resolution), resuming what already ran, then write "
        "claims.md, claims.csv, table1.md and one figure per paper panel into OUT.",
    )
    parser.add_argument(
        "--out",
        default="claims",
        help="where runs and results go (default: ./claims; runs under OUT/runs/<method>/<panel>/<variant>)",
    )
    parser.add_argument(
        "--panels",
        type=_names,
        default=PANEL_NAMES,
        help=f"comma-separated panels (default: all of {','.join(PANEL_NAMES)})",
    )
    parser.add_argument(
        "--methods",
        type=_names,
        default=("litl", "paper"),
        help="comma-separated methods (default: litl,paper)",
    )
    parser.add_argument(
        "--comparators",
        type=_names,
        default=(),
        help="optional comparators added to the biped and bunny panels, with their claims "
        "(pca: does the VAE's nonlinearity matter?; default: none)",
    )
    parser.add_argument(
        "--scale",
        choices=sorted(SCALES),
        default="demo",
        help="demo: the suite of record (default; dx 1/64, 6 x 10 iterations); paper: the presets "
        "as they are (dx 1/128, 20 x 10 iterations: a GPU's work); smoke: seconds per run",
    )
    parser.add_argument(
        "--seeds", type=int, default=None, help="seeds per run (default: the scale's, 10 at demo and paper)"
    )
    parser.add_argument(
        "--episodes",
        type=int,
        default=None,
        help="episodes per run instead of the scale's (6 at demo, the presets' 20 at paper), e.g. "
        "10 to see whether a verdict still moves after 60 iterations; runs of another size need "
        "another --out",
    )
    parser.add_argument(
        "--jobs",
        type=int,
        default=1,
        help="cells run at once, each in a process of its own sharing the device (default: 1, in "
        "this process); refused when the plan's largest cells would not fit the device's memory",
    )
    _add_slice_arguments(parser)
    parser.add_argument(
        "--level", type=float, default=0.9, help="confidence level of intervals and bands (default: 0.9)"
    )
    parser.add_argument(
        "--report-only", action="store_true", help="run nothing; write the results of what has finished"
    )
    parser.add_argument(
        "--list", action="store_true", help="print each run's command line and whether it has finished"
    )
    parser.add_argument(
        "--rejudge",
        metavar="CLAIMS_CSV",
        default=None,
        help="run nothing: judge the rows of a claims.csv written earlier again by the current rules, "
        "from its means, intervals (at --level) and seed counts, into OUT/claims.md and OUT/claims.csv "
        "(rows whose rule needs the runs say so)",
    )
    return parser


def _add_slice_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags that choose a suite's variants and seeds, and run its cells in seed slices
    (`litl.claims.slices`, `litl.claims.launch`)."""
    parser.add_argument(
        "--variants",
        type=_names,
        default=(),
        help="comma-separated variants to run or judge, in this order (default: every variant of "
        "the panels), e.g. --variants kmeans,vae to run k-means' cells first",
    )
    parser.add_argument(
        "--slice-seeds",
        type=int,
        default=None,
        metavar="K",
        help="run each cell as slices of K seeds, each a run of its own under the cell's directory "
        "(seeds-<first>-<last>), as the jobs of one Hydra multirun; a finished slice is never run "
        "again and a cell is judged as the union of its slices (default: each cell whole, in one run)",
    )
    parser.add_argument(
        "--first-seed",
        type=int,
        default=0,
        help="the cells' seeds are FIRST_SEED, ..., FIRST_SEED + seeds - 1 (default: 0), e.g. "
        "--first-seed 10 --seeds 20 for seeds 10-29",
    )
    parser.add_argument(
        "--launcher",
        default="basic",
        help="the Hydra launcher that runs the slices: basic (one after another, in one process; "
        "default), joblib (--jobs N at a time), submitit_local (all at once, a process each), "
        "submitit_slurm (a cluster's array jobs)",
    )
    parser.add_argument(
        "--launcher-option",
        action="append",
        default=[],
        metavar="hydra.launcher.KEY=VALUE",
        help="a setting of the launcher, repeatable: hydra.launcher.partition=cpu, "
        "hydra.launcher.timeout_min=240, hydra.launcher.array_parallelism=8",
    )
    parser.add_argument(
        "--slice-threads",
        choices=("all", "one"),
        default="all",
        help="XLA threads of each slice's process on a CPU: all (XLA's default) or one (slices "
        "side by side, one per core)",
    )
    parser.add_argument(
        "--dry-run",
        action="store_true",
        help="with --slice-seeds: list every slice still to run with its expected wall time, run nothing",
    )
    parser.add_argument(
        "--copy-records-to",
        metavar="DIR",
        default=None,
        help="copy the records of every finished run or slice (run.json, metrics, learning records, "
        "slice.json, timing.json; no checkpoints: a few hundred KB each) to the same place under "
        "DIR, e.g. a folder of the repository to commit them as each slice ends",
    )


# Flags about runs: with --rejudge nothing runs, so any of them other than its default is refused.
RUN_FLAGS = (
    "panels",
    "variants",
    "methods",
    "comparators",
    "scale",
    "seeds",
    "episodes",
    "jobs",
    "report_only",
    "list",
    "slice_seeds",
    "first_seed",
    "launcher",
    "launcher_option",
    "slice_threads",
    "dry_run",
    "copy_records_to",
)


def main(argv: list[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    command = " ".join(["python -m litl.claims", *map(shlex.quote, sys.argv[1:] if argv is None else argv)])
    with exit_on_user_error(parser.prog, os_errors=True):  # OSError: --out is the user's
        if args.rejudge is not None:
            return _rejudge(args, parser, command)
        return _main(args, command)


def _only_variants(suite: list[Cell], names: tuple[str, ...]) -> list[Cell]:
    """The cells of `suite` whose variant is one of `names`, in the order of `names` (all of
    `suite` when none are named)."""
    if not names:
        return suite
    known = list(dict.fromkeys(cell.variant.name for cell in suite))
    unknown = [name for name in names if name not in known]
    if unknown:
        raise ClaimsError(
            f"unknown variant(s) {unknown} in these panels; choose from {known} (--variants kmeans,vae)"
        )
    return [cell for name in names for cell in suite if cell.variant.name == name]


def _rejudge(args: argparse.Namespace, parser: argparse.ArgumentParser, command: str) -> int:
    """`--rejudge CLAIMS_CSV`: claims.md and claims.csv in OUT from a claims.csv's numbers."""
    from litl.claims.rejudge import rejudge

    given = [name for name in RUN_FLAGS if getattr(args, name) != parser.get_default(name)]
    if given:
        flags = ", ".join("--" + name.replace("_", "-") for name in given)
        raise ClaimsError(f"--rejudge runs nothing, so {flags} make(s) no sense with it; leave them out")
    if not 0 < args.level < 1:
        raise ClaimsError(f"--level must lie in (0, 1), e.g. 0.9; got {args.level}")
    out = pathlib.Path(args.out)
    source = pathlib.Path(args.rejudge)
    if (out / "claims.csv").resolve() == source.resolve():
        raise ClaimsError(f"--out {out} would overwrite the claims.csv being re-judged; give another --out")
    results = rejudge(source, args.level)
    out.mkdir(parents=True, exist_ok=True)
    (out / "claims.md").write_text(claims_markdown(results, args.level, command, [], {}, source=str(source)))
    write_csv(results, out / "claims.csv")
    _print_verdicts(results)
    print(out / "claims.md")
    return 0


def _print_verdicts(results: list[Verdict]) -> None:
    """One line per verdict: the verdict after Holm first, then the unadjusted one."""
    width = max((len(v.claim.id) for v in results), default=5)
    for v in results:
        print(f"{v.claim.id:<{width}}  {v.method:<5}  {v.holm_verdict} (unadjusted: {v.verdict})")


def _main(args: argparse.Namespace, command: str) -> int:
    from litl.app import compose
    from litl.claims.suite import finished_records

    scale = SCALES[args.scale]
    if args.episodes is not None:
        if args.episodes < 1:
            raise ClaimsError(f"--episodes must be at least 1, e.g. --episodes 10; got {args.episodes}")
        scale = scale.with_episodes(args.episodes)
    seeds = scale.seeds if args.seeds is None else args.seeds
    if seeds < 2:
        raise ClaimsError(f"--seeds must be at least 2 (a claim needs an interval); got {seeds}")
    if not 0 < args.level < 1:
        raise ClaimsError(f"--level must lie in (0, 1), e.g. 0.9; got {args.level}")
    suite = _only_variants(cells(args.panels, args.methods, args.comparators), args.variants)
    out = pathlib.Path(args.out)
    configs: dict[str, Config] = {}

    def config_of(cell: Cell) -> Config:
        if cell.name not in configs:
            configs[cell.name] = compose(cell.overrides(scale, seeds))
        return configs[cell.name]

    if args.list:
        for cell in suite:
            done = finished_records(cell.run_dir(out))
            print(
                f"{cell.name}: {done} records  python -m litl "
                f"{' '.join(cell.overrides(scale, seeds))} hydra.run.dir={cell.run_dir(out)}"
            )
        return 0
    if not _run(args, out, suite, scale, seeds, config_of):
        return 0
    groups, lacking = load_groups(out, suite, config_of, args.first_seed)
    _copy_records(out, suite, args.copy_records_to)
    results = verdicts(groups, args.methods, args.level)
    timings_path = out / "timings.json"
    timings = json.loads(timings_path.read_text()) if timings_path.exists() else {}
    timings.update(slice_timings(out, suite))
    unfinished = [f"{name}: {what}" for name, what in lacking.items()]
    for line in unfinished:
        print(f"litl.claims: not judged: {line}", file=sys.stderr)
    out.mkdir(parents=True, exist_ok=True)
    judged = [cell for cell in suite if cell.name not in lacking]
    notes = _notes(judged, out, args.scale, config_of, args.first_seed)
    found = origins(out, judged)
    text = claims_markdown(results, args.level, command, unfinished, timings, notes=notes)
    cells_section = cells_markdown(cell_records(groups), timings, found)
    (out / "claims.md").write_text(text + "\n".join(cells_section) + ("\n" if cells_section else ""))
    write_csv(results, out / "claims.csv", found)
    (out / "table1.md").write_text(table1_markdown(groups, args.methods, scale.label))
    plot_panels(groups, args.methods, out, args.level)
    plot_stuck_seeds(groups, args.methods, out)
    first_phase = first_phase_markdown(groups, args.methods)
    if first_phase:
        (out / "first_phase.md").write_text(first_phase)
    _print_verdicts(results)
    print(out / "claims.md")
    return 0


def _run(
    args: argparse.Namespace,
    out: pathlib.Path,
    suite: list[Cell],
    scale: Scale,
    seeds: int,
    config_of: Callable[[Cell], Config],
) -> bool:
    """Run what the flags ask for (cells whole, or in seed slices); False: a dry run, nothing
    more to write."""
    from litl.claims.suite import check_sizes

    if args.first_seed < 0:
        raise ClaimsError(f"--first-seed must be 0 or more; got {args.first_seed}")
    if args.dry_run and args.slice_seeds is None:
        raise ClaimsError("--dry-run lists the slices still to run: give --slice-seeds K with it")
    if args.slice_seeds is None:
        check_sizes(out, suite, config_of)
    if args.slice_seeds is not None and not args.report_only:
        from litl.claims.launch import SliceRun, run_slices

        check_resumable(out, suite, config_of)  # a slice under way resumes only by its own commit

        how = SliceRun(
            args.slice_seeds, args.launcher, args.jobs, tuple(args.launcher_option), args.slice_threads
        )
        run_slices(
            out, suite, scale, range(args.first_seed, args.first_seed + seeds), how, config_of, args.dry_run
        )
        if args.dry_run:
            return False
    elif not args.report_only:
        if args.first_seed:
            raise ClaimsError("--first-seed needs --slice-seeds (a cell run whole starts at seed 0)")
        check_resumable(out, suite, config_of)
        _plan_and_run(out, suite, scale, seeds, args.jobs, config_of)
    return True


def _copy_records(out: pathlib.Path, suite: list[Cell], dest: str | None) -> None:
    """`--copy-records-to DIR`: the finished runs' and slices' records, copied to DIR."""
    if dest is None:
        return
    from litl.claims.slices import copy_records

    for cell in suite:
        for target in copy_records(out, cell, pathlib.Path(dest)):
            print(f"litl.claims: records of {target.relative_to(dest)} -> {target}")


def _notes(
    judged: list[Cell],
    out: pathlib.Path,
    scale: str,
    config_of: Callable[[Cell], Config],
    first_seed: int = 0,
) -> list[str]:
    """claims.md's notes: which litl and material made the judged cells (said on stderr too when
    several commits did), and a paper-scale suite's departure from its committed plans (its
    seeds from `first_seed` on)."""
    from litl.claims.plan import departure_from_plan

    found = origins(out, judged)
    notes = ["\n".join(describe(found))] if found else []
    made = commits(found)
    if len(made) > 1:
        listing = "; ".join(f"{litl}: {', '.join(names)}" for litl, names in made.items())
        print(
            f"litl.claims: warning: the cells judged were made by {len(made)} versions of litl ({listing})",
            file=sys.stderr,
        )
    departure = None
    if judged and scale == "paper":
        departure = departure_from_plan(dataclasses.replace(config_of(judged[0]), seed=first_seed))
    if departure:
        print(f"litl.claims: note: {departure}", file=sys.stderr)
        notes.append(departure)
    return notes


def _plan_and_run(
    out: pathlib.Path,
    suite: list[Cell],
    scale: Scale,
    seeds: int,
    jobs: int,
    config_of: Callable[[Cell], Config],
) -> None:
    """Print the plan (each unfinished cell's estimated time, the total), refuse a job count the
    device cannot hold, then run the suite."""
    import os

    from litl.claims import plan
    from litl.sim.memory import device_memory_bytes

    if jobs < 1:
        raise ClaimsError(f"--jobs must be at least 1; got {jobs}")
    cells_env = dict(os.environ)
    if jobs > 1:  # this process measures only: it must leave the device's memory to the cells
        os.environ.setdefault("XLA_PYTHON_CLIENT_PREALLOCATE", "false")
        os.environ.setdefault("XLA_PYTHON_CLIENT_ALLOCATOR", "platform")
    planned = plan.plan(out, suite, config_of)
    if not planned:
        return
    print(f"litl.claims: the plan ({scale.label}, {seeds} seeds):")
    for line in plan.describe(planned, jobs):
        print(line)
    plan.check_jobs(planned, jobs, device_memory_bytes())
    run_suite(out, suite, scale, seeds, jobs=jobs, env=cells_env)

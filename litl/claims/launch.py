"""Running a claims suite's slices as the jobs of a Hydra multirun, through any Hydra launcher.

`launch` writes each slice's plan (`slice.json`: its overrides and expected time) into its run
directory, then starts one multirun of `python -m litl.claims.job` over the slices:

    python -m litl.claims.job --multirun out=OUT slice=paper/fig4b/vae/seeds-0-1,... \\
        hydra/launcher=submitit_local

so that every launcher Hydra has runs them: ``basic`` one after another in one process,
``joblib`` (``--jobs N``) N at a time on this machine, ``submitit_local`` all at once, each in a
process of its own, ``submitit_slurm`` as a cluster's array jobs (partition, time limit and array
parallelism as ``--launcher-option`` overrides). Each job (`run_slice`) prints its expected time
as it starts and its actual time as it ends, and adds that time to the slice's `timing.json`.
"""

from __future__ import annotations

import dataclasses
import datetime
import json
import pathlib
import subprocess
import sys
import time
from collections.abc import Callable, Sequence

from litl.claims.plan import Measurement, duration
from litl.claims.slices import (
    PLAN_FILE,
    TIMING_FILE,
    CellRuns,
    Slice,
    cut,
    read_cell,
    run_seeds,
    seed_ranges,
    slice_dirs,
    timing,
)
from litl.claims.suite import Cell, ClaimsError, Scale, finished_records
from litl.config import Config

LAUNCHERS = ("basic", "joblib", "submitit_local", "submitit_slurm")
# submitit's own limit is an hour; a slice stopped by it resumes from its checkpoint at the next
# launch, but on one machine there is no queue to wait for: a week, unless the user says.
LOCAL_TIMEOUT_MIN = 7 * 24 * 60
ONE_XLA_THREAD = "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"


def launcher_overrides(launcher: str, jobs: int, options: Sequence[str]) -> list[str]:
    """The Hydra overrides that choose and set `launcher` (``--launcher``, ``--jobs``,
    ``--launcher-option``).

    Raises:
      ClaimsError: an unknown launcher; ``--jobs`` above 1 with a launcher other than joblib's;
        an option that is not ``hydra.launcher.<key>=<value>``.
    """
    if launcher not in LAUNCHERS:
        raise ClaimsError(
            f"unknown launcher {launcher!r}; choose from {list(LAUNCHERS)} (--launcher submitit_local)"
        )
    if jobs < 1:
        raise ClaimsError(f"--jobs must be at least 1; got {jobs}")
    if jobs > 1 and launcher not in ("basic", "joblib"):
        raise ClaimsError(
            f"--jobs {jobs} runs slices with joblib's launcher; {launcher} runs as many at once as its "
            f"own settings say (submitit_slurm: --launcher-option hydra.launcher.array_parallelism=N)"
        )
    bad = [o for o in options if not o.startswith("hydra.launcher.") or "=" not in o]
    if bad:
        raise ClaimsError(
            "--launcher-option takes hydra.launcher.<key>=<value> "
            f"(e.g. hydra.launcher.timeout_min=240); got {bad}"
        )
    if jobs > 1:
        launcher = "joblib"
    overrides = [f"hydra/launcher={launcher}", *options]
    if launcher == "joblib":
        overrides.append(f"hydra.launcher.n_jobs={jobs}")
    if launcher == "submitit_local" and not any(o.startswith("hydra.launcher.timeout_min=") for o in options):
        overrides.append(f"hydra.launcher.timeout_min={LOCAL_TIMEOUT_MIN}")
    return overrides


def write_plan(out: pathlib.Path, piece: Slice, scale: Scale, expected_s: float | None, basis: str) -> None:
    """`slice.json` in the slice's run directory: what runs it and how long it should take."""
    run_dir = piece.run_dir(out)
    run_dir.mkdir(parents=True, exist_ok=True)
    plan = {
        "cell": piece.cell.name,
        "seeds": [piece.first, piece.last],
        "overrides": piece.overrides(scale),
        "expected_s": None if expected_s is None else round(expected_s, 1),
        "expected_from": basis,
        "planned_at": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
    }
    (run_dir / PLAN_FILE).write_text(json.dumps(plan, indent=1) + "\n")


def multirun_command(out: pathlib.Path, pieces: Sequence[Slice], overrides: Sequence[str]) -> list[str]:
    """`python -m litl.claims.job --multirun ...` over `pieces` (one job each)."""
    names = ",".join(piece.name for piece in pieces)
    stamp = datetime.datetime.now(datetime.UTC).strftime("%Y%m%dT%H%M%S")
    return [
        sys.executable,
        "-m",
        "litl.claims.job",
        "--multirun",
        f"out={_quoted(str(out.resolve()))}",
        f"slice={names}",
        f"hydra.sweep.dir={_quoted(str((out / 'launches' / stamp).resolve()))}",
        *overrides,
    ]


def _quoted(text: str) -> str:
    """A value for Hydra's override grammar, quoted so that spaces, commas and `=` stay in it."""
    if "'" in text:
        raise ClaimsError(f"--out may not contain a single quote (Hydra could not be given it): {text}")
    return f"'{text}'"


def launch(
    out: pathlib.Path,
    pieces: Sequence[Slice],
    overrides: Sequence[str],
    say: Callable[[str], None] = print,
    env: dict[str, str] | None = None,
) -> None:
    """Run `pieces` (their plans written) as one Hydra multirun and wait for it.

    Raises:
      ClaimsError: the multirun failed; the slices that finished are kept.
    """
    if not pieces:
        return
    command = multirun_command(out, pieces, overrides)
    say(f"litl.claims: {len(pieces)} slice(s) as one Hydra multirun: {' '.join(command[1:])}")
    result = subprocess.run(command, env=env)
    if result.returncode:
        raise ClaimsError(
            f"the multirun of {len(pieces)} slice(s) failed (exit {result.returncode}); finished slices are "
            f"kept, and running the same command again resumes the others (each slice's log is its "
            f"claims.log; submitit's are under {out / 'launches'})"
        )


def run_slice(out: pathlib.Path, name: str, say: Callable[[str], None] = print) -> None:
    """One job of the multirun: run (or resume) the slice `name` of `out` as its `slice.json` says,
    saying its expected time first and its actual time at the end, which `timing.json` adds up."""
    from litl.app import run_experiment

    run_dir = out / "runs" / name
    plan_path = run_dir / PLAN_FILE
    if not plan_path.exists():
        raise ClaimsError(
            f"{run_dir} holds no {PLAN_FILE}: start slices with python -m litl.claims --slice-seeds K"
        )
    plan = json.loads(plan_path.read_text())
    expected = plan.get("expected_s")
    said = "unknown" if expected is None else duration(expected)
    say(f"litl.claims: slice {name} starts, expected ~{said} ({plan.get('expected_from', 'no estimate')})")
    config = _composed(plan["overrides"])
    recorded = timing(run_dir)
    start = time.perf_counter()
    ended = False
    try:
        run_experiment(config, run_dir)
        ended = True
    finally:  # a stopped slice keeps the time it ran; resuming adds to it
        seconds = time.perf_counter() - start
        total = float(recorded.get("seconds", 0.0)) + seconds
        record = {
            "seconds": round(total, 1),
            "processes": int(recorded.get("processes", 0)) + 1,
            "expected_s": expected,
            "finished": ended,
            "device": _device(),
        }
        (run_dir / TIMING_FILE).write_text(json.dumps(record, indent=1) + "\n")
    say(
        f"litl.claims: slice {name} finished in {duration(seconds)} "
        f"(expected ~{said}; {duration(total)} in all)"
    )


def _composed(overrides: Sequence[str]) -> Config:
    """`litl.app.compose(overrides)`, also inside a Hydra job (which holds Hydra's global state:
    set aside while litl's config is composed, then put back for the launcher)."""
    from hydra.core.global_hydra import GlobalHydra

    from litl.app import compose

    held = GlobalHydra.instance()
    saved = held.hydra
    held.clear()
    try:
        return compose(overrides)
    finally:
        held.clear()
        held.hydra = saved


def _device() -> str:
    import jax

    device = jax.devices()[0]
    return f"{device.platform}: {getattr(device, 'device_kind', '')}".strip()


@dataclasses.dataclass(frozen=True)
class SliceRun:
    """How to run a suite's slices: `size` seeds each, through `launcher` (``--jobs`` at a
    time with joblib's), its `options` (``hydra.launcher.KEY=VALUE``), and `threads` per slice
    on a CPU (``all`` or ``one``)."""

    size: int
    launcher: str = "basic"
    jobs: int = 1
    options: tuple[str, ...] = ()
    threads: str = "all"


def run_slices(
    out: pathlib.Path,
    suite: Sequence[Cell],
    scale: Scale,
    seeds: Sequence[int],
    how: SliceRun,
    config_of: Callable[[Cell], Config],
    dry_run: bool = False,
    say: Callable[[str], None] = print,
    measure_one: Callable[[Config], Measurement] | None = None,
) -> list[Slice]:
    """Run every slice of `suite` (its cells cut into slices of `how.size` of `seeds`) that has
    not finished, after listing each with its expected time; with `dry_run`, only list them.

    Returns the slices that were (or, with `dry_run`, would be) run.

    Raises:
      ClaimsError: a slice size out of range; a cell whose finished slices were cut otherwise
        (a slice to run would repeat a seed they hold); anything `read_cell` refuses.
    """
    overrides = launcher_overrides(how.launcher, how.jobs, how.options)
    if how.threads == "one":
        overrides.append("xla_threads=1")
    todo: list[tuple[Slice, float, str]] = []
    calibrated: dict[tuple[str, int], Measurement] = {}
    for cell in suite:
        config = config_of(cell)
        found = read_cell(cell.run_dir(out), seeds, config.loop.episodes, config.loop.iterations)
        missing = set(found.missing)
        rate = _rate(found)
        for piece in cut(cell, seeds, how.size):
            left = [seed for seed in piece.seeds if seed in missing]
            if not left:
                continue
            if len(left) < piece.count:
                raise ClaimsError(
                    f"{piece.name}: seeds {seed_ranges(sorted(set(piece.seeds) - missing))} of it are "
                    f"already in finished slices of {cell.name} cut otherwise; run it with the "
                    f"--slice-seeds those slices were cut with"
                )
            done = finished_records(piece.run_dir(out)) / max(
                1, piece.count * config.loop.episodes * config.loop.iterations
            )
            if rate is not None:
                seconds, basis = rate * piece.count * (1 - done), "the rate of this cell's finished slices"
            else:
                key = (cell.name, piece.count)
                if key not in calibrated:
                    calibrated[key] = (measure_one or _calibrate)(config_of_slice(config, piece))
                measured = calibrated[key]
                seconds = measured.compile_s + (1 - done) * config.loop.episodes * config.loop.iterations * (
                    measured.iteration_s
                )
                basis = "one measured optimization iteration; learning phases, if any, not counted"
            todo.append((piece, seconds, basis))
    if not todo:
        return []
    say(f"litl.claims: {len(todo)} slice(s) to run ({scale.label}):")
    for piece, seconds, basis in todo:
        say(f"  {piece.name}: ~{duration(seconds)} (from {basis})")
    total = sum(seconds for _, seconds, _ in todo)
    say(f"  ~{duration(total)} one after another")
    if dry_run:
        return [piece for piece, _, _ in todo]
    for piece, seconds, basis in todo:
        write_plan(out, piece, scale, seconds, basis)
    launch(out, [piece for piece, _, _ in todo], overrides, say)
    return [piece for piece, _, _ in todo]


def config_of_slice(config: Config, piece: Slice) -> Config:
    return config.replace(seeds=piece.count, seed=piece.first)


def _calibrate(config: Config) -> Measurement:
    from litl.claims.plan import measure

    return measure(config)


def _rate(found: CellRuns) -> float | None:
    """Seconds per seed of the cell's finished slices that recorded their time (None: none did)."""
    rates = [
        float(timing(run.path)["seconds"]) / len(run_seeds(run))
        for run in found.runs
        if timing(run.path).get("finished")
    ]
    return sum(rates) / len(rates) if rates else None


def slice_timings(out: pathlib.Path, suite: Sequence[Cell]) -> dict[str, float]:
    """{cell name: seconds} of the cells run in slices: their slices' `timing.json`, added."""
    found: dict[str, float] = {}
    for cell in suite:
        seconds = [timing(d).get("seconds") for d in slice_dirs(cell.run_dir(out)) if d != cell.run_dir(out)]
        if any(s is not None for s in seconds):
            found[cell.name] = round(sum(float(s) for s in seconds if s is not None), 1)
    return found

"""The runs behind the paper's claims: which robots, variants and methods, and running them.

A `Panel` is one paper figure panel (Fig. 4a-d): a robot's experiment preset and the variants it
compares. A `Cell` is one run of it: a panel's variant under one method, all its seeds in one run
directory `<out>/runs/<method>/<panel>/<variant>`. `run_suite` runs every cell that has not
finished yet (a killed suite resumes where it stopped, a finished cell is not touched).
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import pathlib
import signal
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from types import FrameType
from typing import Any, NoReturn

from litl.config import Config, Method
from litl.errors import UserError


class ClaimsError(UserError, ValueError):
    """A claims suite that cannot be run or reported as asked; the message says what to change."""


@dataclasses.dataclass(frozen=True)
class Variant:
    """One curve of a panel.

    Attributes:
      name: the variant's name in the suite (also its run directory's name).
      overrides: the Hydra overrides that make it (``variant=vae``, ``size=s4``).
    """

    name: str
    overrides: tuple[str, ...]


@dataclasses.dataclass(frozen=True)
class Panel:
    """One panel of the paper's figures, as runs.

    Attributes:
      name: e.g. ``"fig4a"``.
      title: what the panel shows, for figures and tables.
      experiment: the experiment preset the runs start from (``litl/conf/experiment``).
      variants: its curves.
    """

    name: str
    title: str
    experiment: str
    variants: tuple[Variant, ...]

    def variant(self, name: str) -> Variant:
        for variant in self.variants:
            if variant.name == name:
                return variant
        raise KeyError(f"{self.name} has no variant {name!r}")


def _variants(*names: str) -> tuple[Variant, ...]:
    return tuple(Variant(name, (f"variant={name}",)) for name in names)


def _sized(sizes: tuple[int, ...], *names: str) -> tuple[Variant, ...]:
    return tuple(
        Variant(f"{name}_s{size}", (f"variant={name}", f"size=s{size}")) for size in sizes for name in names
    )


PANELS = (
    Panel(
        "fig4a",
        "Fig. 4a: arm, reach (control only)",
        "fig4a_arm",
        _variants("vae", "kmeans", "vae_one_shot", "vae_no_replay"),
    ),
    Panel("fig4b", "Fig. 4b: biped, run (co-design)", "fig4b_biped", _variants("vae", "kmeans", "sinusoid")),
    Panel("fig4c", "Fig. 4c: elephant, walk and reach", "fig4c_elephant", _sized((4, 8), "vae", "kmeans")),
    Panel(
        "fig4d", "Fig. 4d: bunny, walk and two reaches", "fig4d_bunny", _variants("vae", "kmeans", "sinusoid")
    ),
)
PANEL_NAMES = tuple(panel.name for panel in PANELS)
# Optional comparators (off by default, so the suite's time is unchanged): a variant added to the
# panels named, with its claims in `litl.claims.verdicts` (``comparator=True``).
COMPARATORS = {"pca": (Variant("pca", ("variant=pca",)), ("fig4b", "fig4d"))}


@dataclasses.dataclass(frozen=True)
class Scale:
    """How big every run of the suite is.

    Attributes:
      name: ``"demo"`` (the suite of record) or ``"smoke"`` (seconds per run, for tests).
      seeds: seeds per cell (the paper: 10).
      overrides: what shrinks a paper preset to this scale.
      episodes: the episode count `with_episodes` set instead of the scale's own (None: its own).
    """

    name: str
    seeds: int
    overrides: tuple[str, ...]
    episodes: int | None = None

    def with_episodes(self, episodes: int) -> Scale:
        """This scale with `episodes` episodes per run instead of its own (a longer run, to see
        whether a verdict still moves; the cut check then judges it at 60% of them too)."""
        kept = tuple(o for o in self.overrides if not o.startswith("loop.episodes="))
        return dataclasses.replace(self, episodes=episodes, overrides=(*kept, f"loop.episodes={episodes}"))

    @property
    def label(self) -> str:
        """For people: ``demo scale``, or ``demo scale, 10 episodes`` with another count."""
        return f"{self.name} scale" + ("" if self.episodes is None else f", {self.episodes} episodes")


SCALES = {
    # dx 1/64, 1 s rollouts, 6 episodes x 10 iterations. 10 x 10 (the biped comparison's size)
    # took 6.6 h for the whole suite; the method=paper runs of 10 x 10 cut after 6 episodes give
    # every one of their verdicts (after 5, one changes): docs/guide/claims.md.
    "demo": Scale("demo", 10, ("robot.resolution=demo", "loop.episodes=6", "loop.iterations=10")),
    # The presets as they are: dx 1/128 in 2D, 20 episodes x 10 iterations (`litl/conf/experiment`).
    "paper": Scale("paper", 10, ()),
    "smoke": Scale("smoke", 2, ("+scale=smoke",)),
}


@dataclasses.dataclass(frozen=True)
class Cell:
    """One run of the suite: a panel's variant under a method, every seed in one directory."""

    panel: Panel
    variant: Variant
    method: str

    @property
    def name(self) -> str:
        return f"{self.method}/{self.panel.name}/{self.variant.name}"

    def run_dir(self, out: str | os.PathLike[str]) -> pathlib.Path:
        return pathlib.Path(out) / "runs" / self.method / self.panel.name / self.variant.name

    def overrides(self, scale: Scale, seeds: int) -> list[str]:
        """The command line that makes this cell: ``python -m litl <overrides>``."""
        return [
            f"experiment={self.panel.experiment}",
            *self.variant.overrides,
            f"method={self.method}",
            *scale.overrides,
            f"seeds={seeds}",
            "output.pictures=false",
            "output.animation=false",
            "output.progress=false",
        ]


def cells(
    panels: Sequence[str] = PANEL_NAMES,
    methods: Sequence[str] = ("litl", "paper"),
    comparators: Sequence[str] = (),
) -> list[Cell]:
    """The suite's cells for the named panels and methods, method by method, with the optional
    `comparators`' variants (`COMPARATORS`) added to their panels."""
    unknown_comparators = [name for name in comparators if name not in COMPARATORS]
    if unknown_comparators:
        raise ClaimsError(
            f"unknown comparator(s) {unknown_comparators}; choose from {list(COMPARATORS)} "
            "(--comparators pca)"
        )
    unknown = [name for name in panels if name not in PANEL_NAMES]
    if unknown:
        raise ClaimsError(
            f"unknown panel(s) {unknown}; choose from {list(PANEL_NAMES)} (--panels fig4a,fig4b)"
        )
    known = [m.value for m in Method]
    bad = [m for m in methods if m not in known]
    if bad:
        raise ClaimsError(f"unknown method(s) {bad}; choose from {known} (--methods litl,paper)")
    if not panels or not methods:
        raise ClaimsError("the suite is empty: name at least one panel and one method")
    extra = {
        panel: [COMPARATORS[name][0] for name in comparators if panel in COMPARATORS[name][1]]
        for panel in PANEL_NAMES
    }
    return [
        Cell(panel, variant, method)
        for method in methods
        for panel in PANELS
        if panel.name in panels
        for variant in (*panel.variants, *extra[panel.name])
    ]


def expected_records(config: Config) -> int:
    """metrics.jsonl lines of a finished run: one per seed and optimization iteration."""
    return config.seeds * config.loop.episodes * config.loop.iterations


def _size(config: Config) -> dict[str, Any]:
    return {
        "seeds": config.seeds,
        "loop.episodes": config.loop.episodes,
        "loop.iterations": config.loop.iterations,
    }


def check_sizes(out: str | os.PathLike[str], suite: list[Cell], config_of: Callable[[Cell], Config]) -> None:
    """Refuse (`ClaimsError`, before anything runs) an `out` holding a cell's run started at
    another size (seeds, episodes, iterations; its run.json) than `config_of(cell)`: it would
    neither resume nor compare with the others."""
    for cell in suite:
        path = cell.run_dir(out) / "run.json"
        if not path.exists():
            continue
        recorded = json.loads(path.read_text()).get("config", {})
        loop = recorded.get("loop", {})
        found = {
            "seeds": recorded.get("seeds"),
            "loop.episodes": loop.get("episodes"),
            "loop.iterations": loop.get("iterations"),
        }
        wanted = _size(config_of(cell))
        if found != wanted:
            raise ClaimsError(
                f"{path.parent} was run with {_settings(found)}, but this suite runs "
                f"{_settings(wanted)}: give another --out (or move that run away) to start "
                f"afresh, or the --seeds and --episodes it was run with"
            )


def _settings(size: dict[str, Any]) -> str:
    return " ".join(f"{key}={value}" for key, value in size.items())


def finished_records(run_dir: pathlib.Path) -> int:
    path = run_dir / "metrics.jsonl"
    if not path.exists():
        return 0
    with open(path) as file:
        return sum(1 for line in file if line.strip())


def run_suite(
    out: str | os.PathLike[str],
    suite: list[Cell],
    scale: Scale,
    seeds: int,
    say: Callable[[str], None] = print,
    jobs: int = 1,
    env: dict[str, str] | None = None,
) -> dict[str, str]:
    """Run every unfinished cell of `suite` under `out`: one after another in this process, or
    `jobs` at once, each in a process of its own (`python -m litl`; on a GPU each reserves its
    share of the device's memory).

    Each cell's wall time goes into `<out>/timings.json` ({cell name: seconds}): a cell
    stopped with Ctrl-C or `kill PID` (SIGINT, SIGTERM) keeps the time it ran, and resuming it
    adds to that; one killed otherwise (SIGKILL) loses the time of its interrupted part. A
    stopped suite resumes every unfinished cell (from its last checkpoint) and keeps every
    finished one. `env`: the cells' processes' environment (default: this process's).

    Returns:
      {cell name: "ran" | "done already"}.
    """
    if jobs < 1:
        raise ClaimsError(f"--jobs must be at least 1; got {jobs}")
    with _stopped_by_sigterm():
        if jobs == 1:
            return _run_cells(out, suite, scale, seeds, say)
        return _run_cells_in_processes(out, suite, scale, seeds, say, jobs, env)


@contextlib.contextmanager
def _stopped_by_sigterm() -> Iterator[None]:
    """`kill PID` (SIGTERM) stops the suite as Ctrl-C does, once the computation under way
    returns, so the running cell keeps its time (a suite started in the background with `&`
    ignores Ctrl-C's SIGINT)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def stop(signum: int, frame: FrameType | None) -> NoReturn:
        raise KeyboardInterrupt(f"stopped by signal {signum}")

    previous = signal.signal(signal.SIGTERM, stop)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _run_cells(
    out: str | os.PathLike[str], suite: list[Cell], scale: Scale, seeds: int, say: Callable[[str], None]
) -> dict[str, str]:
    import jax

    from litl.app import compose, run_experiment

    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    timings_path = out / "timings.json"
    timings = json.loads(timings_path.read_text()) if timings_path.exists() else {}
    status = {}
    for number, cell in enumerate(suite, 1):
        overrides = cell.overrides(scale, seeds)
        config = compose(overrides)
        run_dir = cell.run_dir(out)
        if finished_records(run_dir) >= expected_records(config):
            status[cell.name] = "done already"
            continue
        say(
            f"litl.claims: [{number}/{len(suite)}] {cell.name}: python -m litl "
            f"{' '.join(overrides)} hydra.run.dir={run_dir}"
        )
        # A resumed cell adds to the time its earlier parts recorded.
        before = timings.get(cell.name, 0.0) if finished_records(run_dir) else 0.0
        start = time.perf_counter()
        try:
            run_experiment(config, run_dir)
        finally:  # an interrupted cell (Ctrl-C, SIGTERM) keeps the time it ran
            timings[cell.name] = round(before + time.perf_counter() - start, 1)
            timings_path.write_text(json.dumps(timings, indent=1) + "\n")
        status[cell.name] = "ran"
        jax.clear_caches()  # one cell's compiled programs are no use to the next
    return status


def _run_cells_in_processes(
    out: str | os.PathLike[str],
    suite: list[Cell],
    scale: Scale,
    seeds: int,
    say: Callable[[str], None],
    jobs: int,
    env: dict[str, str] | None,
) -> dict[str, str]:
    import subprocess
    import sys

    from litl.app import compose

    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    timings_path = out / "timings.json"
    timings = json.loads(timings_path.read_text()) if timings_path.exists() else {}
    env = dict(os.environ if env is None else env)
    # Each process reserves its share of a GPU's memory (JAX's default is 75% for one).
    env.setdefault("XLA_PYTHON_CLIENT_MEM_FRACTION", f"{0.9 / jobs:.3f}")
    status: dict[str, str] = {}
    waiting: list[tuple[int, Cell, list[str]]] = []
    for number, cell in enumerate(suite, 1):
        overrides = cell.overrides(scale, seeds)
        if finished_records(cell.run_dir(out)) >= expected_records(compose(overrides)):
            status[cell.name] = "done already"
        else:
            waiting.append((number, cell, overrides))
    running: dict[str, tuple[subprocess.Popen[bytes], float, float]] = {}
    failed: list[str] = []

    def record(name: str, before: float, start: float) -> None:
        timings[name] = round(before + time.perf_counter() - start, 1)
        timings_path.write_text(json.dumps(timings, indent=1) + "\n")

    try:
        while waiting or running:
            while waiting and len(running) < jobs:
                number, cell, overrides = waiting.pop(0)
                run_dir = cell.run_dir(out)
                run_dir.mkdir(parents=True, exist_ok=True)
                say(
                    f"litl.claims: [{number}/{len(suite)}] {cell.name}: python -m litl "
                    f"{' '.join(overrides)} hydra.run.dir={run_dir}"
                )
                before = timings.get(cell.name, 0.0) if finished_records(run_dir) else 0.0
                log = open(run_dir / "claims.log", "ab")  # noqa: SIM115 (closed with the process)
                process = subprocess.Popen(
                    [sys.executable, "-m", "litl", *overrides, f"hydra.run.dir={run_dir}"],
                    env=env,
                    stdout=log,
                    stderr=subprocess.STDOUT,
                )
                log.close()
                running[cell.name] = (process, before, time.perf_counter())
            for name, (process, before, start) in list(running.items()):
                if process.poll() is None:
                    continue
                del running[name]
                record(name, before, start)
                if process.returncode:
                    failed.append(name)
                    say(f"litl.claims: {name} failed (exit {process.returncode}); see its claims.log")
                else:
                    status[name] = "ran"
            time.sleep(0.5)
    finally:  # stopped (Ctrl-C, SIGTERM): stop the cells under way, keep the time they ran
        for name, (process, before, start) in running.items():
            process.terminate()
            process.wait()
            record(name, before, start)
    if failed:
        raise ClaimsError(
            f"{len(failed)} cell(s) failed: {failed}; their claims.log says why (rerun to resume)"
        )
    return status

"""Progress on stderr: a status line for runs (episodes, iterations, loss; epochs and validation
loss during learning phases) and `say` for one-off messages, all with the job's label in sweeps.

On a terminal the status line is redrawn in place; in a log (not a TTY) it prints one line per
episode and one per learning phase. Hydra sweeps that run several jobs at once (the joblib
launcher) interleave their output, so `python -m litl` sets a label per job (`set_label`) that
starts every line.

Why no progress library (tqdm, rich): the line is fed from two places, the Python loop over
iterations and `jax.debug.callback`s fired from inside a jitted, vmapped learning phase (one
value per seed), and in a log it must print one line per episode and per phase rather than every
update or nothing; that is this module's ~100 lines, where a library would add a dependency and
still need the same per-job labels and log-mode rules around it.
"""

from __future__ import annotations

import contextlib
import sys
import threading
import time
from collections.abc import Iterator
from typing import TextIO

import numpy as np

# One number format for the status line and the report: significant digits, never "-0".
from litl.records.formatting import format_number

_LABEL = ""


def set_label(label: str) -> None:
    """Start every progress line and message with `label` (e.g. ``"[job 3] "``)."""
    global _LABEL
    _LABEL = label


def say(message: str, stream: TextIO | None = None) -> None:
    """Print one labelled line to stderr."""
    stream = stream or sys.stderr
    stream.write(f"{_LABEL}{message}\n")
    stream.flush()


class Progress:
    """Redraws one status line on a terminal; prints one line per episode otherwise (logs)."""

    def __init__(self, episodes: int, iterations: int, enabled: bool = True, stream: TextIO | None = None):
        self.episodes, self.iterations = episodes, iterations
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.interactive = enabled and getattr(self.stream, "isatty", lambda: False)()
        self.start = time.perf_counter()
        self._epoch = {"epoch": 0, "validation": float("nan")}

    def on_epoch(self, epoch: np.ndarray, validation: np.ndarray) -> None:
        """A learning epoch ended (called from inside the compiled phase, `make_algorithm`'s
        on_epoch): (epoch, validation loss), one entry per seed."""
        latest = self._epoch
        latest["epoch"] = max(latest["epoch"], int(np.max(epoch)))
        latest["validation"] = float(np.mean(validation))

    def _write(self, line: str, newline: bool) -> None:
        self.stream.write(
            ("\r" if self.interactive and not newline else "")
            + _LABEL
            + line
            + ("\n" if newline else " " * 8)
        )
        self.stream.flush()

    def update(self, episode: int, iteration: int, loss: float) -> None:
        if not self.enabled:
            return
        done = episode * self.iterations + iteration + 1
        total = self.episodes * self.iterations
        width = 24
        filled = int(width * done / total)
        elapsed = time.perf_counter() - self.start
        line = (
            f"[{'#' * filled}{'.' * (width - filled)}] episode {episode + 1}/{self.episodes} "
            f"iteration {iteration + 1}/{self.iterations} loss {format_number(loss)} "
            f"({elapsed:.0f} s)"
        )
        if self.interactive:
            self._write(line, newline=False)
        elif iteration + 1 == self.iterations:
            self._write(line, newline=True)

    @contextlib.contextmanager
    def learning(self, episode: int) -> Iterator[None]:
        """Around a learning phase: on a terminal the line shows the epoch and validation loss as
        they come (`on_epoch`) and a ticking clock; in logs one line when it ends."""
        if not self.enabled:
            yield
            return
        start = time.perf_counter()
        done = threading.Event()
        latest = self._epoch = {"epoch": 0, "validation": float("nan")}

        def line() -> str:
            return (
                f"episode {episode + 1}/{self.episodes} learning phase: epoch "
                f"{latest['epoch']}, validation loss {format_number(latest['validation'])} "
                f"({time.perf_counter() - start:.1f} s; run {time.perf_counter() - self.start:.0f} s)"
            )

        def tick() -> None:
            while not done.wait(0.25):
                self._write(line(), newline=False)

        ticker = threading.Thread(target=tick, daemon=True) if self.interactive else None
        if ticker:
            ticker.start()
        try:
            yield
        finally:
            done.set()
            if ticker:
                ticker.join()
                self._write(line(), newline=False)
            else:
                self._write(line(), newline=True)

    def close(self) -> None:
        if self.interactive:
            self.stream.write("\n")
            self.stream.flush()

"""A dependency-free progress bar for runs: episodes, iterations and the current loss."""

from __future__ import annotations

import contextlib
import sys
import threading
import time


class Progress:
    """Redraws one status line on a terminal; prints one line per episode otherwise (logs)."""

    def __init__(self, episodes: int, iterations: int, enabled: bool = True, stream=None):
        self.episodes, self.iterations = episodes, iterations
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.interactive = enabled and getattr(self.stream, "isatty", lambda: False)()
        self.start = time.perf_counter()

    def update(self, episode: int, iteration: int, loss: float) -> None:
        if not self.enabled:
            return
        done = episode * self.iterations + iteration + 1
        total = self.episodes * self.iterations
        width = 24
        filled = int(width * done / total)
        elapsed = time.perf_counter() - self.start
        line = (f"[{'#' * filled}{'.' * (width - filled)}] episode {episode + 1}/{self.episodes} "
                f"iteration {iteration + 1}/{self.iterations} loss {loss:+.5f} "
                f"({elapsed:.0f} s)")
        if self.interactive:
            self.stream.write("\r" + line)
        elif iteration + 1 == self.iterations:
            self.stream.write(line + "\n")
        self.stream.flush()

    @contextlib.contextmanager
    def learning(self, episode: int):
        """Around a learning phase: on a terminal the line keeps moving (a ticking clock, redrawn
        by a thread while the jitted phase runs); in logs one line when it ends."""
        if not self.enabled:
            yield
            return
        start = time.perf_counter()
        done = threading.Event()

        def line():
            return (f"episode {episode + 1}/{self.episodes} learning phase "
                    f"{time.perf_counter() - start:.1f} s (run {time.perf_counter() - self.start:.0f} s)")

        def tick():
            while not done.wait(0.25):
                self.stream.write("\r" + line() + " " * 8)
                self.stream.flush()

        ticker = threading.Thread(target=tick, daemon=True) if self.interactive else None
        if ticker:
            ticker.start()
        try:
            yield
        finally:
            done.set()
            if ticker:
                ticker.join()
                self.stream.write("\r" + line() + " " * 8)
            else:
                self.stream.write(line() + "\n")
            self.stream.flush()

    def close(self) -> None:
        if self.interactive:
            self.stream.write("\n")
            self.stream.flush()

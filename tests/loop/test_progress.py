"""The progress display: iterations move the bar, and a learning phase keeps the line moving."""

import io
import time

from litl.loop.progress import Progress


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_learning_phase_redraws_the_line_while_it_runs_on_a_terminal():
    stream = Terminal()
    bar = Progress(episodes=3, iterations=2, stream=stream)
    bar.update(0, 1, -0.1)
    with bar.learning(0):
        time.sleep(0.8)                 # a phase: the ticker redraws every 0.25 s meanwhile
    redraws = stream.getvalue().count("episode 1/3 learning phase")
    assert redraws >= 3
    assert "iteration 2/2 loss -0.10000" in stream.getvalue()


def test_in_logs_a_learning_phase_is_one_line_and_disabled_bars_print_nothing():
    log = io.StringIO()
    bar = Progress(episodes=2, iterations=1, stream=log)
    with bar.learning(1):
        pass
    assert log.getvalue().count("\n") == 1 and "episode 2/2 learning phase" in log.getvalue()
    quiet = io.StringIO()
    with Progress(2, 1, enabled=False, stream=quiet).learning(0):
        pass
    assert quiet.getvalue() == ""

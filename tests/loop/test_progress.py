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
        time.sleep(0.8)  # a phase: the ticker redraws every 0.25 s meanwhile
    redraws = stream.getvalue().count("episode 1/3 learning phase")
    assert redraws >= 3
    assert "iteration 2/2 loss -0.1 " in stream.getvalue()


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


def test_losses_print_with_significant_digits_and_never_as_negative_zero():
    log = io.StringIO()
    bar = Progress(episodes=3, iterations=1, stream=log)
    bar.update(0, 0, -3.2e-9)  # a tiny negative loss keeps its digits
    bar.update(1, 0, -0.0)
    bar.update(2, 0, 12345.678)
    lines = log.getvalue().splitlines()
    assert "loss -3.2e-09 " in lines[0]
    assert "loss 0 " in lines[1] and "-0" not in lines[1]
    assert "loss 1.235e+04 " in lines[2]

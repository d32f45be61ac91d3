"""`python -m litl --help` names every other command litl has, with one line each, and each of
them answers its own --help."""

import contextlib
import io
import pathlib
import re
import runpy
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "litl"


def _commands() -> set[str]:
    """Every `python -m` entry point of the package but `litl` itself: a package with a
    `__main__.py`, or a module that runs when executed."""
    found = set()
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(ROOT).with_suffix("").parts
        if path.name == "__main__.py":
            found.add(".".join(parts[:-1]))
        elif re.search(r'^if __name__ == "__main__":', path.read_text(), re.M):
            found.add(".".join(parts))
    found.discard("litl")
    return found


@pytest.fixture(scope="module")
def help_text() -> str:
    done = subprocess.run(
        [sys.executable, "-m", "litl", "--help"], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


def test_the_eight_commands_are_found():
    assert _commands() == {
        "litl.claims",
        "litl.claims.job",
        "litl.gradcheck",
        "litl.latent.control",
        "litl.replay",
        "litl.report",
        "litl.report.budget",
        "litl.report.latent_modes",
    }


def test_help_lists_every_other_command_with_one_line(help_text):
    section = help_text.split("== Other commands", 1)
    assert len(section) == 2, "python -m litl --help has no 'Other commands' section"
    lines = section[1].split("\n==", 1)[0].strip().splitlines()[1:]
    listed = {}
    for line in lines:
        match = re.match(r"python -m (litl(?:\.\w+)+)\b\S*(?: [A-Z_.]+)*\s{2,}(\S.{20,})$", line)
        assert match, f"not a command and its line: {line!r}"
        listed[match.group(1)] = match.group(2)
    assert set(listed) == _commands()
    assert len(set(listed.values())) == len(listed), "each command is described in its own words"


# runpy warns that the module is already imported (as `litl.gradcheck`) when it runs a second copy
# as __main__; that copy only parses --help and exits, and the imported one is left untouched.
@pytest.mark.filterwarnings("ignore:.*found in sys.modules after import of package:RuntimeWarning")
@pytest.mark.parametrize("module", sorted(_commands()))
def test_each_listed_command_answers_help(module, monkeypatch):
    monkeypatch.setattr(sys, "argv", [module, "--help"])
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit) as exit_:
        runpy.run_module(module, run_name="__main__", alter_sys=True)
    assert exit_.value.code in (0, None)
    assert out.getvalue().startswith(f"usage: python -m {module}"), out.getvalue()[:200]

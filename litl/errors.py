"""The one base class of the errors that reach a user, `UserError`, and the one way the
command-line tools report them, `exit_on_user_error`.

An error that is about the user's input (a setting, a robot, a PNG, a run directory, a
checkpoint) rather than about litl derives from `UserError`; its message says what is wrong and
how to fix it. The command-line tools (`python -m litl`, `python -m litl.replay`,
`python -m litl.gradcheck`, `python -m litl.report`, `python -m litl.claims`) print such an error
as one line, ``<program>: error: <message>``, without a traceback, and exit with status 2; any
other exception is a bug and keeps its traceback.

This module imports nothing of litl, so every part of litl can derive from it.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Callable, Iterator
from typing import NoReturn


class UserError(Exception):
    """An error in what the user gave litl; the message names it and says how to fix it."""


@contextlib.contextmanager
def exit_on_user_error(
    program: str,
    *,
    os_errors: bool = False,
    keep_traceback: bool = False,
    write: Callable[[str], object] | None = None,
) -> Iterator[None]:
    """Within: a `UserError` prints ``<program>: error: <message>`` and exits with status 2.

        with exit_on_user_error("python -m litl.report", os_errors=True):
            report = write_report(args.dir, args.out, args.level)

    Args:
      program: how the message starts (the command's name).
      os_errors: an `OSError` is the user's too: for commands whose only files are the ones the
        user named (a directory to read, an `--out` to write).
      keep_traceback: re-raise instead (`python -m litl` under ``HYDRA_FULL_ERROR=1``).
      write: prints the line (default: to stderr); `python -m litl` labels it with its job.
    """
    try:
        yield
    except UserError as error:
        _exit(program, error, keep_traceback, write)
    except OSError as error:
        if not os_errors:
            raise
        _exit(program, error, keep_traceback, write)


def _exit(
    program: str, error: Exception, keep_traceback: bool, write: Callable[[str], object] | None
) -> NoReturn:
    if keep_traceback:
        raise error
    line = f"{program}: error: {error}"
    if write is None:
        print(line, file=sys.stderr, flush=True)
    else:
        write(line)
    raise SystemExit(2) from None

"""The one base class of the errors that reach a user: `UserError`.

An error that is about the user's input (a setting, a robot, a PNG, a run directory, a
checkpoint) rather than about litl derives from `UserError`; its message says what is wrong and
how to fix it. The command-line tools (`python -m litl`, `python -m litl.replay`,
`python -m litl.report`) print such an error as one line, without a traceback, and exit with
status 2; any other exception is a bug and keeps its traceback.

This module imports nothing, so every part of litl can derive from it.
"""


class UserError(Exception):
    """An error in what the user gave litl; the message names it and says how to fix it."""

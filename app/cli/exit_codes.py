"""What each error a subcommand lets escape means for the exit code.

Subcommands raise; `app.cli.main` prints the error as one line on stderr and
exits with the code of the first row of `EXIT_CODES` that matches it, so no
handler has its own try/except for the user's mistakes and no mistake shows a
traceback. Anything not listed is a bug and keeps its traceback.
"""

from __future__ import annotations

import argparse

from app.sessions.database import StoreError
from app.sessions.store import UnknownSession
from app.sources.outcomes import ScriptError
from planner.scenario.loading import ScenarioError
from planner.search.cluster import ClusterUnavailable
from planner.search.errors import DeadEnd


class BadInput(Exception):
    """Input the user can fix (an option, a file, an id): one line, exit code 2."""


OK = 0
FAILED = 1  # the command ran and its answer is "no": no plan, violations, not a goal
BAD_INPUT = 2  # the command could not run on what it was given

EXIT_CODES: tuple[tuple[type[Exception], int], ...] = (
    (DeadEnd, FAILED),
    (ScenarioError, BAD_INPUT),
    (BadInput, BAD_INPUT),
    (ClusterUnavailable, BAD_INPUT),
    (ScriptError, BAD_INPUT),
    (UnknownSession, BAD_INPUT),
    (StoreError, BAD_INPUT),
)
HANDLED: tuple[type[Exception], ...] = tuple(error for error, _ in EXIT_CODES)


def exit_code(err: Exception) -> int:
    return next(code for error, code in EXIT_CODES if isinstance(err, error))


def message(err: Exception, args: argparse.Namespace) -> str:
    """The error's line; a dead end names the input it was planned from."""
    if isinstance(err, DeadEnd):
        return f"{args.input}: no plan: {err}"
    return str(err)

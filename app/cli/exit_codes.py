"""What each error a subcommand lets escape means for the exit code.

Subcommands raise; `app.cli.main` prints the error as one line on stderr and
exits with the code of the first row of `EXIT_CODES` that matches it, so no
handler has its own try/except for the user's mistakes and no mistake shows a
traceback. Anything not listed is a bug and keeps its traceback.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass


class BadInput(Exception):
    """Input the user can fix (an option, a file, an id): one line, exit code 2."""


OK = 0
FAILED = 1  # the command ran and its answer is "no": no plan, violations, not a goal
BAD_INPUT = 2  # the command could not run on what it was given


@dataclass(frozen=True)
class Handled:
    """An error type, named by its module so that this table imports none of them."""

    module: str
    name: str
    code: int

    def matches(self, err: Exception) -> bool:
        # An error can only be of a type whose module is loaded: one not loaded is
        # not imported just to be compared (`tandem scenario check` would load the
        # session store, and `tandem sessions list` the planner's search).
        module = sys.modules.get(self.module)
        error_type = getattr(module, self.name, None)
        return isinstance(error_type, type) and isinstance(err, error_type)


DEAD_END = Handled("planner.search.errors", "DeadEnd", FAILED)
EXIT_CODES: tuple[Handled, ...] = (
    DEAD_END,
    Handled("planner.scenario.loading", "ScenarioError", BAD_INPUT),
    Handled(__name__, "BadInput", BAD_INPUT),
    Handled("planner.search.cluster", "ClusterUnavailable", BAD_INPUT),
    Handled("app.sources.outcomes", "ScriptError", BAD_INPUT),
    Handled("app.sessions.store", "UnknownSession", BAD_INPUT),
    Handled("app.sessions.database", "StoreError", BAD_INPUT),
)


def exit_code(err: Exception) -> int | None:
    """The exit code of an error the user can act on; None for a bug."""
    return next((row.code for row in EXIT_CODES if row.matches(err)), None)


def message(err: Exception, args: argparse.Namespace) -> str:
    """The error's line; a dead end names the input it was planned from."""
    if DEAD_END.matches(err):
        return f"{args.input}: no plan: {err}"
    return str(err)

"""The full `tandem` command: the planner's subcommands plus those of the app.

The app's own subcommands (dashboard, execution, sessions) are appended to
`APP_SUBCOMMANDS` by their modules' `register` functions listed here.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from app import cli_dashboard, cli_execute
from planner import cli as planner_cli

APP_SUBCOMMANDS: list[tuple[str, str, planner_cli.Register]] = [
    ("dashboard", "the browser dashboard: bench, planning, plan tree", cli_dashboard.register),
]
APP_SUBCOMMANDS.append(("execute", "run a plan, one branch", cli_execute.register_execute))
APP_SUBCOMMANDS.append(("sessions", "stored executions", cli_execute.register_sessions))


def main(argv: Sequence[str] | None = None) -> int:
    return planner_cli.main(argv, [*planner_cli.SUBCOMMANDS, *APP_SUBCOMMANDS])


if __name__ == "__main__":
    sys.exit(main())

"""The `tandem` command line.

Each subcommand lives in its own module and is listed in `SUBCOMMANDS` as
`(name, help, register)`: `register(parser)` adds its arguments and calls
`parser.set_defaults(run=handler)`, where `handler(args) -> int` returns the
exit code. `app.cli` extends the list with the commands that need the
dashboard or the session store, so the planner imports nothing from `app`.
A `ScenarioError` escaping any handler is printed as its one line
with exit code 2, so no subcommand shows a traceback for a bad scenario.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence

from planner import cli_bench, cli_feasibility, cli_plan, cli_scenario
from planner.scenario import ScenarioError

Register = Callable[[argparse.ArgumentParser], None]

SUBCOMMANDS: list[tuple[str, str, Register]] = [
    ("scenario", "validate scenario files", cli_scenario.register),
    ("plan", "plan every contingency of a scenario", cli_plan.register_plan),
    ("check", "audit a plan file by re-simulating every branch", cli_plan.register_check),
    ("bench", "plan and audit the paper's benchmark instances", cli_bench.register),
    ("feasibility", "which arm reaches which part, by geometry", cli_feasibility.register),
]


def build_parser(
    subcommands: Sequence[tuple[str, str, Register]] = SUBCOMMANDS,
) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="tandem", description="Hybrid conditional planner for human-robot table assembly."
    )
    parser.set_defaults(usage_of=parser)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, help_text, register in subcommands:
        command = sub.add_parser(name, help=help_text, description=help_text)
        # So `tandem NAME` without its action shows NAME's own usage.
        command.set_defaults(usage_of=command)
        register(command)
    return parser


def main(
    argv: Sequence[str] | None = None,
    subcommands: Sequence[tuple[str, str, Register]] = SUBCOMMANDS,
) -> int:
    parser = build_parser(subcommands)
    args = parser.parse_args(argv)
    run: Callable[[argparse.Namespace], int] | None = getattr(args, "run", None)
    if run is None:
        # No command, or a command group without its action.
        usage_of: argparse.ArgumentParser = args.usage_of
        usage_of.print_help(sys.stderr)
        return 2
    try:
        return run(args)
    except ScenarioError as err:
        print(err, file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

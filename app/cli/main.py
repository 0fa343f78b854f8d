"""The `tandem` command line.

The app wires everything, so the command line lives here and the planner
imports nothing from it: `planner` stays a library that tests, the dashboard
and scripts call directly.

Each subcommand has its own module and is listed in `SUBCOMMANDS` with its
name and help line. The module's `register(parser)` adds its arguments and calls
`parser.set_defaults(run=handler)`, where `handler(args) -> int` returns the
exit code. Only the module of the command being run is imported (its name is
read off the command line first): `tandem --help` imports none, `tandem sessions
list` only the sessions module, so neither pays for the solver, the physics
engine or the dashboard. Errors a handler lets escape are mapped to exit codes
by the one table in `app.cli.exit_codes`, applied in `main`.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass

from app.cli import exit_codes


@dataclass(frozen=True)
class Subcommand:
    name: str
    help: str
    module: str  # the module whose `register(parser)` adds the command's arguments


SUBCOMMANDS: tuple[Subcommand, ...] = (
    Subcommand("scenario", "validate scenario files", "app.cli.scenario"),
    Subcommand("plan", "plan every contingency of a scenario", "app.cli.plan"),
    Subcommand("check", "audit a plan file by re-simulating every branch", "app.cli.check"),
    Subcommand("bench", "plan and audit the paper's benchmark instances", "app.cli.benchmark"),
    Subcommand("sweep", "plan scenarios under varied settings: CSV and plot", "app.cli.sweep"),
    Subcommand("feasibility", "which arm reaches which part, by geometry", "app.cli.feasibility"),
    Subcommand(
        "dashboard", "the browser dashboard: bench, planning, plan tree", "app.cli.dashboard"
    ),
    Subcommand("execute", "run a plan, one branch", "app.cli.execute"),
    Subcommand("sessions", "stored executions", "app.cli.sessions"),
    Subcommand(
        "study",
        "simulated participants over conditions: sessions, CSV and figure",
        "app.cli.study",
    ),
    Subcommand(
        "markers", "the printable QR codes of a scenario's parts and bench", "app.cli.markers"
    ),
    Subcommand("camera", "camera set-up: calibrate", "app.cli.camera"),
    Subcommand(
        "track", "what the camera sees: each part's placement as it changes", "app.cli.track"
    ),
    Subcommand(
        "say", "the robot's voice: speak a sentence to the speakers or a file", "app.cli.say"
    ),
    Subcommand("listen", "hear one yes/no answer and show what was understood", "app.cli.listen"),
    Subcommand("robot", "the robot's side: a simulated Baxter on ROS 1 (sim)", "app.cli.robot"),
)


def register(command: Subcommand, parser: argparse.ArgumentParser) -> None:
    """Import the command's module and add its arguments to `parser`."""
    module = importlib.import_module(command.module)
    module.register(parser)


def build_parser(registered: Collection[str] | None = None) -> argparse.ArgumentParser:
    """The parser, with the arguments of the `registered` commands (default: all).

    The others are listed with their help line only, which is all the top
    level's help and its error for an unknown command show."""
    parser = argparse.ArgumentParser(
        prog="tandem", description="Hybrid conditional planner for human-robot table assembly."
    )
    parser.set_defaults(usage_of=parser)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for command in SUBCOMMANDS:
        sub_parser = sub.add_parser(command.name, help=command.help, description=command.help)
        # So `tandem NAME` without its action shows NAME's own usage.
        sub_parser.set_defaults(usage_of=sub_parser)
        if registered is None or command.name in registered:
            register(command, sub_parser)
    return parser


def chosen_command(argv: Sequence[str]) -> str | None:
    """The command named on the command line, before parsing it: the top level
    has no option but --help, so its first argument that is no option."""
    for i, arg in enumerate(argv):
        if arg == "--":
            return argv[i + 1] if i + 1 < len(argv) else None
        if not arg.startswith("-"):
            return arg
    return None


def main(argv: Sequence[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    chosen = chosen_command(argv)
    args = build_parser({chosen} if chosen else set()).parse_args(argv)
    run: Callable[[argparse.Namespace], int] | None = getattr(args, "run", None)
    if run is None:
        # No command, or a command group without its action.
        usage_of: argparse.ArgumentParser = args.usage_of
        usage_of.print_help(sys.stderr)
        return exit_codes.BAD_INPUT
    try:
        return run(args)
    except Exception as err:
        code = exit_codes.exit_code(err)
        if code is None:
            raise  # a bug: its traceback
        print(exit_codes.message(err, args), file=sys.stderr)
        return code


if __name__ == "__main__":
    sys.exit(main())

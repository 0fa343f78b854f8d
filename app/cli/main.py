"""The `tandem` command line.

The app wires everything, so the command line lives here and the planner
imports nothing from it: `planner` stays a library that tests, the dashboard
and scripts call directly.

Each subcommand has its own module and is listed in `SUBCOMMANDS` as
`(name, help, register)`: `register(parser)` adds its arguments and calls
`parser.set_defaults(run=handler)`, where `handler(args) -> int` returns the
exit code. Errors a handler lets escape are mapped to exit codes by the one
table in `app.cli.exit_codes`, applied in `main`.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence

from app.cli import (
    benchmark,
    camera,
    check,
    dashboard,
    execute,
    feasibility,
    listen,
    markers,
    plan,
    robot,
    say,
    scenario,
    sessions,
    study,
    sweep,
    track,
)
from app.cli.exit_codes import BAD_INPUT, HANDLED, exit_code, message

Register = Callable[[argparse.ArgumentParser], None]

SUBCOMMANDS: list[tuple[str, str, Register]] = [
    ("scenario", "validate scenario files", scenario.register),
    ("plan", "plan every contingency of a scenario", plan.register),
    ("check", "audit a plan file by re-simulating every branch", check.register),
    ("bench", "plan and audit the paper's benchmark instances", benchmark.register),
    ("sweep", "plan scenarios under varied settings: CSV and plot", sweep.register),
    ("feasibility", "which arm reaches which part, by geometry", feasibility.register),
    ("dashboard", "the browser dashboard: bench, planning, plan tree", dashboard.register),
    ("execute", "run a plan, one branch", execute.register),
    ("sessions", "stored executions", sessions.register),
    ("study", "simulated participants over conditions: sessions, CSV and figure", study.register),
    ("markers", "the printable QR codes of a scenario's parts and bench", markers.register),
    ("camera", "camera set-up: calibrate", camera.register),
    ("track", "what the camera sees: each part's placement as it changes", track.register),
    ("say", "the robot's voice: speak a sentence to the speakers or a file", say.register),
    ("listen", "hear one yes/no answer and show what was understood", listen.register),
    ("robot", "the robot's side: a simulated Baxter on ROS 1 (sim)", robot.register),
]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="tandem", description="Hybrid conditional planner for human-robot table assembly."
    )
    parser.set_defaults(usage_of=parser)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, help_text, register in SUBCOMMANDS:
        command = sub.add_parser(name, help=help_text, description=help_text)
        # So `tandem NAME` without its action shows NAME's own usage.
        command.set_defaults(usage_of=command)
        register(command)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    run: Callable[[argparse.Namespace], int] | None = getattr(args, "run", None)
    if run is None:
        # No command, or a command group without its action.
        usage_of: argparse.ArgumentParser = args.usage_of
        usage_of.print_help(sys.stderr)
        return BAD_INPUT
    try:
        return run(args)
    except HANDLED as err:
        print(message(err, args), file=sys.stderr)
        return exit_code(err)


if __name__ == "__main__":
    sys.exit(main())

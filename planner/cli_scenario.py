"""`tandem scenario check FILE...`: validate scenario files."""

from __future__ import annotations

import argparse
import sys

from planner.scenario import ScenarioError, load_scenario


def register(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="scenario_command", metavar="ACTION")
    check = sub.add_parser("check", help="validate scenario files (exit 2 if any is bad)")
    check.add_argument("files", nargs="+", metavar="FILE")
    check.set_defaults(run=_check)


def _check(args: argparse.Namespace) -> int:
    status = 0
    # Check every file so one run reports all bad scenarios, one line each.
    for file in args.files:
        try:
            scenario = load_scenario(file)
        except ScenarioError as err:
            print(err, file=sys.stderr)
            status = 2
            continue
        print(
            f"{file}: ok ({len(scenario.parts)} parts, "
            f"{len(scenario.goal_pairs())} goal attachments)"
        )
    return status

"""`tandem scenario check FILE...` (validate scenario files) and
`tandem scenario paper DIR` (write the paper's benchmark scenarios)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from planner.scenario import paper
from planner.scenario.loading import ScenarioError, load_scenario


def register(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="scenario_command", metavar="ACTION")
    check = sub.add_parser("check", help="validate scenario files (exit 2 if any is bad)")
    check.add_argument("files", nargs="+", metavar="FILE")
    check.set_defaults(run=_check)
    write = sub.add_parser(
        "paper", help="write the paper's benchmark scenarios (static/scenarios/paper)"
    )
    write.add_argument("directory", help="where to write the .toml files (created if missing)")
    write.set_defaults(run=_write_paper)


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
        goal = (
            "the table planned per branch"
            if scenario.goal.planned
            else f"{len(scenario.goal_pairs())} goal attachments"
        )
        print(f"{file}: ok ({len(scenario.parts)} parts, {goal})")
    return status


def _write_paper(args: argparse.Namespace) -> int:
    out = Path(args.directory)
    out.mkdir(parents=True, exist_ok=True)
    for name, text in paper.generated_files().items():
        (out / name).write_text(text, encoding="utf-8")
        print(out / name)
    return 0

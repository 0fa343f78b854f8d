"""`tandem check PLAN.json`: audit a plan file by re-simulating every branch.

With `--scenario` (the scenario the plan was made for) it also checks, on the real
Baxter, that every stored motion goes to the slot its branch's state names.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from app.cli.exit_codes import BadInput
from planner.audit.branches import Violation, audit, format_report
from planner.resources import find_scenario
from planner.scenario.loading import ScenarioError, load_scenario


def register(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("plan", help="a tandem-plan/1 JSON file")
    parser.add_argument(
        "--scenario",
        metavar="SCENARIO",
        help="the plan's scenario file: also check by forward kinematics that every "
        "motion ends (or, releasing, starts) over the slot its branch's state names",
    )
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    try:
        doc = json.loads(Path(args.plan).read_text())
    except (OSError, json.JSONDecodeError) as err:
        raise BadInput(f"{args.plan}: cannot read plan: {err}") from err
    if not isinstance(doc, dict):
        raise BadInput(f"{args.plan}: not a tandem-plan/1 document")
    violations = audit(doc)
    if args.scenario is not None:
        violations += _slot_violations(doc, args.scenario)
    print(f"{args.plan}: {format_report(violations)}")
    return 1 if violations else 0


def _slot_violations(doc: dict[str, object], name: str) -> list[Violation]:
    try:
        scenario = load_scenario(find_scenario(name))
    except ScenarioError as err:
        raise BadInput(str(err)) from err
    ref = doc.get("scenario")
    if not isinstance(ref, dict) or ref.get("sha256") != scenario.sha256:
        raise BadInput(f"--scenario {name}: not the scenario of this plan (its sha256 differs)")
    if scenario.feasibility.source != "geometry":
        print(f"{name}: no geometry (declared feasibility): motion targets not checked",
              file=sys.stderr)  # fmt: skip
        return []
    from planner.audit.slots import slot_problems  # loads pybullet: only when asked

    return [Violation(node, "", message) for node, message in slot_problems(doc, scenario)]

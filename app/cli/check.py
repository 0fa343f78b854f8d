"""`tandem check PLAN.json`: audit a plan file by re-simulating every branch."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from app.cli.exit_codes import BadInput
from planner.audit import audit, format_report


def register(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("plan", help="a tandem-plan/1 JSON file")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    try:
        doc = json.loads(Path(args.plan).read_text())
    except (OSError, json.JSONDecodeError) as err:
        raise BadInput(f"{args.plan}: cannot read plan: {err}") from err
    if not isinstance(doc, dict):
        raise BadInput(f"{args.plan}: not a tandem-plan/1 document")
    violations = audit(doc)
    print(f"{args.plan}: {format_report(violations)}")
    return 1 if violations else 0

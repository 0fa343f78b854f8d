"""`tandem sessions list|show|export`: the stored executions."""

from __future__ import annotations

import argparse
import json
import sys
from datetime import date
from pathlib import Path

from app.cli.exit_codes import BadInput
from app.execution.events import RESULTS
from app.sessions.store import SessionStore, iso
from app.sessions.summary import camera_agreement, summary


def register(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="sessions_command", metavar="ACTION")
    listing = sub.add_parser("list", help="sessions, oldest first")
    listing.add_argument("--json", action="store_true", help="as a JSON list")
    listing.add_argument("--scenario", help="only this scenario")
    listing.add_argument("--result", help=f"only this result ({', '.join(RESULTS)}, running)")
    listing.add_argument("--since", metavar="YYYY-MM-DD", help="only sessions started that day on")
    show = sub.add_parser("show", help="one session and its events")
    show.add_argument("id", help="session id")
    export = sub.add_parser("export", help="one session, its events and its plan as JSON")
    export.add_argument("id", help="session id")
    export.add_argument("-o", "--output", help="write here instead of stdout")
    for command, handler in ((listing, _list), (show, _show), (export, _export)):
        command.add_argument("--data-dir", help="session store folder")
        command.set_defaults(usage_of=command, run=handler)


def _session_id(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise BadInput(f"{text}: not a session id (a number)") from None


def _list(args: argparse.Namespace) -> int:
    since = None
    if args.since is not None:
        try:
            since = date.fromisoformat(args.since)
        except ValueError:
            raise BadInput(f"--since {args.since}: expected YYYY-MM-DD") from None
    if args.result is not None and args.result not in (*RESULTS, "running"):
        raise BadInput(f"--result {args.result}: one of {', '.join(RESULTS)}, running")
    with SessionStore(args.data_dir) as store:
        sessions = store.list_sessions(scenario=args.scenario, result=args.result, since=since)
    if args.json:
        print(json.dumps([s.to_json() for s in sessions], indent=1))
        return 0
    if not sessions:
        print("no sessions")
        return 0
    print(f"{'id':>5}  {'started':25}  {'scenario':16}  {'result':11}  {'steps':>5}  note")
    for s in sessions:
        print(
            f"{s.id:>5}  {iso(s.started):25}  {s.scenario or '-':16}  "
            f"{s.result or 'running':11}  {s.events:>5}  {s.note or ''}"
        )
    return 0


def _show(args: argparse.Namespace) -> int:
    session_id = _session_id(args.id)
    with SessionStore(args.data_dir) as store:
        record = store.get(session_id)
        events = store.events(session_id, with_jpeg=True)
    print(f"session {record.id}: {record.result or 'running'}")
    print(f"  scenario  {record.scenario} ({record.scenario_sha256})")
    print(f"  plan      {record.plan_hash}")
    print(f"  started   {iso(record.started)}")
    if record.ended is not None:
        print(f"  ended     {iso(record.ended)}")
    if record.note:
        print(f"  note      {record.note}")
    for event in events:
        line = f"  {event.seq:3d} {event.node:>5} {event.kind:13} {event.action or event.kind}"
        if event.outcome is not None:
            line += f" -> {event.outcome} ({event.source})"
        if event.text:
            line += f"  {event.text}"
        print(line)
        said = summary(event)
        if said:
            print(f"      {said}")
    agree, total = camera_agreement(events)
    if total:
        print(f"  camera answers that agree with the simulated human: {agree}/{total}")
    return 0


def _export(args: argparse.Namespace) -> int:
    session_id = _session_id(args.id)
    with SessionStore(args.data_dir) as store:
        doc = store.export(session_id)
    text = json.dumps(doc, indent=1) + "\n"
    if args.output:
        try:
            Path(args.output).write_text(text, encoding="utf-8")
        except OSError as err:
            raise BadInput(f"{args.output}: cannot write: {err.strerror or err}") from err
    else:
        sys.stdout.write(text)
    return 0

"""`tandem sessions list|show|export|metrics`: the stored executions.

`export` writes JSON (the whole session, the default), CSV (the events with their
times) or MCAP (ROS 2 messages for Foxglove, `app.sessions.mcap_export`); MCAP's
part poses need the session's scenario, found among the shipped ones by its hash
or given with `--scenario`. `metrics` writes each session's measures
(`app.sessions.metrics`) as CSV (the default) or JSON, of one session or of all
those of a scenario or of a study (tagged in the store's `study_sessions` table).
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import importlib.util
import io
import json
import sqlite3
import sys
from datetime import date
from pathlib import Path
from typing import TYPE_CHECKING

from app.cli.exit_codes import BadInput
from app.execution.events import HUMAN, RESULTS
from app.sessions.export import events_csv
from app.sessions.metrics import METRIC_KEYS
from app.sessions.store import SessionRecord, SessionStore, iso
from app.sessions.stored_metrics import stored_metrics
from app.sessions.studies import FINAL_RESULTS
from app.sessions.summary import camera_agreement, summary

if TYPE_CHECKING:
    from planner.scenario.model import Scenario

EXPORT_FORMATS = ("json", "csv", "mcap")


def register(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="sessions_command", metavar="ACTION")
    listing = sub.add_parser("list", help="sessions, oldest first")
    listing.add_argument("--json", action="store_true", help="as a JSON list")
    listing.add_argument("--scenario", help="only this scenario")
    listing.add_argument("--result", help=f"only this result ({', '.join(RESULTS)}, running)")
    listing.add_argument("--since", metavar="YYYY-MM-DD", help="only sessions started that day on")
    show = sub.add_parser("show", help="one session and its events")
    show.add_argument("id", help="session id")
    export = sub.add_parser(
        "export", help="one session: JSON (all of it), CSV (its events) or MCAP (for Foxglove)"
    )
    export.add_argument("id", help="session id")
    export.add_argument(
        "--format", choices=EXPORT_FORMATS, default="json", help="what to write (default: json)"
    )
    export.add_argument("-o", "--output", help="write here instead of stdout (MCAP needs it)")
    export.add_argument(
        "--scenario",
        metavar="FILE",
        help="MCAP: the session's scenario, for the parts' poses (default: the shipped "
        "scenario with the session's hash)",
    )
    metrics = sub.add_parser(
        "metrics", help="sessions' measures (fluency, questions, agreement): CSV or JSON"
    )
    metrics.add_argument("id", nargs="?", help="one session (default: all, as filtered)")
    metrics.add_argument("--scenario", help="only this scenario")
    metrics.add_argument("--study", metavar="NAME", help="only the sessions of this study")
    metrics.add_argument("--json", action="store_true", help="as a JSON list")
    metrics.add_argument("-o", "--output", metavar="FILE", help="write here instead of stdout")
    handlers = ((listing, _list), (show, _show), (export, _export), (metrics, _metrics))
    for command, handler in handlers:
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


# What a session's clock means, for `tandem sessions show`.
CLOCK_WORDS = {
    "wall": "wall (a person, a device or a robot: every step took its real time)",
    "simulated": "simulated (no time passed: each step took its modelled time)",
}
UNSAID_CLOCK = "not said (stored before sessions said their clock: untimed)"


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
    print(f"  clock     {CLOCK_WORDS.get(record.clock or '', UNSAID_CLOCK)}")
    for event in events:
        line = f"  {event.seq:3d} {event.node:>5} {event.kind:13} {event.action or event.kind}"
        if event.outcome is not None:
            line += f" -> {event.outcome} ({event.source})"
        elif event.kind == HUMAN and event.source is not None:
            line += f" ({event.source})"  # where the human's times come from
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
    if args.format == "mcap":
        return _export_mcap(args, session_id)
    with SessionStore(args.data_dir) as store:
        if args.format == "csv":
            text = events_csv(store.events(session_id))
        else:
            text = json.dumps(store.export(session_id), indent=1) + "\n"
    if args.output:
        try:
            Path(args.output).write_text(text, encoding="utf-8", newline="")
        except OSError as err:
            raise BadInput(f"{args.output}: cannot write: {err.strerror or err}") from err
    else:
        sys.stdout.write(text)
    return 0


# The columns before the measures in `metrics`' rows: which session they are of.
SESSION_COLUMNS = ("session", "scenario", "result")


def _metrics(args: argparse.Namespace) -> int:
    with SessionStore(args.data_dir, read_only=True) as store:
        if args.id is not None:
            sessions = [store.get(_session_id(args.id))]
        else:
            sessions = store.list_sessions(scenario=args.scenario)
        if args.study is not None:
            sessions = _counted(store, sessions, args.study)
        measured = stored_metrics(store, sessions)
        rows = [
            {"session": s.id, "scenario": s.scenario, "result": s.result, **m.row()}
            for s, m in zip(sessions, measured, strict=True)
        ]
    if args.json:
        # One session a line: a study's 10,000 rows stay readable, and each is written
        # by the json module's C encoder (an indented document is written in Python).
        text = "[\n" + ",\n".join(json.dumps(row) for row in rows) + "\n]\n" if rows else "[]\n"
    else:
        out = io.StringIO()
        writer = csv.DictWriter(out, (*SESSION_COLUMNS, *METRIC_KEYS), lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
        text = out.getvalue()
    if args.output:
        try:
            Path(args.output).write_text(text, encoding="utf-8", newline="")
        except OSError as err:
            raise BadInput(f"{args.output}: cannot write: {err.strerror or err}") from err
        print(f"{len(rows)} sessions: {args.output}")
    else:
        sys.stdout.write(text)
    return 0


def _counted(store: SessionStore, sessions: list[SessionRecord], study: str) -> list[SessionRecord]:
    """Those of `sessions` that `study` counts: tagged with it and ended at a final
    result, as the study counts them (one killed half-way or still running is run
    again when the study resumes); says on stderr how many it left out."""
    tagged = _study_session_ids(store, study)
    sessions = [s for s in sessions if s.id in tagged]
    counted = [s for s in sessions if s.result in FINAL_RESULTS]
    if len(counted) < len(sessions):
        print(
            f"{len(sessions) - len(counted)} interrupted or unfinished session(s) of "
            f"study {study} left out",
            file=sys.stderr,
        )
    return counted


def _study_session_ids(store: SessionStore, study: str) -> set[int]:
    """The ids of the sessions tagged with `study`; no such study (nor any study
    support, nor a table of tags in this store) is a `BadInput`."""
    if importlib.util.find_spec("app.sessions.studies") is None:
        raise BadInput(f"--study {study}: no such study (this installation runs no studies)")
    try:
        rows = store.db.execute(
            "select session_id from study_sessions where study = ?", [study]
        ).fetchall()
    except sqlite3.OperationalError:  # no study ever ran on this store
        rows = []
    if not rows:
        raise BadInput(f"--study {study}: no such study in {store.db_path}")
    return {row[0] for row in rows}


def _export_mcap(args: argparse.Namespace, session_id: int) -> int:
    # Loaded here: listing sessions needs neither the MCAP writer nor the geometry.
    from app.dashboard.session_files import baxter_model, parts_at
    from app.sessions.mcap_export import SessionRun, write_session

    if not args.output:
        raise BadInput("--format mcap writes a binary file: give it with -o FILE")
    with SessionStore(args.data_dir) as store:
        run = SessionRun.load(store, session_id)
    scenario = _scenario_of(args.scenario, run.record.scenario_sha256)
    if scenario is None:
        print(
            "no scenario with this session's hash is shipped: the parts' poses (/tf) are "
            "left out (give the scenario with --scenario FILE)",
            file=sys.stderr,
        )
    parts = None if scenario is None else parts_at(scenario)
    try:
        with Path(args.output).open("wb") as out:
            counts = write_session(out, run, parts_at=parts, robot=baxter_model(scenario))
    except OSError as err:
        raise BadInput(f"{args.output}: cannot write: {err.strerror or err}") from err
    print(", ".join(f"{topic}: {n}" for topic, n in sorted(counts.items())))
    return 0


def _scenario_of(given: str | None, sha256: str | None) -> Scenario | None:
    """The scenario file given, else the shipped one whose bytes hash to `sha256`."""
    from planner.resources import scenario_dir
    from planner.scenario.loading import ScenarioError, load_scenario

    if given is not None:
        try:
            return load_scenario(given)
        except ScenarioError as err:
            raise BadInput(str(err)) from None
    for path in sorted(scenario_dir().rglob("*.toml")):
        if hashlib.sha256(path.read_bytes()).hexdigest() == sha256:
            return load_scenario(path)
    return None

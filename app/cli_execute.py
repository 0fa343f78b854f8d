"""`tandem execute SCENARIO|PLAN.json` and `tandem sessions list|show|export`."""

from __future__ import annotations

import argparse
import json
import secrets
import signal
import sys
from collections.abc import Callable
from datetime import date
from pathlib import Path
from types import FrameType

from app.execution import RESULTS, ExecutionEvent, Executor
from app.outcomes import (
    ConsoleSource,
    ExpectedSource,
    FallbackSource,
    OutcomeSource,
    RandomSource,
    ScriptedSource,
    ScriptError,
)
from app.store import SessionStore, UnknownSession, iso
from planner.hcp import DeadEnd
from planner.plan import Plan, PlanFormatError
from planner.planning import plan_scenario
from planner.scenario import load_scenario

Handler = Callable[[argparse.Namespace], int]


class BadInput(Exception):
    """Input the user can fix: printed as one line, exit code 2."""


def register_execute(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("target", metavar="SCENARIO|PLAN.json", help="a scenario or a plan file")
    parser.add_argument(
        "--responses",
        default="click",
        help="where outcomes come from: click (numbered choices on stdin), random, "
        "or scripted:FILE (one outcome label a line); default click",
    )
    parser.add_argument("--seed", type=int, help="seed for --responses random")
    parser.add_argument("--data-dir", help="session store folder (default: $TANDEM_DATA_DIR, ...)")
    parser.add_argument(
        "--step-delay", type=float, default=0.0, help="seconds between steps (default 0)"
    )
    parser.add_argument("--note", help="a note stored with the session")
    parser.set_defaults(run=run_execute)


def register_sessions(parser: argparse.ArgumentParser) -> None:
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
        command.set_defaults(usage_of=command, run=_guarded(handler))


def _guarded(handler: Handler) -> Handler:
    def run(args: argparse.Namespace) -> int:
        try:
            result = handler(args)
        except (BadInput, ScriptError, UnknownSession) as err:
            print(err, file=sys.stderr)
            return 2
        return result

    return run


# -- execute ------------------------------------------------------------------


def load_plan(target: str) -> Plan:
    """The plan of a plan file, or a fresh plan of a scenario file."""
    path = Path(target)
    if path.suffix == ".json":
        try:
            return Plan.read(path)
        except PlanFormatError as err:
            raise BadInput(str(err)) from err
    scenario = load_scenario(path)
    return plan_scenario(scenario, workers=1).plan


def make_source(spec: str, seed: int | None, plan: Plan) -> OutcomeSource:
    """The source for `--responses`; each falls back to the expected outcome."""
    primary: OutcomeSource
    if spec == "click":
        primary = ConsoleSource(sys.stdin, sys.stderr)
    elif spec == "random":
        primary = RandomSource(seed)
    elif spec.startswith("scripted:") and spec != "scripted:":
        scripted = ScriptedSource(spec[len("scripted:") :])
        scripted.check_labels(plan.outcome_labels())
        primary = scripted
    else:
        raise BadInput(f"--responses {spec}: expected click, random or scripted:FILE")

    def warn(node_id: str, reason: str) -> None:
        print(f"{node_id}: {reason}; taking the expected outcome", file=sys.stderr)

    return FallbackSource(primary, ExpectedSource(), on_fallback=warn)


def _print_event(event: ExecutionEvent) -> None:
    line = f"{event.seq:3d} {event.node:>5} {event.action or 'goal'}"
    if event.outcome is not None:
        line += f" -> {event.outcome} ({event.source})"
    if event.text:
        line += f"  {event.text}"
    print(line, file=sys.stderr, flush=True)


def run_execute(args: argparse.Namespace) -> int:
    try:
        return _execute(args)
    except (BadInput, ScriptError) as err:
        print(err, file=sys.stderr)
        return 2


def _execute(args: argparse.Namespace) -> int:
    if args.step_delay < 0:
        raise BadInput(f"--step-delay {args.step_delay}: must be 0 or more")
    if args.seed is not None and args.responses != "random":
        raise BadInput("--seed goes with --responses random")
    try:
        plan = load_plan(args.target)
    except DeadEnd as err:
        print(f"{args.target}: no plan: {err}", file=sys.stderr)
        return 1
    seed = args.seed
    if args.responses == "random" and seed is None:
        seed = secrets.randbelow(2**31)
        print(f"seed {seed}", file=sys.stderr)
    source = make_source(args.responses, seed, plan)
    note = args.note
    if args.responses == "random":
        note = f"seed {seed}" + (f"; {note}" if note else "")
    with SessionStore(args.data_dir) as store:
        session_id = store.start(plan, note=note)
        print(f"session {session_id}", flush=True)
        executor = Executor(
            plan, source, [store.recorder(session_id), _print_event], args.step_delay
        )

        def stop(signum: int, frame: FrameType | None) -> None:
            raise KeyboardInterrupt

        previous = signal.signal(signal.SIGTERM, stop)
        try:
            result = executor.run()
        except KeyboardInterrupt:
            result = "interrupted"
        finally:
            signal.signal(signal.SIGTERM, previous)
        store.finish(session_id, result)
    print(f"session {session_id}: {result} after {len(executor.events)} steps")
    return 0 if result == "goal" else 1


# -- sessions -----------------------------------------------------------------


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
        events = store.events(session_id)
    print(f"session {record.id}: {record.result or 'running'}")
    print(f"  scenario  {record.scenario} ({record.scenario_sha256})")
    print(f"  plan      {record.plan_hash}")
    print(f"  started   {iso(record.started)}")
    if record.ended is not None:
        print(f"  ended     {iso(record.ended)}")
    if record.note:
        print(f"  note      {record.note}")
    for event in events:
        line = f"  {event.seq:3d} {event.node:>5} {event.kind:13} {event.action or 'goal'}"
        if event.outcome is not None:
            line += f" -> {event.outcome} ({event.source})"
        if event.text:
            line += f"  {event.text}"
        print(line)
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

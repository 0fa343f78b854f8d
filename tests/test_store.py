"""The session store: real SQLite files, real processes for the liveness checks."""

from __future__ import annotations

import hashlib
import json
import os
import sqlite3
import subprocess
import sys
from collections.abc import Sequence
from datetime import date, datetime, timedelta
from pathlib import Path

import pytest

from app.execution.events import ExecutionEvent, Outcome
from app.execution.evidence import EVIDENCE_VERSION, CameraReading, Evidence, Truth
from app.execution.walker import Executor
from app.sessions.export import exported_event
from app.sessions.processes import process_start
from app.sessions.store import (
    DB_NAME,
    SessionStore,
    UnknownSession,
    default_data_dir,
)
from app.sources.outcomes import RandomSource
from planner.plan.model import Plan, PlanNode, ScenarioRef
from tests.plan_fixtures import default_plan
from tests.plan_paths import is_plan_path, plan_hash


@pytest.fixture(scope="module")
def plan() -> Plan:
    return default_plan()


def run_session(store: SessionStore, doc: Plan, seed: int, note: str = "") -> int:
    session = store.start(doc, note=note or None)
    executor = Executor(doc, RandomSource(seed), [store.recorder(session)])
    store.finish(session, executor.run())
    return session


def dead_pid() -> int:
    """The pid of a process that has exited and been reaped."""
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_default_data_dir_follows_the_environment(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.delenv("TANDEM_DATA_DIR", raising=False)
    monkeypatch.delenv("XDG_DATA_HOME", raising=False)
    assert default_data_dir() == tmp_path / "home" / ".local" / "share" / "tandem"
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    assert default_data_dir() == tmp_path / "xdg" / "tandem"
    monkeypatch.setenv("TANDEM_DATA_DIR", str(tmp_path / "explicit"))
    assert default_data_dir() == tmp_path / "explicit"
    with SessionStore() as store:
        assert store.db_path == tmp_path / "explicit" / DB_NAME


def test_the_database_is_in_wal_mode(tmp_path: Path) -> None:
    with SessionStore(tmp_path):
        pass
    conn = sqlite3.connect(tmp_path / DB_NAME)
    assert conn.execute("pragma journal_mode").fetchone()[0] == "wal"
    tables = {r[0] for r in conn.execute("select name from sqlite_master where type='table'")}
    assert {"plans", "sessions", "events"} <= tables


def test_a_plan_is_stored_once_under_its_canonical_hash(
    plan: Plan, tmp_path: Path
) -> None:
    with SessionStore(tmp_path) as store:
        first = run_session(store, plan, 1)
        # The same plan read back from a file written another way: the same hash.
        copy = Plan.from_json(json.loads(json.dumps(plan.to_json(), indent=3)))
        second = run_session(store, copy, 2)
        digest = store.get(first).plan_hash
        assert store.get(second).plan_hash == digest == plan_hash(plan)
        doc = plan.to_json()
        canonical = json.dumps(doc, sort_keys=True, separators=(",", ":"), ensure_ascii=False)
        assert digest == hashlib.sha256(canonical.encode()).hexdigest()
        assert store.plan(digest) == plan
        assert store.plan_doc(digest) == doc
        assert store.db.table("plans").count == 1


def test_each_event_is_committed_as_it_happens(plan: Plan, tmp_path: Path) -> None:
    with SessionStore(tmp_path) as store:
        session = store.start(plan)
        reader = sqlite3.connect(tmp_path / DB_NAME)
        seen: list[tuple[int, int]] = []

        def check(event: ExecutionEvent) -> None:
            # Another connection sees every event at once, with what decided it, with no
            # commit by the caller.
            seen.append(
                tuple(
                    reader.execute(
                        f"select count(*) from {table} where session_id = ?", [session]
                    ).fetchone()[0]
                    for table in ("events", "evidence")
                )
            )

        executor = Executor(plan, _EvidencedSource(), [store.recorder(session), check])
        store.finish(session, executor.run())
        answered = [e.evidence is not None for e in executor.events]
        assert seen == [(k + 1, sum(answered[: k + 1])) for k in range(len(answered))]
        assert sum(answered) > 0
        assert store.events(session) == executor.events


def test_sessions_of_a_dead_process_are_interrupted(plan: Plan, tmp_path: Path) -> None:
    with SessionStore(tmp_path) as store:
        gone = store.start(plan, pid=dead_pid())
        store.record(gone, ExecutionEvent(0, 1234.5, plan.root, "x", "actuation"))
        mine = store.start(plan)  # this process: alive
    with SessionStore(tmp_path) as store:
        assert store.interrupted == [gone]
        record = store.get(gone)
        assert record.result == "interrupted" and record.ended == 1234.5
        assert store.get(mine).result is None
        assert [s.id for s in store.list_sessions(result="running")] == [mine]


def test_a_reused_pid_does_not_keep_a_session_open(plan: Plan, tmp_path: Path) -> None:
    begun = process_start(os.getpid())
    if begun is None:
        pytest.skip("no /proc here")
    with SessionStore(tmp_path) as store:
        session = store.start(plan)
        # A session started long before this process did cannot be this process's.
        store.db.table("sessions").update(session, {"started": begun - 3600})
    with SessionStore(tmp_path) as store:
        assert store.get(session).result == "interrupted"


def test_list_filters(plan: Plan, tmp_path: Path) -> None:
    other = plan.model_copy(update={"scenario": ScenarioRef(name="other", sha256="0" * 64)})
    with SessionStore(tmp_path) as store:
        a = run_session(store, plan, 1)
        b = run_session(store, other, 2)
        c = store.start(plan)
        store.finish(c, "aborted")
        store.db.table("sessions").update(a, {"started": datetime(2020, 1, 2, 12).timestamp()})
        assert [s.id for s in store.list_sessions()] == [a, b, c]
        assert [s.id for s in store.list_sessions(scenario="other")] == [b]
        assert [s.id for s in store.list_sessions(result="aborted")] == [c]
        assert [s.id for s in store.list_sessions(scenario=plan.scenario.name)] == [a, c]
        assert [s.id for s in store.list_sessions(since=date(2020, 1, 3))] == [b, c]
        assert [s.id for s in store.list_sessions(since=date(2020, 1, 2))] == [a, b, c]
        tomorrow = date.today() + timedelta(days=1)
        assert store.list_sessions(since=tomorrow) == []
        assert store.get(a).events == len(store.events(a)) > 0


def test_paths_and_plan_paths(plan: Plan, tmp_path: Path) -> None:
    with SessionStore(tmp_path) as store:
        session = run_session(store, plan, 5)
        path = store.path(session)
    assert path[0][0] == plan.root and plan.nodes[path[-1][0]].kind == "goal"
    assert is_plan_path(plan, path)
    assert not is_plan_path(plan, path[:-1])
    assert is_plan_path(plan, path[:-1], complete=False)
    assert is_plan_path(plan, [], complete=False) and not is_plan_path(plan, [])
    assert not is_plan_path(plan, path[1:], complete=False)  # not from the root
    branching = next(i for i, (_, outcome) in enumerate(path) if outcome is not None)
    node, outcome = path[branching]
    wrong = next(c.outcome for c in plan.nodes[node].children if c.outcome != outcome)
    bent = [*path[:branching], (node, wrong), *path[branching + 1 :]]
    assert not is_plan_path(plan, bent, complete=False)


def test_export_round_trip(plan: Plan, tmp_path: Path) -> None:
    with SessionStore(tmp_path) as store:
        session = run_session(store, plan, 3, note="round trip")
        doc = store.export(session)
        events = store.events(session)
    again = json.loads(json.dumps(doc))
    assert again == doc
    assert doc["format"] == "tandem-session/2"
    assert doc["plan"] == plan.to_json()
    assert doc["session"]["id"] == session and doc["session"]["note"] == "round trip"
    assert doc["session"]["result"] == "goal"
    assert [exported_event(e) for e in doc["events"]] == events
    stored = Plan.from_json(doc["plan"])
    steps = [(e["node"], e["outcome"]) for e in doc["events"] if e["kind"] != "human"]
    assert is_plan_path(stored, steps)


def test_unknown_sessions(tmp_path: Path) -> None:
    with SessionStore(tmp_path) as store:
        with pytest.raises(UnknownSession, match="no session 42"):
            store.get(42)
        with pytest.raises(UnknownSession):
            store.export(42)


class _EvidencedSource:
    """Answers the first option, with the evidence a camera would keep."""

    name = "camera"

    def choose(self, node_id: str, node: PlanNode, options: Sequence[str]) -> Outcome:
        picture = b"\xff\xd8" + node_id.encode() + b"\xff\xd9"
        reading = CameraReading("label", options[0], 0.9, "seen", 5, 12, 0.1, {"leg1": "held"})
        evidence = Evidence(camera=reading, truth=Truth(options[0]), jpeg=picture)
        return Outcome(options[0], "camera", 0.9, "", evidence)


def test_evidence_is_stored_with_its_event(plan: Plan, tmp_path: Path) -> None:
    store = SessionStore(tmp_path)
    sid = store.start(plan)
    assert Executor(plan, _EvidencedSource(), [store.recorder(sid)]).run() == "goal"
    events = store.events(sid)
    answered = [e for e in events if e.outcome is not None]
    assert answered and all(e.evidence is not None for e in answered)
    assert all(e.evidence is None for e in events if e.outcome is None)
    first = answered[0]
    assert first.evidence is not None and first.evidence.truth == Truth(str(first.outcome))
    assert first.evidence.camera is not None and first.evidence.camera.value == first.outcome
    assert first.evidence.camera.placements == {"leg1": "held"}
    assert first.evidence.jpeg is None  # pictures only when asked
    # The evidence table holds the versioned JSON, one row per answered event.
    with sqlite3.connect(tmp_path / DB_NAME) as db:
        rows = db.execute("select seq, detail from evidence where session_id = ?", [sid])
        stored = {seq: json.loads(detail) for seq, detail in rows}
    assert sorted(stored) == [e.seq for e in answered]
    assert stored[first.seq]["version"] == EVIDENCE_VERSION
    assert stored[first.seq]["truth"] == {"label": first.outcome, "said": []}
    assert store.evidence_jpeg(sid, first.seq) == b"\xff\xd8" + first.node.encode() + b"\xff\xd9"
    with_pictures = store.events(sid, with_jpeg=True)
    assert [e.evidence.jpeg is not None for e in with_pictures if e.evidence] == [True] * len(
        answered
    )
    exported = store.export(sid)["events"]
    assert exported[first.seq]["evidence"] == {**stored[first.seq], "jpeg": True}
    store.close()

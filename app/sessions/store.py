"""Executions on disk: a SQLite database of plans, sessions and their events.

`plans` holds each plan once, keyed by the sha256 of its canonical JSON;
`sessions` one row per execution; `events` every step, committed as it
happens (with its `started` and `ended` times, null in a store older than them:
an untimed session) (with `evidence`, what decided an answer: a JPEG of the camera's
frame, the words heard), so a session killed half-way keeps all it did. A session left
without an end by a process that is gone is marked "interrupted" the next
time the store is opened.
"""

from __future__ import annotations

import hashlib
import json
import os
import socket
import sqlite3
import threading
import time
from collections.abc import Callable, Collection, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import asdict, dataclass, fields
from datetime import date, datetime
from pathlib import Path
from typing import Any

from sqlite_utils import Database
from sqlite_utils.db import Table

from app.execution.events import Clock, ExecutionEvent, Result, is_step
from app.execution.evidence import Evidence
from app.sessions.database import StoreError, open_database, unusable
from app.sessions.export import EXPORT_FORMAT, event_row, export_event, row_event
from app.sessions.processes import boot_id, owner_alive
from app.sessions.studies import ensure_table
from planner.plan.model import Plan

# Stored plans whose hash is remembered, so the same plan object is not
# serialised again (large plans take tens of milliseconds); bounded, so a
# long-running dashboard does not keep every plan it ever executed.
_KNOWN_PLANS = 8

DB_NAME = "sessions.db"
# The events' own columns for when a step began and ended (`ExecutionEvent.start`/`end`)
# and when within it the robot began waiting for the human (`wait_start`).
EVENT_TIMES = ("started", "ended", "wait_start")


class UnknownSession(KeyError):
    def __str__(self) -> str:
        return f"no session {self.args[0]}"


@dataclass(frozen=True)
class SessionRecord:
    id: int
    scenario: str | None
    scenario_sha256: str | None
    plan_hash: str
    started: float
    ended: float | None
    result: Result | None  # None while it runs
    note: str | None
    pid: int | None
    host_boot: str | None
    # The clock its events' times are on (`app.execution.timing.Clock`): None in a
    # session stored before sessions said, whose times cannot be trusted.
    clock: str | None = None
    events: int = 0

    def to_json(self) -> dict[str, Any]:
        out = asdict(self)
        out["started_at"] = iso(self.started)
        out["ended_at"] = iso(self.ended) if self.ended is not None else None
        return out


# The columns of a `SessionRecord`, in its fields' order, with its count of events
# (the events' primary key index counts them without reading a row).
def session_select(columns: Collection[str]) -> str:
    """The query of `SessionRecord`s from a sessions table with `columns` (a store
    opened read-only may be older than some: those read as null)."""
    names = (f.name for f in fields(SessionRecord) if f.name != "events")
    return (
        "select "
        + ", ".join(f"s.{name}" if name in columns else "null" for name in names)
        + ", (select count(*) from events e where e.session_id = s.id) from sessions s"
    )


def iso(t: float) -> str:
    return datetime.fromtimestamp(t).astimezone().isoformat(timespec="seconds")


def default_data_dir() -> Path:
    """$TANDEM_DATA_DIR, else $XDG_DATA_HOME/tandem, else ~/.local/share/tandem."""
    explicit = os.environ.get("TANDEM_DATA_DIR")
    if explicit:
        return Path(explicit)
    xdg = os.environ.get("XDG_DATA_HOME")
    if xdg:
        return Path(xdg) / "tandem"
    return Path.home() / ".local" / "share" / "tandem"


def canonical_json(plan: Plan | Mapping[str, Any]) -> str:
    """The plan as canonical JSON: sorted keys, no spaces, UTF-8 as is."""
    doc = plan.to_json() if isinstance(plan, Plan) else plan
    return json.dumps(doc, sort_keys=True, separators=(",", ":"), ensure_ascii=False)


class SessionStore:
    """The session database in `data_dir` (created if missing); safe across threads."""

    def __init__(self, data_dir: str | Path | None = None, *, read_only: bool = False) -> None:
        """Opens (or creates) the database; raises `StoreError` with one line if it can't.

        A database that can be read but not written opens for reading, with the
        reason in `read_only` (writes then raise `StoreError`); `read_only=True`
        asks for that from the start.
        """
        self.data_dir = Path(data_dir) if data_dir is not None else default_data_dir()
        self.db_path = self.data_dir / DB_NAME
        self._lock = threading.RLock()
        self._plans: dict[int, tuple[Plan, str]] = {}
        self.interrupted: list[int] = []
        self.db, self.read_only = open_database(self.db_path, self._create, read_only=read_only)
        with self._reading():
            columns = [row[1] for row in self.db.execute("pragma table_info(sessions)")]
        self._session_select = session_select(columns)
        if self.read_only is None:
            self.interrupted = self.mark_interrupted()

    @contextmanager
    def _reading(self) -> Iterator[None]:
        """The lock, for a read; a damaged database is one `StoreError` line."""
        try:
            with self._lock:
                yield
        except sqlite3.DatabaseError as err:
            raise unusable(self.db_path, err) from None

    @contextmanager
    def _writing(self) -> Iterator[None]:
        """The lock, for a write; a write that fails is one `StoreError` line."""
        if self.read_only is not None:
            raise StoreError(f"cannot record: {self.read_only}")
        try:
            with self._lock:
                yield
        except sqlite3.Error as err:
            raise StoreError(
                f"{self.db_path}: cannot write ({err}); free space or fix its permissions"
            ) from None

    def close(self) -> None:
        with self._lock:
            self.db.conn.close()

    def __enter__(self) -> SessionStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _table(self, name: str) -> Table:
        return _table(self.db, name)

    @staticmethod
    def _create(db: Database) -> None:
        _table(db, "plans").create({"hash": str, "doc": str}, pk="hash", if_not_exists=True)
        _table(db, "sessions").create(
            {
                "id": int,
                "scenario": str,
                "scenario_sha256": str,
                "plan_hash": str,
                "started": float,
                "ended": float,
                "result": str,
                "note": str,
                "pid": int,
                "host_boot": str,
                "clock": str,
            },
            pk="id",
            foreign_keys=[("plan_hash", "plans", "hash")],
            if_not_exists=True,
        )
        _table(db, "events").create(
            {
                "session_id": int,
                "seq": int,
                "time": float,
                "node": str,
                "action": str,
                "kind": str,
                "outcome": str,
                "source": str,
                "confidence": float,
                "text": str,
                "started": float,
                "ended": float,
                "wait_start": float,
            },
            pk=("session_id", "seq"),
            foreign_keys=[("session_id", "sessions", "id")],
            if_not_exists=True,
        )
        events = _table(db, "events")
        for column in EVENT_TIMES:  # a store older than timed events gets them, null
            if column not in events.columns_dict:
                events.add_column(column, float)
        if "clock" not in _table(db, "sessions").columns_dict:
            _table(db, "sessions").add_column("clock", str)  # null: said nothing
        _table(db, "evidence").create(
            {"session_id": int, "seq": int, "detail": str, "jpeg": bytes},
            pk=("session_id", "seq"),
            foreign_keys=[("session_id", "sessions", "id")],
            if_not_exists=True,
        )
        _table(db, "sessions").create_index(["started"], if_not_exists=True)
        ensure_table(db)  # the studies' tags (tandem study), so every store has them

    # -- writing ----------------------------------------------------------------

    def add_plan(self, plan: Plan) -> str:
        """Stores the plan once; its hash.

        A plan is taken as immutable once stored: the same object is not
        serialised again while it is among the last few stored.
        """
        with self._lock:
            known = self._plans.get(id(plan))
            if known is not None and known[0] is plan:
                return known[1]
            text = canonical_json(plan)
            digest = hashlib.sha256(text.encode("utf-8")).hexdigest()
            with self._writing():
                self._table("plans").insert({"hash": digest, "doc": text}, ignore=True)
            self._plans[id(plan)] = (plan, digest)
            while len(self._plans) > _KNOWN_PLANS:
                del self._plans[next(iter(self._plans))]
        return digest

    def start(
        self,
        plan: Plan,
        *,
        note: str | None = None,
        pid: int | None = None,
        clock: Clock | None = None,
    ) -> int:
        """A new session of `plan`, owned by this process (or `pid`), its events timed on
        `clock` (None: untimed); its id."""
        digest = self.add_plan(plan)
        row = {
            "scenario": plan.scenario.name,
            "scenario_sha256": plan.scenario.sha256,
            "plan_hash": digest,
            "started": time.time(),
            "ended": None,
            "result": None,
            "note": note,
            "pid": os.getpid() if pid is None else pid,
            "host_boot": boot_id() or socket.gethostname(),
            "clock": clock,
        }
        with self._writing():
            table = self._table("sessions").insert(row)
            session_id = table.last_pk
        assert isinstance(session_id, int)
        return session_id

    def record(self, session_id: int, event: ExecutionEvent) -> None:
        """Stores one event; committed before this returns."""
        row = {
            "session_id": session_id, **event_row(event), "started": event.start,
            "ended": event.end, "wait_start": event.wait_start,
        }  # fmt: skip
        evidence = event.evidence
        with self._writing(), self.db.conn:
            # One transaction: an answer is never stored without what decided it.
            self.db.conn.execute(
                f"insert into events ({', '.join(row)}) values ({', '.join('?' * len(row))})",
                list(row.values()),
            )
            if evidence is not None:
                self.db.conn.execute(
                    "insert into evidence (session_id, seq, detail, jpeg) values (?, ?, ?, ?)",
                    [
                        session_id,
                        event.seq,
                        json.dumps(evidence.to_json(), sort_keys=True),
                        evidence.jpeg,
                    ],
                )

    def recorder(self, session_id: int) -> Callable[[ExecutionEvent], None]:
        """A listener for `Executor` that stores each event of `session_id`."""
        return lambda event: self.record(session_id, event)

    def finish(self, session_id: int, result: Result, ended: float | None = None) -> None:
        with self._writing():
            self._table("sessions").update(
                session_id, {"result": result, "ended": time.time() if ended is None else ended}
            )

    def mark_interrupted(self) -> list[int]:
        """Ends, as "interrupted", the open sessions whose process is gone; their ids."""
        marked: list[int] = []
        with self._lock:
            rows = list(self._table("sessions").rows_where("ended is null", select="*"))
            for row in rows:
                if owner_alive(row["pid"], row["started"], row["host_boot"]):
                    continue
                last = self.db.execute(
                    "select max(time) from events where session_id = ?", [row["id"]]
                ).fetchone()[0]
                self.finish(row["id"], "interrupted", last if last is not None else row["started"])
                marked.append(row["id"])
        return marked

    # -- reading ----------------------------------------------------------------

    def list_sessions(
        self,
        scenario: str | None = None,
        result: str | None = None,
        since: date | datetime | float | None = None,
    ) -> list[SessionRecord]:
        """Sessions, oldest first; `since` is a local date, a datetime or epoch seconds."""
        where: list[str] = []
        params: list[Any] = []
        if scenario is not None:
            where.append("s.scenario = ?")
            params.append(scenario)
        if result is not None:
            where.append("s.result is ?" if result == "running" else "s.result = ?")
            params.append(None if result == "running" else result)
        if since is not None:
            where.append("s.started >= ?")
            params.append(_epoch(since))
        sql = (
            self._session_select
            + (" where " + " and ".join(where) if where else "")
            + " order by s.started, s.id"
        )
        with self._reading():
            rows = self.db.execute(sql, params).fetchall()
        # Straight from the row tuples: at a study's 10,000 sessions a dict per row
        # costs as much as the query.
        return [SessionRecord(*row) for row in rows]

    def get(self, session_id: int) -> SessionRecord:
        with self._reading():
            row = self.db.execute(self._session_select + " where s.id = ?", [session_id]).fetchone()
        if row is None:
            raise UnknownSession(session_id)
        return SessionRecord(*row)

    def events(self, session_id: int, *, with_jpeg: bool = False) -> list[ExecutionEvent]:
        """The session's events in order, each with its evidence (the JPEGs if asked)."""
        self.get(session_id)
        jpeg = "v.jpeg" if with_jpeg else "null"
        with self._reading():
            cursor = self.db.execute(
                f"select e.*, v.detail as evidence_detail, {jpeg} as evidence_jpeg, "
                "v.seq is not null as has_evidence from events e left join evidence v "
                "on v.session_id = e.session_id and v.seq = e.seq "
                "where e.session_id = ? order by e.seq",
                [session_id],
            )
            names = [d[0] for d in cursor.description]
            rows = [dict(zip(names, r, strict=True)) for r in cursor.fetchall()]
        # The table names a step's times started/ended (absent in a store opened
        # read-only before timing); an export names them start/end.
        return [
            row_event(
                {**r, "start": r.get("started"), "end": r.get("ended")},
                Evidence.from_json(json.loads(r["evidence_detail"] or "{}"), r["evidence_jpeg"])
                if r["has_evidence"]
                else None,
            )
            for r in rows
        ]

    def evidence_jpeg(self, session_id: int, seq: int) -> bytes | None:
        """The picture that decided event `seq` of the session, if one was kept."""
        with self._reading():
            row = self.db.execute(
                "select jpeg from evidence where session_id = ? and seq = ?", [session_id, seq]
            ).fetchone()
        return None if row is None else row[0]

    def plan_doc(self, digest: str) -> dict[str, Any]:
        """The stored plan's JSON document, as stored."""
        with self._reading():
            row = self.db.execute("select doc from plans where hash = ?", [digest]).fetchone()
        if row is None:
            raise KeyError(f"no plan {digest}")
        doc: dict[str, Any] = json.loads(row[0])
        return doc

    def plan(self, digest: str) -> Plan:
        return Plan.from_json(self.plan_doc(digest), f"stored plan {digest[:12]}")

    def path(self, session_id: int) -> list[tuple[str, str | None]]:
        """The nodes the session went through, with the outcome taken at each."""
        return [(e.node, e.outcome) for e in self.events(session_id) if is_step(e)]

    def export(self, session_id: int) -> dict[str, Any]:
        """The session, its events and its plan, as one JSON-ready document."""
        record = self.get(session_id)
        events = [export_event(e) for e in self.events(session_id, with_jpeg=True)]
        return {
            "format": EXPORT_FORMAT,
            "session": record.to_json(),
            "events": events,
            "plan": self.plan_doc(record.plan_hash),
        }


def _table(db: Database, name: str) -> Table:
    return Table(db, name)


def _epoch(since: date | datetime | float) -> float:
    if isinstance(since, datetime):
        return since.timestamp()
    if isinstance(since, date):
        return datetime(since.year, since.month, since.day).timestamp()
    return float(since)
